"""Stage 3 of the book calibration (mwip.calibration.chains) and its diagnostics, on synthetic
truth: a uniform law on a known region must come back, the ESS of an AR(1) series must be its
analytic value, and the chains are deterministic and resumable."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mwip.calibration.chains import ChainPlan, reflect, run_chains
from mwip.calibration.diagnostics import autocovariance, ess, split_rhat

NAMES = ["a", "b", "c"]
BOUNDS = np.array([[0.0, 1.0], [0.0, 1.0], [0.5, 0.5]])  # c fixed by the prior
# the "conditioned set": an ellipse with semi-axes 0.1 and 0.2 around (0.3, 0.6), touching
# nothing of the box edge but close to it, so proposals leave the box too
CENTRE, AXES = np.array([0.3, 0.6]), np.array([0.1, 0.2])


class Ellipse:
    """The toy twin evaluator: counts calls, refuses any twin outside the prior box."""

    def __init__(self) -> None:
        self.calls = 0
        self.rows = 0

    def __call__(self, v: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        self.calls += 1
        self.rows += len(v["a"])
        for j, n in enumerate(NAMES):
            assert np.all((v[n] >= BOUNDS[j, 0]) & (v[n] <= BOUNDS[j, 1])), n
        q = ((v["a"] - CENTRE[0]) / AXES[0]) ** 2 + ((v["b"] - CENTRE[1]) / AXES[1]) ** 2
        return {"q": q, "a2": v["a"] * 2.0}


def inside(c: dict[str, np.ndarray]) -> np.ndarray:
    return np.asarray(c["q"]) <= 1.0


START = np.array([[0.3, 0.6, 0.5]])


def start_cols() -> dict[str, np.ndarray]:
    return Ellipse()({"a": START[:, 0], "b": START[:, 1], "c": START[:, 2]})


def run(plan: ChainPlan, store: Path | None = None, ev: Ellipse | None = None):  # noqa: ANN201
    return run_chains(plan, NAMES, BOUNDS, START, start_cols(), ev or Ellipse(), inside,
                      store=store)  # fmt: skip


PLAN = ChainPlan(chains=48, steps=160, burn=40, seed=7)


def test_uniform_law_on_an_ellipse_comes_back():
    """Uniform on an ellipse with semi-axes (p, q): each coordinate's mean is the centre and
    its variance p^2 / 4 (resp. q^2 / 4). The means must be within 4 Monte Carlo standard
    errors at the chains' own ESS; the variances within 15 %."""
    ev = Ellipse()
    r = run(PLAN, ev=ev)
    assert r.x.shape == (48, 120, 3)
    assert np.all(inside({"q": r.cols["q"].ravel()}))  # every kept state is in the set
    np.testing.assert_allclose(r.cols["a2"], 2.0 * r.x[:, :, 0])  # columns follow the state
    assert np.ptp(r.x[:, :, 2]) == 0.0  # the fixed unknown never moves
    for j in range(2):
        x = r.x[:, :, j]
        n_eff = ess(x)
        sd = AXES[j] / 2.0
        assert 50 < n_eff < x.size
        assert abs(x.mean() - CENTRE[j]) < 4.0 * sd / np.sqrt(n_eff)
        assert x.var() == pytest.approx(sd**2, rel=0.15)
        assert split_rhat(x) < 1.1
    assert 0.1 < r.acceptance() < 0.45  # the adaptation reached its target region (0.234)
    assert ev.rows == r.evaluations == 48 * 160  # reflected: every proposal is in the box


