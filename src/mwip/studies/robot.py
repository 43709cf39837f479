"""The robot the studies run on: the simulated plant and the designer's nominal model.

By default the book's: the plant is :data:`mwip.params.REAL` (Table 3.1 = 6.1) and every
controller and observer is designed on :data:`mwip.params.NOMINAL` (Table 3.2 = 6.2).
``mwip run/reproduce --params FILE.toml`` replaces the plant with a user's robot and
``--nominal FILE.toml`` the design model, for every study, through :func:`using`.
The Chapter 6 payload case is derived from whatever plant is in use
(:meth:`mwip.params.Params.with_payload`). The Chapter 6 studies run on :func:`twin`, the
digital twin's configuration (default :class:`mwip.hardware.twin.Twin`, the hardware data;
``mwip run/reproduce --twin FILE`` or a study file's ``[robot] twin`` / ``[twin]`` tables
replace it, :mod:`mwip.hardware.twin_config`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from mwip.params import NOMINAL, REAL, Params

if TYPE_CHECKING:
    from mwip.hardware.twin import Twin

__all__ = ["label", "nominal", "plant", "twin", "using"]

_current: dict[str, Any] = {"plant": REAL, "nominal": NOMINAL, "twin": None}


def plant() -> Params:
    """The simulated robot (the "truth")."""
    return _current["plant"]


def nominal() -> Params:
    """The parameters controllers and observers are designed with."""
    return _current["nominal"]


def twin() -> Twin:
    """The digital twin's configuration the Chapter 6 studies run on (default: the default
    twin, :class:`mwip.hardware.twin.Twin`)."""
    from mwip.hardware.twin import Twin

    tw = _current["twin"]
    return Twin() if tw is None else tw


@contextmanager
def using(
    plant: Params | None = None, nominal: Params | None = None, twin: Twin | None = None
) -> Iterator[None]:
    """Run the studies inside the block on ``plant`` with designs on ``nominal`` and the
    Chapter 6 studies on the twin configuration ``twin`` (``None`` keeps the current one)."""
    saved = dict(_current)
    if plant is not None:
        _current["plant"] = plant
    if nominal is not None:
        _current["nominal"] = nominal
    if twin is not None:
        _current["twin"] = twin
    try:
        yield
    finally:
        _current.clear()
        _current.update(saved)


def label(p: Params | None = None) -> str:
    """Which robot ``p`` (default: the current plant) is, for figure titles and settings:
    ``"real plant"`` (Table 3.1, units damping reading: the default), ``"nominal plant"``,
    their ``"... (literal damping)"`` variants (SPEC.md section 2) or ``"user's plant"``."""
    from mwip.params import NOMINAL_LITERAL, REAL_LITERAL

    p = plant() if p is None else p
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
