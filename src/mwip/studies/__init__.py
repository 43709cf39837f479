"""Reproducible studies: each writes ``OUT/<study>/metrics.json`` (SPEC.md section 6),
its time series and a figure.

A study is a function ``run(out: Path, *, quick: bool = False) -> dict`` registered in
:data:`STUDIES`; ``mwip run NAME`` runs one, ``mwip reproduce`` runs them all.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mwip.studies import (
    asta_balance,
    asta_velocity,
    do_comparison,
    exp_asta,
    exp_hodosmc,
    exp_it2,
    hodosmc_vs_smc,
    it2_balance,
    lqr_gain,
    tsmc_circle,
    tsmc_equilibrium,
    tsmc_velocity,
)

__all__ = ["STUDIES", "Study"]

Study = Callable[..., dict[str, Any]]

#: name -> (run function, book source)
STUDIES: dict[str, tuple[Study, str]] = {
    "lqr-gain": (lqr_gain.run, lqr_gain.SOURCE),
    "do-comparison": (do_comparison.run, do_comparison.SOURCE),
    "hodosmc-vs-smc": (hodosmc_vs_smc.run, hodosmc_vs_smc.SOURCE),
    "asta-balance": (asta_balance.run, asta_balance.SOURCE),
    "asta-velocity": (asta_velocity.run, asta_velocity.SOURCE),
    "tsmc-equilibrium": (tsmc_equilibrium.run, tsmc_equilibrium.SOURCE),
    "tsmc-velocity": (tsmc_velocity.run, tsmc_velocity.SOURCE),
    "tsmc-circle": (tsmc_circle.run, tsmc_circle.SOURCE),
    "it2-balance": (it2_balance.run, it2_balance.SOURCE),
    "exp-hodosmc-balance": (exp_hodosmc.run_balance, exp_hodosmc.SOURCE_BALANCE),
    "exp-hodosmc-speed": (exp_hodosmc.run_speed, exp_hodosmc.SOURCE_SPEED),
    "exp-hodosmc-obstacle": (exp_hodosmc.run_obstacle, exp_hodosmc.SOURCE_OBSTACLE),
    "exp-asta": (exp_asta.run, exp_asta.SOURCE),
    "exp-it2": (exp_it2.run, exp_it2.SOURCE),
}


def study_names() -> list[str]:
    """Registered study names, in reproduce order."""
    return list(STUDIES)


def run_study(name: str, out: Path, **kwargs: Any) -> dict[str, Any]:
    """Run one registered study into ``out``; returns its metrics document."""
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r}; choose from: {', '.join(STUDIES)}")
    return STUDIES[name][0](out, **kwargs)