def test_a_set_against_the_walls_is_sampled_without_bias():
    """The conditioned set ``a <= 0.08, b >= 0.9`` lies against two walls of the box (as the
    book's standing twins do): uniform there, ``a`` has mean 0.04 and variance 0.08^2 / 12,
    ``b`` mean 0.95 and variance 0.1^2 / 12. A proposal kernel that is not symmetric at the
    walls (reflection done wrong) would pile draws up at them or push them away."""

    def slab(v: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {"ok": ((v["a"] <= 0.08) & (v["b"] >= 0.9)).astype(float)}

    plan = ChainPlan(chains=48, steps=200, burn=60, seed=11)
    start = np.array([[0.04, 0.95, 0.5]])
    r = run_chains(plan, NAMES, BOUNDS, start, slab({"a": start[:, 0], "b": start[:, 1]}), slab,
                   lambda c: np.asarray(c["ok"]) == 1.0)  # fmt: skip
    for j, (mean, width) in enumerate(((0.04, 0.08), (0.95, 0.1))):
        x = r.x[:, :, j]
        sd = width / np.sqrt(12.0)
        assert abs(x.mean() - mean) < 4.0 * sd / np.sqrt(ess(x))
        assert x.var() == pytest.approx(sd**2, rel=0.15)
        # no pile-up at the wall: the tenth of the set touching it holds about a tenth
        edge = x <= 0.008 if j == 0 else x >= 0.99
        assert 0.05 < edge.mean() < 0.15


def test_reflection_folds_into_the_box():
    b = np.array([[0.0, 1.0], [2.0, 2.0]])
    v = np.array([[-0.25, 7.0], [1.25, 2.0], [2.5, 1.0], [0.4, 2.0], [-3.25, 2.0]])
    np.testing.assert_allclose(reflect(v, b), [[0.25, 2.0], [0.75, 2.0], [0.5, 2.0],
                                               [0.4, 2.0], [0.75, 2.0]])  # fmt: skip


def test_deterministic_and_resumable(tmp_path: Path):
    plan = ChainPlan(chains=8, steps=20, burn=6, seed=3)
    a = run(plan)
    b = run(plan, store=tmp_path / "s")
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.moved, b.moved)
    gens = sorted((tmp_path / "s").glob("gen-*.parquet"))
    assert len(gens) == 20
    for p in gens[-5:]:
        p.unlink()
    ev = Ellipse()
    c = run(plan, store=tmp_path / "s", ev=ev)
    assert ev.calls == 5  # only the lost generations are evaluated again
    np.testing.assert_array_equal(a.x, c.x)
    for k in a.cols:
        np.testing.assert_array_equal(a.cols[k], c.cols[k])
    with pytest.raises(ValueError, match="another chain plan"):
        run(ChainPlan(chains=8, steps=20, burn=6, seed=4), store=tmp_path / "s")


def test_bad_plans_and_starts():
    for kw, field in (({"chains": 1}, "chains.chains"), ({"burn": 1}, "chains.burn"),
                      ({"steps": 7, "burn": 6}, "chains.steps"), ({"scale": 0.0}, "chains.scale"),
                      ({"accept": 1.0}, "chains.accept"), ({"adapt_every": 1}, "adapt_every"),
                      ({"converged": 1.0}, "chains.converged")):  # fmt: skip
        args = {"chains": 4, "steps": 20, "burn": 6, "seed": 1} | kw
        with pytest.raises(ValueError, match=field):
            ChainPlan(**args)
    far = {"q": np.array([4.0]), "a2": np.array([0.0])}
    with pytest.raises(ValueError, match="does not meet"):
        run_chains(PLAN, NAMES, BOUNDS, START, far, Ellipse(), inside)


def test_ess_of_an_ar1_series_is_the_analytic_one():
    """AR(1) ``x_t = phi x_{t-1} + e_t``: integrated autocorrelation time
    ``tau = (1 + phi) / (1 - phi)``, so ``ESS = C M / tau``; white noise: ``C M``."""
    rng = np.random.default_rng(0)
    for phi in (0.0, 0.5, 0.9):
        z = np.zeros((8, 4000))
        e = rng.standard_normal(z.shape)
        z[:, 0] = e[:, 0] / np.sqrt(1 - phi**2)
        for t in range(1, z.shape[1]):
            z[:, t] = phi * z[:, t - 1] + e[:, t]
        expected = z.size * (1 - phi) / (1 + phi)
        assert ess(z) == pytest.approx(expected, rel=0.12), phi
        assert split_rhat(z) < 1.02


def test_rhat_sees_chains_that_disagree_and_constants_have_no_ess():
    rng = np.random.default_rng(1)
    z = rng.standard_normal((4, 500)) + np.array([[0.0], [0.0], [2.0], [2.0]])
    assert split_rhat(z) > 1.3
    assert np.isnan(ess(np.ones((4, 50)))) and np.isnan(split_rhat(np.ones((4, 50))))
    g = autocovariance(np.array([1.0, -1.0, 1.0, -1.0]))
    np.testing.assert_allclose(g, [1.0, -0.75, 0.5, -0.25])
    with pytest.raises(ValueError, match="M >= 4"):
        ess(np.ones((2, 3)))
