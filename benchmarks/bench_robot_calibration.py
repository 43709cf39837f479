"""A robot's calibration on its facts (``mwip twin calibrate FACTS --robot FILE``): the
facts' scenarios on a batch of twins as one batched twin run per scenario (what the command
does) against one run per twin, in one process.

Reference: every twin run alone (:meth:`mwip.scenario.Scenario.run` without ``values``, the
robot file's twin with that twin's unknowns). Against it: the batch
(:func:`mwip.calibration.robot_evidence._chunk`, all twins as rows of one run per scenario).
Both on examples/my_robot_facts.toml's two 10 s scenarios, on the robot of
examples/my_robot.toml, the twins drawn from its prior (seed 0). Wall time after a warm-up
of each (Numba caches warm).

Usage::

    python benchmarks/bench_robot_calibration.py [--twins 64]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from mwip.calibration.robot_evidence import _chunk, prepare
from mwip.robot import load_robot

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=64)
    a = ap.parse_args()
    robot = load_robot(ROOT / "examples" / "my_robot.toml")
    facts, structure, scenarios = prepare(ROOT / "examples" / "my_robot_facts.toml", robot,
                                          "examples/my_robot.toml")  # fmt: skip
    u = np.random.default_rng(0).random((a.twins, len(structure.prior)))
    values = structure.values(structure.from_unit(u))
    one = {k: v[:1] for k, v in values.items()}
    _chunk((scenarios, facts.facts, one, False))  # warm-up
    t0 = time.perf_counter()
    batch = _chunk((scenarios, facts.facts, values, False))
    t_batch = time.perf_counter() - t0
    t0 = time.perf_counter()
    rows = [_chunk((scenarios, facts.facts, {k: v[i:i + 1] for k, v in values.items()}, False))
            for i in range(a.twins)]  # fmt: skip
    t_rows = time.perf_counter() - t0
    for k, v in batch.items():  # the same columns either way
        np.testing.assert_allclose(v, np.concatenate([r[k] for r in rows]), rtol=1e-9,
                                   atol=1e-12, equal_nan=True)  # fmt: skip
    print(f"{a.twins} twins x {len(scenarios)} scenarios: one run per twin {t_rows:.2f} s, "
          f"batched {t_batch:.2f} s: {t_rows / t_batch:.1f}x")


if __name__ == "__main__":
    main()
