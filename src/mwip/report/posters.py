"""A poster frame per study for the report: its main run drawn to scale at its last moment
(:func:`mwip.animate.poster_frame`), ``OUT/<study>/poster/<run>.png``.

Drawn when missing or older than the run's ``.npz``; a study with no run that can be drawn
gets none (the report then shows none).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from mwip.report.results import StudyResult

__all__ = ["POSTER_DIR", "ensure_posters"]

POSTER_DIR = "poster"


def ensure_posters(results: list[StudyResult]) -> dict[str, Path]:
    """Draw the missing or stale poster frames; returns study -> poster path."""
    from mwip.animate import poster_frame
    from mwip.plot.runs import RunFolderError, load_run

    made: dict[str, Path] = {}
    for res in results:
        if res.doc is None or not res.folder.is_dir():
            continue
        try:
            run = load_run(res.folder)
        except (RunFolderError, OSError, ValueError):  # no drawable run: no poster
            continue
        folder = res.folder / POSTER_DIR
        path = folder / f"{run.name}.png"
        stale = [p for p in folder.glob("*.png") if p != path] if folder.is_dir() else []
        for p in stale:
            p.unlink(missing_ok=True)
        if not path.is_file() or path.stat().st_mtime < run.source.stat().st_mtime:
            try:
                poster_frame(run, path)
            except (RunFolderError, OSError, ValueError):
                shutil.rmtree(folder, ignore_errors=True)
                continue
        made[res.name] = path
    return made
