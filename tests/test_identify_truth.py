"""Synthetic truth for `mwip twin fit`: logs from the twin's own elements with hidden
parameters drawn from the bounds (mwip.identify.synth), fitted by mwip.identify.fit."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.identify import excite, synth
from mwip.identify.bounds import centre
from mwip.identify.fit import fit, predict_error
from mwip.identify.logs import Log

SEEDS = range(20)
#: Nominal coverage of a 2-sigma interval.
NOMINAL = 0.9545


def _log(cols: dict, name: str = "synthetic") -> Log:
    inputs = "duty" if "duty_r" in cols else "torque"
    return Log(name, "0" * 64, {k: np.asarray(v, dtype=float) for k, v in cols.items()
                                if k != "mode"}, np.asarray(cols["mode"]), inputs=inputs)


@pytest.fixture(scope="module")
def fits() -> list[tuple[dict, object, Log]]:
    t, duty, mode = excite.schedule(static=0.4, step=0.08, chirp=1.0)
    tv, dv, mv = excite.schedule(static=0.3, step=0.07, chirp=0.8)
    out = []
    for seed in SEEDS:
        truth = synth.draw_truth(seed)
        lg = _log(synth.stand_log(truth, duty, mode, seed=seed))
        held = _log(synth.stand_log(truth, dv[::-1].copy(), mv, seed=seed + 500, torque=True))
        out.append((truth, fit([lg]), held))
    return out


#: The measured coverage two revisions back (sigma^2 (J^T J)^-1 with a Bartlett-inflated
#: sigma^2, the segment start w_{-1} = w_0): 157/199; the previous revision (CR3 errors, the
#: lsmr trust-region solver that stopped short of the optimum) 180/198 = 0.909. This revision
#: (variable projection, the PWM rounding errors held in stage 2) measured 188/200 = 0.940; on
#: the compiled twin, with the model's delay before the back-EMF compensation as the twin's
#: chain has it, 191/200 = 0.955.
PREVIOUS = 157 / 199


def _coverage(fits: list) -> tuple[int, int]:
    hits = total = 0
    per: dict[str, list[int]] = {}
    for truth, res, _ in fits:
        for n in res.free:
            se = res.stderr[n]
            assert se is not None and se > 0
            ok = abs(res.estimates[n] - truth[n]) <= 2.0 * se
            per.setdefault(n, []).append(int(ok))
            hits += ok
            total += 1
    print(f"\n2-sigma coverage over {len(fits)} seeds x parameters: {hits / total:.3f} "
          f"({hits}/{total})")  # fmt: skip
    for n, v in per.items():
        print(f"  {n:24s} {np.mean(v):.2f}")
    return hits, total


@pytest.mark.slow
def test_coverage_improves_on_the_previous_revision(fits: list) -> None:
    """The cluster-robust (CR3) standard errors and the segment start state: more coverage than
    the previous revision's 0.79 (not a claim of 0.95: see the next test)."""
    hits, total = _coverage(fits)
    assert total >= 20 * 9
    assert hits / total > PREVIOUS


@pytest.mark.slow
def test_coverage_of_two_sigma_intervals(fits: list) -> None:
    """Issue 23: each identifiable parameter within its reported 2-sigma interval in about
    95 % of cases. The count of hits over the n cases (seeds x fitted parameters) must lie
    inside the central 98 % of Binomial(n, 0.9545): below it the standard errors are too
    small (or the estimates biased), above it too large. (The cases of one seed share a
    log, so they are not independent; the binomial band is the nominal one.) Measured
    191/200 = 0.955 (band 183-197; docs/twin_fit.md)."""
    from scipy.stats import binom

    hits, total = _coverage(fits)

    lo, hi = binom.ppf(0.01, total, NOMINAL), binom.isf(0.01, total, NOMINAL)
    print(f"  consistent with {NOMINAL}: {lo:.0f} <= hits <= {hi:.0f}")
    assert total >= 20 * 9
    assert lo <= hits <= hi, (hits, total, lo, hi)


@pytest.mark.slow
def test_the_structure_test_accepts_the_twins_own_structure(fits: list) -> None:
    """Issue 37, item 3: on logs of the twin's own structure the structure test
    (mwip.identify.structure) rejects at most 2 of the 20 (declared before this run; on the
    development seeds of benchmarks/coverage_structure.py --structure twin, 1 of 20: a fit
    that stopped in a local minimum, 50 times its truth's residual, which the test rightly
    reports; the other ratios 0.78-1.67 against the limit 2)."""
    ratios = [res.structure.ratio for _, res, _ in fits]
    print("\nBirge ratios on the twin's own structure:", " ".join(f"{r:.3g}" for r in ratios))
    assert sum(res.structure.rejected for _, res, _ in fits) <= 2


