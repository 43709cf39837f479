"""The twin's compiled loop (issue 27, speed): HODOSMC on a batch of robots on the default twin.

In one process, on the robustness campaign's robots (seed 2026, one campaign block per chunk,
:func:`mwip.campaign.blocks.run_block`, as ``mwip tune`` runs them), after a warm-up of each
path (compilation):

- ``bare``: the plain plant (ideal sensors and drive), the compiled batch loop: the reference;
- ``twin python``: the default twin's sensors and drive in the engine's Python sample loop
  (``simulate(..., compiled=False)``, the path before the compiled twin loop);
- ``twin compiled``: the same runs through the compiled twin loop, :mod:`mwip.hardware.loop`
  (the default);

and prints each path's plant-seconds per second and its ratio to ``bare``, and checks that the
two twin paths give the same metrics. The twin integrates at its own ``dt`` = 0.5 ms (RK4, 10
steps per 5 ms sample) where the plain plant takes one 5 ms RK4 step: a compiled twin run costs
about ten plain runs of plant integration alone. Usage::

    python benchmarks/bench_twin.py [--robots 256] [--chunk 256] [--duration 10] [--repeat 2]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from typing import Any


def _rows(plant: str, robots: int, chunk: int, duration: float, compiled: bool | None) -> Any:
    """Metrics of every block, HODOSMC (book gains) on ``plant``; ``compiled=False`` runs the
    engine's Python loop (the engine's ``simulate`` is wrapped for the call)."""
    import functools

    import numpy as np

    import mwip.sim.engine as engine
    from mwip.campaign.blocks import run_block
    from mwip.campaign.spec import ControllerEntry
    from mwip.laws.registry import get
    from mwip.tune.evaluate import robot_set

    rs = robot_set("robustness", robots, chunk, 2026, plant=plant, duration=duration)
    spec = get("hodosmc")
    ctrl = spec.build(rs.campaign.design, spec.resolve({}))
    camp = replace(rs.campaign, controllers=(ControllerEntry("hodosmc", "hodosmc", ()),))
    orig = engine.simulate
    if compiled is False:
        engine.simulate = functools.partial(orig, compiled=False)  # type: ignore[assignment]
    try:
        parts = [run_block(camp, b, {"hodosmc": ctrl})[0] for b in range(robots // chunk)]
    finally:
        engine.simulate = orig
    return np.concatenate([p["rms_theta"] for p in parts])


def bench(robots: int, chunk: int, duration: float, repeat: int) -> dict[str, float]:
    import numpy as np

    paths = {"bare": ("plain", None), "twin python": ("twin", False),
             "twin compiled": ("twin", None)}  # fmt: skip
    for plant, compiled in paths.values():  # warm-up: compilation and caches
        _rows(plant, chunk, chunk, 0.1, compiled)
    best: dict[str, float] = {}
    out: dict[str, Any] = {}
    for _ in range(repeat):
        for name, (plant, compiled) in paths.items():
            t0 = time.perf_counter()
            out[name] = _rows(plant, robots, chunk, duration, compiled)
            best[name] = min(best.get(name, np.inf), time.perf_counter() - t0)
    same = np.array_equal(out["twin python"], out["twin compiled"], equal_nan=True)
    err = float(np.nanmax(np.abs(out["twin python"] - out["twin compiled"])))
    ps = robots * duration
    print(f"HODOSMC, {robots} robots x {duration:g} s in chunks of {chunk} (best of {repeat}):")
    rates = {k: ps / v for k, v in best.items()}
    for name, rate in rates.items():
        print(f"  {name:14s} {best[name]:7.2f} s  {rate:8.0f} plant-s/s  "
              f"ratio to bare {rate / rates['bare']:.3f}")  # fmt: skip
    print(f"  compiled / python twin: {rates['twin compiled'] / rates['twin python']:.1f}x; "
          f"rms_theta identical: {same} (max difference {err:.1e})")  # fmt: skip
    return rates


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
