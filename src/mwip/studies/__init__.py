"""Reproducible studies: each writes ``OUT/<study>/metrics.json`` (SPEC.md section 6),
its time series and a figure.

A study is one module here declaring ``STUDY = Study(...)`` with a run function
``run(ctx: StudyContext) -> dict`` (:mod:`mwip.studies.study`) and one study file
``scenarios/<name>.toml``; :mod:`mwip.studies.registry` finds them. ``mwip run NAME`` runs one,
``mwip reproduce`` runs them all (docs/extending.md, "Adding a study").
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["all_studies", "get_study", "run_study", "study_names"]


def study_names() -> list[str]:
    """Registered study names, in reproduce (book) order."""
    from mwip.studies.registry import names

    return names()


def all_studies() -> list[Any]:
    """Every :class:`~mwip.studies.study.Study`, in book order."""
    from mwip.studies.registry import all_studies as studies

    return studies()


def get_study(name: str) -> Any:
    """The :class:`~mwip.studies.study.Study` called ``name`` (``ValueError`` if none)."""
    from mwip.studies.registry import get

    return get(name)


def run_study(name: str, out: Path, **kwargs: Any) -> dict[str, Any]:
    """Run one study into ``out/<name>``; returns its metrics document
    (:func:`mwip.studies.registry.run_study`: ``quick``, ``plant``, ``nominal``,
    ``overrides``, ``twin``, or ``robot``: a robot file or :class:`mwip.robot.Robot`)."""
    from mwip.studies.registry import run_study as run

    return run(name, out, **kwargs)
