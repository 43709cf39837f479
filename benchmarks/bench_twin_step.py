"""What bounds the compiled twin against the plain batch engine (issue 35, speed): the twin's
integration step ``dt``, measured.

In one process, after a warm-up of each path: HODOSMC (book gains) on the robustness
campaign's robots (seed 2026, one :func:`mwip.campaign.blocks.run_block` per chunk, as
``mwip tune`` and ``mwip campaign run`` run them), on

- ``plain``: the plain plant (ideal sensors and drive), one 5 ms RK4 step per sample: the
  reference rate;
- the default robot's twin (compiled twin loop) with its plant step ``dt`` = 0.5 ms (the
  twin's), and the same robot with ``dt`` halved (0.25 ms: the step-halving check of the
  default) and coarser (1 ms, 1.25 ms, 2.5 ms, 5 ms).

Per step it prints the plant-seconds per second, the ratio to ``plain``, and how far the
campaign metrics move from the finest step (0.25 ms): the largest change of ``rms_theta``
relative to its value, of ``peak_torque`` (N m) and the number of robots whose success
flips. A step whose metrics match the halved step's is converged; the ratio it reaches is what
the step costs. Usage::

    PYTHONPATH=src python benchmarks/bench_twin_step.py [--robots 256] [--chunk 256]
        [--duration 10] [--repeat 2]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from typing import Any

import numpy as np

STEPS_MS = (0.25, 0.5, 1.0, 1.25, 2.5, 5.0)


def _rows(plant: str, robots: int, chunk: int, duration: float, dt: float | None) -> Any:
    """The metrics of HODOSMC on the robots (``dt``: the twin's step, ``None`` its own)."""
    from mwip.campaign.blocks import run_block
    from mwip.campaign.spec import ControllerEntry
    from mwip.laws.registry import get
    from mwip.robot import default_robot
    from mwip.tune.evaluate import robot_set

    robot = default_robot()
    if dt is not None:
        robot = replace(robot, twin=replace(robot.twin, dt=dt))
    rs = robot_set("robustness", robots, chunk, 2026, plant=plant, duration=duration,
                   robot=robot)  # fmt: skip
    spec = get("hodosmc")
    ctrl = spec.build(rs.campaign.design, spec.resolve({}))
    camp = replace(rs.campaign, controllers=(ControllerEntry("hodosmc", "hodosmc", ()),))
    parts = [run_block(camp, b, {"hodosmc": ctrl})[0] for b in range(robots // chunk)]
    return {k: np.concatenate([p[k] for p in parts])
            for k in ("rms_theta", "peak_torque", "success")}  # fmt: skip


def bench(robots: int, chunk: int, duration: float, repeat: int) -> None:
    paths: dict[str, tuple[str, float | None]] = {"plain": ("plain", None)}
    paths.update({f"twin dt {ms:g} ms": ("twin", ms * 1e-3) for ms in STEPS_MS})
    for plant, dt in paths.values():  # warm-up: compilation and caches
        _rows(plant, chunk, chunk, 0.1, dt)
    best: dict[str, float] = {}
    out: dict[str, Any] = {}
    for _ in range(repeat):
        for name, (plant, dt) in paths.items():
            t0 = time.perf_counter()
            out[name] = _rows(plant, robots, chunk, duration, dt)
            best[name] = min(best.get(name, np.inf), time.perf_counter() - t0)
    ps = robots * duration
    ref = out[f"twin dt {STEPS_MS[0]:g} ms"]
    print(f"HODOSMC, {robots} robots x {duration:g} s in chunks of {chunk} (best of {repeat}); "
          f"metric changes against dt = {STEPS_MS[0]:g} ms")
    print("| path | s | plant-s/s | vs plain | max rel. change rms_theta | max change "
          "peak_torque (N m) | success flips |")
    print("|---|---|---|---|---|---|---|")
    plain = ps / best["plain"]
    for name, t in best.items():
        rate = ps / t
        if name == "plain":
            cells = ["-", "-", "-"]
        else:
            m = out[name]
            both = ref["success"] & m["success"]
            rel = np.abs(m["rms_theta"][both] - ref["rms_theta"][both]) / ref["rms_theta"][both]
            dpk = np.abs(m["peak_torque"][both] - ref["peak_torque"][both])
            flips = int(np.sum(m["success"] != ref["success"]))
            cells = [f"{rel.max():.1e}" if both.any() else "-",
                     f"{dpk.max():.1e}" if both.any() else "-", str(flips)]  # fmt: skip
        print(f"| {name} | {t:.2f} | {rate:,.0f} | {rate / plain:.3f} | " + " | ".join(cells)
              + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=256)
    ap.add_argument("--chunk", type=int, default=256)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    bench(a.robots, a.chunk, a.duration, a.repeat)


if __name__ == "__main__":
    main()
