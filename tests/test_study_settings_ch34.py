"""Settings as data for the Chapter 3-4 studies: overrides reach the runs, bad ones are errors.

Runs are quick mode with a short ``duration`` override, so each costs about a second.
"""

from __future__ import annotations

import numpy as np
import pytest

from mwip.params import REAL
from mwip.sim.disturbance import sinusoid_from_settings
from mwip.studies import (
    asta_balance,
    asta_velocity,
    do_comparison,
    get_study,
    hodosmc_vs_smc,
    run_study,
    settings,
    tsmc_circle,
    tsmc_equilibrium,
    tsmc_velocity,
)

MODULES = {
    "do-comparison": do_comparison,
    "hodosmc-vs-smc": hodosmc_vs_smc,
    "asta-balance": asta_balance,
    "asta-velocity": asta_velocity,
    "tsmc-equilibrium": tsmc_equilibrium,
    "tsmc-velocity": tsmc_velocity,
    "tsmc-circle": tsmc_circle,
}
#: study -> (short quick duration, one meaningful override, a metric it changes, where
#: metrics.json's "settings" records the overridden value)
CHANGES = {
    "do-comparison": (4.0, {"disturbance_amplitude": [0.1, 0.1, 0.1]}, "do4.rms_d1_theory",
                      ("disturbance", "amplitude")),
    "hodosmc-vs-smc": (3.0, {"dbar_smc": [20.0, 20.0, 20.0]}, "smc.u_tv", ("dbar", "smc")),
    "asta-balance": (0.5, {"K": [20.0, 0.3]}, "asta.u_tv", ("K",)),
    "asta-velocity": (0.3, {"psi_dot_d": 0.3}, "real.speed_on_surface", ("psi_dot_d",)),
    "tsmc-equilibrium": (0.5, {"theta0": 0.05}, "lqr.max_abs_u", ("initial", "theta0")),
    "tsmc-velocity": (0.3, {"theta_max": 0.01}, "tsmc_lean.theta_target",
                      ("tsmc_lean", "theta_max")),
    "tsmc-circle": (0.3, {"alpha_dot_d": 0.3}, "real.yaw_torque_each_wheel",
                    ("targets", "alpha_dot_d")),
}  # fmt: skip


def _expected(name):
    """The changed metric where it follows exactly from the override (else None: compared
    with a run on the defaults)."""
    real = REAL  # the default robot of a study run
    if name == "do-comparison":  # the sinusoid prediction scales with the amplitude
        cfg = settings.defaults(name)
        th = do_comparison.predicted_rms(tuple(cfg["do4_v"]), sinusoid_from_settings(cfg))
        return pytest.approx(2 * th[0], rel=1e-12)
    if name == "asta-velocity":
        lam = settings.defaults(name)["lam"]
        return asta_velocity.speed_on_surface(real, 0.3, lam)
    if name == "tsmc-velocity":  # the nominal lean for 1 m/s (0.025 rad) clipped to theta_max
        return 0.01
    if name == "tsmc-circle":
        return real.b / real.r * (real.Db + real.Dw) * 0.3
    return None


#: study -> a list setting (for the wrong-length check)
LISTS = {
    "do-comparison": "do4_v",
    "hodosmc-vs-smc": "lambdas",
    "asta-balance": "lam",
    "asta-velocity": "rate",
    "tsmc-equilibrium": "Q_diag",
    "tsmc-velocity": "Gamma",
    "tsmc-circle": "C",
}


def _run(tmp_path, name, overrides):
    return run_study(name, tmp_path, quick=True, overrides=overrides)


@pytest.mark.parametrize("name", list(CHANGES))
def test_an_override_changes_the_run_and_is_recorded(name, tmp_path):
    duration, change, metric, where = CHANGES[name]
    new = _run(tmp_path / "new", name, {"duration": duration, **change})
    assert new["settings"]["duration"] == duration
    assert np.isfinite(new["metrics"][metric])
    expected = _expected(name)
    if expected is None:
        base = _run(tmp_path / "base", name, {"duration": duration})
        assert new["metrics"][metric] != base["metrics"][metric]
    else:
        assert new["metrics"][metric] == expected
        assert settings.defaults(name) != {**settings.defaults(name), **change}
    recorded = new["settings"]
    for part in where:
        recorded = recorded[part]
    assert recorded == next(iter(change.values()))


@pytest.mark.parametrize("name", list(MODULES))
def test_bad_overrides_name_the_key(name, tmp_path):
    with pytest.raises(ValueError, match=rf"^\[settings\] no_such_key: unknown for study '{name}'"):
        _run(tmp_path, name, {"no_such_key": 1.0})
    key = LISTS[name]
    default = settings.defaults(name)[key]
    with pytest.raises(ValueError, match=rf"^\[settings\] {key} must be a list of {len(default)}"):
        _run(tmp_path, name, {key: [*default, 1.0]})
    with pytest.raises(ValueError, match=r"^\[settings\] duration must be a number"):
        _run(tmp_path, name, {"duration": "long"})
    assert not list(tmp_path.iterdir())  # rejected before anything runs


@pytest.mark.parametrize("name", list(MODULES))
def test_module_docstring_lists_the_settings(name):
    mod = MODULES[name]
    assert mod.NAME == name and get_study(name).run is mod.run
    for key in settings.defaults(name):
        assert f"``{key}``" in (mod.__doc__ or ""), key


#: the settings each of these studies declares open (not printed by the book), SPEC issue 12
OPEN = {
    "lqr-gain": {"theta0", "dt_continuous"},
    "do-comparison": {"Ts", "dt", "rms_window"},
    "hodosmc-vs-smc": {"Ts", "dt", "rms_window"},
    "asta-balance": {"Ts", "dt", "Gamma0", "eps"},
    "asta-velocity": {"Ts", "dt", "Gamma0", "eps", "rms_window"},
}


@pytest.mark.parametrize("name", list(OPEN))
def test_open_settings_load_and_contain_their_defaults(name):
    """Every [open] key loads (range, why) and its default lies in the declared range; the
    integration step divides the sample period in every range corner we ship."""
    table = settings.open_settings(name)
    assert set(table) == OPEN[name]
    base = settings.defaults(name)
    for key, entry in table.items():
        lo, hi = entry["range"]
        values = base[key] if isinstance(base[key], list) else [base[key]]
        assert all(lo <= v <= hi for v in values), key
        assert len(entry["why"]) > 40, key  # a reason, not a label
    if "dt" in table:
        assert base["Ts"] / base["dt"] == pytest.approx(round(base["Ts"] / base["dt"]))
