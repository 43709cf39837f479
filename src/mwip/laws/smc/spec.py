"""The smc family's registry entries: ``smc``, ``do1smc``, ``hodosmc`` (Sec. 3.5; Table 6.3).

Found by :mod:`mwip.laws.registry` (no list to edit).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from mwip.core import Controller
from mwip.laws.registry import ControllerSpec, Factory, Setting, need_period, register
from mwip.params import Params

#: Where the family's entries come in the registry's listing (``mwip controllers``).
ORDER = 1

# ---- sliding-mode family (Sec. 3.5; Table 6.3) ---------------------------------------------
_SMC_K = {"smc": (25.0, 21.0), "do1smc": (17.3, 14.0), "hodosmc": (6.3, 4.0)}


def _smc_settings(kind: str) -> tuple[Setting, ...]:
    out: tuple[Setting, ...] = (
        Setting("lambdas", (3.0, 0.01, 0.1, 3.0),
                "sliding-surface coefficients l1..l4 of (3.49) (Table 6.3)", size=4, lo=0.0,
                lo_open=True),
        Setting("K", _SMC_K[kind], f"switching gains K1, K2 of (3.50), rad/s^2 (Table 6.3, "
                f"{kind})", size=2, lo=0.0),
        Setting("switching", "sat", "sat(s/phi) (the robot, Sec. 6.2.1) or sign (Sec. 3.5)",
                choices=("sat", "sign")),
        Setting("phi", 0.05, "boundary layer of sat (ours: the book prints no width)",
                lo=0.0, lo_open=True),
        Setting("psi_dot_d", 0.0, "wheel-speed target q1d' (rad/s) of (3.49)", lo=-100.0,
                hi=100.0),
        Setting("alpha_d", 0.0, "yaw target q3d (rad) of (3.49)", lo=-100.0, hi=100.0),
    )  # fmt: skip
    if kind == "do1smc":
        out += (Setting("L", 50.0, "first-order observer gain L I3 (1/s; ours: the book "
                        "prints none, docs/smc.md)", lo=0.0, lo_open=True),)  # fmt: skip
    if kind == "hodosmc":
        out += (Setting("v", (22.9778, 357.2853, 1831.5, 5737.7),
                        "4th-order observer gains L_i = v_i I3 (Sec. 3.6.1)", size=4,
                        lo=0.0, lo_open=True),)  # fmt: skip
    return out


def _smc_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.laws.smc.controller import make_smc
        from mwip.laws.switching import Switching
        from mwip.observers.design import published_gain_sets

        period = need_period(kind, Ts) if kind != "smc" else (0.005 if Ts is None else Ts)
        obs: Sequence[Any] | None = None
        if kind == "do1smc":
            obs = [s["L"]]
        elif kind == "hodosmc":
            published = published_gain_sets()["do4"]
            obs = published.gains if tuple(s["v"]) == tuple(published.v) else list(s["v"])
        # check=False: Table 6.3's lambdas fail (3.52) on the nominal model (docs/smc.md);
        # `mwip check smc --lambdas ...` reports the conditions
        return make_smc(kind, tuple(s["lambdas"]), K=tuple(s["K"]), observer_gains=obs,
                        params=nominal, Ts=period, switching=Switching(s["switching"], s["phi"]),
                        q1d_dot=s["psi_dot_d"], q3d=s["alpha_d"], check=False)  # fmt: skip

    return make


_SMC_TITLES = {
    "smc": "sliding-mode control (3.49)-(3.51), no observer",
    "do1smc": "sliding-mode control with a first-order disturbance observer",
    "hodosmc": "sliding-mode control with the 4th-order disturbance observer (HODOSMC)",
}
for _kind in ("smc", "do1smc", "hodosmc"):
    register(ControllerSpec(
        _kind, _SMC_TITLES[_kind], "Sec. 3.5, (3.49)-(3.51); Table 6.3",
        _smc_settings(_kind), _smc_factory(_kind), robot=True,
    ))  # fmt: skip
