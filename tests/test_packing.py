"""Packed laws (issue 24 item 1): every law's settings and memory as one parameter vector and
one state vector with declared layouts; a batch with one parameter vector per robot.

- the layouts round-trip and reject what does not fit them;
- the offsets each compiled kernel reads are its layout's (one source of truth);
- a batch of candidates (``mwip.laws.batch``) runs, in one engine call, exactly what each
  candidate's own controller runs alone, in the compiled loop and in the Python loop.
"""

from __future__ import annotations

import numpy as np
import pytest

from mwip.laws import packing
from mwip.laws.batch import PackedController, batch
from mwip.laws.registry import build
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate


def test_layout_round_trip_and_errors():
    lay = packing.Layout((packing.Field("a", (2, 3)), packing.Field("b", ()),
                          packing.Field("c", (0,))))  # fmt: skip
    a = np.arange(6.0).reshape(2, 3)
    v = lay.pack({"a": a, "b": 7.0, "c": np.zeros(0)})
    assert v.shape == (7,) and lay.span("b") == (6, 7)
    back = lay.unpack(v)
    assert np.array_equal(back["a"], a) and float(back["b"]) == 7.0
    with pytest.raises(ValueError, match="shape"):
        lay.pack({"a": np.zeros(6), "b": 1.0, "c": np.zeros(0)})
    with pytest.raises(ValueError, match="missing"):
        lay.pack({"a": a})
    with pytest.raises(ValueError, match="duplicate"):
        packing.Layout((packing.Field("x"), packing.Field("x")))
    with pytest.raises(KeyError):
        lay.span("nope")


def test_kernel_offsets_are_the_layouts():
    from mwip.laws.asta import packing as asta
    from mwip.laws.fig53 import packing as fig53
    from mwip.laws.lqr import packing as lqr
    from mwip.laws.smc import packing as smc
    from mwip.laws.tsmc import packing as tsmc

    assert (lqr.GAIN, lqr.OFFSET) == (lqr.PARAMS.span("gain"), lqr.PARAMS.span("offset"))
    for m in (0, 3, 12):
        lay, st = smc.params_layout(m), smc.state_layout(m)
        assert lay.span("m")[0] == 0 and lay.span("Phi") == (smc.FIXED, smc.FIXED + m * m)
        assert lay.span("Gamma") == (smc.FIXED + m * m, smc.FIXED + m * m + 3 * m)
        assert (lay.span("coef"), lay.span("lam")) == (smc.P_COEF, smc.P_LAM)
        for name, off in (("K1", smc.P_K1), ("K2", smc.P_K2), ("sat", smc.P_SAT),
                          ("phi", smc.P_PHI), ("q1d_dot", smc.P_Q1D_DOT), ("q3d", smc.P_Q3D),
                          ("obs_Ts", smc.P_OBS_TS), ("hold", smc.P_HOLD),
                          ("decoupled", smc.P_DECOUPLED)):  # fmt: skip
            assert lay.span(name)[0] == off
        for name, off in (("th", smc.X_TH), ("qd_prev", smc.X_QD_PREV),
                          ("fg_prev", smc.X_FG_PREV), ("u_prev", smc.X_U_PREV),
                          ("z", smc.X_Z)):  # fmt: skip
            assert st.span(name)[0] == off
        assert st.span("work")[0] == smc.X_Z + m
    for L in (1, 40):
        lay = fig53.params_layout(L)
        assert (lay.span("row")[0], lay.span("fls")[0]) == (fig53.P_ROW, fig53.P_FLS)
    assert asta.STATE.span("Gamma")[0] == asta.X_GAMMA and asta.PARAMS.span("K") == asta.P_K
    assert tsmc.PARAMS.span("cubic") == tsmc.P_CUBIC and tsmc.STATE.span("aug")[0] == tsmc.X_AUG


