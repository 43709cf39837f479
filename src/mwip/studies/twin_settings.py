"""The digital twin a Chapter 6 study runs on, and its ablation.

One source of the twin's numbers: the robot file (:mod:`mwip.robot`, its hardware tables with
their sources; the default robot's twin is the identified one, ``mwip robot show``). A run
takes it from ``mwip run/reproduce --robot FILE`` or from a study file's ``[robot] file =
FILE`` (:mod:`mwip.studies.study_file`), through the context's ``twin``
(:class:`~mwip.studies.study.StudyContext`). The studies' own settings hold only what the book
prints for the experiment (gains, initial state, durations); the controllers sample at the
twin's ``Ts``.

Every Chapter 6 study also runs the ablation of :mod:`mwip.hardware.ablation`: the ideal
robot, then each physical element added in turn (cumulative, in the order of
:data:`mwip.hardware.elements.ELEMENTS`), one batched twin run per controller and case.
Its tables go to ``ablation.md`` and ``ablation.html`` in the study's folder
(:func:`write_ablation`), named in metrics.json under ``settings.ablation_table``
(:data:`ABLATION_FIELD`), and its numbers are the evidence of a claim that fails on the full
twin (:func:`fall_evidence`: where a run stops balancing, :func:`balances`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mwip.hardware.ablation import Ablation
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.identified import default_twin
from mwip.hardware.twin import Twin, case_plant
from mwip.io import write_text_atomic
from mwip.models.reduced import f_g
from mwip.params import Params
from mwip.studies import settings
from mwip.studies.registry import robot as book_robot

__all__ = [
    "ABLATION_FIELD",
    "QUICK_ABLATION",
    "fall_evidence",
    "input_gain_ratio",
    "payload_evidence",
    "first_fall",
    "balances",
    "BALANCE_RMS",
    "robot_label",
    "study_settings",
    "twin_doc",
    "write_ablation",
]

#: Key of metrics.json's ``settings`` naming the ablation table files (``{"html": ...,
#: "md": ...}``, relative to the study's folder).
ABLATION_FIELD = "ablation_table"


def study_settings(
    name: str, cfg: Mapping[str, Any] | None = None, twin: Twin | None = None
) -> tuple[dict[str, Any], Twin]:
    """The settings ``cfg`` of study ``name`` (default: its study file's) with the twin's
    ``Ts`` and ``dt`` (the controllers sample at the twin's period), and the twin ``twin``
    (default: the default twin; a run passes the context's, ``ctx.twin``)."""
    tw = default_twin() if twin is None else twin
    base = settings.defaults(name) if cfg is None else dict(cfg)
    return {**base, "Ts": tw.Ts, "dt": tw.dt}, tw


#: quick mode: the ablation's runs last this long (s), RMS over its second half
QUICK_ABLATION = 2.0


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


def payload_evidence(
    lam: float, which: str = "g2 + l3 g1", *, plant: Params | None = None,
    nominal: Params | None = None, twin: Twin | None = None,
) -> str:  # fmt: skip
    """Why Case 2/3 is hard, from the robot in use (``plant``, designs on ``nominal``;
    default: the book's; the payload of ``twin``, default the data-sheet's): the payload
    (absent from the design model) multiplies the pitch inertia and cuts the input gain the
    controllers assume."""
    p1, nominal = book_robot(plant, nominal)
    p2 = case_plant(2, base=p1, twin=twin)
    low = p1.with_payload(body_height=float(p1.l))
    return (
        f"the 0.5 kg pan (not in the design model) raises the pitch inertia Iby from "
        f"{float(p1.Iby):.3g} to {float(p2.Iby):.3g} kg m^2 and leaves the controllers "
        f"{input_gain_ratio(p2, nominal, lam):.2f} of the input gain {which} of (2.36) "
        f"they divide by (Case 1: {input_gain_ratio(p1, nominal, lam):.2f}; still "
        f"{input_gain_ratio(low, nominal, lam):.2f} with the pan only 0.1 m above the centre "
        f"of mass)"
    )


def twin_doc(twin: Twin) -> str:
    """One line naming the twin (for the recorded settings)."""
    off = [e for e in ELEMENTS if e not in twin.active]
    d = twin.drive
    return (
        f"{d.mode} drive (RE25 + {d.gear_ratio:g}:1, {d.supply_voltage:g} V, "
        f"{d.current_limit:g} A, {d.pwm_levels} PWM levels), {twin.firmware.fusion.kind} fusion "
        f"(tau {twin.firmware.fusion.tau:g} s), "
        f"encoders {twin.encoder.cpr} cpr, sampled every {twin.Ts * 1e3:g} ms with "
        f"{twin.firmware.delay:g} Ts delay, plant step {twin.dt * 1e3:g} ms; elements off: "
        f"{', '.join(off) or 'none'} (mwip robot show)"
    )


def robot_label(plant: Params) -> str:
    """The robot that ran, for figure titles: mass, wheel radius and the damping
    coefficients as the equations use them (whatever reading or file produced them)."""
    return (
        f"plant mb {float(plant.mb):g} kg, r {float(plant.r):g} m, "
        f"Db {float(plant.Db):.3g}, Dw {float(plant.Dw):.3g} N m s/rad"
    )


def write_ablation(ab: Ablation, folder: Path, quantities: Sequence[str]) -> dict[str, str]:
    """Write the tables of ``quantities`` (``rms_theta``, ``t_end``, ...) to
    ``folder/ablation.md`` and ``folder/ablation.html``; returns ``{"md": ..., "html": ...}``
    (names relative to ``folder``) for metrics.json's ``settings[ABLATION_FIELD]``."""
    folder.mkdir(parents=True, exist_ok=True)
    md = "\n\n".join(ab.table(q) for q in quantities) + "\n"
    html = "\n".join(f"<h4>{q}</h4>\n{ab.table(q, html=True)}" for q in quantities) + "\n"
    write_text_atomic(folder / "ablation.md", md)
    write_text_atomic(folder / "ablation.html", html)
    return {"md": "ablation.md", "html": "ablation.html"}


#: a run "balances" at an ablation step when it stays up with an RMS pitch below this (rad)
BALANCE_RMS = 0.35


def _steps(ab: Ablation) -> list[str]:
    return [s for s, _ in ab.steps]


def _key(ab: Ablation, step: str, run: str, case: int, q: str) -> float:
    return float(ab.metrics.get(f"ablation.{step}.{run}.case{case}.{q}", float("nan")))


def balances(ab: Ablation, step: str, run: str, case: int) -> bool:
    """Run ``run`` stays up at ablation step ``step`` (Case ``case``) with an RMS pitch below
    :data:`BALANCE_RMS`."""
    th = _key(ab, step, run, case, "rms_theta")
    return _key(ab, step, run, case, "fell") != 1.0 and bool(np.isfinite(th)) and th < BALANCE_RMS


def first_fall(ab: Ablation, run: str, case: int) -> str | None:
    """The first ablation step at which ``run`` no longer balances in Case ``case``
    (:func:`balances`; ``None``: it balances at every step)."""
    for s in _steps(ab):
        if not balances(ab, s, run, case):
            return s
    return None


def fall_evidence(ab: Ablation, run: str, case: int, label: str | None = None) -> str:
    """Where run ``run`` (Case ``case``) stops balancing along the ablation, with the numbers:
    e.g. "SMC balances with the ideal robot (RMS theta 0.0011 rad) and up to `delay` (RMS theta
    0.004 rad); falls at 0.52 s once `friction` is added"."""
    name = label or run.upper()
    steps = _steps(ab)

    def state(step: str) -> str:
        if _key(ab, step, run, case, "fell") == 1.0:
            return f"falls at {_key(ab, step, run, case, 't_end'):.2f} s"
        return f"stays up but leans with RMS theta {_key(ab, step, run, case, 'rms_theta'):.2g} rad"

    first = first_fall(ab, run, case)
    ideal = _key(ab, "ideal", run, case, "rms_theta")
    if first == "ideal":
        return f"{name} {state('ideal')} already with the ideal robot (no twin element)"
    head = f"{name} balances with the ideal robot (RMS theta {ideal:.2g} rad)"
    if first is None:
        full = _key(ab, steps[-1], run, case, "rms_theta")
        return f"{head} and with every element added (full twin: RMS theta {full:.2g} rad)"
    last = steps[steps.index(first) - 1]
    if last != "ideal":
        head += f" and up to `{last}` (RMS theta {_key(ab, last, run, case, 'rms_theta'):.2g} rad)"
    text = f"{head}; {state(first)} once `{first}` is added"
    again = [s for s in steps[steps.index(first) + 1 :] if balances(ab, s, run, case)]
    if again:
        text += f" (balances again from `{again[0]}` on)"
    return text
