"""Campaigns: file validation, per-sample sampling, metrics against direct runs, chunk/job/
scheduler invariance (bit-identical tables), resuming after an interruption or kill -9."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import tomllib

import numpy as np
import pandas as pd
import pytest

from mwip.campaign.blocks import build_controllers, run_block
from mwip.campaign.execute import done_blocks, run_campaign
from mwip.campaign.sampling import draw
from mwip.campaign.spec import builtin_names, builtin_text, load_campaign, parse_campaign
from mwip.campaign.stats import wilson
from mwip.cli import main
from mwip.params import book_params

SMALL = """
[campaign]
samples = 10
seed = 7
duration = 0.6
block = 4
sensors = "twin"
[[controllers]]
name = "hodosmc"
[[controllers]]
name = "dlqr"
[robot.uncertainty]
mb = { uniform = 0.2 }
l = { normal = 0.1 }
r = { values = [0.04, 0.042] }
[initial]
theta = { uniform = [-0.3, 0.3] }
theta_dot = { uniform = [-0.5, 0.5] }
[[disturbances]]
kind = "none"
[[disturbances]]
kind = "book"
"""


def camp(text: str = SMALL):
    return parse_campaign(tomllib.loads(text))


def quiet(*_a: object) -> None:
    return None


# ---- the campaign file ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (("seed = 7", "seed = 7\nspeed = 3"), "campaign.speed"),
        (("mb = { uniform = 0.2 }", "mass = { uniform = 0.2 }"), "robot.uncertainty.mass"),
        (("mb = { uniform = 0.2 }", "mb = { uniform = 1.2 }"), "robot.uncertainty.mb"),
        (("l = { normal = 0.1 }", "l = { normal = 0.34 }"), "robot.uncertainty.l"),
        (("r = { values = [0.04, 0.042] }", "r = { values = [0.04, -1] }"), "robot.uncertainty.r"),
        (("samples = 10", "samples = 0"), "campaign.samples"),
        (('name = "dlqr"', 'name = "dlqr"\nsettings = { R_diag = [0, 1] }'), "controllers[1]"),
        (('name = "dlqr"', 'name = "nope"'), "controllers[1].name"),
        (("theta_dot = {", "omega = {"), "initial.omega"),
        (('kind = "book"', 'kind = "storm"'), "disturbances[1]"),
    ],
)
def test_bad_campaign_file_exit_2_one_line_naming_field(tmp_path, capsys, edit, field):
    text = SMALL.replace(*edit)
    assert text != SMALL
    path = tmp_path / "c.toml"
    path.write_text(text)
    code = main(["campaign", "run", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and field in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_zero_samples_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    assert main(["campaign", "run", str(path), "--out", str(tmp_path / "o"), "--samples", "0"]) == 2
    assert "--samples" in capsys.readouterr().err


def test_builtin_campaigns_parse_and_show(capsys):
    assert {"robustness", "roa", "claims"} <= set(builtin_names())
    for name in builtin_names():
        load_campaign(name)
    assert main(["campaign", "show", "roa"]) == 0
    assert capsys.readouterr().out == builtin_text("roa")
    roa = load_campaign("roa")
    assert roa.samples == roa.grid_size == 31 * 31


# ---- sampling ---------------------------------------------------------------------------------
def test_sample_depends_on_seed_and_index_alone():
    c = camp()
    whole = draw(c, np.arange(40))
    for i in (0, 13, 39):
        one = draw(c, np.array([i]))
        for k, v in one.items():
            assert v[0] == whole[k][i], k
    other = draw(camp(SMALL.replace("seed = 7", "seed = 8")), np.arange(40))
    assert not np.array_equal(other["mb"], whole["mb"])


def test_distributions_stay_in_their_supports():
    c = camp()
    d = draw(c, np.arange(2000))
    real = book_params("real")
    assert np.all(np.abs(d["mb"] / real.mb - 1) <= 0.2)
    assert np.abs(d["mb"] / real.mb - 1).max() > 0.19  # the range is used
    dev = d["l"] / real.l - 1
    assert np.all(np.abs(dev) <= 0.3 + 1e-12)
    # a standard normal cut at +-3 has sd sqrt(1 - 6 phi(3) / (2 Phi(3) - 1)) = 0.98658;
    # 2000 draws: standard errors 0.0022 (mean) and 0.0016 (sd); 4 of them allowed
    assert abs(dev.mean()) < 4 * 0.0022
    assert abs(dev.std() - 0.098658) < 4 * 0.0016
    assert set(np.unique(d["r"])) == {0.04, 0.042}
    assert set(np.unique(d["disturbance"])) == {"none", "book"}
    assert np.all(np.abs(d["theta0"]) <= 0.3) and np.all(d["alpha0"] == 0)


def test_grid_axes_enumerate_the_grid_once():
    c = load_campaign("roa")
    d = draw(c, np.arange(c.grid_size))
    pairs = set(zip(d["theta0"].round(12), d["theta_dot0"].round(12), strict=True))
    assert len(pairs) == 31 * 31
    assert d["theta0"].min() == -1.2 and d["theta_dot0"].max() == 6.0


# ---- metrics against direct runs ------------------------------------------------------------
def test_block_rows_match_single_runs_of_the_same_inputs():
    """A block's row i is sample i's robot, initial state and disturbance: rerunning that
    sample alone with ``simulate`` gives the same metrics (ideal sensors; the batch differs from
    a single run only by rounding)."""
    from dataclasses import replace

    from mwip.laws.registry import build
    from mwip.metrics import rms, settling_time
    from mwip.sim.disturbance import BOOK_SINUSOIDS
    from mwip.sim.engine import simulate

    c = camp(SMALL.replace('sensors = "twin"', 'sensors = "ideal"').replace("0.6", "2.0"))
    rows = run_block(c, 0, build_controllers(c))
    for cols in rows:
        label = cols["controller"][0]
        for i in range(4):
            p = replace(book_params("real"), mb=cols["mb"][i], l=cols["l"][i], r=cols["r"][i])
            dist = BOOK_SINUSOIDS if cols["disturbance"][i] == "book" else None
            q0, qd0 = (0, cols["theta0"][i], 0), (0, cols["theta_dot0"][i], 0)
            res = simulate(build(label), p, q0=q0, qdot0=qd0, duration=2.0, disturbance=dist)
            assert cols["status"][i] == res.status[0]
            if res.status[0] != "ok":
                np.testing.assert_allclose(cols["fall_time"][i], res.t_end[0], rtol=1e-9)
                continue
            np.testing.assert_allclose(cols["rms_theta"][i], rms(res.t, res.theta), rtol=1e-7)
            v = p.r * res.q_dot[:, 0]
            np.testing.assert_allclose(cols["rms_speed_error"][i], rms(res.t, v), rtol=1e-7)
            np.testing.assert_allclose(cols["peak_torque"][i], np.abs(res.u).max(), rtol=1e-7)
            wr = res.q_dot[:, 0] + p.b / p.r * res.q_dot[:, 2] - res.q_dot[:, 1]
            wl = res.q_dot[:, 0] - p.b / p.r * res.q_dot[:, 2] - res.q_dot[:, 1]
            work = (np.abs(res.u[:-1, 0] * wr[:-1]) + np.abs(res.u[:-1, 1] * wl[:-1])).sum()
            np.testing.assert_allclose(cols["energy"][i], work * 0.005, rtol=1e-7)
            tv = np.abs(np.diff(res.u, axis=0)).sum() / 2.0
            np.testing.assert_allclose(cols["control_tv"][i], tv, rtol=1e-7)
            last = res.theta[res.t >= 2.0 - 1.0 - 1e-9]
            assert cols["success"][i] == bool(np.abs(last).max() < c.success_theta)
            st = settling_time(res.t, res.theta)
            assert (np.isnan(st) and np.isnan(cols["settling_time"][i])) or abs(
                st - cols["settling_time"][i]
            ) < 1e-9


def test_common_random_numbers_across_controllers():
    c = camp()
    a, b = run_block(c, 1, build_controllers(c))
    for k in ("sample", "mb", "l", "r", "theta0", "theta_dot0", "disturbance", "noise_seed"):
        assert np.array_equal(a[k], b[k]), k
    assert not np.array_equal(a["rms_theta"], b["rms_theta"])


def test_wilson_interval_published_value():
    # Newcombe (1998), Table I, 81/263: 0.2553 - 0.3662
    lo, hi = wilson(81, 263)
    assert (round(lo, 4), round(hi, 4)) == (0.2553, 0.3662)
    lo, hi = wilson(10, 10)
    assert hi == 1.0 and round(lo, 4) == 0.7225


# ---- execution: invariance, resuming ----------------------------------------------------------
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    res = run_campaign(camp(), out, jobs=1, chunk=4, progress=quiet)
    assert res.status == "done" and res.rows == 20
    return pd.read_parquet(out / "results.parquet")


def test_table_layout(reference):
    df = reference
    assert list(df["controller"].unique()) == ["hodosmc", "dlqr"]
    assert df["sample"].tolist() == list(range(10)) * 2
    for col in ("mb", "l", "r", "theta0", "disturbance", "status", "fall_time", "settling_time",
                "rms_theta", "rms_speed_error", "peak_torque", "control_tv", "energy"):  # fmt: skip
        assert col in df
    assert df["sample"].dtype == np.int64 and df["success"].dtype == bool


def test_chunk_size_does_not_change_the_table(tmp_path, reference):
    run_campaign(camp(), tmp_path, jobs=1, chunk=12, progress=quiet)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip
    assert len(list((tmp_path / "chunks").iterdir())) == 1


def test_interrupt_then_resume_is_identical(tmp_path, reference, capsys):
    calls = []

    def stop_after_first(done: int, total: int, elapsed: float) -> None:
        calls.append(done)
        raise KeyboardInterrupt

    res = run_campaign(camp(), tmp_path, jobs=1, chunk=4, progress=stop_after_first)
    assert res.status == "interrupted" and done_blocks(tmp_path) == {0}
    assert not (tmp_path / "results.parquet").exists()
    res = run_campaign(camp(), tmp_path, jobs=1, chunk=8, progress=quiet)
    assert res.status == "done" and res.blocks_run == 2
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    assert main(["campaign", "run", str(path), "--out", str(tmp_path), "--jobs", "1"]) == 0
    assert "nothing to do" in capsys.readouterr().out


def test_other_campaign_in_the_folder_is_refused(tmp_path, reference, capsys):
    run_campaign(camp(), tmp_path, jobs=1, progress=quiet)
    path = tmp_path.parent / "other.toml"
    path.write_text(SMALL.replace("seed = 7", "seed = 9"))
    assert main(["campaign", "run", str(path), "--out", str(tmp_path), "--jobs", "1"]) == 2
    assert "different campaign" in capsys.readouterr().err


def test_more_samples_extend_the_same_table(tmp_path, reference):
    run_campaign(camp().with_samples(6), tmp_path, jobs=1, progress=quiet)
    res = run_campaign(camp(), tmp_path, jobs=1, progress=quiet)
    assert res.blocks_run == 1  # blocks 0 and 1 (samples 0-7) were done by the first run
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip


@pytest.mark.slow
def test_kill_9_then_rerun_is_identical(tmp_path, reference):
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mwip", "campaign", "run", str(path), "--out", str(out),
           "--jobs", "1", "--chunk", "4"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 240
    while not done_blocks(out) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    if len(done_blocks(out)) == 3:  # every chunk was saved before the kill landed
        pytest.skip("the run finished its chunks before SIGKILL")
    assert done_blocks(out) and not (out / "results.parquet").exists()
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip


@pytest.mark.slow
def test_jobs_and_scheduler_do_not_change_the_table(tmp_path, reference):
    from dask.distributed import LocalCluster

    run_campaign(camp(), tmp_path / "jobs2", jobs=2, chunk=4, progress=quiet)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "jobs2" / "results.parquet"),
                                  reference, check_exact=True)  # fmt: skip

    def stop(*_a: object) -> None:
        raise KeyboardInterrupt

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:  # fmt: skip
        first = run_campaign(camp(), tmp_path / "sched", scheduler=cluster.scheduler_address,
                             chunk=4, progress=stop)  # fmt: skip
        assert first.status == "interrupted"  # Ctrl-C on Dask: the chunk done is kept
        assert 1 <= len(done_blocks(tmp_path / "sched")) < 3
        res = run_campaign(camp(), tmp_path / "sched", scheduler=cluster.scheduler_address,
                           chunk=8, progress=quiet)  # fmt: skip
    assert res.status == "done"
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "sched" / "results.parquet"),
                                  reference, check_exact=True)  # fmt: skip
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    bad = ["campaign", "run", str(path), "--out", str(tmp_path / "x"), "--scheduler",
           "tcp://127.0.0.1:9"]  # fmt: skip
    assert main(bad) == 2
    assert not (tmp_path / "x").exists()


def test_report(tmp_path, reference):
    from mwip.campaign.report import league_table

    run_campaign(camp(), tmp_path, jobs=1, progress=quiet)
    assert main(["campaign", "report", str(tmp_path)]) == 0
    page = (tmp_path / "report.html").read_text()
    for png in ("fig-league.png", "fig-success-mb.png", "fig-roa-theta0-theta_dot0.png",
                "fig-roa-mb-l.png"):  # fmt: skip
        assert (tmp_path / png).stat().st_size > 5000 and png in page
    for row in league_table(reference):
        g = reference[reference["controller"] == row["controller"]]
        assert row["rate"] == g["success"].mean()
        assert (row["lo"], row["hi"]) == wilson(int(g["success"].sum()), len(g))


# ---- claims over open settings --------------------------------------------------------------
SYNTHETIC = """
[settings]
gain = 1.0
seeds = [1, 2]
[open]
gain = { range = [0.0, 2.0], why = "test: not printed" }
seeds = { range = [0, 9], why = "test: any seed" }
"""


@pytest.fixture
def synthetic_study(monkeypatch):
    """A study 'synthetic' whose file declares open settings and whose claims are decided on
    them: 'gain-above' holds iff gain > 0.5; the second claim (no id) iff seeds[0] is even."""
    from mwip.studies import registry, settings
    from mwip.studies.study import Study

    def run(ctx):
        s = ctx.settings
        return {"claims": [
            {"id": "gain-above", "book": "Sec. 0", "text": "gain above 0.5",
             "holds": s["gain"] > 0.5},
            {"text": "first seed even", "holds": s["seeds"][0] % 2 == 0},
        ]}  # fmt: skip

    real_text = settings.packaged_text
    declared = {**registry._discover(), "synthetic": Study("synthetic", "test", run, place=(0,))}
    monkeypatch.setattr(registry, "_discover", lambda: declared)
    monkeypatch.setattr(
        settings, "packaged_text", lambda n: SYNTHETIC if n == "synthetic" else real_text(n)
    )
    settings._defaults.cache_clear()
    settings._open.cache_clear()
    yield
    settings._defaults.cache_clear()
    settings._open.cache_clear()


CLAIMS = """
[campaign]
kind = "claims"
studies = ["synthetic"]
samples = 30
seed = 5
block = 4
"""


def test_claims_campaign_over_open_settings(tmp_path, synthetic_study):
    import json

    from mwip.campaign.claims import claim_robustness, robustness_text

    c = camp(CLAIMS)
    run_campaign(c, tmp_path / "a", jobs=1, chunk=4, progress=quiet)
    df = pd.read_parquet(tmp_path / "a" / "results.parquet")
    assert set(df["study"]) == {"synthetic"}
    syn = df[df["study"] == "synthetic"]
    assert syn["sample"].nunique() == 30 and (syn["error"] == "").all()
    drawn = [json.loads(s) for s in syn[syn["claim"] == "gain-above"]["settings"]]
    gains = np.array([d["gain"] for d in drawn])
    seeds = np.array([d["seeds"] for d in drawn])
    assert np.all((gains >= 0) & (gains <= 2)) and gains.std() > 0.3
    assert np.all((seeds >= 0) & (seeds <= 9)) and seeds.dtype.kind == "i"
    table = claim_robustness(df)
    r = table[("synthetic", "gain-above")]
    assert r.book == "Sec. 0" and r.n == 30 and r.k == int((gains > 0.5).sum())
    assert (r.lo, r.hi) == wilson(r.k, 30)
    fallback = table[("synthetic", "first seed even")]  # no id: the text is the id
    assert fallback.k == int((seeds[:, 0] % 2 == 0).sum())
    text = robustness_text(table, "synthetic", {"id": "gain-above", "text": "gain above 0.5"})
    assert text == (f"holds in {100 * r.k / 30:.0f} % of plausible settings (95 % interval "
                    f"{100 * r.lo:.0f}-{100 * r.hi:.0f} %, n = 30)")  # fmt: skip
    assert robustness_text(table, "synthetic", {"id": "unknown"}) == ""
    run_campaign(c, tmp_path / "b", jobs=1, chunk=40, progress=quiet)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "b" / "results.parquet"), df,
                                  check_exact=True)  # fmt: skip
    assert main(["campaign", "report", str(tmp_path / "a")]) == 0
    assert "gain-above" in (tmp_path / "a" / "report.html").read_text()


def test_claims_campaign_without_open_settings_is_refused(tmp_path, capsys, monkeypatch):
    from mwip.campaign import claims

    monkeypatch.setattr(claims, "claim_studies", lambda c: [])
    path = tmp_path / "c.toml"
    path.write_text(CLAIMS.replace('"synthetic"', '"lqr-gain"'))
    assert main(["campaign", "run", str(path), "--out", str(tmp_path / "o"), "--jobs", "1"]) == 2
    assert "open settings" in capsys.readouterr().err


@pytest.mark.slow
def test_worker_killed_mid_chunk_loses_only_that_chunk(tmp_path, reference):
    """SIGKILL the Dask worker process that is running a chunk: Dask reruns that chunk on a
    (restarted) worker and the table is still complete and identical."""
    import threading

    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:  # fmt: skip
        pids = client.run(os.getpid)
        result = {}

        def go() -> None:
            result["res"] = run_campaign(camp(), tmp_path, scheduler=cluster.scheduler_address,
                                         chunk=4, progress=quiet)  # fmt: skip

        th = threading.Thread(target=go)
        th.start()
        killed = None
        deadline = time.time() + 240
        while killed is None and time.time() < deadline and th.is_alive():
            for addr, keys in client.processing().items():
                if any(str(k).startswith("mwip-campaign") for k in keys) and addr in pids:
                    if not done_blocks(tmp_path):  # mid-chunk: nothing saved yet
                        os.kill(pids[addr], signal.SIGKILL)
                        killed = addr
                    break
            time.sleep(0.02)
        th.join(timeout=600)
    assert killed is not None, "no chunk was seen running"
    assert result["res"].status == "done"
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip


GRID = """
[campaign]
samples = 12
seed = 1
duration = 1.0
block = 6
sensors = "ideal"
drive = "ideal"
success_theta = 0.5
[[controllers]]
name = "dlqr"
[robot.uncertainty]
Iby = { grid = [0.001, 0.003, 3] }
[initial]
theta = { grid = [-1.4, 1.4, 4] }
"""


def test_grid_campaign_report_plane(tmp_path):
    from mwip.campaign.report import plane_rates

    run_campaign(camp(GRID), tmp_path, jobs=1, progress=quiet)
    df = pd.read_parquet(tmp_path / "results.parquet")
    assert len(set(zip(df["Iby"], df["theta0"], strict=True))) == 12
    cx, cy, maps = plane_rates(df, "Iby", "theta0")
    assert list(cx) == [0.001, 0.002, 0.003] and list(cy) == list(np.linspace(-1.4, 1.4, 4))
    pivot = df.pivot(index="theta0", columns="Iby", values="success").to_numpy(dtype=float)
    np.testing.assert_array_equal(maps["dlqr"], pivot)
    assert 0 < df["success"].sum() < 12  # +-1.4 rad is lost, +-0.47 rad is not
    assert main(["campaign", "report", str(tmp_path)]) == 0
    assert (tmp_path / "fig-roa-Iby-theta0.png").exists()


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_and_resumes(tmp_path, reference):
    """SIGINT (Ctrl-C) after the first chunk: exit 130 with a one-line note, the chunks done
    are kept, no results.parquet; the same command then finishes with the same table."""
    path = tmp_path / "c.toml"
    path.write_text(SMALL)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mwip", "campaign", "run", str(path), "--out", str(out),
           "--jobs", "1", "--chunk", "4"]  # fmt: skip

    def default_sigint() -> None:  # a shell's background jobs start with SIGINT ignored
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_sigint)  # fmt: skip
    deadline = time.time() + 240
    while not done_blocks(out) and time.time() < deadline and proc.poll() is None:
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:  # finished before the signal arrived: nothing to check
        pytest.skip(f"the campaign finished before SIGINT: {err[-300:]}")
    assert proc.returncode == 130
    assert "interrupted" in err and "Traceback" not in err
    assert done_blocks(out) and not (out / "results.parquet").exists()
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference,
                                  check_exact=True)  # fmt: skip
