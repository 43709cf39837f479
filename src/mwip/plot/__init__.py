"""Pictures of runs: the run figure (``run.png``), the robot drawn to scale, animations."""

from mwip.plot.run_figure import run_figure, write_run_figure
from mwip.plot.runs import Run, RunFolderError, find_runs, load_run, main_run_name

__all__ = [
    "Run",
    "RunFolderError",
    "find_runs",
    "load_run",
    "main_run_name",
    "run_figure",
    "write_run_figure",
]
