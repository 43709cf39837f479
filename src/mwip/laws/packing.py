"""A law's settings and memory as two flat vectors with declared, named layouts.

Every compiled law (one folder of :mod:`mwip.laws` each) describes what it needs as two
:class:`Layout` s:

- its **parameter vector** ``p`` (gains, nominal model coefficients, observer matrices, ...),
  read-only during a run;
- its **state vector** ``x`` (what it remembers between samples: an observer's state, an
  adaptive gain, the previous torque; scratch space its kernel writes each sample), with
  the value it starts a run with.

A :class:`PackedLaw` carries both for a batch: ``params`` (R, n_p) with R = 1 (every robot
the same settings) or R = N (one row per robot: a tuner evaluates N candidate gain sets in one
batch), and ``state`` (1 or N, n_x). The same vectors are read by the Python controller's
compiled kernel, the compiled closed loop (:mod:`mwip.sim.loop`: one fixed signature for
every law, dispatching on :attr:`PackedLaw.code` in :mod:`mwip.laws.dispatch`) and the C
export (:mod:`mwip.export.c_code` reads :meth:`PackedLaw.fields`, not a controller's
attributes).

A layout lists its fields in order; a field of shape ``()`` is one number. A law whose size
depends on its design (the observer order, the number of fuzzy sets) puts a *dimension* field
first and the variable-size fields last, so that its compiled kernel can find every offset
from ``p[0]`` (each family's ``packing.py`` says how, and tests/test_packing.py holds the
kernel's offsets equal to the layout's).

>>> lay = Layout((Field("gain", (2, 2)), Field("offset", (2,)), Field("eps", ())))
>>> lay.size, lay.span("offset")
(7, (4, 6))
>>> v = lay.pack({"gain": [[1, 2], [3, 4]], "offset": [5, 6], "eps": 0.5})
>>> v.tolist()
[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.5]
>>> float(lay.unpack(v)["eps"]), lay.unpack(v)["gain"][1, 0].item()
(0.5, 3.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mwip.layout import Field, Layout

__all__ = ["Field", "Layout", "PackedLaw", "stack"]  # Field, Layout: mwip.layout

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PackedLaw:
    """What a controller hands the compiled closed loop and the C export: its law ``code``
    (unique per law family, the ``CODE`` of its ``packing.py``), its parameter vectors
    ``params`` (R, n_p), R = 1 or one row per robot, its initial state ``state`` (1 or N,
    n_x), their layouts, and ``log_names``: the logs its kernel writes each sample and their
    widths, in the order of its log vector.
    """

    code: int
    params: FloatArray
    state: FloatArray
    param_layout: Layout
    state_layout: Layout
    log_names: tuple[tuple[str, int], ...] = ()
    name: str = ""

    def __post_init__(self) -> None:
        p = np.atleast_2d(np.asarray(self.params, dtype=float))
        x = np.atleast_2d(np.asarray(self.state, dtype=float))
        if p.shape[1] != self.param_layout.size:
            raise ValueError(f"packed law: parameter vectors of length {p.shape[1]}, the "
                             f"layout has {self.param_layout.size}")  # fmt: skip
        if x.shape[1] != self.state_layout.size:
            raise ValueError(f"packed law: state vectors of length {x.shape[1]}, the layout "
                             f"has {self.state_layout.size}")  # fmt: skip
        object.__setattr__(self, "params", p)
        object.__setattr__(self, "state", x)

    @property
    def rows(self) -> int:
        """Robots with their own parameter vector (1: shared by the batch)."""
        return int(self.params.shape[0])

    @property
    def log_width(self) -> int:
        return sum(w for _, w in self.log_names)

    def split_logs(self, columns: FloatArray) -> dict[str, FloatArray]:
        """The log columns ``columns`` (..., :attr:`log_width`), as the kernel writes them, by
        log name: views of width ``w`` each, in :attr:`log_names` order."""
        out: dict[str, FloatArray] = {}
        col = 0
        for name, w in self.log_names:
            out[name] = columns[..., col : col + w]
            col += w
        return out

    def fields(self, row: int = 0) -> dict[str, FloatArray]:
        """The parameters of robot ``row`` by name (copies), e.g. ``fields()["gain"]``."""
        return {k: v.copy() for k, v in self.param_layout.unpack(self.params[row]).items()}

    def state_fields(self, row: int = 0) -> dict[str, FloatArray]:
        """The initial state of robot ``row`` by name (copies)."""
        return {k: v.copy() for k, v in self.state_layout.unpack(self.state[row]).items()}

    def arrays(self, n: int) -> tuple[FloatArray, FloatArray]:
        """``(P, X)`` for a batch of ``n`` robots: fresh C-contiguous float64 copies, ``P``
        (1 or n, n_p) and ``X`` (n, max(n_x, 1)), the shapes the compiled loop takes."""
        if self.rows not in (1, n):
            raise ValueError(f"packed law: {self.rows} parameter vectors for {n} robots "
                             "(give one, or one per robot)")  # fmt: skip
        if self.state.shape[0] not in (1, n):
            raise ValueError(f"packed law: {self.state.shape[0]} state vectors for {n} robots")
        P = np.array(self.params, dtype=np.float64, order="C")
        X = np.zeros((n, max(self.state_layout.size, 1)))
        X[:, : self.state_layout.size] = self.state
        return P, X


def stack(laws: Sequence[PackedLaw]) -> PackedLaw:
    """One :class:`PackedLaw` with one parameter (and state) vector per robot, from one law
    per robot: all of the same code and the same layouts (e.g. the same observer order)."""
    if not laws:
        raise ValueError("stack: no laws")
    first = laws[0]
    for law in laws[1:]:
        if (law.code, law.param_layout, law.state_layout, law.log_names) != (
            first.code, first.param_layout, first.state_layout, first.log_names
        ):  # fmt: skip
            raise ValueError("stack: laws of different kinds or layouts cannot share a batch")
        if law.rows != 1 or law.state.shape[0] != 1:
            raise ValueError("stack: each law must have one parameter and state vector")
    return PackedLaw(
        first.code,
        np.concatenate([law.params for law in laws]),
        np.concatenate([law.state for law in laws]),
        first.param_layout,
        first.state_layout,
        first.log_names,
        first.name,
    )

