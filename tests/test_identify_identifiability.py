"""Issue 37, item 4: the identifiability check before the fit (mwip.identify.identifiability).

Synthetic truth: a stand log of a small chirp alone (no steps) cannot tell the back-EMF
compensation from the viscous friction (both damp the wheel's speed); the check says so, the
pair agrees with a Fisher matrix computed here by brute force (central differences of
``stand_rollout`` over the globals and every segment's start state), and the experiment it
advises, added to the log, lets the fit separate them. A current limit no segment reaches is
refused as ``--free`` with the command that informs it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.identify import excite, synth
from mwip.identify.bounds import BOUNDS, NAMES, centre
from mwip.identify.fit import fit, stand_segments
from mwip.identify.identifiability import MU_MIN, check
from mwip.identify.logs import Log
from mwip.identify.model import STAND_PARAMS, Known, stand_rollout

PAIR = ["firmware.emf_compensation", "gearbox.viscous"]
TRUTH = synth.draw_truth(3)


def _log(cols: dict) -> Log:
    return Log("synthetic", "0" * 64, {k: np.asarray(v, dtype=float) for k, v in cols.items()
                                       if k != "mode"}, np.asarray(cols["mode"]), inputs="duty")


@pytest.fixture(scope="module")
def small_chirp() -> Log:
    _, duty, mode = excite.schedule(static=0.2, step=0.0, chirp=2.0)
    return _log(synth.stand_log(TRUTH, 0.1 * duty, mode, seed=1))


def _known() -> Known:
    from mwip.hardware.twin import Twin

    return Known.from_twin(Twin(), 0.005)


def _setup() -> tuple[dict[str, float], dict[str, float]]:
    fixed = {n: TRUTH[n] for n in STAND_PARAMS if n not in PAIR}
    return fixed, {n: fixed.get(n, centre(n)) for n in NAMES}


def _brute_correlation(lg: Log, values: dict[str, float], known: Known) -> float:
    """The pair's correlation from ``(J^T J)^-1``, ``J`` the central-difference Jacobian of all
    segments' residuals (mean per segment and wheel removed) in the scaled pair and every
    segment's start speeds ``w_0``, ``w_{-1}`` (first guesses of the fit)."""
    from dataclasses import replace

    seg = stand_segments([lg], 40)
    assert seg is not None and seg.dw0 is not None
    k = replace(known, pwm_levels=0)
    spans = np.array([BOUNDS[n][1] - BOUNDS[n][0] for n in PAIR])
    x0 = np.concatenate([[values[n] for n in PAIR], seg.w0.ravel(),
                         (seg.w0 - seg.dw0).ravel()])  # fmt: skip
    scale = np.concatenate([spans, np.ones(4 * seg.n)])

    def res(x: np.ndarray) -> np.ndarray:
        p = dict(values)
        p[PAIR[0]], p[PAIR[1]] = x[0], x[1]
        w0 = x[2:2 + 2 * seg.n].reshape(-1, 2)
        wp = x[2 + 2 * seg.n:].reshape(-1, 2)
        phi, _ = stand_rollout(p, seg.cmd, seg.is_duty, w0, k, w_prev=wp, cmd_prev2=seg.prev2)
        r = seg.enc - phi
        return (r - r.mean(axis=1, keepdims=True)).ravel()

    h = 1e-6
    J = np.column_stack([(res(x0 + h * s * e) - res(x0 - h * s * e)) / (2 * h)
                         for s, e in zip(scale, np.eye(x0.size), strict=True)])  # fmt: skip
    C = np.linalg.pinv(J.T @ J)[:2, :2]
    return float(C[0, 1] / np.sqrt(C[0, 0] * C[1, 1]))


def test_a_small_chirp_confounds_the_damping_pair_and_the_advice_separates_it(
        small_chirp: Log) -> None:  # fmt: skip
    fixed, values = _setup()
    known = _known()
    res = check([small_chirp], PAIR, values, known)
    assert [sorted(d.weights) for d in res.confounded] == [sorted(PAIR)], res.lines()
    d = res.confounded[0]
    assert d.normalised < MU_MIN and d.command is not None
    # the independent argument: the brute-force Fisher matrix has the pair correlated too
    rho = _brute_correlation(small_chirp, values, known)
    assert abs(rho) > 0.9 and np.sign(rho) == np.sign(d.correlation), (rho, d.correlation)
    before = fit([small_chirp], free=PAIR, fixed=fixed)
    assert abs(before.correlation["matrix"][0][1]) > 0.9
    assert any("identifiability:" in f and "confounded" in f for f in before.flags)
    # run the advised experiment (the command's options) and fit both logs
    a = d.command.split()
    opts = {a[i]: float(a[i + 1]) for i in range(len(a) - 1) if a[i] in
            ("--static", "--step", "--chirp")}  # fmt: skip
    _, duty, mode = excite.schedule(static=opts["--static"], step=opts["--step"],
                                    chirp=opts["--chirp"])  # fmt: skip
    extra = _log(synth.stand_log(TRUTH, duty, mode, seed=2))
    after = fit([small_chirp, extra], free=PAIR, fixed=fixed)
    assert abs(after.correlation["matrix"][0][1]) < 0.9, after.correlation
    assert after.identifiability is not None and not after.identifiability.confounded


def test_the_check_is_deterministic_and_in_fit_json(small_chirp: Log) -> None:
    _, values = _setup()
    a = check([small_chirp], list(STAND_PARAMS), values, _known()).to_json()
    b = check([small_chirp], list(STAND_PARAMS), values, _known()).to_json()
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    # the current limit: no current of this log reaches it at any point
    assert a["status"]["drive.current_limit"] == "not informed"
    assert "mwip twin excite" in a["inform"]["drive.current_limit"]["command"]


def test_free_of_an_uninformed_parameter_is_refused(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    _, duty, mode = excite.schedule(static=0.2, step=0.0, chirp=1.0)
    log = synth.write_csv(tmp_path / "small.csv", synth.stand_log(TRUTH, 0.1 * duty, mode))
    out = tmp_path / "fit"
    name = "drive.current_limit"
    assert main(["twin", "fit", str(log), "--free", f"{name},drive.gear_ratio",
                 "--out", str(out)]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"--free {name}" in err and "mwip twin excite --static" in err, err
    assert f"--fix {name}=VALUE" in err and not out.exists()
    # held, the same log fits; left out of --free, it is reported, not refused
    res = fit([_log_of(log)])
    assert res.status[name] == "not informed"
    assert res.to_json()["identifiability"]["status"][name] == "not informed"


def _log_of(path: Path) -> Log:
    from mwip.identify.logs import read_log

    return read_log(str(path))
