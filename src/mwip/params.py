"""Physical parameters of a mobile wheeled inverted pendulum.

A :class:`Params` holds the book's symbols (list of Symbols, Tables 3.1/3.2 = 6.1/6.2):

==========  ==========================================================  ========
symbol      meaning                                                     unit
==========  ==========================================================  ========
``mb``      body mass                                                   kg
``mw``      mass of one wheel                                           kg
``Iby``     body pitch inertia: about the axis through the body's      kg m^2
            centre of mass parallel to the axle (not about the axle)
``Ibz``     the book's Ibz, the inertia (2.32) multiplies by            kg m^2
            ``sin^2 theta``: physically the body's roll inertia about
            its forward axis through the centre of mass
``Iwa``     wheel inertia about the axle                                kg m^2
``Iwd``     wheel inertia about a diameter                              kg m^2
``l``       distance from the axle to the body's centre of mass         m
``b``       half the distance between the wheels                        m
``r``       wheel radius                                                m
``Db``      body-wheel (motor/gearbox) rotational damping               N m s/rad
``Dw``      wheel-ground rotational damping                             N m s/rad
``g``       gravitational acceleration                                  m/s^2
``Iyaw``    body yaw inertia about its own vertical axis through the    kg m^2
            centre of mass (0 = the book's (2.32); an extension)
==========  ==========================================================  ========

Body inertias (docs/models.md, "The body's inertias"). ``Iby``, ``Ibz`` and ``Iyaw`` are the
body's principal inertias about its centre of mass, as a user measures them (CAD, pendulum
test): pitch (axis along the axle), roll (forward axis) and yaw (the body's own vertical
axis, upright). With pitch ``theta`` the body's yaw kinetic energy is
``1/2 [Ibz sin^2 theta + Iyaw cos^2 theta + mb l^2 sin^2 theta] alpha'^2``; the book's
(2.32) writes ``1/2 [(Ibz + mb l^2) sin^2 theta] alpha'^2``, which is the case ``Iyaw = 0``
(the spatial model's (2.20) keeps both terms). With ``Iyaw`` the general body keeps (2.32)'s
form exactly: ``Ibl = Ibz - Iyaw + mb l^2`` and ``m33`` gains ``+ Iyaw``. ``Iyaw`` defaults to
0, so the book's robot (Tables 6.1/6.2) is (2.32) as printed.

Damping. In a :class:`Params`, ``Db`` and ``Dw`` are the *rotational* coefficients that (2.32)
multiplies with angular rates, in N m s/rad; a user's own parameter file gives them so. The
book's tables print them in N s/m (viscous friction at the wheel rim), so for the book's sets
the equations need ``D r^2``, each set with its own ``r`` (SPEC.md section 2, "Damping"):

- ``"units"`` (default): ``Db = Db_table r^2``, ``Dw = Dw_table r^2`` -- what the printed units
  say; real ``8.0e-4, 1.28e-3``, nominal ``3.6e-4, 5.4e-4`` N m s/rad.
- ``"literal"``: the printed numbers used as rotational coefficients (``Db = 0.5`` N m s/rad...),
  the project's earlier reading. It caps the steady wheel speed at ``Gb / (2 Dw) = 0.98``
  rad/s (4 cm/s, real parameters), so every speed run of the book is impossible under it; it
  is kept by name for comparison (:func:`book_params`, ``--damping literal`` on the CLI).

Fields may be floats (one robot) or NumPy arrays of a common shape (a batch of robots, e.g.
for Monte Carlo); every derived coefficient and every model function broadcasts over them.

The derived coefficients of (2.32) are properties: ``m11, m12, m22, m33, Ibl, Gb``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import tomli_w
from numpy.typing import NDArray

from mwip.damping import DAMPING_READINGS
from mwip.io import read_toml, write_text_atomic

__all__ = [
    "Params",
    "REAL",
    "NOMINAL",
    "GRAVITY",
    "PARAM_FIELDS",
    "load_params",
    "save_params",
    "stack_params",
    "DAMPING_READINGS",
    "BOOK_TABLES",
    "book_params",
    "REAL_LITERAL",
    "NOMINAL_LITERAL",
    "steady_speed_cap",
    "Value",
]

GRAVITY = 9.81

#: A parameter value: a number, or an (N,) array of numbers for a batch of N robots.
Value: TypeAlias = float | NDArray[np.float64]

#: (lower bound, upper bound, lower bound inclusive?) for each field: the allowed ranges.
_RANGES: dict[str, tuple[float, float, bool]] = {
    "mb": (0.0, math.inf, False),
    "mw": (0.0, math.inf, False),
    "Iby": (0.0, math.inf, False),
    "Ibz": (0.0, math.inf, False),
    "Iwa": (0.0, math.inf, False),
    "Iwd": (0.0, math.inf, True),
    "l": (0.0, math.inf, False),
    "b": (0.0, math.inf, False),
    "r": (0.0, math.inf, False),
    "Db": (0.0, math.inf, True),
    "Dw": (0.0, math.inf, True),
    "g": (0.0, math.inf, False),
    "Iyaw": (0.0, math.inf, True),
}


#: Physically plausible sizes (SI) of each field, from a toy robot to a car: a value outside
#: them (e.g. r = 1e-300 m) passes the sign check but overflows the derived coefficients.
_PLAUSIBLE: dict[str, tuple[float, float]] = {
    "mb": (1e-6, 1e5), "mw": (1e-6, 1e5),
    "Iby": (1e-12, 1e5), "Ibz": (1e-12, 1e5), "Iwa": (1e-12, 1e5), "Iwd": (1e-12, 1e5),
    "l": (1e-6, 1e3), "b": (1e-6, 1e3), "r": (1e-6, 1e3),
    "Db": (1e-12, 1e6), "Dw": (1e-12, 1e6), "g": (1e-3, 1e3), "Iyaw": (1e-12, 1e5),
}  # fmt: skip


#: Fields with a default: a file or mapping may leave them out (``g`` = 9.81 m/s^2, ``Iyaw`` =
#: 0, the book's (2.32)).
_OPTIONAL = ("g", "Iyaw")


def _range_text(name: str) -> str:
    lo, hi, closed = _RANGES[name]
    return f"{'[' if closed else '('}{lo:g}, {'inf' if math.isinf(hi) else f'{hi:g}'})"


@dataclass(frozen=True)
class Params:
    """Parameters of one MWIP (or of a batch, when the fields are arrays).

    Raises ``ValueError`` naming the field and its allowed range when a value is not finite
    or is outside the physical range (masses, inertias and lengths > 0; ``Iwd``, ``Iyaw`` and
    damping >= 0). ``Iyaw`` comes after ``g`` (default 0, the book's (2.32)) so that
    positional construction with the book's twelve symbols stays valid.

    Examples
    --------
    >>> from mwip.params import REAL
    >>> round(REAL.m11, 6)     # (mb + 2 mw) r^2 + 2 Iwa
    0.004856
    """

    mb: Value
    mw: Value
    Iby: Value
    Ibz: Value
    Iwa: Value
    Iwd: Value
    l: Value
    b: Value
    r: Value
    Db: Value
    Dw: Value
    g: Value = GRAVITY
    Iyaw: Value = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            raw = getattr(self, f.name)
            try:
                kind = np.asarray(raw).dtype.kind
                value = np.asarray(raw, dtype=float) if kind in "iuf" else None
            except (TypeError, ValueError):
                value = None
            if value is None:  # a string, a bool, a ragged list, an object
                raise ValueError(
                    f"parameter {f.name!r} must be a number in {_range_text(f.name)}, got {raw!r}"
                )
            lo, hi, closed = _RANGES[f.name]
            ok_lo = value >= lo if closed else value > lo
            if not (np.all(np.isfinite(value)) and np.all(ok_lo) and np.all(value < hi)):
                raise ValueError(
                    f"parameter {f.name!r} must be finite and in {_range_text(f.name)}, got {raw!r}"
                )
            plo, phi = _PLAUSIBLE[f.name]
            if np.any((value < plo) & (value != 0)) or np.any(value > phi):
                raise ValueError(
                    f"parameter {f.name!r} must be in [{plo:g}, {phi:g}] {UNITS[f.name]} "
                    f"(a physically plausible size; 0 allowed where the range says so), "
                    f"got {raw!r}"
                )
            object.__setattr__(self, f.name, float(value) if value.ndim == 0 else value)
        try:
            shape = np.broadcast_shapes(*(np.shape(getattr(self, f.name)) for f in fields(self)))
        except ValueError:
            raise ValueError("parameter arrays must have broadcastable shapes") from None
        object.__setattr__(self, "_batch_shape", shape)  # derived once: fields are frozen
        with np.errstate(all="ignore"):
            derived = {k: np.asarray(getattr(self, k), dtype=float)
                       for k in ("m11", "m12", "m22", "m33", "Ibl", "Gb")}  # fmt: skip
            det = derived["m11"] * derived["m22"] - derived["m12"] ** 2
            # Ibl = Ibz - Iyaw + mb l^2 may be negative (a flat, wide body): the yaw inertia
            # m33 + Ibl sin^2 theta of (2.32) must be positive at every pitch instead
            yaw = derived["m33"] + np.minimum(derived["Ibl"], 0.0)
        for k, v in {**derived, "m11 m22 - m12^2": det}.items():
            if not (np.all(np.isfinite(v)) and (k == "Ibl" or np.all(v > 0))):
                raise ValueError(
                    f"parameters give a derived coefficient {k} of (2.32) = {v!r} that is not "
                    "finite"
                    + ("" if k == "Ibl" else " and > 0")
                    + "; check the sizes of mb, mw, the inertias, l, b and r"
                )
        if not np.all(yaw > 0):
            raise ValueError(
                f"parameters give a yaw inertia m33 + min(Ibl, 0) = {yaw!r} <= 0 at some pitch "
                "(2.32); check Ibz, Iyaw, mb, l, Iwd, Iwa, mw, b and r"
            )

    # ---- derived coefficients of (2.32) --------------------------------------------------
    @property
    def m11(self) -> Any:
        """m11 = (mb + 2 mw) r^2 + 2 Iwa  (2.32)."""
        return (self.mb + 2.0 * self.mw) * self.r**2 + 2.0 * self.Iwa

    @property
    def m12(self) -> Any:
        """m12 = mb l r  (2.32)."""
        return self.mb * self.l * self.r

    @property
    def m22(self) -> Any:
        """m22 = mb l^2 + Iby  (2.32)."""
        return self.mb * self.l**2 + self.Iby

    @property
    def Ibl(self) -> Any:
        """Ibl = Ibz - Iyaw + mb l^2: (2.32)'s ``Ibz + mb l^2``, less the body's own yaw
        inertia (an extension; ``Iyaw = 0`` is the book's (2.32), module docstring and
        docs/models.md). The coefficient of ``sin^2 theta`` in the yaw inertia; it may be
        negative for a flat, wide body."""
        return self.Ibz - self.Iyaw + self.mb * self.l**2

    @property
    def Gb(self) -> Any:
        """Gb = mb g l  (2.32)."""
        return self.mb * self.g * self.l

    @property
    def m33(self) -> Any:
        """m33 = 2 Iwd + (2 b^2 / r^2) (Iwa + mw r^2) + Iyaw: (2.32) plus the body's own yaw
        inertia (an extension; ``Iyaw = 0`` is the book's (2.32), docs/models.md). The yaw
        inertia upright."""
        return (
            2.0 * self.Iwd
            + 2.0 * self.b**2 / self.r**2 * (self.Iwa + self.mw * self.r**2)
            + self.Iyaw
        )

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Common broadcast shape of the fields: ``()`` for a single robot."""
        return self._batch_shape  # type: ignore[attr-defined]

    # ---- conversions ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Field values as a plain dict (arrays become lists)."""
        return {
            k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, base: Params | None = None) -> Params:
        """Build from a mapping. With ``base``, missing fields are taken from it; without it
        every field but ``g`` and ``Iyaw`` (defaults 9.81 m/s^2 and 0) is required.

        Unknown keys raise ``ValueError`` (a typo must not be silently ignored).
        """
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(
                f"unknown parameter {unknown[0]!r}; allowed: {', '.join(sorted(names))}"
            )
        if base is not None:
            return replace(base, **dict(data))
        missing = [n for n in names if n not in data and n not in _OPTIONAL]
        if missing:
            raise ValueError(f"parameter {sorted(missing)[0]!r} is missing")
        return cls(**dict(data))

    def with_payload(
        self,
        mass: float = 0.5,
        height: float | NDArray[np.float64] = 0.1,
        body_height: float | None = None,
        pan_radius: float | NDArray[np.float64] = 0.08,
    ) -> Params:
        """The robot with a payload on top (Chapter 6, Case 2; SPEC.md section 5).

        Geometry assumed (the book gives only "a 0.5 kg pan on four 0.1 m rods", Fig. 6.2):
        the body is a uniform slender block whose centre of mass is at ``l`` above the axle,
        so its top is at ``body_height`` above the axle (default ``2 l``). The payload is a
        thin uniform disc ("pan") of radius ``pan_radius`` whose centre sits ``height`` above
        the top of the body, i.e. at ``h_p = body_height + height`` above the axle. The rods'
        mass is neglected. Then, with ``m_p = mass``:

        - ``mb' = mb + m_p``
        - ``l' = (mb l + m_p h_p) / mb'``  (combined centre of mass)
        - ``Iby' = Iby + mb (l - l')^2 + m_p (h_p - l')^2 + m_p R^2 / 4``  (parallel axes,
          about the new centre of mass; a disc about a diameter has ``m R^2 / 4``)
        - ``Ibz' = Ibz + m_p R^2 / 2``  (disc about its axis, on the yaw axis)

        The wheels and damping are unchanged. ``height`` and ``pan_radius`` may be (N,) arrays
        (a batch of payloads; the result then has fields of shape (N,)).
        """
        for name, value, lo in (("mass", mass, 0.0), ("height", height, 0.0)):
            if not (np.all(np.isfinite(value)) and np.all(np.asarray(value) >= lo)):
                raise ValueError(f"payload {name!r} must be finite and in [0, inf), got {value!r}")
        if not (np.all(np.isfinite(pan_radius)) and np.all(np.asarray(pan_radius) >= 0)):
            raise ValueError(
                f"payload 'pan_radius' must be finite and in [0, inf), got {pan_radius!r}"
            )
        top = 2.0 * self.l if body_height is None else body_height
        if not (np.all(np.isfinite(top)) and np.all(np.asarray(top) > 0)):
            raise ValueError(f"payload 'body_height' must be finite and in (0, inf), got {top!r}")
        hp = top + height
        mb2 = self.mb + mass
        l2 = (self.mb * self.l + mass * hp) / mb2
        iby2 = (
            self.Iby
            + self.mb * (self.l - l2) ** 2
            + mass * (hp - l2) ** 2
            + mass * pan_radius**2 / 4.0
        )
        ibz2 = self.Ibz + mass * pan_radius**2 / 2.0
        return replace(self, mb=mb2, l=l2, Iby=iby2, Ibz=ibz2)

    def __getitem__(self, index: Any) -> Params:
        """Select robots of a batch (fields indexed after broadcasting to the batch shape)."""
        shape = self.batch_shape
        return Params(
            **{f.name: np.broadcast_to(getattr(self, f.name), shape)[index] for f in fields(self)}
        )


PARAM_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(Params))


#: The book's parameter tables as printed (Db, Dw in the tables' N s/m): Table 3.1 (= 6.1,
#: the real robot, the plant) and Table 3.2 (= 6.2, the nominal model designs use).
BOOK_TABLES: dict[str, dict[str, float]] = {
    "real": dict(mb=2.58, mw=0.14, Iby=1.77e-3, Ibz=1.77e-3, Iwa=1.4e-4, Iwd=8.4e-4,
                 l=0.0622, b=0.15, r=0.04, Db=0.5, Dw=0.8, g=GRAVITY),
    "nominal": dict(mb=2.50, mw=0.12, Iby=1.57e-3, Ibz=1.57e-3, Iwa=1.2e-4, Iwd=8.1e-4,
                    l=0.0582, b=0.14, r=0.03, Db=0.4, Dw=0.6, g=GRAVITY),
}  # fmt: skip


def book_params(which: str, damping: str = "units") -> Params:
    """The book's parameter set ``which`` (``"real"``: Table 3.1, ``"nominal"``: Table 3.2)
    under the damping reading ``damping`` (SPEC.md section 2).

    ``"units"``: the tables' ``Db, Dw`` in N s/m enter (2.32) as ``D r^2`` (N m s/rad), with
    the set's own ``r``; ``"literal"``: the printed numbers as rotational coefficients.

    >>> book_params("real").Db            # 0.5 N s/m * (0.04 m)^2
    0.0008
    >>> book_params("nominal", "literal").Dw
    0.6
    """
    key = str(which).lower()
    if key not in BOOK_TABLES:
        raise ValueError(f"book parameter set must be one of 'real', 'nominal', got {which!r}")
    if damping not in DAMPING_READINGS:
        raise ValueError(
            f"damping reading must be one of {', '.join(DAMPING_READINGS)}, got {damping!r}"
        )
    table = dict(BOOK_TABLES[key])
    if damping == "units":
        r2 = table["r"] ** 2
        table["Db"], table["Dw"] = table["Db"] * r2, table["Dw"] * r2
    return Params(**table)


#: Real parameters of the robot: Table 3.1 (= Table 6.1), damping read as ``D r^2``. The plant.
REAL = book_params("real")

#: Nominal (estimated) parameters: Table 3.2 (= Table 6.2), damping ``D r^2``. What designs use.
NOMINAL = book_params("nominal")

#: Table 3.1 under the literal damping reading (``Db = 0.5``, ``Dw = 0.8`` N m s/rad).
REAL_LITERAL = book_params("real", "literal")

#: Table 3.2 under the literal damping reading (``Db = 0.4``, ``Dw = 0.6`` N m s/rad).
NOMINAL_LITERAL = book_params("nominal", "literal")


def steady_speed_cap(p: Params) -> Any:
    """Highest steady wheel speed the robot can hold, in rad/s: ``Gb / (2 Dw)``.

    In steady rolling (``theta' = 0, psi'' = 0``) the first row of (2.32) plus the second
    give ``Gb sin(theta) = 2 Dw psi'`` (gravity on the lean pays the wheel-ground damping), so
    ``|psi'| <= Gb / (2 Dw)``, reached only lying flat.

    >>> round(steady_speed_cap(REAL_LITERAL), 3), round(steady_speed_cap(REAL), 1)
    (0.984, 614.9)
    """
    return p.Gb / (2.0 * p.Dw)


def stack_params(items: Iterable[Params]) -> Params:
    """Stack robots into one batched :class:`Params` (fields of shape (N,))."""
    items = list(items)
    if not items:
        raise ValueError("stack_params needs at least one Params")
    return Params(
        **{
            name: np.array([np.asarray(getattr(p, name), dtype=float) for p in items])
            for name in PARAM_FIELDS
        }
    )


def load_params(path: str | os.PathLike[str], *, base: Params | None = None) -> Params:
    """Read parameters from a TOML file.

    The file holds the symbols at top level or under a ``[params]`` table, e.g.::

        [params]
        mb = 2.58   # kg
        l = 0.0622  # m

    With ``base`` (e.g. ``REAL``) missing fields are taken from it; without it every field
    but ``g`` and ``Iyaw`` is required (a file written before ``Iyaw`` existed loads with
    ``Iyaw = 0``, the book's (2.32), unless its base has another). A value may also be
    ``"real"``/``"nominal"`` at the top level key ``base``.
    """
    p = Path(path)
    data = read_toml(p, "parameter file")
    try:
        return _params_from_file_data(data, base)
    except ValueError as exc:
        raise ValueError(f"parameter file {str(p)!r}: {exc}") from None


def _params_from_file_data(data: dict[str, Any], base: Params | None) -> Params:
    if "params" in data and isinstance(data["params"], dict):
        extra = {k: v for k, v in data.items() if k not in ("params", "base")}
        if extra:
            raise ValueError(f"unknown key {sorted(extra)[0]!r}; allowed: params, base")
        body = data["params"]
    else:
        body = {k: v for k, v in data.items() if k != "base"}
    if not body and "base" not in data:
        raise ValueError("holds no parameters (an empty file would silently mean the default "
                         "robot); give at least one field, or base = 'real'")  # fmt: skip
    for key, value in body.items():
        if key in _RANGES and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise ValueError(
                f"parameter {key!r} must be a number in {_range_text(key)} (one robot: no "
                f"arrays, strings or tables), got {value!r}"
            )
    if "base" in data:
        named = {"real": REAL, "nominal": NOMINAL}
        key = str(data["base"]).lower() if isinstance(data["base"], str) else None
        if key not in named:
            raise ValueError(f"'base' must be one of 'real', 'nominal', got {data['base']!r}")
        base = named[key]
    return Params.from_dict(body, base=base)


#: Units of the fields, for files and ``mwip params show``.
UNITS: dict[str, str] = {
    "mb": "kg", "mw": "kg", "Iby": "kg m^2", "Ibz": "kg m^2", "Iwa": "kg m^2", "Iwd": "kg m^2",
    "l": "m", "b": "m", "r": "m", "Db": "N m s/rad", "Dw": "N m s/rad", "g": "m/s^2",
    "Iyaw": "kg m^2",
}  # fmt: skip

FILE_HEADER = (
    "# MWIP parameters (mwip.params): SI units; mb, mw kg; Iby, Ibz, Iwa, Iwd, Iyaw kg m^2;\n"
    "# l, b, r m; g m/s^2. Db (body-wheel) and Dw (wheel-ground) are the ROTATIONAL damping\n"
    "# coefficients of (2.32) in N m s/rad. The book's tables print N s/m: for them this file\n"
    "# holds D r^2 (the 'units' reading, SPEC.md section 2). The body's inertias are about\n"
    "# its centre of mass: Iby pitch (axle direction), Ibz roll (forward), Iyaw yaw (its own\n"
    "# vertical axis); Iyaw = 0 (the default) is the book's (2.32).\n"
)


def save_params(params: Params, path: str | os.PathLike[str]) -> None:
    """Write parameters to a TOML file (atomically: a temporary file, then rename).

    The file starts with a comment giving every field's unit; ``Db, Dw`` are written as the
    rotational coefficients of (2.32) in N m s/rad, which is how :func:`load_params` reads them.
    """
    text = FILE_HEADER + tomli_w.dumps({"params": params.to_dict()})
    write_text_atomic(Path(path), text)
