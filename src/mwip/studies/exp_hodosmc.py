"""Experiments ``exp-hodosmc-{balance,speed,obstacle}`` (Sec. 6.2.1) emulated on the twin.

Set-up (SPEC.md section 5): the digital twin of the run (``ctx.twin``: the robot file's
twin, default the default robot's with every element on; ``mwip run --robot FILE``;
:mod:`mwip.studies.twin_settings`); controllers sampled at its ``Ts`` (5 ms); controllers
designed on the robot's nominal model (Table 6.2 by default) with Table 6.3's
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

Runs whose plant falls get ``null`` metrics (status in ``runs``). The ablation
(:mod:`mwip.hardware.ablation`): each controller and case on the ideal robot, then with the
twin's elements added in turn (cumulative, :data:`mwip.hardware.elements.ELEMENTS` order), one
batched run per controller and case (2 s in quick mode), keys
``ablation.<step>.<run>.case<k>.<quantity>`` (``rms_theta``, ``rms_theta_meas``,
``rms_speed_err``, ``max_abs_u``, ``t_end``, ``fell``, ``final_speed``, obstacle also
``settling_time``); its tables are ``ablation.md``/``ablation.html`` in the study's folder,
named in metrics.json's ``settings.ablation_table``. Balance and speed also run DO1SMC on
Case 1 at both ends of the ``do1_gain`` range of the study's ``[open]`` table (keys
``sweep.do1smc_L<gain>.case1.*``), because that unprinted gain decides DO1SMC against DO4SMC;
the obstacle study also runs ``case1_stick`` (the stick without the payload).

Claims are data (:func:`mwip.schema.claims.validate_claim`), judged on the twin of the run; a
failing book claim names its cause with evidence computed here: where the runs that fell stop
balancing along the ablation (:func:`mwip.studies.twin_settings.fall_evidence`; balancing with
the ideal robot makes it ``twin-model``), the payload's cut of the input gain ``g2 + l3 g1`` of
(2.36) that (3.50) divides by (:func:`input_gain_ratio`) when they fall with the ideal robot
too, the steady-speed cap, or the unprinted DO1 gain.

Settings (``scenarios/exp-hodosmc-{balance,speed,obstacle}.toml``, one file per study,
:mod:`mwip.studies.settings`): ``theta0``, ``speed``, ``lambdas``, ``smc_K``, ``do1smc_K``,
``do4smc_K``, ``do1_gain``, ``phi``, ``duration``, ``record_every``, ``seed`` (the twin's
numbers are the robot file's); balance and speed also ``rms_window``;
obstacle also ``rms_start``, ``stick_start``, ``stick_height``, ``stick_speed``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from functools import partial
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.hardware.ablation import (
    Ablation,
    MetricFn,
    board_signals,
    mark_fall,
    rms_metrics,
    run_ablation,
)
from mwip.hardware.identified import default_twin
from mwip.hardware.obstacle import StickObstacle
from mwip.hardware.twin import Twin, case_plant, run_on_twin
from mwip.laws.smc.controller import SMCDesignWarning, make_smc
from mwip.laws.switching import Switching
from mwip.metrics import rms, total_variation_rate
from mwip.params import Params, steady_speed_cap
from mwip.sim import SimResult
from mwip.studies import settings
from mwip.studies.registry import robot as book_robot
from mwip.studies.study import Study, StudyContext, runs_record, save_study
from mwip.studies.twin_settings import (
    ABLATION_FIELD,
    QUICK_ABLATION,
    fall_evidence,
    first_fall,
    payload_evidence,
    robot_label,
    study_settings,
    twin_doc,
    write_ablation,
)
from mwip.studies.twin_settings import (
    input_gain_ratio as input_gain_ratio,  # re-exported: tests and examples use it from here
)

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


def make_controller(
    kind: str, cfg: Mapping[str, Any], q1d_dot: float = 0.0, params: Params | None = None
) -> Any:
    """Table 6.3's controller ``kind`` (smc, do1smc, do4smc) with saturation, gains from the
    calling study's settings ``cfg`` (``lambdas``, ``{kind}_K``, ``do1_gain``, ``phi``,
    ``Ts``), designed on ``params`` (default: the book's design model, Table 3.2)."""
    if params is None:
        params = book_robot()[1]
    obs = [cfg["do1_gain"]] if kind == "do1smc" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SMCDesignWarning)
        return make_smc(kind, tuple(cfg["lambdas"]), K=tuple(cfg[f"{kind}_K"]),
                        observer_gains=obs, params=params, Ts=cfg["Ts"],
                        switching=Switching("sat", cfg["phi"]), q1d_dot=q1d_dot)  # fmt: skip