def test_not_informed_parameters_are_flagged(fits: list) -> None:
    for _, res, _ in fits:
        assert res.status["imu.height"] == "not informed"
        assert any(f.startswith("imu.height") for f in res.flags)
        assert res.estimates["imu.height"] == centre("imu.height")


def test_fit_predicts_held_out_log_better_than_prior(fits: list) -> None:
    from mwip.identify.model import Known

    better = 0
    for _, res, held in fits[:8]:
        prior = {n: centre(n) for n in res.estimates}
        k = Known.from_twin(__import__("mwip.hardware.twin", fromlist=["Twin"]).Twin(), held.Ts)
        e_fit = predict_error(held, res.estimates, k)
        e_pri = predict_error(held, prior, k)
        better += e_fit["enc_rms"] < e_pri["enc_rms"] and \
            e_fit["theta_rate_rms"] <= e_pri["theta_rate_rms"] * 1.001  # fmt: skip
    assert better == 8


def test_the_fit_says_how_far_it_has_come() -> None:
    """Issue 23: `mwip twin fit LOG` was silent for its whole run; it now reports every 100
    model evaluations of each stage."""
    t, duty, mode = excite.schedule(static=0.3, step=0.07, chirp=0.6)
    lg = _log(synth.stand_log(synth.draw_truth(3), duty, mode, seed=3))
    lines: list[str] = []
    res = fit([lg], progress=lines.append)
    # issue 37, item 4: the identifiability check's findings come first
    first = [line for line in lines if line.startswith("identifiability: ")]
    assert first and lines[:len(first)] == first
    lines = lines[len(first):]
    assert lines and all(line.startswith("fit: stage ") for line in lines)
    assert "model evaluations; encoder residual RMS, best so far: " in lines[0]
    # issue 40: in the final residual's units (rad), never below it within a stage's lines
    best = [float(line.split("best so far: ")[1].split()[0]) for line in lines
            if line.startswith("fit: stage 1") and line.endswith(" rad")]  # fmt: skip
    assert best and best == sorted(best, reverse=True)
    assert best[-1] >= 0.5 * res.residuals["enc"]["rms"]


def _stand_base() -> object:
    """The elements of the generator's twin (synth.twin_for: backlash off)."""
    from dataclasses import replace

    from mwip.hardware.elements import ELEMENTS
    from mwip.hardware.twin import Twin

    return replace(Twin(), elements=frozenset(e for e in ELEMENTS if e != "backlash"))


@pytest.mark.slow
@pytest.mark.parametrize("controller", ["lqr", "hodosmc"])
def test_fit_predicts_a_log_of_another_controller_better_than_prior(
    fits: list, controller: str
) -> None:
    """Issue 23: the held-out log is produced under a different controller than the fitting
    log: fitted on the open-loop excitation (wheels off the ground), validated on the robot
    balancing under LQR or HODOSMC (50 ms predictions from fitted start states,
    mwip.identify.balance). On every seed the fit predicts the encoders and the gyro better
    than the prior's centre, and the encoders within 1.5 times the error of the true
    parameters (the gyro's floor is its noise)."""
    from mwip.identify.model import Known

    base = _stand_base()
    for seed, (truth, res, _) in zip(SEEDS, fits[:3], strict=False):
        held = _log(synth.balancing_log(truth, controller, 0.4, seed=seed + 900))
        k = Known.from_twin(base, held.Ts)
        prior = {n: centre(n) for n in res.estimates}
        e_fit = predict_error(held, res.estimates, k, twin=base)
        e_pri = predict_error(held, prior, k, twin=base)
        e_true = predict_error(held, truth, k, twin=base)
        assert e_fit["balance_segments"] >= 5
        assert e_fit["balance_enc_rms"] < e_pri["balance_enc_rms"], (seed, e_fit, e_pri)
        assert e_fit["balance_gyro_rms"] < e_pri["balance_gyro_rms"], (seed, e_fit, e_pri)
        assert e_fit["balance_enc_rms"] <= 1.5 * e_true["balance_enc_rms"], (seed, e_fit, e_true)
        print(f"\n{controller} seed {seed}: enc {e_fit['balance_enc_rms']:.3g} (prior "
              f"{e_pri['balance_enc_rms']:.3g}, truth {e_true['balance_enc_rms']:.3g}), gyro "
              f"{e_fit['balance_gyro_rms']:.3g} (prior {e_pri['balance_gyro_rms']:.3g})")
