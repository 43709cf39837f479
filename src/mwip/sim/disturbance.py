"""External disturbances ``tau_ext(t)`` added to the plant's generalised forces (2.33).

A disturbance is any callable ``d(t) -> array`` taking a 1-D array of times (K,) and returning
``(K, 3)`` (the same for every plant) or ``(K, N, 3)`` (one per plant), in N m on
``[psi, theta, alpha]``. The classes here are frozen data so scenarios can describe them in TOML.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Disturbance",
    "Sinusoid",
    "Pulse",
    "Sum",
    "BOOK_SINUSOIDS",
    "disturbance_from_dict",
    "sinusoid_from_settings",
]

Disturbance = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def _vec3(name: str, value: Sequence[float] | float) -> tuple[float, float, float]:
    what = f"disturbance {name!r} must be a number or 3 numbers (N m, rad/s or rad)"
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf" or raw.shape not in ((), (3,)):  # not [x]: 1 or 3
            raise ValueError
        arr = np.broadcast_to(raw.astype(float), (3,))
    except (TypeError, ValueError):
        raise ValueError(f"{what}, got {value!r}") from None
    if not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > 1e6):
        raise ValueError(f"{what}, finite and in [-1e6, 1e6], got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class Sinusoid:
    """``tau_j(t) = amplitude_j sin(omega_j t + phase_j) + offset_j`` per channel j."""

    amplitude: tuple[float, float, float] = (0.0, 0.0, 0.0)
    omega: tuple[float, float, float] = (1.0, 1.0, 1.0)
    phase: tuple[float, float, float] = (0.0, 0.0, 0.0)
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("amplitude", "omega", "phase", "offset"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float)[..., None]
        return np.asarray(self.amplitude) * np.sin(
            np.asarray(self.omega) * tt + np.asarray(self.phase)
        ) + np.asarray(self.offset)


@dataclass(frozen=True)
class Pulse:
    """A rectangular pulse ``value`` (3,) on ``start <= t < start + width`` (e.g. a bump)."""

    value: tuple[float, float, float]
    start: float
    width: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", _vec3("value", self.value))
        for name in ("start", "width"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise ValueError(f"pulse {name!r} must be a number (s), got {v!r}")
        if not (np.isfinite(self.start) and np.isfinite(self.width) and self.width > 0):
            raise ValueError(f"pulse 'width' must be finite and in (0, inf), got {self.width!r}")

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float)[..., None]
        on = (tt >= self.start) & (tt < self.start + self.width)
        return on * np.asarray(self.value)


@dataclass(frozen=True)
class Sum:
    """The sum of several disturbances."""

    parts: tuple[Disturbance, ...] = field(default_factory=tuple)

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((*np.shape(t), 3))
        for p in self.parts:
            out = out + p(t)
        return out


#: The disturbance of the book's simulation studies (Section 3.6, SPEC.md section 4):
#: tau*_1 = 0.05 sin(2t + pi/2), tau*_2 = 0.05 sin t, tau*_3 = 0.05 sin t (N m).
BOOK_SINUSOIDS = Sinusoid(
    amplitude=(0.05, 0.05, 0.05), omega=(2.0, 1.0, 1.0), phase=(np.pi / 2, 0.0, 0.0)
)


def disturbance_from_dict(data: Mapping[str, Any]) -> Disturbance:
    """Build a disturbance from scenario data: ``{"kind": "sinusoid", ...}`` or ``"pulse"``."""
    kinds: dict[str, type] = {"sinusoid": Sinusoid, "pulse": Pulse}
    if not isinstance(data, Mapping):
        raise ValueError(f"disturbance must be a table, got {data!r}")
    d = dict(data)
    kind_value = d.pop("kind", "")
    kind = kind_value.lower() if isinstance(kind_value, str) else repr(kind_value)
    if kind == "book":
        if d:
            raise ValueError(f"disturbance 'book' takes no other keys, got {sorted(d)[0]!r}")
        return BOOK_SINUSOIDS
    if kind not in kinds:
        raise ValueError(f"disturbance 'kind' must be one of book, pulse, sinusoid; got {kind!r}")
    try:
        return kinds[kind](**d)
    except TypeError as exc:
        raise ValueError(f"disturbance {kind!r}: {exc}") from None


def sinusoid_from_settings(cfg: Mapping[str, Any], prefix: str = "disturbance") -> Sinusoid:
    """The external sinusoids of a study's settings: ``<prefix>_amplitude``, ``_omega`` and
    ``_phase`` (3 values each, per channel of ``[psi, theta, alpha]``; e.g. the book's
    ``tau*_d1 = 0.05 sin(2t + pi/2)``, ``tau*_d2 = tau*_d3 = 0.05 sin t`` of Sec. 3.6)."""
    return Sinusoid(
        amplitude=tuple(cfg[f"{prefix}_amplitude"]),
        omega=tuple(cfg[f"{prefix}_omega"]),
        phase=tuple(cfg[f"{prefix}_phase"]),
    )