def _fell_text(runs: Mapping[str, SimResult], names: Mapping[str, str]) -> str:
    """The fall times of the runs ``names`` (label -> run key): "SMC at 0.54 s, ..."."""
    parts = [f"{lab} at {float(runs[n].t_end[0]):.2f} s" for lab, n in names.items()
             if n in runs and runs[n].status[0] != "ok"]  # fmt: skip
    return "fell: " + ", ".join(parts) if parts else "none fell"


def run_one(
    kind: str, case: int, q1d_dot: float, cfg: Mapping[str, Any], *,
    duration: float | None = None, twin: Twin | None = None, plant: Params | None = None,
    nominal: Params | None = None,
) -> SimResult:  # fmt: skip
    """One controller on the twin for a case (3 = payload + stick; ``case=-1``: stick on the
    Case 1 robot): the given ``twin`` (default: the default twin), the robot ``plant`` and
    design model ``nominal`` (default: the book's); the calling study's settings ``cfg``
    (``Ts`` must be the twin's; ``duration`` default: ``cfg["duration"]``; the stick from
    ``stick_start``, ``stick_speed``, ``stick_height``)."""
    base, nominal = book_robot(plant, nominal)
    ctrl = make_controller(kind, cfg, q1d_dot, nominal)
    payload = case in (2, 3)
    twin = default_twin() if twin is None else twin
    plant = case_plant(2 if payload else 1, base=base, twin=twin)  # the twin's payload
    dist = None
    if case in (3, -1):
        dist = StickObstacle(height=cfg.get("stick_height", 0.01),
                             start=cfg.get("stick_start", 6.0),
                             speed=cfg.get("stick_speed", -7.0),
                             mass=float(plant.mb + 2.0 * plant.mw), r=float(plant.r))  # fmt: skip
    return run_on_twin(
        ctrl, 2 if payload else 1, twin=twin, plant=plant,
        q0=(0.0, cfg["theta0"], 0.0), record_every=cfg["record_every"], seed=cfg["seed"],
        duration=cfg["duration"] if duration is None else duration, disturbance=dist,
    )  # fmt: skip


