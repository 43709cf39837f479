"""The twin's unknown values as a declared parameter vector with a prior (docs/twin_model.md).

The book prints the robot's parameters (Table 6.1), the motor's data sheet (Table 2.1), the
battery voltage, the encoder's lines and the 5 ms sampling period: those stay fixed. What it
does not print is an :class:`Unknown` with a continuous uniform range, declared by the element
module it belongs to in a module-level ``UNKNOWNS`` tuple (:mod:`mwip.hardware.motor`,
:mod:`~mwip.hardware.drivetrain`, :mod:`~mwip.hardware.imu`, :mod:`~mwip.hardware.twin`,
:mod:`~mwip.hardware.payload`, :mod:`~mwip.hardware.obstacle`); :data:`PRIOR` collects them in
that order (a new element: one module and its ``UNKNOWNS``, named in :data:`_MODULES`).

A twin file carries the prior as ``[twin.prior]``, one inline table per unknown::

    [twin.prior]
    "drive.gear_ratio" = { low = 3.7, high = 51.0, unit = "", source = "..." }

(:meth:`Prior.to_dict` / :meth:`Prior.from_dict`); a user may narrow a range or fix an unknown
with ``low = high``. ``Twin.prior``, ``Twin.values()`` and ``Twin.with_values()`` use it, and
``run_on_twin(..., values=...)`` runs one twin per row of values.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.unknown import Unknown

__all__ = ["Unknown", "Prior", "PRIOR", "declared"]

#: The element modules that declare unknowns, in the prior's order.
_MODULES = (
    "mwip.hardware.motor",
    "mwip.hardware.drivetrain",
    "mwip.hardware.twin",
    "mwip.hardware.imu",
    "mwip.hardware.payload",
    "mwip.hardware.obstacle",
)

_ENTRY_KEYS = ("low", "high", "unit", "source")


@dataclass(frozen=True)
class Prior:
    """An ordered tuple of :class:`Unknown`, a uniform prior over their box."""

    unknowns: tuple[Unknown, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "unknowns", tuple(self.unknowns))
        names = [u.name for u in self.unknowns]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"twin.prior: {dup[0]!r} is declared twice")

    def __len__(self) -> int:
        return len(self.unknowns)

    def __iter__(self) -> Any:
        return iter(self.unknowns)

    @property
    def names(self) -> tuple[str, ...]:
        """The dotted names, in order."""
        return tuple(u.name for u in self.unknowns)

    @property
    def bounds(self) -> NDArray[np.float64]:
        """(P, 2) array of ``[low, high]``."""
        return np.array([[u.low, u.high] for u in self.unknowns], dtype=float).reshape(-1, 2)

    def index(self, name: str) -> int:
        """Position of ``name``; an unknown name is a one-line ``ValueError``."""
        try:
            return self.names.index(name)
        except ValueError:
            raise ValueError(
                f"twin.prior: unknown name {name!r}; allowed: {', '.join(self.names)}"
            ) from None

    def __getitem__(self, name: str) -> Unknown:
        return self.unknowns[self.index(name)]

    def sample(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """``n`` uniform draws, (n, P) (a fixed unknown: its value)."""
        b = self.bounds
        u = rng.random((int(n), len(self)))
        return b[:, 0] + u * (b[:, 1] - b[:, 0])

    def centre(self) -> NDArray[np.float64]:
        """The box's centre, (P,)."""
        return self.bounds.mean(axis=1)

    def subset(self, names: Iterable[str]) -> Prior:
        """The prior of ``names`` (in the order given)."""
        return Prior(tuple(self[n] for n in names))

    def as_values(self, rows: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """(n, P) draws as ``{name: (n,) array}`` for ``run_on_twin(..., values=...)``."""
        a = np.asarray(rows, dtype=float).reshape(-1, len(self))
        return {name: a[:, i].copy() for i, name in enumerate(self.names)}

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """``{name: {"low", "high", "unit", "source"}}`` (the ``[twin.prior]`` table)."""
        return {u.name: {"low": u.low, "high": u.high, "unit": u.unit, "source": u.source}
                for u in self.unknowns}  # fmt: skip

    def check(self, values: Mapping[str, float]) -> None:
        """Every value of ``values`` (a twin's :meth:`~mwip.hardware.twin.Twin.values`) with a
        name in the prior inside its range: else a one-line ``ValueError`` naming
        ``twin.prior.<name>``."""
        for u in self.unknowns:
            if u.name in values:
                u.check(float(values[u.name]))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base: Prior | None = None) -> Prior:
        """A prior from a ``[twin.prior]`` table: entries of ``base`` (default :data:`PRIOR`)
        with ranges (and sources) replaced, names not given keeping ``base``'s. One-line
        ``ValueError`` naming ``twin.prior.<name>``."""
        pr = PRIOR if base is None else base
        if not isinstance(data, Mapping):
            raise ValueError(f"twin.prior must be a table, got {data!r}")
        for name, entry in data.items():
            if name not in pr.names:
                raise ValueError(f"twin.prior.{name}: unknown name; allowed: {', '.join(pr.names)}")
            if not isinstance(entry, Mapping):
                raise ValueError(
                    f"twin.prior.{name} must be a table {{ low = .., high = .. }}, got {entry!r}"
                )
            bad = sorted(set(entry) - set(_ENTRY_KEYS))
            if bad:
                raise ValueError(
                    f"twin.prior.{name}: unknown key {bad[0]!r}; allowed: {', '.join(_ENTRY_KEYS)}"
                )
        out = []
        for u in pr.unknowns:
            entry = data.get(u.name, {})
            kw: dict[str, Any] = {k: entry[k] for k in ("low", "high", "source") if k in entry}
            try:
                out.append(replace(u, **kw))
            except (TypeError, ValueError) as exc:
                msg = str(exc)
                raise ValueError(msg if msg.startswith("twin.prior.")
                                 else f"twin.prior.{u.name}: {msg}") from None  # fmt: skip
        return cls(tuple(out))


def declared() -> Prior:
    """The prior the element modules declare (their ``UNKNOWNS``, in :data:`_MODULES` order)."""
    out: list[Unknown] = []
    for mod in _MODULES:
        out.extend(importlib.import_module(mod).UNKNOWNS)
    return Prior(tuple(out))


#: The declared default prior.
PRIOR: Prior = declared()
