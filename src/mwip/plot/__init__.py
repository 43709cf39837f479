"""Pictures of runs: the run figure (``run.png``), the robot drawn to scale, animations.

The names below are imported on first use (:mod:`mwip.lazy`): matplotlib only when a figure
is drawn.
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = [
    "Run",
    "RunFolderError",
    "find_runs",
    "load_run",
    "main_run_name",
    "run_figure",
    "write_run_figure",
]

__getattr__, __dir__ = exports(
    __name__,
    {"run_figure": "mwip.plot.run_figure", "write_run_figure": "mwip.plot.run_figure",
     **{n: "mwip.plot.runs" for n in ("Run", "RunFolderError", "find_runs", "load_run",
                                      "main_run_name")}},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.plot.run_figure import run_figure, write_run_figure
    from mwip.plot.runs import Run, RunFolderError, find_runs, load_run, main_run_name