def _rms_metrics(res: SimResult, q1d_dot: float, window: tuple[float, float]) -> dict[str, float]:
    ok = res.status[0] == "ok"
    s = res.series()
    nan = float("nan")
    lim = s.get("drive_limited")
    last = res.t >= res.t[-1] - TRACK_WINDOW - 1e-9
    th, speed = board_signals(res)  # measured, as the book's tables (issue 23)
    return {
        "rms_theta": float(rms(res.t, th, window)) if ok else nan,
        "rms_speed_err": float(rms(res.t, speed - q1d_dot, window)) if ok else nan,
        "final_speed": float(np.mean(speed[last])) if ok else nan,
        "rms_theta_true": float(rms(res.t, res.theta, window)) if ok else nan,
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
    """DO4SMC, DO1SMC, SMC values of ``fmt`` ("fell" where not finite)."""

    def num(v: float) -> str:
        return f"{v:.4g}" if np.isfinite(v) else "fell"

    return ", ".join(f"{LABEL[k]} {num(metrics.get(fmt.format(k=k), float('nan')))}"
                     for k in ("do4smc", "do1smc", "smc"))  # fmt: skip


def _settings(
    cfg: Mapping[str, Any], tw: Twin, extra: dict[str, Any], duration: float,
    window: tuple[float, float], tables: dict[str, str], plant: Params,
) -> dict:  # fmt: skip
    base = {
        "dt": tw.dt, "Ts": tw.Ts, "window": list(window), "seed": cfg["seed"],
        "duration": duration, "record_every": cfg["record_every"],
        "record_period": tw.Ts * cfg["record_every"],
        "mode": f"sampled on the digital twin ({tw.Ts * 1e3:g} ms)",
        "lambdas": list(cfg["lambdas"]), "gamma": list(GAMMA_PRINTED),
        "K": {k: list(cfg[f"{k}_K"]) for k in KINDS}, "dbar_printed": dict(DBAR_PRINTED),
        "switching": f"saturation, phi = {cfg['phi']}", "phi": cfg["phi"],
        "theta0": cfg["theta0"], "do1_gain": cfg["do1_gain"],
        "observers": f"DO1: L = {cfg['do1_gain']:g} I3; DO4: Sec. 3.6.1 gains",
        "twin": twin_doc(tw), "plant": robot_label(plant),
        "ablation": "the ideal robot, then the twin's elements added in turn (keys "
                    "ablation.<step>.<run>.case<k>.*; one batched run per controller and case)",
        ABLATION_FIELD: tables,
        "track": f"mean psi' over the last {TRACK_WINDOW:g} s within {TRACK_TOL:.0%} of q1d'",
    }  # fmt: skip
    base.update(extra)
    return base


def _ablation_metrics(
    window: tuple[float, float], q1d_dot: float, stick_start: float | None
) -> MetricFn:
    """The ablation's quantities of one run: :func:`mwip.hardware.ablation.rms_metrics` plus
    ``final_speed`` (mean ``psi'`` over the last :data:`TRACK_WINDOW`) and, with a stick,
    ``settling_time`` (:func:`obstacle_settling_time`)."""
    base = rms_metrics(window, q1d_dot)

    def fn(res: SimResult, run: str, case: int) -> dict[str, float]:
        out = dict(base(res, run, case))
        ok = res.status[0] == "ok"
        last = res.t >= res.t[-1] - TRACK_WINDOW - 1e-9
        out["final_speed"] = float(np.mean(res.q_dot[last, 0])) if ok else float("nan")
        if stick_start is not None:
            out["settling_time"] = (obstacle_settling_time(res.t, res.q_dot[:, 0], stick_start)
                                    if ok else float("nan"))  # fmt: skip
        return out

    return fn


def _run_ablation(
    cfg: Mapping[str, Any], tw: Twin, q1d_dot: float, cases: tuple[int, ...], duration: float,
    window: tuple[float, float], claims: list[tuple[str, Any]], plant: Params | None = None,
    nominal: Params | None = None,
) -> Ablation:  # fmt: skip
    """The cumulative ablation of the three controllers for ``cases`` on the twin's values:
    one batched run per controller and case (:func:`mwip.hardware.ablation.run_ablation`), on
    ``plant`` with designs on ``nominal`` (default: the book's)."""
    stick = cfg.get("stick_start") if 3 in cases else None
    base, nominal = book_robot(plant, nominal)

    def kw(run: str, case: int) -> dict[str, Any]:
        out = {"q0": (0.0, cfg["theta0"], 0.0), "duration": duration,
               "record_every": cfg["record_every"], "seed": cfg["seed"]}  # fmt: skip
        if case == 3:
            out.update(stick_speed=cfg["stick_speed"], stick_start=cfg["stick_start"],
                       stick_height=cfg["stick_height"])  # fmt: skip
        return out

    return run_ablation(
        [(k, partial(make_controller, k, cfg, q1d_dot, nominal)) for k in KINDS], tw,
        cases=cases, metrics=_ablation_metrics(window, q1d_dot, stick), run_kwargs=kw,
        plant=lambda case: case_plant(2 if case in (2, 3) else 1, base=base, twin=tw),
        claims=claims,
    )  # fmt: skip


def _ab_order(q: str, case: int) -> tuple[str, Any]:
    def test(m: Mapping[str, float]) -> bool:
        return _ordered([m[f"{k}.case{case}.{q}"] for k in ("do4smc", "do1smc", "smc")])

    return f"DO4SMC < DO1SMC < SMC in {q}, Case {case}", test


def _ab_up(case: int) -> tuple[str, Any]:
    def test(m: Mapping[str, float]) -> bool:
        return all(m[f"{k}.case{case}.fell"] != 1.0 for k in KINDS)

    return f"all three stay up, Case {case}", test


class _Evidence:
    """Cause and evidence of a failing book claim of a HODOSMC study, from its runs and its
    ablation ``ab`` (``runs`` holds the full-twin runs of one case by controller name) on
    ``plant`` with designs on ``nominal`` (default: the book's)."""

    def __init__(self, study: str, cfg: Mapping[str, Any], runs: Mapping[str, SimResult],
                 metrics: Mapping[str, float], ab: Ablation, plant: Params | None = None,
                 nominal: Params | None = None, twin: Twin | None = None) -> None:  # fmt: skip
        self.study, self.cfg, self.runs, self.m, self.ab = study, cfg, runs, metrics, ab
        self.plant, self.nominal = book_robot(plant, nominal)
        self.twin = twin  # its payload: Cases 2 and 3

    def fallen(self) -> list[str]:
        return [k for k in KINDS if k in self.runs and self.runs[k].status[0] != "ok"]

    def fall(self, case: int) -> tuple[str, str]:
        """The runs of Case ``case`` fell on the twin: where they stop balancing along the
        ablation. Balancing with the ideal robot puts the cause in the twin's elements
        (``twin-model``); falling there too is the payload (Cases 2, 3) or not explained."""
        kinds = self.fallen() or list(KINDS)
        names = {LABEL[k]: k for k in KINDS}
        text = f"on the full twin {_fell_text(self.runs, names)}; ablation: " + "; ".join(
            fall_evidence(self.ab, k, case, LABEL[k]) for k in kinds
        )
        if any(first_fall(self.ab, k, case) == "ideal" for k in kinds):
            if case in (2, 3):
                why = payload_evidence(self.cfg["lambdas"][2], plant=self.plant,
                                       nominal=self.nominal, twin=self.twin)  # fmt: skip
                return "book-inconsistency", f"{why}; {text}"
            return "implementation", text + " (not explained)"
        return "twin-model", text

    def speed_cap(self, case: int) -> tuple[str, str] | None:
        """When the set speed exceeds the plant's steady-speed cap ``Gb / (2 Dw)`` (steady
        rolling needs ``Gb sin(theta) = 2 Dw psi'``, :func:`mwip.params.steady_speed_cap`),
        no controller can reach it: the damping decides (``None`` when it is reachable)."""
        target = float(self.cfg["speed"])
        plant = case_plant(2 if case in (2, 3) else 1, base=self.plant, twin=self.twin)
        cap = float(steady_speed_cap(plant))
        if target == 0.0 or abs(target) <= cap:
            return None
        text = (
            f"the set speed {target:g} rad/s exceeds the plant's steady-speed cap "
            f"Gb / (2 Dw) = {cap:.3g} rad/s (Dw = {float(plant.Dw):.3g} N m s/rad)"
        )
        return "damping-reading", text

    def order(self, fmt: str, case: int, q: str) -> tuple[str, str]:
        """A failing ordering DO4SMC < DO1SMC < SMC of quantity ``q`` in Case ``case``."""
        vals = _values_text(self.m, fmt)
        capped = self.speed_cap(case) if q != "rms_theta" else None
        if capped is not None:
            return capped[0], f"{vals}; {capped[1]}"
        if self.fallen():
            cause, text = self.fall(case)
            ideal = "ablation.ideal.{k}." + f"case{case}.{q}"
            verdict = "holds" if _ordered(_order_values(self.m, ideal)) else "fails"
            return cause, (f"{vals}; {text}; with the ideal robot the ordering {verdict}: "
                           f"{_values_text(self.m, ideal)}")  # fmt: skip
        sweep = self.sweep(q, f"case{case}")
        if sweep is not None:
            return (
                "unprinted-setting",
                f"{vals} (DO1SMC observer gain L = {self.cfg['do1_gain']:g}); {sweep}",
            )
        return "implementation", f"{vals}: all up, the ordering differs (not explained)"

    def sweep(self, q: str, case_key: str) -> str | None:
        """The DO1SMC values at the ends of the ``do1_gain`` range when one of them puts the
        three in the book's order; ``None`` otherwise."""
        lo, hi = _do1_range(self.study)
        keys = [f"sweep.do1smc_L{g:g}.{case_key}.{q}" for g in (lo, hi)]
        if not all(k in self.m for k in keys):
            return None
        v4, _, vs = _order_values(self.m, "{k}." + f"{case_key}.{q}")
        vals = [self.m[k] for k in keys]
        if not any(_ordered([v4, v, vs]) for v in vals):
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
    ctx: StudyContext, published: dict[str, float], keys: tuple[str, ...], table: str
) -> dict[str, Any]:
    study, folder, quick, robot = ctx.name, ctx.out, ctx.quick, (ctx.plant, ctx.nominal)
    cfg, tw = study_settings(study, ctx.settings, ctx.twin)
    q1d_dot = cfg["speed"]
    duration = min(4.0, cfg["duration"]) if quick else cfg["duration"]
    window = (2.0, duration) if quick else tuple(cfg["rms_window"])
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for case in (1, 2):
        for kind in KINDS:
            res = run_one(kind, case, q1d_dot, cfg, duration=duration, twin=tw, plant=ctx.plant,
                          nominal=ctx.nominal)  # fmt: skip
            name = f"{kind}.case{case}"
            runs[name] = res
            for q, v in _rms_metrics(res, q1d_dot, window).items():
                metrics[f"{name}.{q}"] = v
    for gain in _do1_range(study):  # DO1SMC at the ends of its open observer gain, Case 1
        res = run_one("do1smc", 1, q1d_dot, {**cfg, "do1_gain": gain}, duration=duration,
                      twin=tw, plant=ctx.plant, nominal=ctx.nominal)  # fmt: skip
        name = f"sweep.do1smc_L{gain:g}.case1"
        runs[name] = res
        for q, v in _rms_metrics(res, q1d_dot, window).items():
            metrics[f"{name}.{q}"] = v
    ab_duration = min(QUICK_ABLATION, duration) if quick else duration
    ab_window = (ab_duration / 2, ab_duration) if quick else window
    ab = _run_ablation(cfg, tw, q1d_dot, (1, 2), ab_duration, ab_window,
                       [_ab_order(q, c) for c in (1, 2) for q in keys]
                       + [_ab_up(c) for c in (1, 2)], *robot)  # fmt: skip
    metrics.update(ab.metrics)
    claims = []
    for case in (1, 2):
        ck = f"case{case}"
        ev = _Evidence(study, cfg, {k: runs[f"{k}.{ck}"] for k in KINDS}, metrics, ab, *robot,
                       twin=tw)
        for q in keys:
            fmt = "{k}." + f"{ck}.{q}"
            holds = _ordered(_order_values(metrics, fmt))
            claims.append(_claim(
                f"order.{q}.{ck}", f"DO4SMC < DO1SMC < SMC in {q}, Case {case} ({table})",
                holds, True, [fmt.format(k=k) for k in ("do4smc", "do1smc", "smc")],
                None if holds else ev.order(fmt, case, q),
            ))  # fmt: skip
        up = not ev.fallen()
        claims.append(_claim(
            f"up.{ck}", f"all three keep the robot up for {duration:g} s, Case {case}", up,
            True, [f"{k}.{ck}.t_end" for k in KINDS], None if up else ev.fall(case),
        ))  # fmt: skip
        if q1d_dot != 0.0:
            finals = [metrics[f"{k}.{ck}.final_speed"] for k in KINDS]
            track = all(np.isfinite(v) and abs(v - q1d_dot) <= TRACK_TOL * abs(q1d_dot)
                        for v in finals)  # fmt: skip
            why = None
            if not track:
                why = ev.speed_cap(case) or (ev.fall(case) if not up else (
                    "implementation",
                    "mean speeds " + ", ".join(f"{LABEL[k]} {v:.3g}" for k, v in
                                               zip(KINDS, finals, strict=True))
                    + " rad/s, all up (not explained)"))  # fmt: skip
            claims.append(_claim(
                f"track.{ck}",
                f"all three move at {q1d_dot:g} rad/s (mean over the last {TRACK_WINDOW:g}"
                f" s within {TRACK_TOL:.0%}), Case {case}", track, True,
                [f"{k}.{ck}.final_speed" for k in KINDS], why,
            ))  # fmt: skip
    tables = write_ablation(ab, folder, ("rms_theta", *[q for q in keys if q != "rms_theta"],
                                         "t_end"))  # fmt: skip
    return save_study(
        ctx, metrics=metrics, published=published, claims=claims, runs=runs_record(runs),
        settings=_settings(cfg, tw, {"q1d_dot": q1d_dot}, duration, window, tables, ctx.plant),
        series=runs, figures={f"{study}.png": _figure(runs, q1d_dot, study, ctx.plant)},
    )  # fmt: skip


