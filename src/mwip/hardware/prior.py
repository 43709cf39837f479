"""The twin's unknown values as a declared parameter vector with a prior (docs/twin_model.md).

The book prints the robot's parameters (Table 6.1), the motor's data sheet (Table 2.1), the
battery voltage, the encoder's lines and the 5 ms sampling period: those stay fixed. What it
does not print is an :class:`Unknown` with a continuous uniform (or log-uniform) range, declared
by the element module it belongs to in a module-level ``UNKNOWNS`` tuple
(:mod:`mwip.hardware.motor`, :mod:`~mwip.hardware.firmware`, :mod:`~mwip.hardware.drivetrain`,
:mod:`~mwip.hardware.imu`, :mod:`~mwip.hardware.payload`, :mod:`~mwip.hardware.obstacle`);
:data:`PRIOR` collects them in :data:`ORDER` (a new element: one module and its ``UNKNOWNS``,
named in :data:`_MODULES`).

A robot file (:mod:`mwip.robot`, docs/robot.md) carries the prior as ``[prior]``, one inline
table per unknown::

    [prior]
    "drive.gear_ratio" = { low = 3.7, high = 51.0, unit = "", source = "..." }

(:meth:`Prior.to_dict` / :meth:`Prior.from_dict`); a user may narrow or widen a range or fix an
unknown with ``low = high``. ``Twin.prior``, ``Twin.values()`` and ``Twin.with_values()`` use
it, and ``run_on_twin(..., values=...)`` runs one twin per row of values.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.unknown import LEGACY_NAMES, Unknown, current_name

__all__ = ["Unknown", "Prior", "PRIOR", "declared", "ORDER", "LEGACY_NAMES", "current_name"]

#: The element modules that declare unknowns, in the prior's order.
_MODULES = (
    "mwip.hardware.motor",
    "mwip.hardware.firmware",
    "mwip.hardware.drivetrain",
    "mwip.hardware.imu",
    "mwip.hardware.payload",
    "mwip.hardware.obstacle",
)

#: The prior's order: the book calibration's unknowns in the order they were declared (its
#: draws are columns in this order; renamed where the robot file moved them,
#: :data:`LEGACY_NAMES`), then the later ones in :data:`_MODULES` order.
ORDER = (
    "drive.gear_ratio", "firmware.emf_compensation", "drive.deadband", "drive.current_limit",
    "gearbox.coulomb", "gearbox.viscous", "gearbox.backlash", "firmware.delay",
    "imu.gyro_bias", "imu.accel_bias", "imu.accel_sigma", "imu.gyro_sigma", "imu.height",
    "firmware.fusion.tau", "payload.height", "payload.radius", "stick.height",
)  # fmt: skip

_ENTRY_KEYS = ("low", "high", "unit", "source", "scale")


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

    @property
    def uniform(self) -> bool:
        """Every unknown is uniform in its value (a box prior of constant density)."""
        return all(u.scale == "linear" for u in self.unknowns)

    def sample(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """``n`` draws, (n, P) (a fixed unknown: its value; log-uniform ones by their
        logarithm)."""
        b = self.bounds
        u = rng.random((int(n), len(self)))
        out = b[:, 0] + u * (b[:, 1] - b[:, 0])
        for j, unk in enumerate(self.unknowns):
            if unk.scale == "log":
                out[:, j] = unk.from_unit(u[:, j])
        return out

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
        """``{name: {"low", "high", "unit", "source"[, "scale"]}}`` (the ``[prior]`` table;
        ``scale`` only where it is ``"log"``)."""
        out: dict[str, dict[str, Any]] = {}
        for u in self.unknowns:
            e: dict[str, Any] = {"low": u.low, "high": u.high, "unit": u.unit,
                                 "source": u.source}  # fmt: skip
            if u.scale != "linear":
                e["scale"] = u.scale
            out[u.name] = e
        return out

    def check(self, values: Mapping[str, float]) -> None:
        """Every value of ``values`` (a twin's :meth:`~mwip.hardware.twin.Twin.values`) with a
        name in the prior inside its range: else a one-line ``ValueError`` naming
        ``twin.prior.<name>``."""
        for u in self.unknowns:
            if u.name in values:
                u.check(float(values[u.name]))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base: Prior | None = None) -> Prior:
        """A prior from a robot file's ``[prior]`` table: entries of ``base`` (default
        :data:`PRIOR`) with ranges (and sources) replaced, names not given keeping ``base``'s.
        One-line ``ValueError`` naming ``twin.prior.<name>`` (the robot file's loader says
        ``prior.<name>``)."""
        pr = PRIOR if base is None else base
        if not isinstance(data, Mapping):
            raise ValueError(f"twin.prior must be a table, got {data!r}")
        data = {current_name(k): v for k, v in data.items()}
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
            kw: dict[str, Any] = {k: entry[k] for k in ("low", "high", "source", "scale")
                                  if k in entry}  # fmt: skip
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
    rank = {n: i for i, n in enumerate(ORDER)}
    out.sort(key=lambda u: rank.get(u.name, len(ORDER)))  # stable: the rest in module order
    return Prior(tuple(out))


#: The declared default prior.
PRIOR: Prior = declared()
