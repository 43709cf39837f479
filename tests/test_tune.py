"""``mwip tune`` (issue 27, item 2): the tuner finds a known optimum, resumes after kill -9,
keeps every setting inside the registry's range and refuses bad input without writing."""

from __future__ import annotations

import math
import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("optuna")

from scipy.linalg import solve_discrete_lyapunov  # noqa: E402

from mwip.cli import main  # noqa: E402
from mwip.laws.lqr.controller import dlqr, zoh  # noqa: E402
from mwip.laws.registry import CONTROLLERS, get  # noqa: E402
from mwip.laws.settings_file import load_settings  # noqa: E402
from mwip.models.linear import linearize  # noqa: E402
from mwip.params import NOMINAL  # noqa: E402
from mwip.schema.settings import settings_text  # noqa: E402
from mwip.tune import study as st  # noqa: E402
from mwip.tune.objective import Objective, Term, parse_objective, scalar_cost  # noqa: E402
from mwip.tune.space import Dim, Space, build_space  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

#: A small objective for the command-line tests: 16 robots of 2 s on the plain plant.
TINY = """
[objective]
title = "tiny"
[[objective.terms]]
metric = "rms_theta"
[robots]
campaign = "robustness"
plant = "plain"
samples = 16
chunk = 8
duration = 2.0
[validation]
samples = 8
seed = 9
[space]
tune = ["K", "phi"]
"""