def run_balance(ctx: StudyContext) -> dict[str, Any]:
    """``exp-hodosmc-balance``: Table 6.4 on the twin (Cases 1-2, ``q1d' = 0``)."""
    return _rms_experiment(ctx, PUBLISHED_BALANCE, ("rms_theta", "rms_speed_err"), "Table 6.4")


def run_speed(ctx: StudyContext) -> dict[str, Any]:
    """``exp-hodosmc-speed``: Table 6.5 on the twin (Cases 1-2, ``q1d' = -7 rad/s``)."""
    return _rms_experiment(ctx, PUBLISHED_SPEED, ("rms_speed_err",), "Table 6.5")


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


def run_obstacle(ctx: StudyContext) -> dict[str, Any]:
    """``exp-hodosmc-obstacle``: Table 6.6 on the twin (Case 3: payload + stick at 6 s)."""
    study, folder, quick, robot = ctx.name, ctx.out, ctx.quick, (ctx.plant, ctx.nominal)
    cfg, tw = study_settings(study, ctx.settings, ctx.twin)
    speed, stick_start = cfg["speed"], cfg["stick_start"]
    duration = min(7.0, cfg["duration"]) if quick else cfg["duration"]
    cases = ((3, ""),) if quick else ((3, ""), (-1, "case1_stick."))
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for case, tag in cases:
        for kind in KINDS:
            res = run_one(kind, case, speed, cfg, duration=duration, twin=tw, plant=ctx.plant,
                          nominal=ctx.nominal)  # fmt: skip
            name = f"{tag}{kind}"
            runs[name] = res
            ok = res.status[0] == "ok"
            w_meas = board_signals(res)[1]  # the encoder speed, as Table 6.6 (issue 23)
            metrics[f"{name}.settling_time"] = (
                obstacle_settling_time(res.t, w_meas, stick_start) if ok else float("nan")
            )
            metrics[f"{name}.rms_speed_err"] = (
                float(rms(res.t, w_meas - speed, (cfg["rms_start"], stick_start)))
                if ok else float("nan")
            )  # fmt: skip
            pre_stick = res.t < stick_start
            metrics[f"{name}.speed_before_stick"] = (
                float(np.nanmean(w_meas[pre_stick][-50:])) if ok else float("nan")
            )
            metrics[f"{name}.t_end"] = float(res.t_end[0])

    def settle_order(m: Mapping[str, float]) -> bool:
        return _ordered([m[f"{k}.case3.settling_time"] for k in ("do4smc", "do1smc", "smc")])

    ab = _run_ablation(cfg, tw, speed, (3,), duration, (cfg["rms_start"], stick_start),
                       [("settling time DO4SMC < DO1SMC < SMC, Case 3", settle_order),
                        _ab_up(3)], *robot)  # fmt: skip
    metrics.update(ab.metrics)
    claims = []
    for case, tag in cases:
        book = case == 3
        what = "Case 3" if case == 3 else "stick without payload (extra)"
        fmt = tag + "{k}.settling_time"
        holds = _ordered(_order_values(metrics, fmt))
        ev = _Evidence(study, cfg, {k: runs[f"{tag}{k}"] for k in KINDS}, metrics, ab, *robot,
                       twin=tw)
        why = None
        if book and not holds:
            why = ev.speed_cap(3) or (ev.fall(3) if ev.fallen() else (
                "implementation", f"{_values_text(metrics, fmt)}: all up, the ordering "
                "differs (not explained)"))  # fmt: skip
        claims.append(_claim(
            f"order.{tag or 'case3.'}settling_time",
            f"settling time DO4SMC < DO1SMC < SMC, {what} (Table 6.6)", holds, book,
            [fmt.format(k=k) for k in ("do4smc", "do1smc", "smc")], why,
        ))  # fmt: skip
        settled = all(np.isfinite(metrics[f"{tag}{k}.settling_time"]) for k in KINDS)
        why = None
        if book and not settled:
            why = ev.speed_cap(3) or (ev.fall(3) if ev.fallen() else (
                "implementation",
                "all up; never in (-9, -5) rad/s after the stick: "
                + _values_text(metrics, fmt) + " (not explained)"))  # fmt: skip
        claims.append(_claim(
            f"settle.{tag or 'case3.'}".rstrip("."),
            f"all three cross the stick and settle in (-9, -5) rad/s, {what}",
            settled, book, [f"{tag}{k}.settling_time" for k in KINDS], why,
        ))  # fmt: skip
    stick = _stick_doc(cfg, ctx.plant)
    tables = write_ablation(ab, folder, ("settling_time", "rms_theta", "t_end"))
    return save_study(
        ctx, metrics=metrics, published=PUBLISHED_OBSTACLE, claims=claims, runs=runs_record(runs),
        settings=_settings(cfg, tw, {"q1d_dot": speed, "band": list(BAND), "stick": stick,
                                     "stick_speed": cfg["stick_speed"]},
                           duration, (cfg["rms_start"], stick_start), tables, ctx.plant),
        series=runs,
        figures={f"{study}.png": _figure(runs, speed, study, ctx.plant, cases=("",))},
    )  # fmt: skip


