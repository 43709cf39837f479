"""The fit's structure test and widened intervals (issue 37, item 3) on stand logs of a
robot of another structure, made by a simulator written apart from the twin's code
(tests/independent_stand.py, the ``off`` structure: gear efficiency 0.70 where the robot file
says 0.75, the rotor reflected through a lossy gearbox, the wheel's inertia 10 % up, a smooth
Coulomb law, a true delay, the compensation of the measured speed, a current clamp, no
battery sag).

Declared before these seeds were run (the method and its constants were set on the
development seeds 0-19 of benchmarks/coverage_structure.py; these are seeds 100-119):

- the structure test rejects the twin's structure on at least 19 of the 20 logs (on the
  development seeds: 20 of 20, the smallest ratio 4.9 against the limit 2);
- the reported intervals (+- 2 widened standard errors where the structure is rejected)
  cover the truth in at least the lower end of the central 98 % band of Binomial(n, 0.9545)
  over the n cases (seeds x fitted drive parameters). The widened intervals are conservative
  by construction, so only under-coverage fails. Per parameter the rates are printed, not
  asserted: on the development seeds the gear ratio's was 14 of 20 (docs/twin_fit.md).

The matched structure's side (the test does not reject the twin's own logs) is in
tests/test_identify_truth.py.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from scipy import stats

from independent_stand import DRIVE, consts_of, simulate, truth
from mwip.identify import excite, synth
from mwip.identify.fit import fit
from mwip.identify.logs import read_log
from mwip.robot import default_robot

SEEDS = range(100, 120)
NOMINAL = 0.9545


@pytest.fixture(scope="module")
def fits(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[dict, object, object]]:
    robot = default_robot()
    consts = consts_of(robot)
    _, duty, mode = excite.schedule(robot.twin.Ts, 0.5, 0.1, 1.0)
    tmp = tmp_path_factory.mktemp("structure")
    out = []
    for seed in SEEDS:
        t = truth(seed)
        path = Path(tmp) / f"log{seed}.csv"
        path.write_text(synth.csv_text(simulate(t, duty, mode, consts, "off", seed)))
        lg = read_log(str(path))
        out.append((t, fit([lg], robot.twin, body=robot.body), lg))
    return out


@pytest.mark.slow
def test_the_structure_test_rejects_another_structure(fits: list) -> None:
    ratios = [res.structure.ratio for _, res, _ in fits]
    print("\nBirge ratios:", " ".join(f"{r:.3g}" for r in ratios))
    assert sum(res.structure.rejected for _, res, _ in fits) >= 19
    for _, res, _ in fits:
        if res.structure.rejected:
            assert any(f.startswith("structure: rejected") for f in res.flags)


@pytest.mark.slow
def test_the_reported_intervals_cover_the_truth(fits: list) -> None:
    hits = total = 0
    per: dict[str, list[int]] = {n: [] for n in DRIVE}
    primary = 0
    for t, res, _ in fits:
        sc = res.structure
        for n in DRIVE:
            se = res.stderr.get(n)
            if res.status[n] != "fitted" or se is None:
                continue
            s = sc.widened[n] if sc.rejected else se
            assert s >= se
            ok = abs(res.estimates[n] - t[n]) <= 2.0 * s
            per[n].append(int(ok))
            hits += ok
            primary += abs(res.estimates[n] - t[n]) <= 2.0 * se
            total += 1
    print(f"\nreported intervals cover {hits}/{total}; the primary ones {primary}/{total}")
    for n, v in per.items():
        print(f"  {n:28s} {sum(v)}/{len(v)}")
    assert total >= 20 * 6
    assert hits >= stats.binom.ppf(0.01, total, NOMINAL)


@pytest.mark.slow
def test_the_fitted_robot_file_carries_the_widened_errors(fits: list) -> None:
    """The robot file a rejected fit writes (the one tune, bench and export then take) gives
    each drive value's widened standard error and says why, not the primary one alone."""
    from mwip.identify.report import fitted_robot

    _, res, lg = next(f for f in fits if f[1].structure.rejected)
    src = fitted_robot(res, [lg]).sources()
    for n in DRIVE:
        if res.status[n] == "fitted":
            assert f"+- {res.structure.widened[n]:.3g} (1 standard error widened" in src[n]
            assert "structure was rejected" in src[n]
