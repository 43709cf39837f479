"""The robot the studies run on: the simulated plant and the designer's nominal model.

By default the book's: the plant is :data:`mwip.params.REAL` (Table 3.1 = 6.1) and every
controller and observer is designed on :data:`mwip.params.NOMINAL` (Table 3.2 = 6.2).
``mwip run/reproduce --params FILE.toml`` replaces the plant with a user's robot and
``--nominal FILE.toml`` the design model, for every study, through :func:`using`.
The Chapter 6 payload case is derived from whatever plant is in use
(:meth:`mwip.params.Params.with_payload`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from mwip.params import NOMINAL, REAL, Params

__all__ = ["label", "nominal", "plant", "using"]

_current: dict[str, Params] = {"plant": REAL, "nominal": NOMINAL}


def plant() -> Params:
    """The simulated robot (the "truth")."""
    return _current["plant"]


def nominal() -> Params:
    """The parameters controllers and observers are designed with."""
    return _current["nominal"]


@contextmanager
def using(plant: Params | None = None, nominal: Params | None = None) -> Iterator[None]:
    """Run the studies inside the block on ``plant`` with designs on ``nominal``
    (``None`` keeps the current one)."""
    saved = dict(_current)
    if plant is not None:
        _current["plant"] = plant
    if nominal is not None:
        _current["nominal"] = nominal
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
