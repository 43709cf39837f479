"""Ablation of the twin: the ideal robot, then each physical element added in turn.

A study hands over its runs as ``(name, controller factory)`` pairs and gets, for every step
``ideal, +inertia, +motor, ...`` (:data:`mwip.hardware.elements.ELEMENTS` order) and every
case, its metrics under the keys ``ablation.<step>.<run>.case<k>.<quantity>`` (``<step>`` is
``ideal`` or the element just added; the last step is the full twin) plus a table that shows
which physical effect decides which claim::

    from mwip.hardware.ablation import rms_metrics, run_ablation
    ab = run_ablation(
        [("smc", lambda: make_controller("smc", cfg, q1d)), ...],
        cases=(1, 2),
        metrics=rms_metrics(window=(2.0, 10.0), q1d_dot=q1d),
        run_kwargs=lambda run, case: {"q0": (0, cfg["theta0"], 0), "duration": 10.0,
                                      "record_every": 2, "seed": cfg["seed"]},
        claims=[("DO4SMC < DO1SMC < SMC in rms_theta, Case 1",
                 lambda m: m["do4smc.case1.rms_theta"] < m["do1smc.case1.rms_theta"]
                 < m["smc.case1.rms_theta"])],
    )
    metrics.update(ab.metrics)          # flat floats for metrics.json
    text = ab.table("rms_theta")        # markdown; ab.table(..., html=True) for the report

All steps of one (run, case) are one batched engine run (one controller instance drives a
batch of twins that differ only in their elements; every row sees the IMU noise of a single
run with the same seed), so the controller must be batch-capable; ``batched=False`` runs them
one by one (same numbers, tested).
"""

from __future__ import annotations

import html as _html
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from mwip.hardware.elements import ELEMENTS, REQUIRES, check_elements
from mwip.hardware.identified import default_twin
from mwip.hardware.twin import Twin, run_on_twin
from mwip.metrics import rms
from mwip.params import Params
from mwip.sim.result import SimResult

__all__ = [
    "board_signals", "mark_fall", "ablation_steps", "rms_metrics", "run_ablation", "Ablation",
    "MetricFn"]

#: ``metrics(result, run, case) -> {quantity: value}`` for one (unbatched) twin run.
MetricFn = Callable[[SimResult, str, int], Mapping[str, float]]
#: A claim: its text and a test on one step's metrics (keys ``<run>.case<k>.<quantity>``);
#: the test may return ``None`` when it cannot be judged (a run fell).
Claim = tuple[str, Callable[[Mapping[str, float]], bool | None]]


def ablation_steps(
    order: Sequence[str] = ELEMENTS, *, cumulative: bool = True
) -> list[tuple[str, frozenset[str]]]:
    """``[("ideal", {}), (e1, {e1}), (e2, {e1, e2}), ...]`` (``cumulative``) or each element
    alone with what it acts through (``[("ideal", {}), (e1, {e1}), ("pwm", {"motor", "pwm"}),
    ...]``, :data:`mwip.hardware.elements.REQUIRES`)."""
    names = list(order)
    check_elements(names, "order")
    if len(set(names)) != len(names):
        raise ValueError(f"'order' lists an element twice: {names}")
    steps: list[tuple[str, frozenset[str]]] = [("ideal", frozenset())]
    for k, name in enumerate(names):
        alone = frozenset({name}) | REQUIRES.get(name, frozenset())
        steps.append((name, frozenset(names[: k + 1]) if cumulative else alone))
    return steps


def board_signals(res: SimResult) -> tuple[Any, Any]:
    """What the robot's board recorded in a single twin run: its fused pitch estimate and
    the encoder wheel speed ``psi'`` (``y_meas`` columns 1 and 3), the signals the book's
    Chapter 6 tables and figures show (issue 23); the true ``theta``, ``psi'`` where the run
    has no measurements (a plain-plant run)."""
    meas = res.series().get("y_meas")
    if meas is None:
        return res.theta, res.q_dot[:, 0]
    return meas[:, 1], meas[:, 3]


