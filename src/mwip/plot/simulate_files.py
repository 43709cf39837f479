"""What ``mwip simulate --out OUT`` writes beside the time series for drawing the run:
``OUT/plant.toml`` (the simulated robot, so that ``mwip animate OUT`` draws it to scale) and,
with ``--plot``, ``OUT/run.png`` (:mod:`mwip.plot.run_figure`)."""

from __future__ import annotations

from pathlib import Path

from mwip.params import Params, save_params
from mwip.plot.runs import Run
from mwip.sim.result import SimResult

__all__ = ["write_simulate_extras"]


def write_simulate_extras(
    res: SimResult,
    plant: Params,
    out: Path,
    *,
    plot: bool,
    reference: float | None = 0.0,
    torque_limit: float | None = None,
) -> list[Path]:
    """Write ``out/plant.toml`` and, if ``plot``, ``out/run.png``; returns the paths written.

    ``reference`` is the wheel-speed reference psi'_d (rad/s) drawn in the figure: the LQR of
    ``simulate`` regulates the state to zero, so psi'_d = 0. ``torque_limit``: the drive's
    wheel-torque limit (N m) flagged in the figure (default: the default twin's).
    """
    save_params(plant, out / "plant.toml")
    written = [out / "plant.toml"]
    if plot:
        from mwip.plot.run_figure import write_run_figure  # matplotlib only for --plot

        run = Run(name="simulate", result=res.plant(0) if not res.batched else res,
                  params=plant, payload=False, reference=reference,
                  source=out / "timeseries.npz", torque_limit=torque_limit)  # fmt: skip
        written.append(write_run_figure(run, out / "run.png", title="mwip simulate"))
    return written