# ---- (a) a known optimum: the discrete LQR gain ---------------------------------------------
def _pitch_plant(Ts: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """The linearised plant's pitch/wheel subsystem ``[theta, theta', v]`` with one input
    (both wheels' torque together), sampled by zero-order hold at ``Ts``."""
    A, B = linearize(NOMINAL)
    idx = [0, 2, 3]
    return zoh(A[np.ix_(idx, idx)], (B[idx, 0] + B[idx, 1])[:, None], Ts)


Q = np.diag([10.0, 1.0, 1.0])
R = np.array([[1.0]])


def _mean_cost(Ad: np.ndarray, Bd: np.ndarray, k: np.ndarray) -> float:
    """``E sum_k x'Qx + u'Ru`` from ``x0 ~ N(0, I)`` under ``u = -k x``: ``trace(P_k)`` with
    ``P = (A - Bk)' P (A - Bk) + Q + k'Rk`` (exact; discrete Lyapunov). An unstable gain
    costs ``1e6 rho`` (rho: spectral radius), ordered by how unstable it is."""
    Acl = Ad - Bd @ k[None, :]
    rho = float(np.max(np.abs(np.linalg.eigvals(Acl))))
    if rho >= 1.0:
        return 1e6 * rho
    P = solve_discrete_lyapunov(Acl.T, Q + R[0, 0] * np.outer(k, k))
    return float(np.trace(P))


def _start(Ad: np.ndarray, Bd: np.ndarray) -> np.ndarray:
    from scipy.signal import place_poles

    return np.asarray(place_poles(Ad, Bd, [0.9, 0.92, 0.95]).gain_matrix[0])


def _search(seed: int, trials: int = 400) -> tuple[np.ndarray, float, list[dict[str, float]]]:
    import optuna

    Ad, Bd = _pitch_plant()
    K_star = dlqr(Ad, Bd, Q, R)[0][0]
    # the start: the gain placing the closed-loop poles at 0.9, 0.92, 0.95 (J about 45 % above
    # the optimum); the box: a factor 10 either way of it, searched on a log scale of |k_i|
    # (the signs of a stabilising gain of this plant are known: all of K* is negative)
    K0 = _start(Ad, Bd)
    sign = np.sign(K0)
    dims = tuple(Dim(f"k[{i}]", "k", i, abs(K0[i]) / 10, abs(K0[i]) * 10, True, abs(K0[i]))
                 for i in range(3))  # fmt: skip
    space = Space("", dims)
    study = st.open_study(optuna.storages.InMemoryStorage(), "lqr", ["minimize"],
                          st.make_sampler("cmaes", seed, space))  # fmt: skip

    def objective(p, report):
        k = sign * np.array([p[f"k[{i}]"] for i in range(3)])
        return st.Outcome((_mean_cost(Ad, Bd, k),))

    st.optimise(study, space, objective, trials, exclusive=True)
    best = sign * np.array([study.best_params[f"k[{i}]"] for i in range(3)])
    assert np.all(np.sign(K_star) == sign)
    return best, study.best_value, [t.params for t in study.trials]


def test_direct_search_recovers_the_discrete_lqr_gain():
    """CMA-ES over the static gain, minimising the exact mean cost trace(P_K), reaches the
    discrete LQR gain of the same Q, R.

    Tolerances. The cost: within 1e-6 of J* = trace(S) relative (S the Riccati solution,
    trace(S) the minimum of trace(P_K) over stabilising K); the start costs ~45 % more, so
    the search must close six orders of magnitude of the gap: in 400 evaluations in 3
    dimensions CMA-ES (linear convergence) reached below 1e-7 for each of the seeds 0-5.
    The gain: near K* the excess cost is the quadratic form 1/2 dK' H dK (H the Hessian of
    trace(P_K) at K*, by finite differences), so a relative cost excess eps allows
    |dK| <= sqrt(2 eps J* / lambda_min(H)); the test asserts that bound (with 20 % for the
    cubic remainder) for eps = 1e-6."""
    Ad, Bd = _pitch_plant()
    K_star, S, _ = dlqr(Ad, Bd, Q, R)
    K_star = K_star[0]
    J_star = float(np.trace(S))
    assert _mean_cost(Ad, Bd, K_star) == pytest.approx(J_star, rel=1e-9)  # the identity used
    assert _mean_cost(Ad, Bd, _start(Ad, Bd)) > 1.4 * J_star  # the start is clearly off
    best, value, _ = _search(seed=0)
    eps = 1e-6
    assert (value - J_star) / J_star < eps
    h = 1e-4 * np.abs(K_star)
    H = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            ei, ej = np.eye(3)[i] * h[i], np.eye(3)[j] * h[j]
            H[i, j] = (_mean_cost(Ad, Bd, K_star + ei + ej) - _mean_cost(Ad, Bd, K_star + ei - ej)
                       - _mean_cost(Ad, Bd, K_star - ei + ej)
                       + _mean_cost(Ad, Bd, K_star - ei - ej)) / (4 * h[i] * h[j])  # fmt: skip
    lam = float(np.min(np.linalg.eigvalsh(0.5 * (H + H.T))))
    assert lam > 0
    bound = 1.2 * math.sqrt(2 * eps * J_star / lam)
    assert np.linalg.norm(best - K_star) <= bound


def test_sequential_search_is_reproducible_for_a_seed():
    a = _search(seed=5, trials=40)
    b = _search(seed=5, trials=40)
    c = _search(seed=6, trials=40)
    assert a[2] == b[2] and a[1] == b[1]
    assert a[2] != c[2]


# ---- the objective and the space ------------------------------------------------------------
def test_scalar_cost_puts_success_strictly_first():
    """One more successful robot lowers the cost whatever the terms (J = (f + g) / N,
    g in [0, 1)), and among equal successes the terms order the candidates."""
    obj = Objective("t", terms=(Term("rms_theta", 0.02), Term("control_tv", 20.0, 0.5)),
                    torque_limit=None)  # fmt: skip
    rng = np.random.default_rng(0)
    n = 32
    for _ in range(200):
        k = int(rng.integers(1, n))
        ok = np.zeros(n, dtype=bool)
        ok[:k] = True
        worse = {"success": ok, "rms_theta": np.full(n, 1e-6), "control_tv": np.full(n, 1e-6),
                 "peak_torque": np.zeros(n)}  # fmt: skip
        ok2 = ok.copy()
        ok2[k] = True
        better = {"success": ok2, "rms_theta": rng.uniform(0, 1e3, n),
                  "control_tv": rng.uniform(0, 1e6, n), "peak_torque": np.zeros(n)}  # fmt: skip
        assert scalar_cost(obj, better) < scalar_cost(obj, worse)
    base = {"success": np.ones(n, dtype=bool), "rms_theta": np.full(n, 0.01),
            "control_tv": np.full(n, 5.0), "peak_torque": np.zeros(n)}  # fmt: skip
    calmer = dict(base, rms_theta=np.full(n, 0.005))
    assert scalar_cost(obj, calmer) < scalar_cost(obj, base)


def test_torque_above_the_limit_fails_without_a_drive_model_only():
    obj = parse_objective({"objective": {"torque_limit": 0.5}})
    drive = parse_objective({"objective": {"torque_limit": "drive"}})
    met = {"success": np.array([True, True]), "peak_torque": np.array([0.4, 0.6])}
    from mwip.tune.objective import successes

    assert successes(obj, met).tolist() == [True, False]
    assert successes(obj, met, "twin").tolist() == [True, False]  # a number: on any robot
    assert drive.torque_limit is not None
    met["peak_torque"] = np.array([0.1, 2 * drive.torque_limit])
    assert successes(drive, met, "ideal").tolist() == [True, False]
    assert successes(drive, met, "twin").tolist() == [True, True]  # the twin's drive bounds it


@pytest.mark.parametrize("name", list(CONTROLLERS))
def test_every_default_space_stays_inside_the_registry_range(name):
    """Every dimension of every controller's default space lies inside its setting's allowed
    range (open ends excluded), and the space's corners resolve through the registry."""
    spec = get(name)
    space = build_space(spec)
    for d in space.dims:
        s = spec.setting(d.setting)
        assert d.lo < d.hi
        for x in (d.lo, d.hi):
            assert (x > s.lo if s.lo_open else x >= s.lo) and (x < s.hi if s.hi_open else x <= s.hi)
    for corner in ("lo", "hi"):
        spec.resolve(space.settings({d.name: getattr(d, corner) for d in space.dims}))


def test_a_narrowed_range_must_lie_inside_the_registry_range():
    spec = get("hodosmc")
    space = build_space(spec, ["K"], {"K": {"lo": [1.0, 2.0], "hi": 20.0}})
    assert [(d.name, d.lo, d.hi) for d in space.dims] == [("K[0]", 1.0, 20.0), ("K[1]", 2.0, 20.0)]
    with pytest.raises(ValueError, match=r"K\[0\]: -1 is outside controller 'hodosmc'"):
        build_space(spec, ["K"], {"K": {"lo": -1.0, "hi": 20.0}})
    with pytest.raises(ValueError, match="phi"):
        build_space(spec, ["phi"], {"phi": {"lo": 0.0, "hi": 1.0}})  # phi > 0 (open)


def test_a_population_in_one_batch_equals_each_candidate_alone():
    """Candidates evaluated together (one parameter vector per robot, the chunk's robots
    repeated per candidate) give each candidate exactly the metrics of its own run on the
    plain plant; a candidate whose design fails still fails alone."""
    from mwip.tune.evaluate import evaluate, robot_set

    robots = robot_set("robustness", samples=8, chunk=4, seed=3, plant="plain", duration=1.0)
    cands = [{"K": (6.3, 4.0)}, {"K": (12.0, 2.0), "phi": 0.1}, {"K": (3.0, 8.0)}]
    together = evaluate("hodosmc", cands, robots)
    for c, got in zip(cands, together, strict=True):
        (alone,) = evaluate("hodosmc", [c], robots)
        for key in alone:
            a, b = np.asarray(alone[key]), np.asarray(got[key])
            same = np.array_equal(a, b, equal_nan=True) if a.dtype.kind == "f" else (a == b).all()
            assert same, key
    assert not np.array_equal(together[0]["rms_theta"], together[1]["rms_theta"])


def test_settings_file_round_trip():
    text = settings_text("hodosmc", {"K": (7.5, 3.25), "phi": 0.04}, "made by a test")
    assert text.startswith("# made by a test\n")
    import tomllib

    assert tomllib.loads(text) == {"controller": {"name": "hodosmc"},
                                   "settings": {"K": [7.5, 3.25], "phi": 0.04}}  # fmt: skip


# ---- the command line ---------------------------------------------------------------------
def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT / "src"))


