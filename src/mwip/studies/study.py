"""What a study is: a declaration (:class:`Study`), the context it runs in
(:class:`StudyContext`) and the one writer of what every study saves (:func:`save_study`).

A study is one module of :mod:`mwip.studies` that declares ``STUDY = Study(...)`` (or, for a
module holding several, ``STUDIES = (Study(...), ...)``) and one study file
``mwip/studies/scenarios/<name>.toml`` (its settings, the open ones with their ranges, and the
texts of the report in ``[report]``). :mod:`mwip.studies.registry` finds the declarations;
there is no other place to register a study (docs/extending.md).

The run function gets everything it may depend on from its context, never from module state::

    def run(ctx: StudyContext) -> dict:
        cfg = ctx.settings                      # validated [settings] of the study file
        res = simulate(..., ctx.plant, ...)     # the simulated robot
        ctrl = design(ctx.nominal, ...)         # controllers see only the design model
        ...
        return save_study(ctx, metrics=..., claims=..., series={"run": res}, figures=...)
"""

from __future__ import annotations

import types
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.hardware.twin import Twin
from mwip.params import NOMINAL, NOMINAL_LITERAL, REAL, REAL_LITERAL, Params
from mwip.schema.metrics import metrics_document, write_metrics
from mwip.studies.common import save_figure

__all__ = ["Study", "StudyContext", "plant_label", "runs_record", "save_study"]


def runs_record(runs: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The ``runs`` block of metrics.json (SPEC.md section 6): each single run's status and
    end time, from its :class:`mwip.sim.SimResult`."""
    return {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()}


def plant_label(p: Params) -> str:
    """Which robot ``p`` is, for figure titles and settings: ``"real plant"`` (Table 3.1,
    units damping reading: the default), ``"nominal plant"``, their ``"... (literal damping)"``
    variants (SPEC.md section 2) or ``"user's plant"``."""
    named = (
        (REAL, "real plant"),
        (NOMINAL, "nominal plant"),
        (REAL_LITERAL, "real plant (literal damping)"),
        (NOMINAL_LITERAL, "nominal plant (literal damping)"),
    )
    if p.batch_shape == ():
        for q, text in named:
            if p == q:
                return text
    return "user's plant"


@dataclass(frozen=True)
class StudyContext:
    """Everything a study run depends on.

    ``plant`` is the simulated robot (the "truth", default Table 3.1), ``nominal`` the model
    controllers and observers are designed on (default Table 3.2); ``settings`` the study's
    ``[settings]`` (packaged defaults with the user's overrides, validated; read-only);
    ``out`` the study's own folder (``OUT/<name>``); ``quick`` shorter runs for smoke tests;
    ``seed`` the noise seed (the ``seed`` setting where the study has one, else 0); ``twin``
    the digital twin a Chapter 6 study runs on: the robot file's (``--robot FILE``, a study
    file's ``[robot] file`` or ``run_study(..., robot=...)``; without one the default
    robot's, ``mwip robot show``; a context constructed directly: the data-sheet twin).
    """

    name: str
    source: str
    plant: Params
    nominal: Params
    settings: Mapping[str, Any]
    out: Path
    quick: bool = False
    seed: int = 0
    twin: Twin = field(default_factory=Twin)

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", types.MappingProxyType(dict(self.settings)))
        object.__setattr__(self, "out", Path(self.out))

    @property
    def plant_label(self) -> str:
        """:func:`plant_label` of the simulated robot."""
        return plant_label(self.plant)


@dataclass(frozen=True)
class Study:
    """A study's declaration: its ``name`` (``mwip list``; also its study file's name), the
    book ``source`` it reproduces (e.g. ``"Fig. 3.2, Table 3.3"``), its ``run`` function
    (:class:`StudyContext` -> metrics document), where it sits in the book for ordering
    (``place``: chapter and first figure, e.g. ``(3, 2)``) and its relative ``cost`` (seconds
    on one core for the full run; the runner starts the longest first)."""

    name: str
    source: str
    run: Callable[[StudyContext], dict[str, Any]]
    place: tuple[int, ...]
    cost: float = 5.0

    @property
    def title(self) -> str:
        """The report title from the study file's ``[report]`` table (the name if none)."""
        from mwip.studies.settings import report_texts

        return report_texts(self.name).get("title", self.name)


def save_study(
    ctx: StudyContext,
    *,
    metrics: dict[str, Any],
    claims: list[dict[str, Any]],
    runs: dict[str, dict[str, Any]],
    settings: dict[str, Any],
    published: dict[str, Any] | None = None,
    series: Mapping[str, Any] | None = None,
    figures: Mapping[str, Figure] | None = None,
    arrays: Mapping[str, Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """Write what every study saves into ``ctx.out`` and return the metrics document.

    The document is :func:`~mwip.schema.metrics.metrics_document` of the arguments (SPEC.md
    section 6). ``series`` maps a file stem to a run result (anything with ``to_npz``), saved
    as ``<stem>.npz``; ``figures`` maps a file name (``.png``) to a figure; ``arrays`` maps a
    file name (``.npz``) to named arrays of extra data (saved compressed). Every file is
    written atomically (:mod:`mwip.io`), ``metrics.json`` last, so a folder with it is
    complete.
    """
    from mwip.io import write_atomic

    doc = metrics_document(ctx.name, ctx.source, metrics, published or {}, claims, runs,
                           settings)  # fmt: skip
    ctx.out.mkdir(parents=True, exist_ok=True)
    for fname, fig in (figures or {}).items():
        save_figure(fig, ctx.out / fname)
    for stem, res in (series or {}).items():
        res.to_npz(ctx.out / f"{stem}.npz")
    for fname, data in (arrays or {}).items():
        write_atomic(ctx.out / fname, partial(np.savez_compressed, **data))
    write_metrics(ctx.out, doc)
    return doc
