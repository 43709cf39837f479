"""The asta family's registry entries: ``asta`` and ``asmc`` (Sec. 4.2; (6.1)-(6.2), Table 6.7).

Found by :mod:`mwip.laws.registry` (no list to edit).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mwip.core import Controller
from mwip.laws.registry import ControllerSpec, Factory, Setting, need_period, register
from mwip.params import Params

#: Where the family's entries come in the registry's listing (``mwip controllers``).
ORDER = 2

# ---- adaptive super-twisting and adaptive SMC (Sec. 4.2; (6.1)-(6.2), Table 6.7) -----------
def _asta_settings() -> tuple[Setting, ...]:
    return (
        Setting("lam", (10.0, 0.3, 3.0), "surface (4.1) lambda_1..3, constraints (4.2) "
                "((6.1)-(6.2))", size=3, lo=0.0, lo_open=True),
        Setting("K", (10.0, 10.0), "super-twisting gains K1, K2 of (4.3) ((6.1)-(6.2))",
                size=2, lo=0.0, lo_open=True),
        Setting("rate", (5.0, 5.0), "adaptation rates 1/partial_i of (4.5), the book's "
                "Gamma_1,2 ((6.1)-(6.2))", size=2, lo=0.0),
        Setting("Gamma0", (0.0, 0.0), "initial adaptive gains Gamma(0) (Remark 4.1)", size=2,
                lo=0.0),
        Setting("eps", 0.01, "boundary layer of the adaptive law (4.5) (ours)", lo=0.0),
        Setting("psi_dot_d", 0.0, "wheel-speed target (rad/s) of (4.1)", lo=-100.0, hi=100.0),
        Setting("theta_d", 0.0, "pitch target (rad) of (4.1)", lo=-0.5, hi=0.5),
        Setting("alpha_d", 0.0, "yaw target (rad) of (4.1)", lo=-100.0, hi=100.0),
    )  # fmt: skip


def _asta_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.laws.asta.controller import ASMC, ASTA

        cls = ASTA if kind == "asta" else ASMC
        return cls(nominal, lam=s["lam"], K=s["K"], rate=s["rate"], Gamma0=s["Gamma0"],
                   eps=s["eps"], psi_dot_ref=s["psi_dot_d"], theta_ref=s["theta_d"],
                   alpha_ref=s["alpha_d"], Ts=need_period(kind, Ts))  # fmt: skip

    return make


register(ControllerSpec(
    "asta", "adaptive super-twisting control (4.1), (4.3)-(4.5), (4.7)",
    "Sec. 4.2; (6.1)-(6.2), Table 6.7", _asta_settings(), _asta_factory("asta"), robot=True,
))  # fmt: skip
register(ControllerSpec(
    "asmc", "adaptive sliding-mode control, the ASTA baseline (same surface and gains)",
    "Sec. 4.2; (6.1)-(6.2), Table 6.7", _asta_settings(), _asta_factory("asmc"), robot=True,
))  # fmt: skip
