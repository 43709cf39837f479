"""Experiments ``exp-hodosmc-{balance,speed,obstacle}`` (Sec. 6.2.1) emulated on the twin.

Set-up (SPEC.md section 5): the digital twin (:mod:`mwip.hardware.twin`, built from the
study's settings by :func:`mwip.studies.twin_settings.twin_from`: IMU with complementary
fusion, encoders, RE25 motors through the gearbox and the PWM driver, 5 ms sampling);
controllers designed on the robot's nominal model (Table 6.2 by default) with Table 6.3's
gains: all ``lambda = (3, 0.01, 0.1, 3)``, ``gamma = 1``; SMC ``K = (25, 21)``, DO1SMC
``K = (17.3, 14)`` (first-order DO (3.2), gain ``do1_gain``: the book prints none), DO4SMC
``K = (6.3, 4)`` (4th-order DO with the Sec. 3.6.1 gains); saturation switching with boundary
layer ``phi`` (the robot used saturation, Sec. 6.2.1; no width printed).
``theta0 = pi/18``, 10 s, records every 10 ms, RMS (6.3) over 2-10 s. The plant is the
robot's plant (Table 6.1 by default, its ``Db, Dw`` read as SPEC.md section 2 says; a run
under another reading is ``mwip run --damping ...``: nothing here chooses one).

- balance (Table 6.4): ``q1d' = 0``, Cases 1 and 2;
- speed (Table 6.5): ``q1d' = -7 rad/s``, Cases 1 and 2;
- obstacle (Table 6.6): ``q1d' = -7 rad/s``, Case 3 (payload + stick at 6 s); settling time
  after the stick until ``psi'`` stays in (-9, -5) rad/s.

Runs whose plant falls get ``null`` metrics (status in ``runs``). Extra runs: keys prefixed
``ideal.``, the same with ideal sensors and actuator (what the hardware adds); balance and
speed also run DO1SMC on Case 1 at both ends of the ``do1_gain`` range of the study's
``[open]`` table (keys ``sweep.do1smc_L<gain>.case1.*``), because that unprinted gain decides
DO1SMC against DO4SMC; the obstacle study also runs ``case1_stick`` (the stick without the
payload).

Claims are data (:func:`mwip.studies.common.validate_claim`); a failing book claim names its
cause with evidence computed here: the payload's cut of the input gain ``g2 + l3 g1`` of
(2.36) that (3.50) divides by (:func:`input_gain_ratio`), the accelerometer reading the
robot's own acceleration as tilt (:func:`accelerometer_evidence`), or the unprinted DO1 gain.

Settings (``scenarios/exp-hodosmc-{balance,speed,obstacle}.toml``, one file per study,
:mod:`mwip.studies.settings`): ``theta0``, ``speed``, ``lambdas``, ``smc_K``, ``do1smc_K``,
``do4smc_K``, ``do1_gain``, ``phi``, ``duration``, ``Ts``, ``record_every``, ``seed``, the
twin's :data:`~mwip.studies.twin_settings.TWIN_KEYS`; balance and speed also ``rms_window``;
obstacle also ``rms_start``, ``stick_start``, ``stick_height``, ``stick_speed``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.control.smc import SMCDesignWarning, make_smc
from mwip.control.switching import Switching
from mwip.hardware.obstacle import StickObstacle
from mwip.hardware.twin import Twin, case_plant, run_on_twin
from mwip.metrics import rms, total_variation_rate
from mwip.models.reduced import f_g
from mwip.params import Params, steady_speed_cap
from mwip.sim import SimResult
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, save_figure, write_metrics
from mwip.studies.twin_settings import robot_label, twin_doc, twin_from

SOURCE_BALANCE = "Sec. 6.2.1, Figs. 6.4-6.5, Table 6.4"
SOURCE_SPEED = "Sec. 6.2.1, Figs. 6.6-6.7, Table 6.5"
SOURCE_OBSTACLE = "Sec. 6.2.1, Fig. 6.8, Table 6.6"

NAME_BALANCE = "exp-hodosmc-balance"
NAME_SPEED = "exp-hodosmc-speed"
NAME_OBSTACLE = "exp-hodosmc-obstacle"

KINDS = ("smc", "do1smc", "do4smc")
LABEL = {"smc": "SMC", "do1smc": "DO1SMC", "do4smc": "DO4SMC"}
#: Table 6.3's dbar and gamma (printed, not used: the gains K are given directly, settings)
DBAR_PRINTED = {"smc": 20.0, "do1smc": 13.0, "do4smc": 3.0}
GAMMA_PRINTED = (1.0, 1.0)
#: Table 6.6's steady-state band of ``psi'`` (rad/s) for the obstacle settling time
BAND = (-9.0, -5.0)
#: "moves at the set speed": mean ``psi'`` over the last TRACK_WINDOW s within TRACK_TOL of it
TRACK_WINDOW = 2.0
TRACK_TOL = 0.05
#: the accelerometer evidence is read where the true lean first passes this (rad)
FALL_LEAN = 0.35

PUBLISHED_BALANCE = {
    "smc.case1.rms_theta": 0.0216, "smc.case2.rms_theta": 0.0257,
    "do1smc.case1.rms_theta": 0.0156, "do1smc.case2.rms_theta": 0.0158,
    "do4smc.case1.rms_theta": 0.0055, "do4smc.case2.rms_theta": 0.0079,
    "smc.case1.rms_speed_err": 1.3240, "smc.case2.rms_speed_err": 1.8414,
    "do1smc.case1.rms_speed_err": 0.8442, "do1smc.case2.rms_speed_err": 0.9886,
    "do4smc.case1.rms_speed_err": 0.5113, "do4smc.case2.rms_speed_err": 0.6157,
}  # fmt: skip
PUBLISHED_SPEED = {
    "smc.case1.rms_speed_err": 1.4640, "smc.case2.rms_speed_err": 1.6085,
    "do1smc.case1.rms_speed_err": 0.9974, "do1smc.case2.rms_speed_err": 1.2081,
    "do4smc.case1.rms_speed_err": 0.7353, "do4smc.case2.rms_speed_err": 0.9144,
}  # fmt: skip
PUBLISHED_OBSTACLE = {
    "smc.settling_time": 1.74,
    "do1smc.settling_time": 0.86,
    "do4smc.settling_time": 0.19,
}

#: variant -> (key prefix, claim label). "twin": the study's keys; "ideal": the same plant
#: with ideal sensors and actuator (separates the hardware's share of a gap).
VARIANTS = {
    "twin": ("", ""),
    "ideal": ("ideal.", " [extra: ideal sensors and actuator]"),
}


def make_controller(
    kind: str, cfg: Mapping[str, Any], q1d_dot: float = 0.0, params: Params | None = None
) -> Any:
    """Table 6.3's controller ``kind`` (smc, do1smc, do4smc) with saturation, gains from the
    calling study's settings ``cfg`` (``lambdas``, ``{kind}_K``, ``do1_gain``, ``phi``,
    ``Ts``), designed on ``params`` (default: the robot's nominal model,
    :func:`mwip.studies.robot.nominal`)."""
    if params is None:
        params = robot.nominal()
    obs = [cfg["do1_gain"]] if kind == "do1smc" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SMCDesignWarning)
        return make_smc(kind, tuple(cfg["lambdas"]), K=tuple(cfg[f"{kind}_K"]),
                        observer_gains=obs, params=params, Ts=cfg["Ts"],
                        switching=Switching("sat", cfg["phi"]), q1d_dot=q1d_dot)  # fmt: skip


def input_gain_ratio(plant: Params, nominal: Params, lam: float) -> float:
    """``(g2 + lam g1)`` of (2.36) at upright rest for ``plant`` over the same for ``nominal``.

    (3.50) divides by ``g2 + l3 g1`` (and (4.7) by ``g2 + lambda_2 g1``) computed on the
    nominal model, so a plant with this ratio ``rho`` turns the law's intended ``S1'`` into
    ``rho`` times it plus the model mismatch: the fraction of the assumed input gain the
    plant delivers.
    """
    zero = np.zeros(3)
    _, gp = f_g(plant, zero, zero)
    _, gn = f_g(nominal, zero, zero)
    return float((gp[1, 0] + lam * gp[0, 0]) / (gn[1, 0] + lam * gn[0, 0]))


def payload_evidence(lam: float, which: str = "g2 + l3 g1") -> str:
    """Why Case 2/3 is hard, from the robot in use: the payload (absent from the design
    model) multiplies the pitch inertia and cuts the input gain the controllers assume."""
    p1, nominal = robot.plant(), robot.nominal()
    p2 = case_plant(2, base=p1)
    low = p1.with_payload(body_height=float(p1.l))
    return (
        f"the 0.5 kg pan (not in the design model) raises the pitch inertia Iby from "
        f"{float(p1.Iby):.3g} to {float(p2.Iby):.3g} kg m^2 and leaves the controllers "
        f"{input_gain_ratio(p2, nominal, lam):.2f} of the input gain {which} of (2.36) "
        f"they divide by (Case 1: {input_gain_ratio(p1, nominal, lam):.2f}; still "
        f"{input_gain_ratio(low, nominal, lam):.2f} with the pan only 0.1 m above the centre "
        f"of mass)"
    )


def accelerometer_evidence(res: SimResult) -> str:
    """How the twin's pitch estimate failed in the run ``res``: where the true lean first
    passes :data:`FALL_LEAN` (or at its largest), the fused and the accelerometer pitch
    beside the true one and the axle's acceleration ``r psi''`` that the accelerometer
    reads as tilt (``-r psi'' / g`` rad, (2.37)-(2.39))."""
    s = res.series()
    th, th_hat, th_acc = res.theta, s["y_meas"][:, 1], s["imu_theta_acc"]
    xdd = float(res.r[0]) * np.gradient(res.q_dot[:, 0], res.t)
    finite = np.isfinite(th)
    past = np.nonzero(finite & (np.abs(th) >= FALL_LEAN))[0]
    j = int(past[0]) if past.size else int(np.nanargmax(np.where(finite, np.abs(th), -1.0)))
    return (
        f"at t = {res.t[j]:.2f} s the true pitch is {th[j]:+.3f} rad, the fused one "
        f"{th_hat[j]:+.3f} rad and the accelerometer's {th_acc[j]:+.3f} rad while the axle "
        f"accelerates at {xdd[j]:+.2f} m/s^2 (read as {-xdd[j] / 9.81:+.3f} rad of tilt)"
    )


def _fell_text(runs: Mapping[str, SimResult], names: Mapping[str, str]) -> str:
    """The fall times of the runs ``names`` (label -> run key): "SMC at 0.54 s, ..."."""
    parts = [f"{lab} at {float(runs[n].t_end[0]):.2f} s" for lab, n in names.items()
             if n in runs and runs[n].status[0] != "ok"]  # fmt: skip
    return "fell: " + ", ".join(parts) if parts else "none fell"


def _twin_for(variant: str, cfg: Mapping[str, Any], twin: Twin | None) -> Twin:
    if twin is not None:
        return twin
    return twin_from(cfg, ideal=variant == "ideal")


def run_one(
    kind: str, case: int, q1d_dot: float, cfg: Mapping[str, Any], *, variant: str = "twin",
    duration: float | None = None, twin: Twin | None = None,
) -> SimResult:  # fmt: skip
    """One controller on the twin for a case (3 = payload + stick; ``case=-1``: stick on the
    Case 1 robot) with ``variant`` "twin" (the study's twin, from ``cfg``) or "ideal" (ideal
    sensors and actuator), or the given ``twin``; the calling study's settings ``cfg``
    (``duration`` default: ``cfg["duration"]``; the stick from ``stick_start``,
    ``stick_speed``, ``stick_height``)."""
    if variant not in VARIANTS:
        raise ValueError(f"'variant' must be one of {', '.join(VARIANTS)}, got {variant!r}")
    ctrl = make_controller(kind, cfg, q1d_dot)
    payload = case in (2, 3)
    plant = case_plant(2 if payload else 1, base=robot.plant())
    dist = None
    if case in (3, -1):
        dist = StickObstacle(height=cfg.get("stick_height", 0.01),
                             start=cfg.get("stick_start", 6.0),
                             speed=cfg.get("stick_speed", -7.0),
                             mass=float(plant.mb + 2.0 * plant.mw), r=float(plant.r))  # fmt: skip
    return run_on_twin(
        ctrl, 2 if payload else 1, twin=_twin_for(variant, cfg, twin), plant=plant,
        q0=(0.0, cfg["theta0"], 0.0), record_every=cfg["record_every"], seed=cfg["seed"],
        duration=cfg["duration"] if duration is None else duration, disturbance=dist,
    )  # fmt: skip


def _rms_metrics(res: SimResult, q1d_dot: float, window: tuple[float, float]) -> dict[str, float]:
    ok = res.status[0] == "ok"
    s = res.series()
    nan = float("nan")
    lim = s.get("drive_limited")
    last = res.t >= res.t[-1] - TRACK_WINDOW - 1e-9
    return {
        "rms_theta": float(rms(res.t, res.theta, window)) if ok else nan,
        "rms_speed_err": float(rms(res.t, res.q_dot[:, 0] - q1d_dot, window)) if ok else nan,
        "final_speed": float(np.mean(res.q_dot[last, 0])) if ok else nan,
        "u_tv": float(np.sum(total_variation_rate(res.t, res.u.T))),
        "max_abs_u": float(np.nanmax(np.abs(s["u_applied"]))),
        "sat_fraction": float(np.nanmean(lim)) if lim is not None else 0.0,
        "t_end": float(res.t_end[0]),
    }


def _order_values(metrics: Mapping[str, float], fmt: str) -> list[float]:
    """DO4SMC, DO1SMC, SMC values of ``fmt`` (a key with ``{k}`` for the controller)."""
    return [metrics.get(fmt.format(k=k), float("nan")) for k in ("do4smc", "do1smc", "smc")]


def _ordered(vals: list[float]) -> bool:
    return bool(np.all(np.isfinite(vals)) and vals[0] < vals[1] < vals[2])


def _values_text(metrics: Mapping[str, float], fmt: str) -> str:
    return ", ".join(f"{LABEL[k]} {metrics.get(fmt.format(k=k), float('nan')):.4g}"
                     for k in ("do4smc", "do1smc", "smc"))  # fmt: skip


def _runs_doc(runs: dict[str, SimResult]) -> dict[str, dict[str, Any]]:
    return {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()}


def _settings(
    cfg: Mapping[str, Any], extra: dict[str, Any], duration: float, window: tuple[float, float]
) -> dict:
    base = {
        "dt": cfg["dt"], "Ts": cfg["Ts"], "window": list(window), "seed": cfg["seed"],
        "duration": duration, "record_every": cfg["record_every"],
        "record_period": cfg["Ts"] * cfg["record_every"],
        "mode": f"sampled on the digital twin ({cfg['Ts'] * 1e3:g} ms)",
        "lambdas": list(cfg["lambdas"]), "gamma": list(GAMMA_PRINTED),
        "K": {k: list(cfg[f"{k}_K"]) for k in KINDS}, "dbar_printed": dict(DBAR_PRINTED),
        "switching": f"saturation, phi = {cfg['phi']}", "phi": cfg["phi"],
        "theta0": cfg["theta0"], "do1_gain": cfg["do1_gain"],
        "observers": f"DO1: L = {cfg['do1_gain']:g} I3; DO4: Sec. 3.6.1 gains",
        "twin": twin_doc(cfg), "plant": robot_label(robot.plant()),
        "ideal": "extra runs: the same plant, ideal sensors and actuator",
        "track": f"mean psi' over the last {TRACK_WINDOW:g} s within {TRACK_TOL:.0%} of q1d'",
    }  # fmt: skip
    base.update(extra)
    return base


class _Evidence:
    """Cause and evidence of a failing book claim of a HODOSMC study, from its runs."""

    def __init__(self, study: str, cfg: Mapping[str, Any], runs: Mapping[str, SimResult],
                 metrics: Mapping[str, float]) -> None:  # fmt: skip
        self.study, self.cfg, self.runs, self.m = study, cfg, runs, metrics

    def fallen(self, pre: str, tag: str) -> list[str]:
        return [k for k in KINDS if f"{pre}{tag}{k}" in self.runs
                and self.runs[f"{pre}{tag}{k}"].status[0] != "ok"]  # fmt: skip

    def payload(self, tag: str) -> tuple[str, str]:
        names = {LABEL[k]: f"{tag}{k}" for k in KINDS}
        ideal = {LABEL[k]: f"ideal.{tag}{k}" for k in KINDS}
        text = (f"{payload_evidence(self.cfg['lambdas'][2])}; on the twin "
                f"{_fell_text(self.runs, names)}")  # fmt: skip
        if any(n in self.runs for n in ideal.values()):
            text += f"; with ideal sensors and actuator {_fell_text(self.runs, ideal)}"
        return "book-inconsistency", text

    def sensors(self, kind: str, tag: str) -> tuple[str, str]:
        res = self.runs[f"{tag}{kind}"]
        text = (f"{LABEL[kind]} fell at {float(res.t_end[0]):.2f} s: "
                f"{accelerometer_evidence(res)}")  # fmt: skip
        ideal = self.runs.get(f"ideal.{tag}{kind}")
        if ideal is not None:
            text += ("; with ideal sensors and actuator it stays up"
                     if ideal.status[0] == "ok"
                     else f"; with ideal sensors and actuator it falls too, at "
                          f"{float(ideal.t_end[0]):.2f} s")  # fmt: skip
            if ideal.status[0] != "ok":
                return "implementation", text + " (not explained)"
        return "twin-model", text

    def speed_cap(self, case: int) -> tuple[str, str] | None:
        """When the set speed exceeds the plant's steady-speed cap ``Gb / (2 Dw)`` (steady
        rolling needs ``Gb sin(theta) = 2 Dw psi'``, :func:`mwip.params.steady_speed_cap`),
        no controller can reach it: the damping decides (``None`` when it is reachable)."""
        target = float(self.cfg["speed"])
        plant = case_plant(2 if case in (2, 3) else 1, base=robot.plant())
        cap = float(steady_speed_cap(plant))
        if target == 0.0 or abs(target) <= cap:
            return None
        text = (
            f"the set speed {target:g} rad/s exceeds the plant's steady-speed cap "
            f"Gb / (2 Dw) = {cap:.3g} rad/s (Dw = {float(plant.Dw):.3g} N m s/rad)"
        )
        return "damping-reading", text

    def order(self, fmt: str, tag: str, case_key: str, q: str) -> tuple[str, str]:
        """A failing ordering DO4SMC < DO1SMC < SMC of quantity ``q``."""
        fallen = self.fallen("", tag)
        vals = _values_text(self.m, fmt)
        capped = self.speed_cap(int(case_key[-1])) if q != "rms_theta" else None
        if capped is not None:
            return capped[0], f"{vals}; {capped[1]}"
        if fallen and case_key in ("case2", "case3"):
            cause, text = self.payload(tag)
            return cause, f"{vals}; {text}"
        if fallen:
            cause, text = self.sensors(fallen[0], tag)
            pair = self.sweep(q, case_key, pair=True)
            return cause, f"{vals}; {text}" + (f"; besides, {pair}" if pair else "")
        sweep = self.sweep(q, case_key)
        if sweep is not None:
            return (
                "unprinted-setting",
                f"{vals} (DO1SMC observer gain L = {self.cfg['do1_gain']:g}); {sweep}",
            )
        return "implementation", f"{vals}: all up, the ordering differs (not explained)"

    def sweep(self, q: str, case_key: str, *, pair: bool = False) -> str | None:
        """The DO1SMC values at the ends of the ``do1_gain`` range when one of them puts the
        three in the book's order (``pair``: puts DO4SMC below DO1SMC, whatever SMC did);
        ``None`` otherwise."""
        lo, hi = _do1_range(self.study)
        keys = [f"sweep.do1smc_L{g:g}.{case_key}.{q}" for g in (lo, hi)]
        if not all(k in self.m for k in keys):
            return None
        v4, _, vs = _order_values(self.m, "{k}." + f"{case_key}.{q}")
        vals = [self.m[k] for k in keys]
        if pair:
            flips = any(np.isfinite(v4) and np.isfinite(v) and v4 < v for v in vals)
        else:
            flips = any(_ordered([v4, v, vs]) for v in vals)
        if not flips:
            return None
        return (
            f"with L = {lo:g} DO1SMC gives {vals[0]:.4g}, with L = {hi:g} {vals[1]:.4g}: "
            f"the unprinted first-order observer gain decides DO1SMC against DO4SMC"
        )


def _do1_range(study: str) -> tuple[float, float]:
    lo, hi = settings.open_settings(study)["do1_gain"]["range"]
    return float(lo), float(hi)


def _claim(cid: str, text: str, holds: bool, book: bool, keys: list[str],
           why: tuple[str, str] | None = None) -> dict[str, Any]:  # fmt: skip
    c: dict[str, Any] = {"id": cid, "text": text, "holds": bool(holds), "book": book,
                         "keys": keys}  # fmt: skip
    if book and not holds and why is not None:
        c["cause"], c["evidence"] = why
    return c


def _rms_experiment(
    study: str, source: str, published: dict[str, float], out: Path, quick: bool,
    keys: tuple[str, ...], table: str,
) -> dict[str, Any]:  # fmt: skip
    folder = Path(out) / study
    cfg = settings.current(study)
    q1d_dot = cfg["speed"]
    duration = min(4.0, cfg["duration"]) if quick else cfg["duration"]
    window = (2.0, duration) if quick else tuple(cfg["rms_window"])
    variants = ("twin",) if quick else tuple(VARIANTS)
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for variant in variants:
        pre = VARIANTS[variant][0]
        for case in (1, 2):
            for kind in KINDS:
                res = run_one(kind, case, q1d_dot, cfg, variant=variant, duration=duration)
                name = f"{pre}{kind}.case{case}"
                runs[name] = res
                for q, v in _rms_metrics(res, q1d_dot, window).items():
                    metrics[f"{name}.{q}"] = v
    for gain in _do1_range(study):  # DO1SMC at the ends of its open observer gain, Case 1
        res = run_one("do1smc", 1, q1d_dot, {**cfg, "do1_gain": gain}, duration=duration)
        name = f"sweep.do1smc_L{gain:g}.case1"
        runs[name] = res
        for q, v in _rms_metrics(res, q1d_dot, window).items():
            metrics[f"{name}.{q}"] = v
    ev = _Evidence(study, cfg, {}, metrics)
    claims = []
    for variant in variants:
        pre, label = VARIANTS[variant]
        book = variant == "twin"
        for case in (1, 2):
            ck = f"case{case}"
            # the evidence reads runs by "<prefix><kind>" for this case
            ev.runs = {f"{p}{k}": runs[f"{p}{k}.{ck}"] for p in ("", "ideal.") for k in KINDS
                       if f"{p}{k}.{ck}" in runs}  # fmt: skip
            for q in keys:
                fmt = pre + "{k}." + f"{ck}.{q}"
                holds = _ordered(_order_values(metrics, fmt))
                claims.append(_claim(
                    f"{pre}order.{q}.{ck}",
                    f"DO4SMC < DO1SMC < SMC in {q}, Case {case} ({table}){label}", holds, book,
                    [fmt.format(k=k) for k in ("do4smc", "do1smc", "smc")],
                    None if holds or not book else ev.order(fmt, "", ck, q),
                ))  # fmt: skip
            up = all(runs[f"{pre}{k}.{ck}"].status[0] == "ok" for k in KINDS)
            fallen = ev.fallen("", "")
            why = None
            if book and not up:
                why = ev.payload("") if case == 2 else ev.sensors(fallen[0], "")
            claims.append(_claim(
                f"{pre}up.{ck}",
                f"all three keep the robot up for {duration:g} s, Case {case}{label}", up, book,
                [f"{pre}{k}.{ck}.t_end" for k in KINDS], why,
            ))  # fmt: skip
            if q1d_dot != 0.0:
                finals = [metrics[f"{pre}{k}.{ck}.final_speed"] for k in KINDS]
                track = all(np.isfinite(v) and abs(v - q1d_dot) <= TRACK_TOL * abs(q1d_dot)
                            for v in finals)  # fmt: skip
                claims.append(_claim(
                    f"{pre}track.{ck}",
                    f"all three move at {q1d_dot:g} rad/s (mean over the last {TRACK_WINDOW:g}"
                    f" s within {TRACK_TOL:.0%}), Case {case}{label}", track, book,
                    [f"{pre}{k}.{ck}.final_speed" for k in KINDS],
                    None if track or not book else (ev.speed_cap(case) or why or (
                        "implementation",
                        "mean speeds " + ", ".join(f"{LABEL[k]} {v:.3g}" for k, v in
                                                   zip(KINDS, finals, strict=True))
                        + " rad/s, all up (not explained)")),
                ))  # fmt: skip
    doc = metrics_document(study, source, metrics, published, claims, _runs_doc(runs),
                           _settings(cfg, {"q1d_dot": q1d_dot}, duration, window))  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    _figure(runs, q1d_dot, folder / f"{study}.png", study)
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    write_metrics(folder, doc)
    return doc


def run_balance(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-balance``: Table 6.4 on the twin (Cases 1-2, ``q1d' = 0``)."""
    return _rms_experiment(NAME_BALANCE, SOURCE_BALANCE, PUBLISHED_BALANCE, out, quick,
                           ("rms_theta", "rms_speed_err"), "Table 6.4")  # fmt: skip


