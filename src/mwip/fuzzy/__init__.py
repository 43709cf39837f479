"""Interval type-2 fuzzy logic modelling and control of the MWIP (Chapter 5).

- :mod:`mwip.fuzzy.sets` - triangular type-1 / IT2 sets, minimum t-norm, rule firing
- :mod:`mwip.fuzzy.reducers` - Nie-Tan (5.8), Begian-Melek-Mendel, Karnik-Mendel
- :mod:`mwip.fuzzy.ts_model` - IT2 Takagi-Sugeno model (5.4)-(5.8)
- :mod:`mwip.fuzzy.pdc` - PDC balance controller (5.9)-(5.11), LMI design (5.12)-(5.20)
- :mod:`mwip.fuzzy.mamdani` - IT2 Mamdani position/direction control (Section 5.3.2)

See ``docs/fuzzy.md``.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = [
    "LABELS7",
    "TriangularIT2Set",
    "TriangularSet",
    "UniformPartition",
    "firing_grid",
    "min_tnorm",
    "triangle",
    "bmm",
    "karnik_mendel",
    "km_output",
    "nie_tan",
    "weighted_average",
]

__getattr__, __dir__ = exports(
    __name__,
    {**{n: "mwip.fuzzy.sets" for n in __all__[:7]},
     **{n: "mwip.fuzzy.reducers" for n in __all__[7:]}},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.fuzzy.reducers import bmm, karnik_mendel, km_output, nie_tan, weighted_average
    from mwip.fuzzy.sets import (
        LABELS7,
        TriangularIT2Set,
        TriangularSet,
        UniformPartition,
        firing_grid,
        min_tnorm,
        triangle,
    )
