"""Quadrature wheel encoders (Sec. 2.5.1, HED-5540 class).

The encoder sits on the motor shaft, so it counts the rotation of the wheel *relative to the
body* through the gearbox: ``counts_i = floor(cpr * N_gear (psi_i - theta) / 2 pi)`` with
``psi_r = psi + b alpha / r``, ``psi_l = psi - b alpha / r``. The controller board recovers
``psi = mean(relative angle) + theta^`` (the fused pitch), ``alpha = r (psi_r - psi_l) / 2b``
and the rates by differences over the sample period ("the number of pulses measured per unit
time is the angular velocity", Sec. 2.5.1).

Defaults: the book's HED-5540-C06 (Fig. 2.6): in the HEDS-5540 ordering code the letter is
the resolution, ``C`` = 100 lines per turn (``A`` would be 500), and the LM3S2965's
quadrature encoder interface counts all four edges: 400 counts per motor turn, 9200 per wheel
turn behind the 23:1 gearbox (docs/twin_model.md; 2000 with 500 lines is the sensitivity).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["EncoderSpec", "count", "counts_to_angle", "difference_rate"]


@dataclass(frozen=True)
class EncoderSpec:
    """``cpr`` counts per motor revolution (after quadrature decoding), ``gear_ratio`` motor
    turns per wheel turn (the encoder is on the motor shaft)."""

    cpr: int = 400
    gear_ratio: float = 23.0

    def __post_init__(self) -> None:
        if int(self.cpr) != self.cpr or not (1 <= self.cpr <= 10_000_000):
            raise ValueError(f"'cpr' must be an integer in [1, 1e7], got {self.cpr!r}")
        if not (np.isfinite(self.gear_ratio) and 1.0 <= self.gear_ratio <= 1000.0):
            raise ValueError(
                f"'gear_ratio' must be finite and in [1, 1000], got {self.gear_ratio!r}"
            )

    @property
    def resolution(self) -> float:
        """Wheel angle per count (rad)."""
        return 2.0 * np.pi / (self.cpr * self.gear_ratio)


def count(
    rel_angle: ArrayLike, spec: EncoderSpec, resolution: ArrayLike | None = None
) -> NDArray[np.int64]:
    """Counter value for a wheel-relative-to-body angle (rad): ``floor(angle / resolution)``
    (``resolution``: the spec's, or given, e.g. per row as an (N, 1) column)."""
    res = spec.resolution if resolution is None else resolution
    return np.floor(np.asarray(rel_angle, dtype=float) / res).astype(np.int64)


def counts_to_angle(
    counts: ArrayLike, spec: EncoderSpec, resolution: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Wheel-relative angle of a counter value (rad); error in ``[0, resolution)``."""
    res: Any = spec.resolution if resolution is None else resolution
    return np.asarray(counts, dtype=float) * res


def difference_rate(angle_now: ArrayLike, angle_prev: ArrayLike, Ts: float) -> NDArray[np.float64]:
    """Rate by the difference over one sample, ``(a_k - a_{k-1}) / Ts``."""
    return (np.asarray(angle_now, dtype=float) - np.asarray(angle_prev, dtype=float)) / Ts
