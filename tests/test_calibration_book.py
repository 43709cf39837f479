"""The book calibration end to end, on a few short prior draws: deterministic, resumable, the
studies' own runs, the CLI (`mwip twin calibrate book --record`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from mwip.calibration.book import calibrate_book
from mwip.calibration.chains import ChainPlan
from mwip.calibration.mixture import EnvelopePlan, MixturePlan
from mwip.calibration.runs import RUNS, run_batch
from mwip.hardware.twin import Twin

SMALL = {"samples": 4, "block": 2, "duration": 0.6, "jobs": 1, "progress": None,
         "proposal_draws": 3, "chains": ChainPlan(chains=4, steps=8, burn=2, seed=1),
         "mixture": MixturePlan(draws=5, seed=1, factors=(0.5, 1.0), effective=2.0),
         "envelope": EnvelopePlan(draws=3, seed=2)}


def test_one_draw_at_the_default_values_is_the_studys_run():
    from mwip.studies import exp_hodosmc
    from mwip.studies.twin_settings import study_settings

    tw = Twin()
    values = {k: np.array([v]) for k, v in tw.values().items()}
    run = RUNS[0]
    assert run.name == "exp-hodosmc-balance/smc.case1"
    cols = run_batch(values, runs=(run,), duration=1.0)
    cfg = dict(study_settings(run.study, None, tw)[0])
    single = exp_hodosmc.run_one("smc", 1, 0.0, cfg, duration=1.0, twin=tw)
    assert cols[f"{run.name}.t_end"][0] == pytest.approx(float(single.t_end[0]), abs=1e-12)
    assert cols[f"{run.name}.stands"][0] == float(single.status[0] == "ok")


def test_deterministic_and_resumable(tmp_path: Path):
    a = calibrate_book(tmp_path / "a", **SMALL)
    calibrate_book(tmp_path / "b", **SMALL)
    da = json.loads((tmp_path / "a" / "posterior.json").read_text())
    db = json.loads((tmp_path / "b" / "posterior.json").read_text())
    assert da == db and a.doc["posterior"]["n_prior"] == 4 + 3 + 5 + 3 and a.doc["samples"] == 4
    table = pd.read_parquet(tmp_path / "a" / "prior-draws" / "results.parquet")
    assert list(table["sample"]) == [0, 1, 2, 3]
    # resume: lose a chunk and the assembled table, run again -> the same table
    chunks = sorted((tmp_path / "b" / "prior-draws" / "chunks").iterdir())
    chunks[-1].unlink()
    (tmp_path / "b" / "prior-draws" / "results.parquet").unlink()
    gens = sorted((tmp_path / "b" / "chains").glob("gen-*.parquet"))
    assert len(gens) == 8
    gens[-1].unlink()
    calibrate_book(tmp_path / "b", **SMALL)
    again = pd.read_parquet(tmp_path / "b" / "prior-draws" / "results.parquet")
    pd.testing.assert_frame_equal(table, again)
    assert json.loads((tmp_path / "b" / "posterior.json").read_text()) == da
    mix = sorted((tmp_path / "b" / "mixture").glob("block-*.parquet"))
    env = sorted((tmp_path / "b" / "envelope").glob("block-*.parquet"))
    assert len(mix) == 1 and len(env) == 1
    mix[0].unlink()
    env[0].unlink()
    calibrate_book(tmp_path / "b", **SMALL)
    assert json.loads((tmp_path / "b" / "posterior.json").read_text()) == da
    # stage 4 is the posterior of record: the pool of stages 1, 2 and 4 conditioned on the
    # largest consistent subset over every twin stages 1-3 evaluated; stage 3 is a record
    p = da["posterior"]
    s4, s3 = p["sampler"], p["stage3"]
    assert s4["kind"] == "mixture" and s4["draws"] == 5 and p["n_prior"] == 4 + 3 + 5 + 3
    env = s4["envelope"]
    assert env["draws"] == 3 and all(lo <= hi for lo, hi in zip(env["low"], env["high"],
                                                                  strict=True))  # fmt: skip
    assert 0 < env["fraction_of_prior"] <= 1
    assert s4["evaluated_before"] == 4 + 3 + s3["evaluations"] and s4["seeds"] >= 1
    assert s3["kept"] == 6 and s4["components"] == 2 * s4["seeds"]
    assert sum(s4["hits"].values()) == p["size"] and 0 < p["effective_size"] <= p["size"]
    assert s4["precise"] == (p["effective_size"] >= 2.0)
    assert abs(sum(s4["weight_share"].values()) - 1.0) < 1e-9
    assert len(da["members"]) == 256 and all(set(m) == set(da["prior"]["names"])
                                             for m in da["members"])  # fmt: skip
    assert all(c["effective_n"] >= 1 for c in da["claims"])
    for name in ("posterior.md", "marginals.png"):
        assert (tmp_path / "a" / name).stat().st_size > 0
    doc = da
    assert set(doc["claim_counts"]) == {"holds", "fails", "undecided", "no posterior"}
    assert sum(doc["claim_counts"].values()) == len(doc["claims"])
    # the draws are the prior's: every unknown inside its range
    for name, (lo, hi) in zip(doc["prior"]["names"], doc["prior"]["bounds"], strict=True):
        x = table[f"param.{name}"].to_numpy()
        assert np.all((x >= lo) & (x <= hi))


def test_the_envelope_extension_extends_the_same_sample(tmp_path: Path):
    """Revision 5: stage 5 going on past its declared draws (here until its maximum: the
    effective size asked for is out of reach) draws what a larger declared stage 5 would."""
    whole = calibrate_book(tmp_path / "w", **{**SMALL, "envelope": EnvelopePlan(6, 2)}).doc
    ext = calibrate_book(tmp_path / "e", **{**SMALL, "envelope": EnvelopePlan(
        2, 2, max_draws=6, effective=1e9)}).doc  # fmt: skip
    a = pd.read_parquet(tmp_path / "w" / "envelope" / "block-000.parquet")
    b = pd.concat([pd.read_parquet(tmp_path / "e" / "envelope" / "block-000.parquet"),
                   pd.read_parquet(tmp_path / "e" / "envelope" / "extension" /
                                   "block-000.parquet")], ignore_index=True)  # fmt: skip
    pd.testing.assert_frame_equal(a, b)
    env = ext["posterior"]["sampler"]["envelope"]
    assert env["draws"] == 6 and env["declared"] == 2 and len(env["ess_by_block"]) == 1
    assert ext["posterior"]["effective_size"] == pytest.approx(env["ess_by_block"][-1])
    assert ext["posterior"]["effective_size"] == whole["posterior"]["effective_size"]
    assert ext["claims"] == whole["claims"] and ext["map_values"] == whole["map_values"]


def test_chains_alone_sample_the_posterior_of_stages_1_2(tmp_path: Path):
    """Without stage 4 (revision 2's record): the chains sample the posterior stages 1-2
    conditioned, the same facts, every member meets them, intervals at their ESS."""
    d = calibrate_book(tmp_path / "c", **{**SMALL, "mixture": None}).doc
    p = d["posterior"]
    s3, s12 = p["sampler"], p["stage12"]
    assert p["used"] == s12["used"] and p["size"] == 4 * 6 and s3["kept"] == 6
    assert 0 < p["effective_size"] == s3["ess_min"] <= 4 * 6 * np.log10(24)
    assert len(d["members"]) == 4 * 4


def test_cli_evidence_book(tmp_path: Path):
    from mwip.cli import cli

    out = tmp_path / "cal"
    r = CliRunner().invoke(cli, ["twin", "calibrate", "book", "--record", "--out", str(out),
                                 "--samples", "2", "--duration", "0.4", "--stage2-draws", "1",
                                 "--chain-steps", "0", "--mixture-draws", "2",
                                 "--envelope-draws", "1"])
    assert r.exit_code == 0, r.output
    assert "twins evaluated 6 " in r.output and (out / "posterior.json").is_file()
    assert "stage 4: 2 mixture draws" in r.output and "stage 5: 1 envelope draws" in r.output
    r = CliRunner().invoke(cli, ["twin", "calibrate", "book", "--record", "--out",
                                 str(tmp_path / "x"), "--structures", "S0"])
    assert r.exit_code == 2 and not (tmp_path / "x").exists()
    r = CliRunner().invoke(cli, ["twin", "fit", "--evidence", "book", "--out",
                                 str(tmp_path / "z")])  # gone: one line naming its successor
    assert r.exit_code == 2 and "mwip twin calibrate book --record" in r.output
    assert not (tmp_path / "z").exists()
    r = CliRunner().invoke(cli, ["twin", "fit", "--out", str(tmp_path / "y")])
    assert r.exit_code == 2 and not (tmp_path / "y").exists()
