"""The Case 2/3 payload of the twin: a 0.5 kg pan on rods above the body (Sec. 6.2.2).

The book says only that "the height ... increased by 10 cm and the weight by 0.5 kg"; the
geometry (:meth:`mwip.params.Params.with_payload`) is a thin disc of ``radius`` whose centre is
``height`` above the body's top, the body's top at ``2 l`` above the axle (kept fixed: the
body is a uniform block about its centre of mass; not an unknown), the rods massless.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mwip.hardware.unknown import Unknown

__all__ = ["PayloadSpec", "UNKNOWNS"]


@dataclass(frozen=True)
class PayloadSpec:
    """``mass`` (kg; 0.5, Sec. 6.2.2, fixed), ``height`` of the pan's centre above the body's
    top (m) and pan ``radius`` (m; inertia ``m R^2 / 4``)."""

    mass: float = 0.5
    height: float = 0.1
    radius: float = 0.08

    def __post_init__(self) -> None:
        for name in ("mass", "height", "radius"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v <= 10.0):
                raise ValueError(f"{name!r} must be finite and in [0, 10], got {v!r}")


#: The payload's unknowns (docs/twin_model.md, "The prior"); its mass (0.5 kg) is printed and
#: the body's height stays 2 l (the body a uniform block).
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("payload.height", 0.0, 0.1, "m", 'pan centre above the body\'s top; Sec. 6.2.2 '
            'says only "the height ... increased by 10 cm and the weight by 0.5 kg" (mass '
            "fixed; body height fixed at 2l)", "case 2/3", 0.1),
    Unknown("payload.radius", 0.0, 0.1, "m", "pan radius (inertia m R^2/4), not printed",
            "case 2/3", 0.08),
)  # fmt: skip
