"""Settling time of a run that stopped (fell or diverged) is n/a (NaN), never 0 s."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.metrics import settling_time
from mwip.sim.result import SimResult


def _cut_run(status: str) -> SimResult:
    """A run whose records stop at the stop time with a pitch inside any band: a wheel mode
    that diverged under a small lean (the records are cut where the numbers went bad)."""
    t = np.arange(4) * 0.005
    states = np.zeros((1, t.size, 8))
    states[0, :, 1] = 1e-5  # theta, far inside the 1 mrad floor of the band
    states[0, :, 3] = 10.0 ** np.arange(t.size)  # psi' blowing up
    return SimResult(
        t=t, states=states, inputs=np.zeros((1, t.size, 2)), status=np.array([status]),
        t_end=np.array([t[-1]]), final_state=states[:, -1], r=np.array([0.04]), batched=False,
    )  # fmt: skip


@pytest.mark.parametrize("status", ["fell", "diverged"])
def test_stopped_run_has_no_settling_time(status):
    t = np.linspace(0.0, 1.0, 11)
    x = np.zeros_like(t)
    assert settling_time(t, x) == 0.0  # settled from the start: a run that ended ok
    assert np.isnan(settling_time(t, x, status=status))
    s = _cut_run(status).summary()
    assert s["status"] == status and np.isnan(s["settling_time"])


def test_ok_run_keeps_its_settling_time():
    s = _cut_run("ok").summary()
    assert s["settling_time"] == 0.0
    t = np.linspace(0.0, 2.0, 201)
    x = np.exp(-5.0 * t)  # enters 2 % of its peak at ln(50)/5 s
    assert settling_time(t, x, status="ok") == pytest.approx(np.log(50) / 5, abs=0.01)