def run_speed(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-speed``: Table 6.5 on the twin (Cases 1-2, ``q1d' = -7 rad/s``)."""
    return _rms_experiment(NAME_SPEED, SOURCE_SPEED, PUBLISHED_SPEED, out, quick,
                           ("rms_speed_err",), "Table 6.5")  # fmt: skip


def obstacle_settling_time(
    t: np.ndarray, psi_dot: np.ndarray, start: float = 6.0,
    band: tuple[float, float] = BAND,
) -> float:  # fmt: skip
    """Time after ``start`` until ``psi'`` enters ``band`` for good (Table 6.6's definition:
    "steady state ... when the actual velocity falls within (-9, -5)"); 0 if it never leaves
    the band after ``start``, ``nan`` if it is outside at the end (never settles)."""
    after = t >= start - 1e-12
    tt, x = t[after], psi_dot[after]
    if tt.size == 0 or not np.all(np.isfinite(x)):
        return float("nan")
    outside = np.nonzero((x <= band[0]) | (x >= band[1]))[0]
    if outside.size == 0:
        return 0.0
    if outside[-1] == x.size - 1:
        return float("nan")
    return float(tt[outside[-1] + 1] - start)


def run_obstacle(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-obstacle``: Table 6.6 on the twin (Case 3: payload + stick at 6 s)."""
    study = NAME_OBSTACLE
    folder = Path(out) / study
    cfg = settings.current(study)
    speed, stick_start = cfg["speed"], cfg["stick_start"]
    duration = min(7.0, cfg["duration"]) if quick else cfg["duration"]
    variants = ("twin",) if quick else tuple(VARIANTS)
    cases = ((3, ""),) if quick else ((3, ""), (-1, "case1_stick."))
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for variant in variants:
        pre = VARIANTS[variant][0]
        for case, tag in cases:
            for kind in KINDS:
                res = run_one(kind, case, speed, cfg, variant=variant, duration=duration)
                name = f"{pre}{tag}{kind}"
                runs[name] = res
                ok = res.status[0] == "ok"
                metrics[f"{name}.settling_time"] = (
                    obstacle_settling_time(res.t, res.q_dot[:, 0], stick_start)
                    if ok
                    else float("nan")
                )
                metrics[f"{name}.rms_speed_err"] = (
                    float(rms(res.t, res.q_dot[:, 0] - speed, (cfg["rms_start"], stick_start)))
                    if ok else float("nan")
                )  # fmt: skip
                pre_stick = res.t < stick_start
                metrics[f"{name}.speed_before_stick"] = (
                    float(np.nanmean(res.q_dot[pre_stick, 0][-50:])) if ok else float("nan")
                )
                metrics[f"{name}.t_end"] = float(res.t_end[0])
    ev = _Evidence(study, cfg, runs, metrics)
    claims = []
    for variant in variants:
        pre, label = VARIANTS[variant]
        for case, tag in cases:
            book = variant == "twin" and case == 3
            what = "Case 3" if case == 3 else "stick without payload (extra)"
            fmt = pre + tag + "{k}.settling_time"
            holds = _ordered(_order_values(metrics, fmt))
            ck = "case3" if case == 3 else "case1"
            claims.append(_claim(
                f"{pre}order.{tag or 'case3.'}settling_time",
                f"settling time DO4SMC < DO1SMC < SMC, {what} (Table 6.6){label}", holds, book,
                [fmt.format(k=k) for k in ("do4smc", "do1smc", "smc")],
                None if holds or not book else ev.order(fmt, tag, ck, "settling_time"),
            ))  # fmt: skip
            settled = all(np.isfinite(metrics[f"{pre}{tag}{k}.settling_time"]) for k in KINDS)
            why = None
            if book and not settled:
                fallen = ev.fallen(pre, tag)
                why = ev.speed_cap(3) or (
                    ev.payload(tag)
                    if fallen
                    else (
                        "implementation",
                        "all up; never in (-9, -5) rad/s after the stick: "
                        + _values_text(metrics, fmt)
                        + " (not explained)",
                    )
                )
            claims.append(_claim(
                f"{pre}settle.{tag or 'case3.'}".rstrip("."),
                f"all three cross the stick and settle in (-9, -5) rad/s, {what}{label}",
                settled, book, [f"{pre}{tag}{k}.settling_time" for k in KINDS], why,
            ))  # fmt: skip
    stick = _stick_doc(cfg)
    doc = metrics_document(
        study, SOURCE_OBSTACLE, metrics, PUBLISHED_OBSTACLE, claims, _runs_doc(runs),
        _settings(cfg, {"q1d_dot": speed, "band": list(BAND), "stick": stick,
                        "stick_speed": cfg["stick_speed"]},
                  duration, (cfg["rms_start"], stick_start)),
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    _figure(runs, speed, folder / f"{study}.png", study, cases=("",))
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    write_metrics(folder, doc)
    return doc


def _stick_doc(cfg: Mapping[str, Any]) -> dict[str, float]:
    p = case_plant(2, base=robot.plant())
    s = StickObstacle(
        height=cfg["stick_height"],
        start=cfg["stick_start"],
        speed=cfg["stick_speed"],
        mass=float(p.mb + 2.0 * p.mw),
        r=float(p.r),
    )
    return {"height": s.height, "start": s.start, "duration_each": s.duration,
            "torque": s.torque, "mass": s.mass}  # fmt: skip


def _figure(
    runs: dict[str, SimResult], q1d_dot: float, path: Path, title: str,
    cases: tuple[str, ...] = (".case1", ".case2"),
) -> None:  # fmt: skip
    """The book's layout (Figs. 6.4-6.8): angle, speed and torque against time in 0.1 s."""
    fig = Figure(figsize=(6 * len(cases), 9), layout="constrained")
    axes = fig.subplots(3, len(cases), squeeze=False)
    colors = {"smc": "tab:blue", "do1smc": "tab:green", "do4smc": "tab:red"}
    for j, case in enumerate(cases):
        for kind in KINDS:
            res = runs[f"{kind}{case}"]
            t = res.t * 10.0
            kw = {"color": colors[kind], "lw": 0.9, "label": LABEL[kind]}
            axes[0, j].plot(t, res.theta, **kw)
            axes[1, j].plot(t, res.q_dot[:, 0], **kw)
            axes[2, j].plot(t, res.series()["u_applied"][:, 0], **kw)
        axes[0, j].set_title(case.strip(".") or "case 3")
        if q1d_dot != 0:
            axes[1, j].axhline(q1d_dot, color="k", ls=":", lw=0.8)
        axes[0, j].set_ylabel("Angle [rad]")
        axes[1, j].set_ylabel("Speed [rad/s]")
        axes[2, j].set_ylabel("Torque [N.m] (right wheel, applied)")
        axes[2, j].set_xlabel("Time [0.1s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title} on the digital twin ({robot_label(robot.plant())})")
    save_figure(fig, path)
