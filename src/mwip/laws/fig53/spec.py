"""The fig53 family's registry entries: ``it2`` and ``t1`` (Chapter 5; Sec. 6.2.3).

Found by :mod:`mwip.laws.registry` (no list to edit).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mwip.core import Controller
from mwip.laws.registry import ControllerSpec, Factory, Setting, register
from mwip.params import Params

#: Where the family's entries come in the registry's listing (``mwip controllers``).
ORDER = 4

# ---- the Fig. 5.3 fuzzy controller (Chapter 5; Sec. 6.2.3) ----------------------------------
def _fuzzy_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.fuzzy.pdc import design_pdc, uncertainty_models
        from mwip.laws.fig53.controller import Fig53Controller

        if s["uncertainty"] > 0:
            models = uncertainty_models(nominal, s["uncertainty"])
            design = design_pdc(models, epsilon=s["epsilon"], rho=s["rho"])
        else:
            design = design_pdc(epsilon=s["epsilon"], rho=s["rho"], params=nominal)
        return Fig53Controller([design], [kind], [s["p_d"]], [s["alpha_d"]], params=nominal,
                               Ts=Ts)  # fmt: skip

    return make


def _fuzzy_settings() -> tuple[Setting, ...]:
    return (
        Setting("epsilon", 0.2, "radius of Lemma 5.2's ball ||x0|| <= epsilon (rad; Sec. 5.4)",
                lo=0.0, lo_open=True, hi=10.0),  # as `mwip design it2 --epsilon`
        Setting("rho", 20.0, "input bound of Lemma 5.2 (N m; Sec. 5.4)", lo=0.0, lo_open=True),
        Setting("uncertainty", 0.0, "0: Lemma 5.1/5.2 on the nominal TS model (the book); "
                "u > 0: also on r, mb, l scaled by 1 +- u (ours, docs/fuzzy.md)",
                lo=0.0, hi=1.0, hi_open=True),
        Setting("p_d", None, "position target (m) of the position FLS (Sec. 5.3.2)",
                lo=-100.0, hi=100.0, optional=True),
        Setting("alpha_d", None, "heading target (rad) of the direction FLS (Sec. 5.3.2)",
                lo=-100.0, hi=100.0, optional=True),
    )  # fmt: skip


register(ControllerSpec(
    "it2", "IT2 fuzzy control of Fig. 5.3: PDC balance (5.10) + Mamdani position/direction",
    "Sec. 5.3, Fig. 5.3, Tables 5.1-5.2; Sec. 6.2.3", _fuzzy_settings(), _fuzzy_factory("it2"),
    robot=True,
))  # fmt: skip
register(ControllerSpec(
    "t1", "type-1 counterpart of it2 (same rules and gains, sets at the footprints' middle)",
    "Sec. 6.2.3", _fuzzy_settings(), _fuzzy_factory("t1"), robot=True,
))  # fmt: skip
