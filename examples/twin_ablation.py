"""Ablation of the Chapter 6 studies on the default twin (the book's robot identified from its
Chapter 6 evidence, `mwip robot show`; or the robot of --robot FILE, a robot file: its twin,
its body and its design model): the ideal robot first, then the twin's elements added one at
a time.

Shows how a study calls :func:`mwip.hardware.ablation.run_ablation` with its own controller
factories, settings and claims. Run (four studies; about 10 s in all with warm caches on the
2-core machine, BENCHMARKS.md "Silence")::

    python examples/twin_ablation.py [--robot FILE] [--out DIR] [--quick] [--alone] [--force]

``--alone``: each element alone on the ideal robot instead of added in turn. ``--out``: a new
or empty folder, or one this script wrote (default ``ablation``; another only with --force).

Writes ``DIR/ablation.json`` (flat ``ablation.<element>.<run>.case<k>.<quantity>``) and
``DIR/ablation.md`` (the tables).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mwip import outdir
from mwip.hardware.ablation import Ablation, rms_metrics, run_ablation
from mwip.hardware.identified import default_twin
from mwip.hardware.twin import Twin
from mwip.io import write_text_atomic
from mwip.metrics import rms
from mwip.studies import exp_asta, exp_hodosmc, settings
from mwip.studies.exp_hodosmc import obstacle_settling_time


def _ordered(key: str, kinds: tuple[str, ...]) -> Callable[[Mapping[str, float]], bool | None]:
    def test(m: Mapping[str, float]) -> bool | None:
        v = [m[key.format(k=k)] for k in kinds]
        if not np.all(np.isfinite(v)):
            return None
        return bool(all(a < b for a, b in zip(v, v[1:], strict=False)))

    return test


def hodosmc(
    study: str, twin: Twin, quick: bool, alone: bool = False, robot: Any = None
) -> Ablation:
    cfg = {**settings.defaults(study), "Ts": twin.Ts}  # the controllers sample at the twin's Ts
    q1d = cfg["speed"]
    duration = 4.0 if quick else cfg["duration"]
    obstacle = study == exp_hodosmc.NAME_OBSTACLE
    window = (2.0, duration) if quick or obstacle else tuple(cfg["rms_window"])
    base = rms_metrics(window, q1d)

    def metrics(res: Any, run: str, case: int) -> dict[str, float]:
        out = dict(base(res, run, case))
        if obstacle:
            ok = res.status[0] == "ok"
            out["settling_time"] = (
                obstacle_settling_time(res.t, res.q_dot[:, 0], cfg["stick_start"])
                if ok
                else float("nan")
            )
        return out

    kinds = ("do4smc", "do1smc", "smc")
    cases = (3,) if obstacle else (1, 2)
    claims = []
    for case in cases:
        for q in ("settling_time",) if obstacle else ("rms_theta", "rms_speed_err"):
            claims.append(
                (
                    f"DO4SMC < DO1SMC < SMC in {q}, Case {case}",
                    _ordered("{k}.case" + str(case) + "." + q, kinds),
                )
            )
    extra = {k: cfg[k] for k in ("stick_speed", "stick_start") if k in cfg}
    design = None if robot is None else robot.design
    return run_ablation(
        [(k, lambda k=k: exp_hodosmc.make_controller(k, cfg, q1d, design)) for k in kinds[::-1]],
        twin,
        cases=cases,
        plant=None if robot is None else robot.case_plant,
        metrics=metrics,
        run_kwargs={
            "q0": (0.0, cfg["theta0"], 0.0),
            "duration": duration,
            "record_every": cfg["record_every"],
            "seed": cfg["seed"],
            **extra,
        },
        claims=claims,
        cumulative=not alone,
    )


def asta(twin: Twin, quick: bool, alone: bool = False, robot: Any = None) -> Ablation:
    cfg = {**settings.defaults(exp_asta.NAME), "Ts": twin.Ts}
    duration = 4.0 if quick else cfg["duration"]
    window = (2.0, duration) if quick else tuple(cfg["rms_window"])
    base = rms_metrics(window)

    def metrics(res: Any, run: str, case: int) -> dict[str, float]:
        out = dict(base(res, run, case))
        ok = res.status[0] == "ok"
        sig = res.series().get("sigma")
        out["rms_s1"] = float(rms(res.t, sig[:, 0], window)) if ok else float("nan")
        return out

    claims = [
        (f"ASTA < ASMC in {q}, Case {c}", _ordered("{k}.case" + str(c) + "." + q, ("asta", "asmc")))
        for c in (1, 2)
        for q in ("rms_theta", "rms_s1")
    ]
    design = None if robot is None else robot.design
    return run_ablation(
        [(k, lambda k=k: exp_asta.make_controller(k, cfg, design)) for k in exp_asta.KINDS],
        twin,
        cases=(1, 2),
        plant=None if robot is None else robot.case_plant,
        metrics=metrics,
        run_kwargs={
            "q0": (0.0, cfg["theta0"], 0.0),
            "duration": duration,
            "record_every": cfg["record_every"],
            "seed": cfg["seed"],
        },
        claims=claims,
        cumulative=not alone,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", type=Path, default=None, help="a robot file (docs/robot.md)")
    ap.add_argument("--out", type=Path, default=Path("ablation"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--alone", action="store_true")
    ap.add_argument("--force", action="store_true", help="write into a folder not mwip's")
    args = ap.parse_args()
    try:
        outdir.check(args.out, args.force)
    except ValueError as exc:
        ap.error(str(exc))
    robot = None
    if args.robot:
        from mwip.robot import RobotFileError, load_robot

        try:
            robot = load_robot(args.robot)
        except (RobotFileError, OSError) as exc:
            ap.error(str(exc))
    twin = robot.twin if robot is not None else default_twin()
    which = f"the robot of {args.robot}" if robot is not None else "the default twin"
    runs = "quick" if args.quick else "full"
    print(f"ablation on {which}: 4 studies, {runs} runs", flush=True)
    flat: dict[str, float] = {}
    text = []
    quick, al = args.quick, args.alone
    bal, spd, obs = exp_hodosmc.NAME_BALANCE, exp_hodosmc.NAME_SPEED, exp_hodosmc.NAME_OBSTACLE
    jobs: list[tuple[str, Callable[[], Ablation], tuple[str, ...]]] = [
        (
            bal,
            lambda: hodosmc(bal, twin, quick, al, robot),
            ("rms_theta", "rms_theta_meas", "rms_speed_err"),
        ),
        (spd, lambda: hodosmc(spd, twin, quick, al, robot), ("rms_theta", "rms_speed_err")),
        (obs, lambda: hodosmc(obs, twin, quick, al, robot), ("settling_time",)),
        (
            exp_asta.NAME,
            lambda: asta(twin, quick, al, robot),
            ("rms_theta", "rms_theta_meas", "rms_s1"),
        ),
    ]
    for name, job, quantities in jobs:
        ab = job()
        flat.update({f"{name}.{k}": v for k, v in ab.metrics.items()})
        for q in quantities:
            text.append(f"## {name}: {ab.table(q)}\n")
        print(name, "done", flush=True)
    outdir.claim(args.out)
    write_text_atomic(args.out / "ablation.json", json.dumps(flat, indent=1))
    write_text_atomic(args.out / "ablation.md", "\n".join(text))
    print("\n".join(text))
    print(f"wrote {args.out / 'ablation.json'}, {args.out / 'ablation.md'}")


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # Ctrl-C: one line, exit 130 (nothing written yet)
        print("interrupted; nothing written", file=sys.stderr)
        sys.exit(130)
