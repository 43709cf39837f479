"""Disturbance observers (Chapter 3.2-3.4) and their gain design.

- :class:`HighOrderDO` (alias :data:`HODO`): the n-th order observer (3.20)-(3.23), sampled;
- :class:`FirstOrderDO` (3.2) and :class:`SecondOrderDO` (3.7): its n = 1 and n = 2 forms;
- :mod:`mwip.observers.design`: error dynamics (3.31)-(3.32), impulse-to-energy gain
  (3.35)/(3.39)-(3.41), the LMI problem (3.36), a prescribed-ie design, and the book's
  published gain sets.

The names are imported on first use (PEP 562), so that the compiled observer update
(:mod:`mwip.observers._hodo_kernel`) loads without cvxpy.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "HighOrderDO",
    "HODO",
    "FirstOrderDO",
    "SecondOrderDO",
    "discretize_observer",
    "euler_substeps_needed",
    "error_dynamics",
    "lmi_matrices",
    "impulse_to_energy_gain",
    "solve_ie_lmi",
    "design_for_ie",
    "GainDesign",
    "ObserverDesignError",
    "PublishedGainSet",
    "PUBLISHED_GAIN_SETS",
    "published_gain_sets",
    "compare_published",
    "format_comparison",
    "as_gain_matrices",
    "stacked_gain",
]

_WHERE = {
    **{
        n: "mwip.observers.hodo"
        for n in ("HighOrderDO", "HODO", "discretize_observer", "euler_substeps_needed")
    },
    "FirstOrderDO": "mwip.observers.first_order",
    "SecondOrderDO": "mwip.observers.second_order",
}


def __getattr__(name: str) -> Any:
    if name in __all__:
        module = _WHERE.get(name, "mwip.observers.design")
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'mwip.observers' has no attribute {name!r}")
