"""The lqr family's registry entries: ``lqr`` and ``dlqr`` (Sec. 4.4.2).

Found by :mod:`mwip.laws.registry` (no list to edit).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mwip.core import Controller
from mwip.laws.registry import ControllerSpec, Factory, Setting, register
from mwip.params import Params

#: Where the family's entries come in the registry's listing (``mwip controllers``).
ORDER = 0

def _lqr_settings(with_design: bool) -> tuple[Setting, ...]:
    out: tuple[Setting, ...] = (
        Setting("Q_diag", (1000.0, 100.0, 100.0, 100.0, 1000.0),
                "state weights on [theta, alpha, theta', v, alpha'] (Sec. 4.4.2)",
                size=5, lo=0.0),
        Setting("R_diag", (0.01, 0.01), "input weights on [u_r, u_l] (Sec. 4.4.2)", size=2,
                lo=0.0, lo_open=True),
        Setting("v_d", 0.0, "speed reference (m/s) of x_ref = [0, 0, 0, v_d, 0] (ours)",
                lo=-10.0, hi=10.0),
    )  # fmt: skip
    if with_design:
        out += (Setting("design", "auto",
                        "auto: continuous Riccati gain in continuous mode, zero-order-hold "
                        "discrete gain when sampled (SPEC.md section 2); or force either",
                        choices=("auto", "continuous", "sampled")),)  # fmt: skip
    return out


def _lqr_factory(discrete: bool) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        import numpy as np

        from mwip.laws.lqr.controller import LQR, design_lqr

        how = "sampled" if discrete else s["design"]
        if how == "auto":
            how = "continuous" if Ts is None else "sampled"
        if how == "sampled" and Ts is None:
            raise ValueError("a sampled (discrete Riccati) LQR needs a sample period")
        Q, R = np.diag(s["Q_diag"]), np.diag(s["R_diag"])
        design = design_lqr(nominal, Q, R, Ts=Ts if how == "sampled" else None)
        return LQR(design, reference=(0.0, 0.0, 0.0, s["v_d"], 0.0))

    return make


register(ControllerSpec(
    "lqr", "linear-quadratic regulator about upright, the book's weights",
    "Sec. 4.4.2 (Q, R)", _lqr_settings(True), _lqr_factory(False),
))  # fmt: skip
register(ControllerSpec(
    "dlqr", "LQR for the sample period: discrete Riccati on the zero-order-hold model",
    "Sec. 4.4.2 (Q, R); SPEC.md section 2", _lqr_settings(False), _lqr_factory(True),
))  # fmt: skip
