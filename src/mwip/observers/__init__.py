"""Disturbance observers (Chapter 3.2-3.4) and their gain design.

- :class:`HighOrderDO` (alias :data:`HODO`): the n-th order observer (3.20)-(3.23), sampled;
- :class:`FirstOrderDO` (3.2) and :class:`SecondOrderDO` (3.7): its n = 1 and n = 2 forms;
- :mod:`mwip.observers.design`: error dynamics (3.31)-(3.32), impulse-to-energy gain
  (3.35)/(3.39)-(3.41), the LMI problem (3.36), a prescribed-ie design, and the book's
  published gain sets.
"""

from mwip.observers.design import (
    PUBLISHED_GAIN_SETS,
    GainDesign,
    ObserverDesignError,
    PublishedGainSet,
    as_gain_matrices,
    compare_published,
    design_for_ie,
    error_dynamics,
    format_comparison,
    impulse_to_energy_gain,
    lmi_matrices,
    published_gain_sets,
    solve_ie_lmi,
    stacked_gain,
)
from mwip.observers.first_order import FirstOrderDO
from mwip.observers.hodo import HODO, HighOrderDO, discretize_observer, euler_substeps_needed
from mwip.observers.second_order import SecondOrderDO

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
