"""Packing a chain of twin elements for a batch of robots (:mod:`mwip.hardware.element`).

:func:`pack_chain` keeps the elements of a chain that run for this batch
(:meth:`~mwip.hardware.element.Element.active`) and lays their parameter vectors, states,
noise variates and logs side by side: a :class:`Chain` carries the vectors and the *plan*, one
row per element (its code and the spans of its parameters, state, noise and logs), which is all
the compiled loop (:mod:`mwip.hardware.loop`) needs to run them in order.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.element import Element, PackContext

__all__ = ["Chain", "pack_chain", "PLAN_COLUMNS"]

#: The columns of a plan row: the element's code, then ``[start, stop)`` of its parameters,
#: state, noise variates and logs in the chain's vectors.
PLAN_COLUMNS = ("code", "p0", "p1", "x0", "x1", "z0", "z1", "l0", "l1")


@dataclass(frozen=True)
class Chain:
    """A chain packed for ``n`` robots: the active ``elements``, the ``plan`` (E, 9) int64,
    the parameters ``P`` (1 or n, total), the initial states ``X`` (n, total), the normal
    variates drawn per sample ``noise`` and the ``logs`` (name, width) in log-vector order."""

    elements: tuple[Element, ...]
    plan: NDArray[np.int64]
    P: NDArray[np.float64]
    X: NDArray[np.float64]
    noise: int
    logs: tuple[tuple[str, int], ...]

    @property
    def log_width(self) -> int:
        return sum(w for _, w in self.logs)

    @property
    def empty(self) -> bool:
        return len(self.elements) == 0

    def names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.elements)

    def split_logs(self, columns: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """The log columns (..., :attr:`log_width`) by log name."""
        out: dict[str, NDArray[np.float64]] = {}
        col = 0
        for name, w in self.logs:
            out[name] = columns[..., col : col + w]
            col += w
        return out

    def fresh_state(self) -> NDArray[np.float64]:
        """A writable copy of the initial states."""
        return np.array(self.X, dtype=np.float64, order="C")


def pack_chain(chain: Sequence[Element], ctx: PackContext) -> Chain:
    """The elements of ``chain`` active for ``ctx``, packed (module docstring)."""
    active = tuple(e for e in chain if e.active(ctx))
    n = ctx.n
    plan = np.zeros((len(active), len(PLAN_COLUMNS)), dtype=np.int64)
    ps, xs = [], []
    p0 = x0 = z0 = l0 = 0
    for j, e in enumerate(active):
        P, X = e.vectors(ctx)
        ps.append(P)
        xs.append(X)
        p1, x1 = p0 + P.shape[1], x0 + X.shape[1]
        z1, l1 = z0 + e.noise, l0 + e.log_width
        plan[j] = (e.code, p0, p1, x0, x1, z0, z1, l0, l1)
        p0, x0, z0, l0 = p1, x1, z1, l1
    rows = n if any(P.shape[0] > 1 for P in ps) else 1
    Pall = (np.concatenate([np.broadcast_to(P, (rows, P.shape[1])) for P in ps], axis=1)
            if ps else np.zeros((1, 1)))  # fmt: skip
    Xall = np.concatenate(xs, axis=1) if xs else np.zeros((n, 1))
    logs = tuple(lg for e in active for lg in e.logs)
    return Chain(active, plan, np.ascontiguousarray(Pall), np.ascontiguousarray(Xall), z0, logs)
