"""Stage 2 of the book calibration (mwip.calibration.pmc): the proposal density is a density,
the sampler follows it, and the weighted population recovers a known posterior (the uniform
prior restricted to a small box) that plain prior draws almost never hit."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mwip.calibration.evidence import Evidence
from mwip.calibration.pmc import Refine, distance, proposal_density, propose, refine
from mwip.calibration.posterior import weighted_quantile

RUNS = ["s/a.case1", "s/b.case1"]
DUR = {r: 1.0 for r in RUNS}
BOUNDS = np.array([[0.0, 1.0], [0.0, 2.0]])
# the region each run stands in (x1, x2 boxes); together: x1 in [0.6, 0.7], x2 in [0.2, 0.6]
REGION = {"s/a.case1": ((0.6, 0.7), (0.0, 2.0)), "s/b.case1": ((0.0, 1.0), (0.2, 0.6))}


def _ev() -> Evidence:
    return Evidence(title="t", standing_source="s", numbers=(), tolerance=1.5, decided=0.95,
                    interval=0.95, identified=0.5, samples=0, seed=0, block=10,
                    source={})  # fmt: skip


def _evaluate(calls: list[int] | None = None):
    def run(values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if calls is not None:
            calls.append(len(values["x1"]))
        x = np.column_stack([values["x1"], values["x2"]])
        out = {}
        for r, box in REGION.items():
            gap = sum(np.maximum(0.0, np.maximum(lo - x[:, j], x[:, j] - hi))
                      for j, (lo, hi) in enumerate(box))  # fmt: skip
            out[f"{r}.stands"] = (gap == 0).astype(float)
            out[f"{r}.t_end"] = np.clip(1.0 - gap, 0.0, 1.0)  # a twin near the region falls later
        return out

    return run


def _prior(n: int, seed: int = 1) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    x = BOUNDS[:, 0] + rng.random((n, 2)) * (BOUNDS[:, 1] - BOUNDS[:, 0])
    values = {"x1": x[:, 0], "x2": x[:, 1]}
    return pd.DataFrame({"evidence": "t", "sample": np.arange(n), "param.x1": x[:, 0],
                         "param.x2": x[:, 1], **_evaluate()(values)})  # fmt: skip


def _refine(table0: pd.DataFrame, settings: Refine, **kw):
    return refine(table0, _ev(), settings, names=["x1", "x2"], bounds=BOUNDS, run_names=RUNS,
                  durations=DUR, evaluate=kw.pop("evaluate", _evaluate()), seed=7,
                  **kw)  # fmt: skip


def test_proposal_density_integrates_to_one_over_the_cube() -> None:
    rng = np.random.default_rng(0)
    centres = rng.random((5, 2))
    centres[0] = [0.02, 0.98]  # a kernel mostly outside the cube
    w = rng.random(5)
    w /= w.sum()
    sigma = np.array([0.15, 0.3])
    g = (np.arange(400) + 0.5) / 400
    uu = np.array(np.meshgrid(g, g, indexing="ij")).reshape(2, -1).T
    integral = proposal_density(uu, centres, w, sigma).mean()  # midpoint rule on [0, 1]^2
    assert integral == pytest.approx(1.0, abs=2e-4)
    per_centre = rng.uniform(0.05, 0.4, size=(5, 2))  # one width per centre (local kernels)
    assert proposal_density(uu, centres, w, per_centre).mean() == pytest.approx(1.0, abs=5e-4)


def test_proposals_follow_the_proposal_density() -> None:
    rng = np.random.default_rng(3)
    centres = np.array([[0.1, 0.5], [0.8, 0.5]])
    w = np.array([0.3, 0.7])
    sigma = np.array([0.2, 0.2])
    sigma = np.array([[0.2, 0.2], [0.1, 0.3]])  # one width per centre
    u = propose(rng, centres, w, sigma, 20000)
    assert np.all((u >= 0) & (u <= 1))
    hist, edges = np.histogram(u[:, 0], bins=10, range=(0, 1), density=True)
    g = (np.arange(200) + 0.5) / 200
    # the bin average of the first coordinate's marginal density (midpoint rule, 20 x 200)
    marg = []
    for lo in edges[:-1]:
        x1 = lo + (np.arange(20) + 0.5) / 200
        uu = np.array(np.meshgrid(x1, g, indexing="ij")).reshape(2, -1).T
        marg.append(proposal_density(uu, centres, w, sigma).mean())
    assert np.max(np.abs(hist - marg)) < 0.08  # sampling error of 2,000 per bin: ~0.03


def test_distance_is_zero_exactly_on_the_facts() -> None:
    cols = {"s/a.case1.stands": np.array([1.0, 0.0, 0.0]), "s/a.case1.t_end": np.array([1, .5, .9]),
            "s/b.case1.stands": np.array([1.0, 1.0, 0.0]), "s/b.case1.t_end": np.ones(3)}
    d = distance(cols, RUNS, DUR, _ev())
    assert d[0] == 0.0 and d[1] == pytest.approx(1.5) and d[2] == pytest.approx(1.1 + 1.0)
    only_b = distance(cols, RUNS, DUR, _ev(), use=frozenset({"up:s/b.case1"}))
    assert list(only_b[:2]) == [0.0, 0.0] and only_b[2] > 0


@pytest.mark.parametrize("local", [0.0, 0.5])
def test_weighted_population_recovers_the_uniform_posterior_on_a_small_region(local) -> None:
    table0 = _prior(300)
    n_in = int(np.sum((table0["s/a.case1.stands"] == 1) & (table0["s/b.case1.stands"] == 1)))
    assert n_in <= 15  # the region is 2 % of the prior box: 6 of 300 prior draws expected
    pop, hist, pool = _refine(table0, Refine(keep=300, propose=300, generations=12,
                                             min_acceptance=0.0, local=local))  # fmt: skip
    assert hist[-1]["epsilon"] == 0.0  # every kept twin meets every fact
    x1, x2 = pop["param.x1"].to_numpy(), pop["param.x2"].to_numpy()
    w = pop["weight"].to_numpy()
    assert np.all((x1 >= 0.6) & (x1 <= 0.7) & (x2 >= 0.2) & (x2 <= 0.6))
    ess = w.sum() ** 2 / np.sum(w * w)
    assert ess > 60
    # the uniform posterior's quantiles: 5-50-95 % of [0.6, 0.7] and of [0.2, 0.6]; the
    # tolerance is 4 standard errors of a quantile at this effective size (~0.25 sd / sqrt(ess))
    q1 = weighted_quantile(x1, w, [0.05, 0.5, 0.95])
    q2 = weighted_quantile(x2, w, [0.05, 0.5, 0.95])
    np.testing.assert_allclose(q1, [0.605, 0.65, 0.695], atol=4 * 0.1 * 0.3 / np.sqrt(ess) + 0.005)
    np.testing.assert_allclose(q2, [0.22, 0.4, 0.58], atol=4 * 0.4 * 0.3 / np.sqrt(ess) + 0.01)
    assert len(pool) == 300 + sum(h["evaluated"] for h in hist[1:])


def test_refine_is_deterministic_and_resumes_from_its_store(tmp_path) -> None:
    table0 = _prior(100)
    settings = Refine(keep=40, propose=40, generations=3, min_acceptance=0.0)
    calls: list[int] = []
    pop1, hist1, _ = _refine(table0, settings, store=tmp_path, evaluate=_evaluate(calls))
    assert calls == [40] * (len(hist1) - 1)
    pop2, hist2, _ = _refine(table0, settings)

    def boom(values):
        raise AssertionError("a resumed run must not evaluate again")

    pop3, hist3, _ = _refine(table0, settings, store=tmp_path, evaluate=boom)
    pd.testing.assert_frame_equal(pop1, pop2)
    pd.testing.assert_frame_equal(pop1, pop3)
    assert hist1 == hist2 == hist3


def test_refine_settings_are_validated() -> None:
    with pytest.raises(ValueError, match="refine.keep"):
        Refine(keep=0)
    with pytest.raises(ValueError, match="refine.min_acceptance"):
        Refine(min_acceptance=1.0)
