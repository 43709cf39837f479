"""The library Fig. 5.3 batch controller: row by row equal to FuzzyMWIPController (the
composition term by term), one row drives a whole batch, and it is the study's batched law
(studies/exp_it2.BatchFuzzyController) exactly."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.core import Measurement
from mwip.fuzzy.mamdani import FuzzyMWIPController
from mwip.fuzzy.pdc import BOOK_G1, BOOK_G2, PDCBalance, PDCDesign
from mwip.laws.fig53.controller import Fig53Controller
from mwip.params import NOMINAL

G_A = np.array([BOOK_G1, BOOK_G2]) * 1e-3
G_B = G_A * np.array([1.3, 0.7, 1.1, 0.9])


def _Design(G: np.ndarray) -> PDCDesign:  # noqa: N802 - a design with given gains
    z = np.zeros((4, 4))
    return PDCDesign(
        G=G,
        P=z,
        Q=z,
        N=G,
        Y=z,
        W=z,
        status="given",
        solver="none",
        epsilon=None,
        rho=None,
        margin=0.0,
        model=None,
    )  # type: ignore[arg-type]


ROWS = [(G_A, "it2", None, None), (G_B, "t1", 0.7, None), (G_A, "it2", 1.0, 1.5),
        (G_B, "t1", None, -0.4), (G_A, "t1", -0.5, 0.3), (G_B, "it2", 0.2, None)]  # fmt: skip


def _meas(rng: np.random.Generator, n: int) -> Measurement:
    y = np.column_stack([rng.uniform(-20, 20, n), rng.uniform(-0.5, 0.5, n),
                         rng.uniform(-2, 2, n), rng.uniform(-5, 5, (n, 3)),
                         np.zeros((n, 2))])  # fmt: skip
    return Measurement(0.3, y)


def test_rows_equal_the_single_robot_controller():
    rng = np.random.default_rng(3)
    meas = _meas(rng, len(ROWS))
    designs = [_Design(r[0]) for r in ROWS]
    ctrl = Fig53Controller(designs, [r[1] for r in ROWS], [r[2] for r in ROWS],
                           [r[3] for r in ROWS], params=NOMINAL)  # fmt: skip
    assert all(v is not None for v in ctrl._scale.values())  # the merged FLS call is used
    u = ctrl(0.3, meas)
    for i, (G, kind, pd, ad) in enumerate(ROWS):
        ref = FuzzyMWIPController(G, kind=kind, p_d=pd, alpha_d=ad, params=NOMINAL)
        want = ref(0.3, Measurement(0.3, meas.y[i : i + 1]))
        np.testing.assert_allclose(u[i], want[0], rtol=1e-12, atol=1e-12)
        assert ref.log()["theta_off"][0] == pytest.approx(ctrl.log()["theta_off"][i], abs=1e-15)


def test_one_row_drives_a_batch():
    rng = np.random.default_rng(4)
    meas = _meas(rng, 7)
    one = Fig53Controller([_Design(G_A)], ["it2"], [0.7], [1.0])
    ref = FuzzyMWIPController(G_A, kind="it2", p_d=0.7, alpha_d=1.0)
    np.testing.assert_allclose(one(0.0, meas), ref(0.0, meas), rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="2 rows, the batch 7"):
        Fig53Controller([_Design(G_A)] * 2, ["it2", "t1"], [None, None],
                        [None, None])(0.0, meas)  # fmt: skip


def test_balance_only_is_the_pdc():
    """Without targets Fig. 5.3 reduces to the PDC law (5.10) on [theta, theta', psi, psi']."""
    rng = np.random.default_rng(5)
    meas = _meas(rng, 5)
    ctrl = Fig53Controller([_Design(G_B)], ["t1"], [None], [None])
    np.testing.assert_allclose(ctrl(0.0, meas), PDCBalance(G_B, kind="t1")(0.0, meas),
                               rtol=1e-12, atol=1e-12)  # fmt: skip
