"""Tuning speed (issue 27): ``mwip tune hodosmc`` with 100 trials x 256 robots x 10 s.

For each plant (``plain``: ideal sensors and drive; ``twin``: the default twin's sensors and
drive) the script

1. runs the bare batch engine once as the reference: the book's HODOSMC on the same 256 robots
   (the robustness campaign's distribution, seed 2026), one engine batch per chunk of robots
   (:func:`mwip.tune.evaluate.evaluate`), after a warm-up run (compilation);
2. runs the tuning (:func:`mwip.tune.run.execute`, TPE, seed 0, default SQLite storage in a
   temporary folder; validation and page excluded from the time) and counts the robot-seconds
   it simulated (a pruned trial: only its chunks run);

and prints the wall time, the plant-seconds per second of both and their ratio (tuning /
bare: what the study, the sampler and the per-trial designs cost). Usage::

    python benchmarks/bench_tune.py [--plant plain|twin|both] [--trials 100] [--robots 256]
                                    [--chunk 64] [--duration 10]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

OBJECTIVE = """
[objective]
title = "bench: HODOSMC, {plant}"
[[objective.terms]]
metric = "rms_theta"
[[objective.terms]]
metric = "rms_speed_error"
[[objective.terms]]
metric = "control_tv"
scale = 20.0
weight = 0.5
[robots]
campaign = "robustness"
plant = "{plant}"
samples = {robots}
chunk = {chunk}
seed = 2026
duration = {duration}
[validation]
samples = {chunk}
seed = 7
"""


def quiet(_text: str) -> None:
    return None


def bench(plant: str, trials: int, robots: int, chunk: int, duration: float) -> dict[str, float]:
    import optuna

    from mwip.tune.evaluate import evaluate
    from mwip.tune.run import execute, plan

    with tempfile.TemporaryDirectory() as tmp:
        obj = Path(tmp) / "objective.toml"
        obj.write_text(OBJECTIVE.format(plant=plant, robots=robots, chunk=chunk,
                                        duration=duration))  # fmt: skip
        p = plan("hodosmc", Path(tmp) / "run", str(obj), trials)
        evaluate("hodosmc", [{}], p.robots, blocks=[0])  # warm-up: compilation, caches
        t0 = time.perf_counter()
        evaluate("hodosmc", [{}], p.robots)
        bare_s = time.perf_counter() - t0
        bare = p.robots.plant_seconds / bare_s
        summary = execute(p, log=quiet)
        storage = optuna.storages.RDBStorage(p.storage_url)
        study = optuna.load_study(study_name=p.study_name, storage=storage)
        simulated = 0.0
        for t in study.get_trials(deepcopy=False):
            if t.state.name == "COMPLETE":
                simulated += p.robots.plant_seconds
            elif t.state.name == "PRUNED":
                simulated += (t.last_step or 0) * chunk * duration
        wall = float(summary["tuning_wall_s"])
        pruned = sum(t.state.name == "PRUNED" for t in study.get_trials(deepcopy=False))
    rate = simulated / wall
    print(f"{plant:5s}: {trials} trials x {robots} robots x {duration:g} s (chunks of {chunk}): "
          f"tuning {wall:.1f} s, {pruned} pruned, {simulated:.0f} plant-s simulated, "
          f"{rate:.0f} plant-s/s; bare batch engine {bare:.0f} plant-s/s "
          f"({bare_s:.2f} s for {robots} robots); ratio {rate / bare:.2f}")  # fmt: skip
    return {"wall": wall, "rate": rate, "bare": bare}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", choices=["plain", "twin", "both"], default="both")
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--robots", type=int, default=256)
    ap.add_argument("--chunk", type=int, default=64)
    ap.add_argument("--duration", type=float, default=10.0)
    a = ap.parse_args()
    for plant in ["plain", "twin"] if a.plant == "both" else [a.plant]:
        bench(plant, a.trials, a.robots, a.chunk, a.duration)


if __name__ == "__main__":
    main()