def mark_fall(axes: Any, res: SimResult, label: str, color: str, scale: float = 1.0) -> str:
    """On a study figure, a run that stopped early: a dashed line at its stop time on every
    axis in ``axes`` (time in units of ``1 / scale`` s) and the legend label with its status and
    cause, e.g. ``"SMC: fell at t = 0.42 s (|theta| beyond the fall limit)"`` (issue 25: a
    fall drawn with no word why). Returns the label to use (``label`` itself for a run that
    stood)."""
    status = str(res.status[0])
    if status == "ok":
        return label
    t_end = float(res.t_end[0])
    for ax in axes:
        ax.axvline(t_end * scale, color=color, ls="--", lw=0.8)
    why = {"fell": "|theta| beyond the fall limit",
           "diverged": "the state left its numeric range"}.get(status, status)  # fmt: skip
    return f"{label}: {status} at t = {t_end:.2f} s ({why})"


def rms_metrics(window: tuple[float, float], q1d_dot: float = 0.0) -> MetricFn:
    """The Table 6.4/6.5/6.7 quantities of a run, RMS (6.3) over ``window``:
    ``rms_theta`` (true pitch), ``rms_theta_meas`` (the board's estimate, what the book's
    hardware logs show), ``rms_speed_err`` (``psi' - q1d_dot``), ``max_abs_u`` (applied),
    ``t_end`` and ``fell`` (1 when the run stopped early). RMS values are NaN for a fall."""

    def fn(res: SimResult, run: str, case: int) -> dict[str, float]:
        ok = bool(res.status[0] == "ok")
        s = res.series()
        nan = float("nan")
        meas = s.get("y_meas")
        u = s.get("u_applied", res.u)
        return {
            "rms_theta": float(rms(res.t, res.theta, window)) if ok else nan,
            "rms_theta_meas": float(rms(res.t, meas[:, 1], window)) if ok and meas is not None
            else nan,
            "rms_speed_err": float(rms(res.t, res.q_dot[:, 0] - q1d_dot, window)) if ok else nan,
            "max_abs_u": float(np.nanmax(np.abs(u))) if np.size(u) else nan,
            "t_end": float(res.t_end[0]),
            "fell": 0.0 if ok else 1.0,
        }  # fmt: skip

    return fn


@dataclass(frozen=True)
class Ablation:
    """Result of :func:`run_ablation`.

    ``metrics``: flat ``ablation.<step>.<run>.case<k>.<quantity>`` floats; ``steps``: the
    step names in order with their element sets; ``claims``: ``{step: [holds, ...]}`` in the
    order of the claims given (``None`` where a claim could not be judged); ``claim_texts``.
    """

    metrics: dict[str, float]
    steps: list[tuple[str, frozenset[str]]]
    runs: list[str]
    cases: tuple[int, ...]
    claim_texts: list[str] = field(default_factory=list)
    claims: dict[str, list[bool | None]] = field(default_factory=dict)
    alone: bool = False

    def step_metrics(self, step: str) -> dict[str, float]:
        """One step's metrics without the ``ablation.<step>.`` prefix."""
        pre = f"ablation.{step}."
        return {k[len(pre) :]: v for k, v in self.metrics.items() if k.startswith(pre)}

    def table(self, quantity: str = "rms_theta", *, html: bool = False, digits: int = 4) -> str:
        """One row per step: ``quantity`` of every run and case ("fell" for a fall), then the
        claims' verdicts (C1, C2, ... listed under the table)."""
        cols = [f"{r}.case{c}" for c in self.cases for r in self.runs]
        head = ["step", *cols, *[f"C{i + 1}" for i in range(len(self.claim_texts))]]
        body = []
        alone = self.alone
        for step, _ in self.steps:
            m = self.step_metrics(step)
            label = f"only {step}"
            if alone and step in REQUIRES:
                label += f" (with {', '.join(sorted(REQUIRES[step]))})"
            row = ["ideal robot" if step == "ideal" else (label if alone else f"+ {step}")]
            for c in cols:
                v = m.get(f"{c}.{quantity}", float("nan"))
                fell = m.get(f"{c}.fell", 0.0) == 1.0
                row.append("fell" if fell else ("n/a" if not np.isfinite(v) else f"{v:.{digits}g}"))
            for h in self.claims.get(step, []):
                row.append("n/a" if h is None else ("holds" if h else "fails"))
            body.append(row)
        notes = [f"C{i + 1}: {t}" for i, t in enumerate(self.claim_texts)]
        if html:
            esc = _html.escape
            out = ["<table>", "<tr>" + "".join(f"<th>{esc(h)}</th>" for h in head) + "</tr>"]
            out += ["<tr>" + "".join(f"<td>{esc(x)}</td>" for x in r) + "</tr>" for r in body]
            out.append("</table>")
            if notes:
                out.append("<p>" + "<br>".join(esc(n) for n in notes) + "</p>")
            return "\n".join(out)
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(r) + " |" for r in body]
        how = "each alone" if alone else "added in turn"
        text = f"{quantity} with the twin's elements {how}\n\n" + "\n".join(lines)
        return text + ("\n\n" + "\n".join(notes) if notes else "")


