"""The one registry of studies: every module of :mod:`mwip.studies` that declares ``STUDY``
(a :class:`~mwip.studies.study.Study`) or ``STUDIES`` (several) is a study; nothing else
registers one. Studies are ordered by their place in the book (``Study.place``, then name).

:func:`run_study` builds the :class:`~mwip.studies.study.StudyContext` (robot, design model,
validated settings, folder, seed) and runs one study; ``mwip run``, ``mwip reproduce``, the
runner and the tests go through it.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

from mwip.hardware.twin import Twin
from mwip.params import NOMINAL, REAL, Params
from mwip.studies import settings as study_settings
from mwip.studies.study import Study, StudyContext

__all__ = ["all_studies", "context", "get", "names", "robot", "run_study"]

#: Modules of the package that are infrastructure, not studies (not imported by discovery).
_NOT_STUDIES = frozenset({"common", "registry", "runner", "settings", "study", "study_file"})


@cache
def _discover() -> dict[str, Study]:
    import mwip.studies as package

    found: list[Study] = []
    for info in pkgutil.iter_modules(package.__path__):
        if info.ispkg or info.name.startswith("_") or info.name in _NOT_STUDIES:
            continue
        module = importlib.import_module(f"mwip.studies.{info.name}")
        declared = getattr(module, "STUDIES", None) or ()
        one = getattr(module, "STUDY", None)
        for s in (*declared, *([one] if one is not None else [])):
            if not isinstance(s, Study):
                raise TypeError(f"mwip.studies.{info.name}: STUDY/STUDIES must be Study objects")
            found.append(s)
    found.sort(key=lambda s: (s.place, s.name))
    out: dict[str, Study] = {}
    for s in found:
        if s.name in out:
            raise ValueError(f"study name {s.name!r} is declared twice")
        out[s.name] = s
    return out


def all_studies() -> list[Study]:
    """Every study, in book order."""
    return list(_discover().values())


def names() -> list[str]:
    """Every study's name, in book order (``mwip list``, ``mwip reproduce``)."""
    return list(_discover())


def get(name: str) -> Study:
    """The study called ``name``; ``ValueError`` listing the names if there is none."""
    studies = _discover()
    if name not in studies:
        raise ValueError(f"unknown study {name!r}; choose from: {', '.join(studies)}")
    return studies[name]


def robot(plant: Params | None = None, nominal: Params | None = None) -> tuple[Params, Params]:
    """The simulated robot and the design model a study runs on: the given ones, else the
    book's (Table 3.1 and Table 3.2, units damping reading; SPEC.md section 2)."""
    return (REAL if plant is None else plant), (NOMINAL if nominal is None else nominal)


def context(
    name: str,
    out: Path,
    *,
    quick: bool = False,
    plant: Params | None = None,
    nominal: Params | None = None,
    overrides: Mapping[str, Any] | None = None,
    twin: Twin | None = None,
) -> StudyContext:
    """The context study ``name`` runs in: its folder ``out/<name>``, the robot ``plant``
    (default Table 3.1) and design model ``nominal`` (default Table 3.2), its settings (the
    study file's defaults with ``overrides``, validated), its seed (setting ``seed``, else
    0) and, for the Chapter 6 studies, the twin configuration ``twin`` (default: the default
    twin, :class:`mwip.hardware.twin.Twin`)."""
    study = get(name)
    try:
        base = study_settings.defaults(name)
    except ValueError:  # a study without a study file has no settings (e.g. in a test)
        base = {}
    cfg = {**base, **study_settings.validate(name, overrides or {})}
    plant, nominal = robot(plant, nominal)
    return StudyContext(
        name=name,
        source=study.source,
        plant=plant,
        nominal=nominal,
        settings=cfg,
        out=Path(out) / name,
        quick=quick,
        seed=int(cfg.get("seed", 0)),
        **({} if twin is None else {"twin": twin}),
    )


def run_study(
    name: str,
    out: Path,
    *,
    quick: bool = False,
    plant: Params | None = None,
    nominal: Params | None = None,
    overrides: Mapping[str, Any] | None = None,
    twin: Twin | None = None,
) -> dict[str, Any]:
    """Run study ``name`` into ``out/<name>`` (see :func:`context`); returns its metrics
    document."""
    ctx = context(name, out, quick=quick, plant=plant, nominal=nominal, overrides=overrides,
                  twin=twin)  # fmt: skip
    return get(name).run(ctx)
