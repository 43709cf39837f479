"""Named layouts of flat vectors: the meaning of each number of a parameter or state vector.

Ground floor (imports only NumPy). A compiled kernel reads a flat float64 vector; a
:class:`Layout` lists its :class:`Field` s in order, so that Python code packs and unpacks it by
name (:meth:`Layout.pack`, :meth:`Layout.unpack`) and a kernel finds each entry by a constant
offset taken from the layout (:meth:`Layout.index`), never a hand-numbered slot. The laws'
packed parameters (:mod:`mwip.laws.packing`) and the digital twin's elements
(:mod:`mwip.hardware.element`) both use it.

>>> lay = Layout((Field("gain", (2, 2)), Field("offset", (2,)), Field("eps", ())))
>>> lay.size, lay.span("offset")
(7, (4, 6))
>>> lay.index().eps, lay.index().offset
(6, 4)
"""

from __future__ import annotations

import math
from collections import namedtuple
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Field", "Layout"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Field:
    """One named entry of a layout: ``shape`` ``()`` for a number, else the array's shape
    (stored row-major)."""

    name: str
    shape: tuple[int, ...] = ()
    doc: str = ""

    @property
    def size(self) -> int:
        return math.prod(self.shape)


@dataclass(frozen=True)
class Layout:
    """An ordered list of :class:`Field` s: the meaning of each number of a flat vector."""

    fields: tuple[Field, ...] = ()

    def __post_init__(self) -> None:
        names = [f.name for f in self.fields]
        if len(set(names)) != len(names):
            raise ValueError(f"layout: duplicate field names in {names}")

    @property
    def size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)

    def span(self, name: str) -> tuple[int, int]:
        """``(start, stop)`` of field ``name`` in the vector."""
        start = 0
        for f in self.fields:
            if f.name == name:
                return start, start + f.size
            start += f.size
        raise KeyError(f"layout has no field {name!r}; fields: {', '.join(self.names)}")

    def pack(self, values: Mapping[str, ArrayLike]) -> FloatArray:
        """The vector of ``values`` (one entry per field, each of its field's shape)."""
        missing = [n for n in self.names if n not in values]
        extra = [n for n in values if n not in self.names]
        if missing or extra:
            raise ValueError(f"layout: missing fields {missing}, unknown fields {extra}")
        out = np.empty(self.size)
        start = 0
        for f in self.fields:
            a = np.asarray(values[f.name], dtype=float)
            if a.shape != f.shape:
                raise ValueError(f"layout: field {f.name!r} has shape {a.shape}, "
                                 f"expected {f.shape}")  # fmt: skip
            out[start : start + f.size] = a.reshape(-1)
            start += f.size
        return out

    def unpack(self, vec: ArrayLike) -> dict[str, FloatArray]:
        """Views of ``vec`` (length :attr:`size`) by field name, each of its field's shape."""
        v = np.asarray(vec, dtype=float)
        if v.shape != (self.size,):
            raise ValueError(f"layout: vector of shape {v.shape}, expected ({self.size},)")
        out: dict[str, FloatArray] = {}
        start = 0
        for f in self.fields:
            out[f.name] = v[start : start + f.size].reshape(f.shape)
            start += f.size
        return out

    def describe(self) -> list[tuple[str, int, int, tuple[int, ...], str]]:
        """``(name, start, stop, shape, doc)`` per field: the layout as a table."""
        rows, start = [], 0
        for f in self.fields:
            rows.append((f.name, start, start + f.size, f.shape, f.doc))
            start += f.size
        return rows

    def index(self) -> Any:
        """The start offset of every field as a named tuple (``layout.index().gain``): a
        constant a compiled kernel can read by name (Numba folds a global named tuple of ints
        into the code)."""
        start, out = 0, []
        for f in self.fields:
            out.append(start)
            start += f.size
        index_type: Any = namedtuple("Index", list(self.names))  # type: ignore[misc]
        return index_type(*out)