def _trials(db: Path) -> list[tuple]:
    """(number, state, value, params) of every trial, read straight from the SQLite file."""
    con = sqlite3.connect(db)
    try:
        rows = con.execute("SELECT trial_id, number, state FROM trials ORDER BY number").fetchall()
        out = []
        for tid, number, state in rows:
            vals = con.execute("SELECT value FROM trial_values WHERE trial_id = ?",
                               (tid,)).fetchall()  # fmt: skip
            params = con.execute("SELECT param_name, param_value FROM trial_params WHERE "
                                 "trial_id = ? ORDER BY param_name", (tid,)).fetchall()  # fmt: skip
            out.append((number, state, tuple(v for (v,) in vals), tuple(params)))
        return out
    finally:
        con.close()


#: Runs ``mwip tune ARGS`` and sends itself SIGKILL inside its 9th robot-chunk evaluation
#: (trial 4 or so, mid-trial: its parameters drawn, its result not yet told): a kill -9 at a
#: known point instead of a race against a clock.
KILLER = """
import os, signal, sys
import mwip.tune.run as run
calls = [0]
real = run.evaluate
def evaluate(*args, **kw):
    calls[0] += 1
    if calls[0] == 9:
        os.kill(os.getpid(), signal.SIGKILL)
    return real(*args, **kw)
run.evaluate = evaluate
from mwip.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_kill_9_then_rerun_continues_without_losing_or_repeating_a_trial(tmp_path):
    obj = tmp_path / "tiny.toml"
    obj.write_text(TINY)
    out = tmp_path / "run"
    args = ["tune", "hodosmc", "--out", str(out), "--objective", str(obj), "--trials", "20",
            "--seed", "1"]  # fmt: skip
    cmd = [sys.executable, "-m", "mwip", *args]
    db = out / "study.db"
    killed = subprocess.run([sys.executable, "-c", KILLER, *args], env=_env(),
                            capture_output=True, text=True, timeout=600)  # fmt: skip
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    before = _trials(db)
    done_before = [t for t in before if t[1] in ("COMPLETE", "PRUNED")]
    running = [t for t in before if t[1] == "RUNNING"]
    assert len(done_before) >= 3 and len(running) == 1 and running[0][3]  # params drawn
    assert not (out / "best.toml").exists()

    res = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert f"continuing the study at {len(done_before)} of 20" in res.stderr
    after = _trials(db)
    done_after = [t for t in after if t[1] in ("COMPLETE", "PRUNED")]
    assert len(done_after) == 20  # the count continued to the target, not 20 more
    by_number = {t[0]: t for t in after}
    for t in done_before:  # nothing finished before the kill changed
        assert by_number[t[0]] == t
    assert not [t for t in after if t[1] in ("RUNNING", "WAITING")]
    failed = [t for t in after if t[1] == "FAIL"]
    assert [t[0] for t in failed] == [running[0][0]]  # only the killed trial failed ...
    again = [u for u in done_after if u[3] == running[0][3]]
    assert len(again) == 1 and again[0][0] > running[0][0]  # ... and ran again, once
    import json

    summary = json.loads((out / "tune.json").read_text())["summary"]
    assert summary["trials_run_now"] == 20 - len(done_before)
    best = (out / "best.toml").read_text()
    res2 = subprocess.run(cmd, env=_env(), capture_output=True, text=True, timeout=600)
    assert res2.returncode == 0 and "nothing to run" in res2.stderr
    assert _trials(db) == after and (out / "best.toml").read_text() == best


def test_tune_writes_a_settings_file_that_simulate_reads(tmp_path, capsys):
    obj = tmp_path / "tiny.toml"
    obj.write_text(TINY)
    out = tmp_path / "run"
    assert main(["tune", "hodosmc", "--out", str(out), "--objective", str(obj),
                 "--trials", "3", "--sampler", "cmaes"]) == 0  # fmt: skip
    for f in ("best.toml", "index.html", "history.png", "trials.csv", "validation.json"):
        assert (out / f).is_file()
    name, settings = load_settings(out / "best.toml")
    assert name == "hodosmc" and set(settings) == {"K", "phi"}
    capsys.readouterr()
    assert main(["simulate", "--settings", str(out / "best.toml"), "--duration", "0.5",
                 "--json"]) in (0, 1)  # fmt: skip
    import json

    shown = json.loads(capsys.readouterr().out)
    assert shown["controller"] == "hodosmc"
    assert tuple(shown["settings"]["K"]) == tuple(settings["K"])
    assert main(["simulate", "--controller", "smc", "--settings", str(out / "best.toml")]) == 2
    assert "--settings" in capsys.readouterr().err
    # the C export takes such a file (here one with other gains than the book's)
    mine = tmp_path / "mine.toml"
    mine.write_text(settings_text("hodosmc", {"K": (7.5, 3.25)}))
    assert main(["export", "c", "--controller", "hodosmc", "--settings", str(mine),
                 "--out", str(tmp_path / "c_tuned")]) == 0  # fmt: skip
    assert main(["export", "c", "--controller", "hodosmc", "--out", str(tmp_path / "c_book")]) == 0
    tuned_c = (tmp_path / "c_tuned" / "mwip_hodosmc.c").read_text()
    book_c = (tmp_path / "c_book" / "mwip_hodosmc.c").read_text()
    assert tuned_c != book_c and "7.5" in tuned_c and "7.5" not in book_c
    assert main(["export", "c", "--controller", "smc", "--settings", str(out / "best.toml"),
                 "--out", str(tmp_path / "c_bad")]) == 2  # fmt: skip
    assert not (tmp_path / "c_bad").exists()


def test_a_pareto_objective_gives_a_front_and_its_least_failing_member(tmp_path, capsys):
    import json

    obj = tmp_path / "front.toml"
    obj.write_text(TINY.replace('title = "tiny"', 'title = "tiny"\nmode = "pareto"')
                   + '[[objective.terms]]\nmetric = "control_tv"\n')  # fmt: skip
    out = tmp_path / "front"
    assert main(["tune", "hodosmc", "--out", str(out), "--objective", str(obj),
                 "--trials", "6"]) == 0  # fmt: skip
    assert (out / "pareto.png").is_file()
    summary = json.loads((out / "tune.json").read_text())["summary"]
    assert summary["sampler"] == "nsga2" and len(summary["best_values"]) == 3
    import optuna

    study = optuna.load_study(study_name=summary["study"], storage=summary["storage"])
    front = study.best_trials
    assert summary["best_trial"] in [t.number for t in front]
    assert summary["best_values"][0] == min(t.values[0] for t in front)


def test_the_command_is_reproducible_for_a_seed(tmp_path):
    """TPE past its 10 random start-up trials: two runs with one seed write the same trials,
    best settings and validation; another seed draws other trials."""
    obj = tmp_path / "tiny.toml"
    obj.write_text(TINY)
    for name, seed in (("a", "4"), ("b", "4"), ("c", "5")):
        assert main(["tune", "hodosmc", "--out", str(tmp_path / name), "--objective", str(obj),
                     "--trials", "12", "--seed", seed]) == 0  # fmt: skip
    for f in ("trials.csv", "best.toml", "validation.json"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    assert (tmp_path / "a" / "trials.csv").read_bytes() != (
        tmp_path / "c" / "trials.csv"
    ).read_bytes()


def test_processes_with_one_storage_share_one_study(tmp_path, capsys):
    """Two runs (two output folders) on one --storage URL work on the same study: the second
    continues the trial count of the first."""
    import json

    obj = tmp_path / "tiny.toml"
    obj.write_text(TINY)
    url = f"sqlite:///{tmp_path / 'shared.db'}"
    common = ["tune", "hodosmc", "--objective", str(obj), "--storage", url]
    assert main([*common, "--out", str(tmp_path / "a"), "--trials", "3"]) == 0
    assert main([*common, "--out", str(tmp_path / "b"), "--trials", "5"]) == 0
    assert "continuing the study at 3 of 5" in capsys.readouterr().err
    a = json.loads((tmp_path / "a" / "tune.json").read_text())["summary"]
    b = json.loads((tmp_path / "b" / "tune.json").read_text())["summary"]
    assert a["study"] == b["study"] and b["trials_finished"] == 5 and b["trials_run_now"] == 2
    assert not (tmp_path / "a" / "study.db").exists()


def _bad(tmp_path: Path, capsys, args: list[str]) -> str:
    out = tmp_path / "out"
    code = main(["tune", *args, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and err.startswith("mwip: error:"), err
    assert not out.exists()
    return err


def test_bad_input_exits_2_in_one_line_and_writes_nothing(tmp_path, capsys):
    good = tmp_path / "tiny.toml"
    good.write_text(TINY)
    assert "unknown controller 'nope'" in _bad(tmp_path, capsys, ["nope"])
    key = tmp_path / "key.toml"
    key.write_text(TINY.replace('title = "tiny"', 'title = "tiny"\nspeed = 1'))
    assert "objective.speed: unknown key" in _bad(tmp_path, capsys, ["hodosmc", "--objective",
                                                                     str(key)])  # fmt: skip
    metric = tmp_path / "metric.toml"
    metric.write_text(TINY.replace('metric = "rms_theta"', 'metric = "rms_pitch"'))
    assert "unknown metric 'rms_pitch'" in _bad(tmp_path, capsys, ["hodosmc", "--objective",
                                                                   str(metric)])  # fmt: skip
    wide = tmp_path / "wide.toml"
    wide.write_text(TINY + "[space.ranges]\nK = { lo = [-1.0, 1.0], hi = [20.0, 20.0] }\n")
    assert "outside controller 'hodosmc'" in _bad(tmp_path, capsys, ["hodosmc", "--objective",
                                                                      str(wide)])  # fmt: skip
    assert "--trials" in _bad(tmp_path, capsys, ["hodosmc", "--objective", str(good),
                                                 "--trials", "0"])  # fmt: skip
    url = f"sqlite:///{tmp_path / 'no' / 'such' / 'folder' / 'study.db'}"
    assert "--storage" in _bad(tmp_path, capsys, ["hodosmc", "--objective", str(good),
                                                  "--storage", url])  # fmt: skip
    assert "--storage" in _bad(tmp_path, capsys, ["hodosmc", "--objective", str(good),
                                                  "--storage", "nosuchdb://host/x"])  # fmt: skip
    assert "neither a built-in objective" in _bad(tmp_path, capsys, ["hodosmc", "--objective",
                                                                     "nosuch"])  # fmt: skip
    assert "pareto" in _bad(tmp_path, capsys, ["hodosmc", "--objective", "pareto",
                                               "--sampler", "cmaes"])  # fmt: skip


def test_without_optuna_the_command_says_so_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "optuna", None)  # import optuna raises ImportError
    err = _bad(tmp_path, capsys, ["hodosmc"])
    assert "pip install 'mwip[tune]'" in err
