"""The tsmc family's registry entries: ``tsmc`` (Sec. 4.3).

Found by :mod:`mwip.laws.registry` (no list to edit).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mwip.core import Controller
from mwip.laws.registry import ControllerSpec, Setting, register
from mwip.params import Params

#: Where the family's entries come in the registry's listing (``mwip controllers``).
ORDER = 3

# ---- terminal SMC (Sec. 4.3) ---------------------------------------------------------------
def _tsmc_factory(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
    from mwip.laws.switching import Switching
    from mwip.laws.tsmc.controller import TSMC

    return TSMC(nominal, C=s["C"], Gamma=s["Gamma"], D=s["D"], Ftilde_ratio=s["Ftilde_ratio"],
                Tf=s["Tf"], switching=Switching(s["switching"], s["phi"]),
                theta_ref=s["theta_d"], alpha_ref=s["alpha_d"],
                alpha_dot_ref=s["alpha_dot_d"], v_ref=s["v_d"], speed=s["speed"],
                Ts=Ts)  # fmt: skip


register(ControllerSpec(
    "tsmc", "terminal sliding-mode control with augmented surfaces (4.30)-(4.32), (4.43)",
    "Sec. 4.3, Sec. 4.4.2",
    (
        Setting("C", (2.5, 2.5), "surface slopes C = diag(c1, c2) (Sec. 4.4.2)", size=2,
                lo=0.0, lo_open=True),
        Setting("Gamma", (10.0, 10.0), "reaching margins (Sec. 4.4.2)", size=2, lo=0.0,
                lo_open=True),
        Setting("D", 0.4, "input-gain uncertainty bound D = d I, ||D|| < 1 (4.29), "
                "(Sec. 4.4.2)", lo=0.0, hi=1.0, hi_open=True),
        Setting("Ftilde_ratio", 0.8, "F~ = ratio |F^| (4.28) (Sec. 4.4.2)", lo=0.0),
        Setting("Tf", 1.0, "convergence time T_f of (4.43), s (Sec. 4.4.2)", lo=1e-3),
        Setting("switching", "sat", "sat(s/phi) (Sec. 4.4.2) or sign",
                choices=("sat", "sign")),
        Setting("phi", 0.05, "boundary layer of sat (ours)", lo=0.0, lo_open=True),
        Setting("theta_d", 0.0, "pitch target theta* (rad)", lo=-0.5, hi=0.5),
        Setting("alpha_d", 0.0, "yaw target alpha*(0) (rad)", lo=-100.0, hi=100.0),
        Setting("alpha_dot_d", 0.0, "yaw-rate target alpha'* (rad/s): alpha*(t) ramps",
                lo=-10.0, hi=10.0),
        Setting("speed", "none", "none (the book: v left to the internal dynamics) or lean "
                "(pitch target from v_d, docs/chapter4.md)", choices=("none", "lean")),
        Setting("v_d", 0.0, "speed target (m/s) with speed = lean", lo=-10.0, hi=10.0),
    ),
    _tsmc_factory,
))  # fmt: skip
