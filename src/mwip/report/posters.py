"""A poster frame per study for the report: its main run drawn to scale at its last moment
(:func:`mwip.animate.poster_frame`), ``OUT/<study>/poster/<run>.png``.

Drawn by the runner right after each study (in the study's worker process) and, for folders
written before, by the report where missing or older than the run's ``.npz``; a study with no
run that can be drawn gets none (the report then shows none).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from mwip.report.results import StudyResult

__all__ = ["POSTER_DIR", "draw_poster", "ensure_posters"]

POSTER_DIR = "poster"


def draw_poster(folder: Path) -> Path | None:
    """Draw the poster of the study in ``folder`` unless it is there and newer than its run;
    returns its path (``None``: no run that can be drawn)."""
    from mwip.animate import poster_frame
    from mwip.plot.runs import RunFolderError, load_run

    try:
        run = load_run(folder)
    except (RunFolderError, OSError, ValueError):  # no drawable run: no poster
        return None
    posters = Path(folder) / POSTER_DIR
    path = posters / f"{run.name}.png"
    for old in posters.glob("*.png") if posters.is_dir() else []:
        if old != path:
            old.unlink(missing_ok=True)
    if not path.is_file() or path.stat().st_mtime < run.source.stat().st_mtime:
        try:
            poster_frame(run, path)
        except (RunFolderError, OSError, ValueError):
            shutil.rmtree(posters, ignore_errors=True)
            return None
    return path


def ensure_posters(results: list[StudyResult]) -> dict[str, Path]:
    """Draw the missing or stale poster frames; returns study -> poster path."""
    made: dict[str, Path] = {}
    for res in results:
        if res.doc is not None and res.folder.is_dir():
            path = draw_poster(res.folder)
            if path is not None:
                made[res.name] = path
    return made