def test_every_family_is_found_and_dispatched():
    """Every law folder's code is unique (families) and law_step runs it (a code the
    dispatcher does not know would leave u untouched: NaN here)."""
    from mwip.laws.dispatch import step_batch
    from mwip.laws.families import codes

    found = codes()
    assert sorted(found.values()) == ["asta", "fig53", "lqr", "smc", "tsmc"]
    cases = {"lqr": {}, "smc": {}, "asta": {}, "tsmc": {}, "fig53": {}}
    names = {"lqr": "dlqr", "smc": "hodosmc", "asta": "asta", "tsmc": "tsmc", "fig53": "it2"}
    for code, fam in found.items():
        ctrl = build(names[fam], NOMINAL, cases[fam], Ts=0.005)
        y = np.zeros((1, 8))
        y[0, 1] = 0.05
        from mwip.core import Measurement

        ctrl.reset(Measurement(0.0, y))
        law = ctrl.packed_law()
        assert law is not None and law.code == code
        P, X = law.arrays(1)
        u = np.full((1, 2), np.nan)
        step_batch(np.int64(code), P, X, np.int64(0), 0.0, y, u, np.zeros((1, law.log_width)))
        assert np.isfinite(u).all() and np.abs(u).max() > 0, fam


CANDIDATES = {
    "lqr": [{"R_diag": (0.01, 0.01)}, {"R_diag": (0.05, 0.02)},
            {"Q_diag": (500, 50, 100, 80, 900)}],
    "hodosmc": [{"K": (6.3, 4.0)}, {"K": (9.0, 2.0)}, {"K": (4.0, 6.0), "phi": 0.1}],
    "asta": [{}, {"K": (8.0, 12.0)}, {"rate": (2.0, 7.0)}],
    "tsmc": [{}, {"C": (2.0, 3.0)}, {"Gamma": (5.0, 12.0)}],
    "it2": [{}, {"p_d": 0.3}, {"alpha_d": 0.2}],
}


@pytest.mark.parametrize("name", sorted(CANDIDATES))
def test_a_batch_of_candidates_runs_each_candidates_law(name):
    """Three candidates x two robots in one compiled run equal each candidate's own
    controller run alone on those two robots (bit for bit: the same kernel, the same numbers);
    the Python loop (``compiled=False``, as the twin runs) agrees to round-off."""
    rows = CANDIDATES[name]
    q0 = np.array([[0.0, 0.08, 0.0], [0.0, -0.05, 0.02]])
    plant = REAL
    ctrl = batch(name, rows, NOMINAL, Ts=0.005, repeat=2)
    q0_all = np.tile(q0, (len(rows), 1))
    res = simulate(ctrl, plant, q0=q0_all, duration=1.0)
    assert res.settings["compiled"] is True
    res_py = simulate(batch(name, rows, NOMINAL, Ts=0.005, repeat=2), plant, q0=q0_all,
                      duration=1.0, compiled=False)  # fmt: skip
    for j, row in enumerate(rows):
        own = simulate(build(name, NOMINAL, row, Ts=0.005), plant, q0=q0, duration=1.0)
        sl = slice(2 * j, 2 * j + 2)
        assert np.array_equal(res.states[sl], own.states), (name, row)
        assert np.array_equal(res.u[sl], own.u)
        assert np.allclose(res_py.states[sl], own.states, rtol=0, atol=1e-12)
    assert not np.array_equal(res.u[0:2], res.u[2:4])  # the candidates differ


def test_batch_rejects_what_does_not_fit():
    with pytest.raises(ValueError, match="robots"):
        simulate(batch("lqr", [{}, {}], NOMINAL, Ts=0.005, repeat=2), REAL,
                 q0=np.zeros((3, 3)), duration=0.1)  # fmt: skip
    mixed = PackedController([build("smc", NOMINAL, Ts=0.005), build("hodosmc", NOMINAL)])
    with pytest.raises(ValueError, match="layout"):  # no observer, and a 4th-order one
        simulate(mixed, REAL, q0=np.zeros((2, 3)), duration=0.1)
    with pytest.raises(ValueError, match="setting 'K'"):
        batch("hodosmc", [{"K": (-1.0, 2.0)}], NOMINAL)
    with pytest.raises(ValueError, match="no settings"):
        batch("lqr", [], NOMINAL)
