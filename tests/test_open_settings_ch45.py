"""The [open] tables of the TSMC and IT2 balance studies load: every setting the book leaves
open is declared with a range that holds its default, and a reason."""

from __future__ import annotations

import pytest

from mwip.studies import settings

EXPECTED = {
    "tsmc-equilibrium": {"phi", "dt", "Ts_record"},
    "tsmc-velocity": {"phi", "dt", "Ts_record", "theta_max"},
    "tsmc-circle": {"phi", "dt", "Ts_record", "theta_max", "theta0", "alpha0", "v0"},
    "it2-balance": {"epsilon", "rho", "uncertainty", "Ts"},
}


@pytest.mark.parametrize("name", list(EXPECTED))
def test_open_settings_load(name):
    table = settings.open_settings(name)
    assert set(table) == EXPECTED[name]
    defaults = settings.defaults(name)
    for key, entry in table.items():
        lo, hi = entry["range"]
        values = defaults[key] if isinstance(defaults[key], list) else [defaults[key]]
        assert all(lo <= v <= hi for v in values), key
        assert len(entry["why"]) > 40, key


def test_it2_epsilon_range_respects_lemma_5_2():
    """Lemma 5.2 needs ||x0|| <= epsilon: the range starts at the book's theta0 = pi/18."""
    lo, _ = settings.open_settings("it2-balance")["epsilon"]["range"]
    assert lo == pytest.approx(settings.defaults("it2-balance")["theta0"])