def _judge(test: Callable[[Mapping[str, float]], bool | None], m: Mapping[str, float]) -> Any:
    try:
        out = test(m)
    except KeyError:
        return None
    return None if out is None else bool(out)


def run_ablation(
    runs: Sequence[tuple[str, Callable[[], Any]]],
    twin: Twin | None = None,
    *,
    cases: Iterable[int] = (1,),
    metrics: MetricFn | None = None,
    run_kwargs: Mapping[str, Any] | Callable[[str, int], Mapping[str, Any]] | None = None,
    plant: Callable[[int], Params] | None = None,
    order: Sequence[str] = ELEMENTS,
    cumulative: bool = True,
    claims: Sequence[Claim] = (),
    batched: bool = True,
) -> Ablation:
    """The ideal robot, then the elements of ``order`` added in turn (or alone), on ``twin``
    (default: the default twin; its values are used, its own ``elements`` are ignored).

    runs : ``(name, factory)``; ``factory()`` builds a fresh controller (designed on the
        nominal parameters: the twin never changes a design).
    cases : Chapter 6 cases (1 robot, 2 payload, 3 payload + stick).
    metrics : quantities of one run (default :func:`rms_metrics` over 2-10 s, ``q1d' = 0``).
    run_kwargs : extra keywords of :func:`mwip.hardware.twin.run_on_twin` (``q0``,
        ``duration``, ``record_every``, ``seed``, ``stick_speed``, ...), or a function of
        ``(run, case)`` returning them.
    plant : ``case -> Params``, the case's plant before the twin's drive train (default
        :func:`mwip.hardware.twin.case_plant`).
    claims : ``(text, test)``: each test gets one step's metrics (keys
        ``<run>.case<k>.<quantity>``) and says whether the claim holds.
    """
    tw = replace(default_twin() if twin is None else twin, elements=frozenset(ELEMENTS),
                 ideal_sensors=False, ideal_actuator=False)  # fmt: skip
    steps = ablation_steps(order, cumulative=cumulative)
    fn = metrics if metrics is not None else rms_metrics((2.0, 10.0))
    cases = tuple(cases)
    out: dict[str, float] = {}
    names = [name for name, _ in runs]
    if len(set(names)) != len(names):
        raise ValueError(f"run names must be unique, got {names}")
    for name, factory in runs:
        for case in cases:
            kw = dict(run_kwargs(name, case) if callable(run_kwargs) else (run_kwargs or {}))
            if plant is not None:
                kw["plant"] = plant(case)
            if batched:
                res = run_on_twin(factory(), case, twin=tw, rows=[s for _, s in steps], **kw)
                rows = [res.plant(i) for i in range(len(steps))]
            else:
                rows = [run_on_twin(factory(), case, twin=replace(tw, elements=s), **kw)
                        for _, s in steps]  # fmt: skip
            for (step, _), r in zip(steps, rows, strict=True):
                for q, v in fn(r, name, case).items():
                    out[f"ablation.{step}.{name}.case{case}.{q}"] = float(v)
    ab = Ablation(out, steps, names, cases, [t for t, _ in claims], alone=not cumulative)
    for step, _ in steps:
        m = ab.step_metrics(step)
        ab.claims[step] = [_judge(test, m) for _, test in claims]
    return ab
