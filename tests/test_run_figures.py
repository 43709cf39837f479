"""Run figures (issue 25): panels at the signal's physical size, no empty panel, a torque
beyond the drive's limit flagged in the figure and in the run summary."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.hardware.identified import default_twin, wheel_torque_limit


@pytest.fixture(scope="module")
def run():
    from mwip.laws import LQR, design_lqr
    from mwip.params import NOMINAL, REAL
    from mwip.plot.runs import Run
    from mwip.sim import simulate

    res = simulate(LQR(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0, 0.05, 0), duration=1.0)
    states = res.states.copy()
    states[..., 2] = 1e-17 * np.sin(np.arange(states.shape[1]))  # yaw: rounding noise only
    res = dataclasses.replace(res, states=states)
    return Run(name="r", result=res, params=REAL, payload=False, reference=0.0,
               source=Path("r.npz"))  # fmt: skip


def _panels(fig):
    axs = fig.axes
    return {ax.get_ylabel(): ax for ax in axs}


def test_panels_at_physical_size_and_none_empty(run):
    from mwip.plot.run_figure import MIN_SPAN, run_figure

    fig = run_figure(run)
    panels = _panels(fig)
    lo, hi = panels["yaw alpha (rad)"].get_ylim()
    assert hi - lo == pytest.approx(MIN_SPAN["rad"]) and abs(lo + hi) < 1e-12  # flat at zero
    for ax in fig.axes:  # every panel draws data (no observer: the rates instead)
        assert any(len(line.get_xdata()) > 1 for line in ax.get_lines()), ax.get_ylabel()
        y0, y1 = ax.get_ylim()
        assert y1 - y0 >= min(MIN_SPAN.values()) * 0.999, ax.get_ylabel()
    assert "rates (rad/s)" in panels
    torque = panels["wheel torque (N m)"]
    assert torque.get_title() == ""  # within the drive's limit: no flag


def test_torque_beyond_the_limit_is_flagged_in_the_figure(run):
    from mwip.plot.run_figure import run_figure, torque_limit

    v = default_twin().values()  # the identified twin's drive: N eta k_t I_max
    n_eta_kt_i = v["drive.gear_ratio"] * 0.75 * 0.0239 * v["drive.current_limit"]
    assert torque_limit(run) == pytest.approx(n_eta_kt_i, rel=0.05)
    peak = float(np.max(np.abs(run.result.u)))
    fig = run_figure(dataclasses.replace(run, torque_limit=peak / 10))
    torque = _panels(fig)["wheel torque (N m)"]
    assert "10.0x the drive's limit" in torque.get_title()
    levels = sorted(
        line.get_ydata()[0] for line in torque.get_lines() if line.get_linestyle() == ":"
    )
    assert levels == pytest.approx([-peak / 10, peak / 10])


def test_torque_beyond_the_limit_is_flagged_in_the_summary(tmp_path, capsys):
    args = ["simulate", "--mode", "continuous", "--theta0", "0.1745", "--duration", "0.3"]
    assert main([*args, "--out", str(tmp_path / "o"), "--plot"]) == 0
    out = capsys.readouterr().out
    limit = wheel_torque_limit()  # the identified default twin's (0.72 N m)
    assert f"x the drive limit of {limit:.3g} N m per wheel" in out
    doc = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert doc["over_torque_limit"] is True and doc["torque_limit"] == pytest.approx(limit)
    assert doc["max_abs_u"] > 10 * doc["torque_limit"]
    assert main(["simulate", "--theta0", "0.05", "--duration", "0.3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["over_torque_limit"] is False


def test_a_study_figure_marks_a_fall_and_names_its_cause() -> None:
    """Issue 25: a study figure of a run that fell showed the fall with no word why."""
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    from mwip.hardware.ablation import mark_fall

    axes = Figure().subplots(3, 1)
    fell = SimpleNamespace(status=np.array(["fell"]), t_end=np.array([0.42]))
    label = mark_fall(axes, fell, "SMC", "tab:blue", scale=10.0)
    assert label == "SMC: fell at t = 0.42 s (|theta| beyond the fall limit)"
    for ax in axes:  # the stop time on every panel, in the figure's time unit (0.1 s)
        assert [line.get_xdata()[0] for line in ax.get_lines()] == [pytest.approx(4.2)]
    stood = SimpleNamespace(status=np.array(["ok"]), t_end=np.array([20.0]))
    assert mark_fall(axes, stood, "ASTA", "tab:red") == "ASTA"
