"""The drive train between motor and wheel: reflected rotor inertia, friction, backlash.

Reflected rotor inertia (element ``inertia``)
    The motor's stator is fixed to the body and its rotor turns at ``N (psi_i' - theta')``
    relative to it, so the rotor's absolute spin rate is ``theta' + N (psi_i' - theta')``
    (``psi_{r,l} = psi +- (b/r) alpha``). Its kinetic energy, summed over both wheels, is
    ``J [N^2 psi'^2 + N^2 (b/r)^2 alpha'^2 - 2 N (N-1) psi' theta' + (N-1)^2 theta'^2]``,
    i.e. it adds to the mass matrix of (2.32)

    - ``m11 += 2 N^2 J``  (exactly ``Iwa -> Iwa + N^2 J``),
    - ``m33 += 2 (b/r)^2 N^2 J``  (the same ``Iwa`` term of ``m33``),
    - ``m22 += 2 (N-1)^2 J``  (exactly ``Iby -> Iby + 2 (N-1)^2 J``),
    - ``M12 += -2 N (N-1) J``, a *constant* coupling: carried as ``m12 -> m12 - 2 N (N-1) J``
      (:class:`TwinPlant`), i.e. multiplied by ``cos theta`` like the rest of ``M12``
      (error ``2 N (N-1) J (1 - cos theta)``, 1.5 % of the term at 10 deg) and entering the
      small ``m12 sin theta`` velocity terms of ``N`` (where a constant entry has none).

    For ``N >> 1`` it is ``2 N^2 J`` on the *relative* wheel-body motion: the famous
    "``Iwa + N^2 J``" alone would spin the rotor when the whole robot pitches about a locked
    wheel, which the body-mounted stator does not. With Table 2.1's ``J = 10.8 g cm^2`` and
    ``N = 23``: ``N^2 J = 5.7e-4 kg m^2`` per wheel, four times Table 6.1's ``Iwa``.
Back-EMF of a voltage drive (element ``motor``, ``mode = "voltage"``)
    With the inductance's 0.1 ms settled, the wheel torque of a voltage-driven motor is
    ``eta N k_t (V - k_e N w) / R`` with ``w = psi_i' - theta'``: the speed term is a
    viscous torque on exactly the relative motion that ``Db`` damps in (2.32). The twin
    therefore adds ``c_emf = eta N^2 k_t k_e / R`` to the plant's ``Db`` (integrated inside
    the sample, not held from its start) and the driver holds only the voltage term.
Gearbox friction (switch ``friction``)
    Viscous: ``GearboxSpec.viscous`` is added to ``Db`` (the book's ``Db`` stays the rest of
    the drive train's viscous loss). Coulomb: ``-F_c sign(w)`` held over the sample, and
    stiction, in the discrete stick-slip form of the element :mod:`mwip.hardware.friction`.
Backlash (switch ``backlash``)
    :mod:`mwip.hardware.backlash`: a play of ``backlash`` rad at the wheel; after a torque
    reversal the motor side (inertia ``N^2 J``) must cross it before torque reaches the wheel.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.hardware.unknown import Unknown
from mwip.params import Params

__all__ = [
    "GearboxSpec",
    "TwinPlant",
    "reflected_inertia",
    "derive_plant",
    "relative_mobility",
    "UNKNOWNS",
]


def _check(name: str, value: float, lo: float, hi: float) -> None:
    if not (np.isfinite(value) and lo <= value <= hi):
        raise ValueError(f"{name!r} must be finite and in [{lo:g}, {hi:g}], got {value!r}")


@dataclass(frozen=True)
class GearboxSpec:
    """Gearbox losses, at the wheel (docs/twin_model.md for the sources).

    coulomb : Coulomb friction torque per wheel (N m). Default ``N k_t I_0`` with the no-load
        current ``I_0 = I_A (1 - sqrt(eta_max))^2`` of MAXON's efficiency relation and Table
        2.1's ``eta_max = 85 %``: ``I_0 = 62 mA``, ``F_c = 23 x 1.49 mN m = 0.034 N m``.
    viscous : extra viscous friction per wheel (N m s/rad), added to ``Db``; default 0 (the
        book's ``Db`` is the drive train's viscous friction).
    backlash : play at the wheel (rad); default 0.7 deg (MAXON GP 32 A catalogue, average
        no-load backlash; the book names no gearbox).
    """

    coulomb: float = 0.034
    viscous: float = 0.0
    backlash: float = float(np.deg2rad(0.7))

    def __post_init__(self) -> None:
        _check("coulomb", self.coulomb, 0.0, 100.0)
        _check("viscous", self.viscous, 0.0, 100.0)
        _check("backlash", self.backlash, 0.0, 1.0)


@dataclass(frozen=True)
class TwinPlant(Params):
    """:class:`~mwip.params.Params` with a constant coupling removed from ``m12``:
    ``m12 = mb l r - m12_offset`` (the reflected rotor's ``2 N (N-1) J``, module docstring).
    Every other coefficient follows from the fields as in (2.32)."""

    m12_offset: Any = 0.0

    def __post_init__(self) -> None:
        base = Params(**{f.name: getattr(self, f.name) for f in fields(Params)})
        for f in fields(Params):
            object.__setattr__(self, f.name, getattr(base, f.name))
        off = np.asarray(self.m12_offset, dtype=float)
        m12 = np.asarray(base.mb * base.l * base.r)
        if not (np.all(np.isfinite(off)) and np.all(off >= 0) and np.all(off < m12)):
            raise ValueError(
                f"'m12_offset' must be finite and in [0, mb l r), got {self.m12_offset!r}"
            )
        object.__setattr__(self, "m12_offset", float(off) if off.ndim == 0 else off)
        shape = np.broadcast_shapes(base.batch_shape, off.shape)
        object.__setattr__(self, "_batch_shape", shape)

    @property
    def m12(self) -> Any:
        """m12 = mb l r  (2.32), less the reflected rotor's constant coupling."""
        return self.mb * self.l * self.r - self.m12_offset

    def __getitem__(self, index: Any) -> TwinPlant:
        shape = self.batch_shape
        return TwinPlant(
            **{f.name: np.broadcast_to(getattr(self, f.name), shape)[index] for f in fields(self)}
        )


def reflected_inertia(gear_ratio: ArrayLike, rotor_inertia: float) -> dict[str, Any]:
    """Mass-matrix increments of two rotors behind ``gear_ratio`` (module docstring):
    ``{"Iwa": N^2 J, "Iby": 2 (N-1)^2 J, "m12_offset": 2 N (N-1) J}`` (floats, or arrays of
    ``gear_ratio``'s shape for per-row ratios)."""
    n: Any = float(gear_ratio) if np.ndim(gear_ratio) == 0 else np.asarray(gear_ratio, float)  # type: ignore[arg-type]
    j = float(rotor_inertia)
    return {
        "Iwa": n * n * j,
        "Iby": 2.0 * (n - 1.0) ** 2 * j,
        "m12_offset": 2.0 * n * (n - 1.0) * j,
    }


def derive_plant(
    base: Params,
    *,
    inertia: ArrayLike = False,
    extra_db: ArrayLike = 0.0,
    gear_ratio: ArrayLike = 23.0,
    rotor_inertia: float = 10.8e-7,
) -> Params:
    """The plant the twin integrates: ``base`` plus the reflected rotor inertia where
    ``inertia`` (bool, per row) and ``extra_db`` (N m s/rad, per row: back-EMF and gearbox
    viscous friction) on ``Db``; ``gear_ratio`` a float or per row. Returns ``base`` itself
    when nothing is added."""
    on = np.asarray(inertia, dtype=bool)
    db = np.asarray(extra_db, dtype=float)
    if not on.any() and not np.any(db != 0):
        return base
    inc = reflected_inertia(gear_ratio, rotor_inertia)
    vals = {f.name: getattr(base, f.name) for f in fields(Params)}
    sel = on.astype(float)

    def add(x: Any, y: Any) -> Any:
        z = np.asarray(x, dtype=float) + y
        return float(z) if z.ndim == 0 else z

    vals["Iwa"] = add(vals["Iwa"], sel * inc["Iwa"])
    vals["Iby"] = add(vals["Iby"], sel * inc["Iby"])
    vals["Db"] = add(vals["Db"], db)
    off = sel * inc["m12_offset"]
    base_off = getattr(base, "m12_offset", 0.0)
    return TwinPlant(**vals, m12_offset=add(base_off, off))


def relative_mobility(plant: Params) -> NDArray[np.float64]:
    """Relative acceleration of one wheel per unit torque on it, upright at rest:
    ``e M(0)^-1 e^T`` with ``e = [1, -1, b/r]`` (the torque ``u`` on a wheel is the
    generalised force ``u e`` of (2.32)); shape ``plant.batch_shape``."""
    from mwip.models.reduced import mass_matrix

    M = mass_matrix(plant, np.zeros(3))
    br = np.asarray(plant.b / plant.r, dtype=float)
    e = np.stack(np.broadcast_arrays(np.ones_like(br), -np.ones_like(br), br), axis=-1)
    x = np.linalg.solve(M, e[..., None])[..., 0]
    return np.sum(e * x, axis=-1)


#: The gearbox's unknowns (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("gearbox.coulomb", 0.0, 0.06, "N m", "per wheel; 0 to ~1.8x the 23:1 value from "
            "Table 2.1's 85 % efficiency (0.034)", "friction", 0.034),
    Unknown("gearbox.viscous", 0.0, 0.005, "N m s/rad", "per wheel, beyond the book's Db",
            "friction", 0.0),
    Unknown("gearbox.backlash", 0.0, 0.0175, "rad", "at the wheel, 0-1 deg; GP 32 A catalogue "
            "<= 0.7-1.0 deg", "backlash", float(np.deg2rad(0.7))),
)  # fmt: skip