def _stick_doc(cfg: Mapping[str, Any], plant: Params) -> dict[str, float]:
    p = case_plant(2, base=plant)
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
    runs: dict[str, SimResult], q1d_dot: float, title: str, plant: Params,
    cases: tuple[str, ...] = (".case1", ".case2"),
) -> Figure:  # fmt: skip
    """The book's layout (Figs. 6.4-6.8): angle, speed and torque against time in 0.1 s."""
    fig = Figure(figsize=(6 * len(cases), 9), layout="constrained")
    axes = fig.subplots(3, len(cases), squeeze=False)
    colors = {"smc": "tab:blue", "do1smc": "tab:green", "do4smc": "tab:red"}
    for j, case in enumerate(cases):
        for kind in KINDS:
            res = runs[f"{kind}{case}"]
            t = res.t * 10.0
            label = mark_fall(axes[:, j], res, LABEL[kind], colors[kind], scale=10.0)
            kw = {"color": colors[kind], "lw": 0.9, "label": label}
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
    for ax in axes[0]:
        ax.legend(fontsize=8)
    fig.suptitle(f"{title} on the digital twin ({robot_label(plant)})")
    return fig


STUDIES = (
    Study(NAME_BALANCE, SOURCE_BALANCE, run_balance, place=(6, 4), cost=7),
    Study(NAME_SPEED, SOURCE_SPEED, run_speed, place=(6, 6), cost=6),
    Study(NAME_OBSTACLE, SOURCE_OBSTACLE, run_obstacle, place=(6, 8), cost=6),
)
