"""Revision 6 of the book calibration: the declared structures (book-structures.toml), their
draws, and ``mwip twin calibrate`` (deterministic, resumable, replayed byte for byte)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mwip.calibration.structure import BOOK_PRIOR
from mwip.calibration.structures import load_directed, load_plan, load_structures

KALMAN = ("firmware.fusion.q_angle", "firmware.fusion.q_bias", "firmware.fusion.r_angle")


def test_the_declared_structures_are_what_spec_names() -> None:
    """S0 = revisions 1-5's unknowns; S1 = S0 + the torque gain; S2 = S1 + gyro zeroing;
    S3 = S1 + Kalman fusion with its tuning unknown (SPEC.md "Twin structure"); the payload's
    prior is both of the book's sentences in every one."""
    ss = load_structures()
    assert list(ss) == ["S0", "S1", "S2", "S3"]
    s0, s1, s2, s3 = ss.values()
    assert s0.prior.names == BOOK_PRIOR.names
    assert s0.twin.firmware.torque_gain == 1.0 and not s0.twin.firmware.gyro_zeroing
    assert s1.prior.names == BOOK_PRIOR.names + ("firmware.torque_gain",)
    assert s1.prior["firmware.torque_gain"].scale == "log"
    assert s2.prior.names == s1.prior.names and s2.twin.firmware.gyro_zeroing
    assert not s1.twin.firmware.gyro_zeroing and not s3.twin.firmware.gyro_zeroing
    assert s3.twin.firmware.fusion.kind == "kalman"
    assert "firmware.fusion.tau" not in s3.prior.names
    assert all(s3.prior[n].scale == "log" for n in KALMAN)
    assert all(s3.prior[n].element == "fusion" for n in KALMAN)  # the twin element they tune
    for s in ss.values():
        u = s.prior["payload.height"]
        assert (u.low, u.high) == (0.08, 0.10)
        assert "rods of 0.1 m" in u.source and "10 cm" in u.source
        # every other unknown is the declared prior's own
        for unk in s.prior.unknowns:
            if unk.name in BOOK_PRIOR.names and unk.name != "payload.height":
                assert unk == BOOK_PRIOR[unk.name]
    plan = load_plan()
    assert plan.prior_draws > 0 and plan.kernel_draws >= 0 and plan.block > 0


def test_unit_coordinates_invert_and_are_log_uniform_where_declared() -> None:
    s1 = load_structures()["S1"]
    rng = np.random.default_rng(1)
    u = rng.random((50, len(s1.prior)))
    x = s1.from_unit(u)
    np.testing.assert_allclose(s1.to_unit(x), u, atol=1e-12)
    j = s1.prior.index("firmware.torque_gain")
    half = np.full((1, len(s1.prior)), 0.5)
    assert s1.from_unit(half)[0, j] == pytest.approx(1.0)  # sqrt(0.25 * 4)
    lo, hi = s1.prior.bounds.T
    assert np.all((x >= lo) & (x <= hi))


def test_each_structure_element_changes_the_runs() -> None:
    """The switches and the Kalman tuning reach the compiled twin: the default robot's twin
    (it stands) as S1, S2 and S3 gives a different final pitch, and so do two Kalman tunings
    on S3."""
    from mwip.calibration.runs import RUNS, run_batch
    from mwip.robot import default_robot

    known = default_robot().twin.values()
    ss = load_structures()
    run = tuple(r for r in RUNS if r.name == "exp-it2/it2.exp1")
    metric = "exp-it2/it2.exp1.final_abs_theta"

    def final(name: str, rows: int = 1, **fixed: list[float]) -> np.ndarray:
        s = ss[name]
        v = {}
        for unk in s.prior.unknowns:
            x = known.get(unk.name, unk.default)
            v[unk.name] = np.full(rows, float(np.clip(x, unk.low, unk.high)))
        for k, xs in fixed.items():
            v[k.replace("__", ".")] = np.asarray(xs, dtype=float)
        c = run_batch(v, twin=s.twin, runs=run, duration=4.0)
        assert np.all(c["exp-it2/it2.exp1.stands"] == 1.0)
        return c[metric]

    s1, s2 = final("S1")[0], final("S2")[0]
    k = final("S3", 2, firmware__fusion__r_angle=[3e-2, 1e-1])
    assert np.all(np.isfinite([s1, s2, *k]))
    assert s1 != s2 and k[0] != k[1] and s1 != k[0]


def _run(out: Path, *extra: str) -> tuple[int, str]:
    from click.testing import CliRunner

    from mwip.cli import cli

    r = CliRunner().invoke(cli, ["twin", "calibrate", "book", "--out", str(out), *extra])
    return r.exit_code, r.output


SMOKE = ("--structures", "S0,S1", "--draws", "6", "--kernel-draws", "3", "--directed-draws",
         "2", "--duration", "1.5")


def test_calibrate_is_deterministic_resumable_and_replays_byte_for_byte(tmp_path: Path) -> None:
    code, text = _run(tmp_path / "a", *SMOKE)
    assert code == 0, text
    assert "S0 met every calibration fact" in text or "S0 met them" in text
    a = tmp_path / "a"
    # a block lost (kill -9 before it was written): the rerun computes it again, same bytes
    block = a / "draws" / "S1" / "A-0000.parquet"
    block.unlink()
    first = (a / "structures.json").read_bytes()
    code, text = _run(a, *SMOKE)
    assert code == 0, text
    assert block.exists()
    assert (a / "structures.json").read_bytes() == first
    code, text = _run(tmp_path / "b", *SMOKE)
    assert code == 0, text
    assert (tmp_path / "b" / "draws.parquet").read_bytes() == (a / "draws.parquet").read_bytes()
    code, text = _run(tmp_path / "c", "--structures", "S0,S1", "--replay",
                      str(a / "draws.parquet"))  # fmt: skip
    assert code == 0, text
    for f in ("structures.json", "structures.md", "structures.png"):
        assert (tmp_path / "c" / f).read_bytes() == (a / f).read_bytes()
    md = (a / "structures.md").read_text()
    assert "| claim | S0 (" in md and "| S1 (" in md and "revisions 1-5" in md


@pytest.mark.parametrize("args, field", [
    (("--structures", "S9"), "--structures"),
    (("--structures", ","), "--structures"),
    (("--draws", "0"), "--draws"),
    (("--replay", "nofile.parquet"), "--replay"),
])  # fmt: skip
def test_bad_input_is_one_line_and_writes_nothing(tmp_path: Path, args: tuple[str, ...],
                                                  field: str) -> None:  # fmt: skip
    code, text = _run(tmp_path / "o", *args)
    assert code == 2
    assert field in text and "Traceback" not in text
    assert not (tmp_path / "o").exists()


def test_the_shipped_comparison_replays_byte_for_byte(tmp_path: Path) -> None:
    """docs/book_calibration/structures.{json,md,png} are rebuilt from the shipped per-twin
    file (at most 20 MB) by ``--replay``, byte for byte, with the default robot
    (``src/mwip/robot/book.toml``: revision 9's most probable member of the most probable
    structure), and say what the declaration's sample showed for every structure."""
    import json

    from mwip.calibration.structures import load_importance
    from mwip.hardware.identified import STATUS_FILE
    from mwip.robot import BOOK_FILE, default_robot

    docs = Path(__file__).resolve().parents[1] / "docs" / "book_calibration"
    draws = docs / "structures.parquet"
    assert draws.stat().st_size <= 20 * 10**6
    code, text = _run(tmp_path / "r", "--replay", str(draws))
    assert code == 0, text
    for f in ("structures.json", "structures.md", "structures.png"):
        assert (tmp_path / "r" / f).read_bytes() == (docs / f).read_bytes(), f
    assert (tmp_path / "r" / "robot.toml").read_bytes() == BOOK_FILE.read_bytes()
    assert (tmp_path / "r" / "book-twin.json").read_bytes() == STATUS_FILE.read_bytes()
    doc = json.loads((docs / "structures.json").read_text())
    plan = load_plan()
    directed = load_directed()
    importance = load_importance()
    for s in doc["structures"].values():
        c = directed.generations * directed.per_generation  # stage C where A, B met not all
        ab = s["hits_by_stage"]["A"] + s["hits_by_stage"]["B"]
        d = importance.draws if ab + s["hits_by_stage"]["C"] > 0 else 0  # D where one met all
        assert s["stages"] == {"A": plan.prior_draws, "B": plan.kernel_draws,
                               "C": c if ab == 0 else 0, "D": d}  # fmt: skip
    # the default robot is the member the document names, in its structure's firmware
    m = doc["member"]
    post = doc["posterior_probability"]
    assert post[m["structure"]] == max(post.values()) > 0.5
    robot = default_robot()
    assert robot.values() == pytest.approx(m["values"], rel=1e-15)
    st = load_structures()[m["structure"]]
    assert robot.twin.firmware.gyro_zeroing == st.twin.firmware.gyro_zeroing
    assert robot.twin.firmware.fusion.kind == st.twin.firmware.fusion.kind
    assert robot.prior.names == st.prior.names
    # a structure rejected only by facts, never by a held-out claim: a claim that needs a
    # rejecting fact is "not judgeable" on that structure
    for c in doc["claims"]:
        for name, v in c["per_structure"].items():
            if set(c["needs"]) & set(doc["structures"][name]["rejected_by"]):
                assert v["verdict"] == "not judgeable"


def test_the_evidence_estimates_a_known_probability(tmp_path: Path, monkeypatch) -> None:
    """Synthetic truth for stages A-B (revision 7): with a fake twin that meets every fact
    exactly when the torque gain is in [1.5, 3] (log-uniform on [0.25, 4]: probability
    ln 2 / ln 16 = 1/4) and the gear ratio below 10 (uniform on [3.7, 51]: 6.3 / 47.3), ``Z``
    with its interval covers the truth, and stage B's search lands in the set more often than
    the prior draws (the point of it). Revision 6's pooling of B with A by the balance
    heuristic failed this (``Z`` near 1e-6 against 0.033): the boxes are centred on the draws
    they would reweight."""
    from dataclasses import replace

    import mwip.calibration.sample as sample
    from mwip.calibration.comparison import sample_structure, structure_evidence
    from mwip.calibration.evidence import load_evidence
    from mwip.calibration.runs import run_names

    ev = load_evidence()

    def fake(values: dict, **kw: object) -> dict:
        ok = ((values["firmware.torque_gain"] >= 1.5) & (values["firmware.torque_gain"] <= 3)
              & (values["drive.gear_ratio"] < 10.0))  # fmt: skip
        cols = {f"{r}.stands": ok.astype(float) for r in run_names()}
        for n in ev.numbers:
            cols[n.key] = np.where(ok, n.book, 10 * n.book)
        return cols

    monkeypatch.setattr(sample, "evaluate", fake)
    truth = 0.25 * (10.0 - 3.7) / (51.0 - 3.7)
    s1 = load_structures()["S1"]
    covered = 0
    for seed in range(10):
        plan = replace(load_plan(), prior_draws=400, kernel_draws=200, seed=seed, block=200)
        pool = sample_structure(s1, plan, tmp_path / f"s{seed}", ev)
        se = structure_evidence("S1", pool, ev)
        e = se.evidence
        assert e.n == 400 and not se.rejected
        covered += e.lo <= truth <= e.hi
        a = pool["stage"].to_numpy() == "A"
        assert se.accepted[~a].mean() > 2 * se.accepted[a].mean()
    assert covered >= 8  # a 95 % interval: 9.5 of 10 expected (P(covered < 8) < 0.02)


def test_the_directed_search_finds_a_thin_set_the_prior_misses(tmp_path: Path,
                                                                monkeypatch) -> None:  # fmt: skip
    """Synthetic truth for revision 8's stage C: a fake twin stands where the torque gain is
    in [1.5, 3] and the gear ratio below 10 (a thirtieth of the prior), and meets Table 6.4's
    RMS pitch only where, besides, its gyro offset is within 2.6e-4 rad/s of 0.016 (1.3 % of
    its range; the number's error grows smoothly away from it). Stages A and B (200 + 100
    twins) find no twin meeting every fact; the directed search finds some, so the structure
    is not rejected, Z stays stage A's (0), and a rerun reads the generations back. Where A or
    B already met every fact, stage C adds nothing."""
    from dataclasses import replace

    import mwip.calibration.sample as sample
    from mwip.calibration.comparison import (
        directed_stage,
        sample_structure,
        structure_evidence,
    )
    from mwip.calibration.evidence import load_evidence
    from mwip.calibration.structures import load_directed

    ev = load_evidence()
    fake, _ = _thin_fake(ev)
    monkeypatch.setattr(sample, "evaluate", fake)
    s1 = load_structures()["S1"]
    plan = replace(load_plan(), prior_draws=200, kernel_draws=100, seed=7, block=100)
    declared = load_directed()
    assert declared is not None and declared.generations > 0
    directed = replace(declared, generations=12, per_generation=60)
    ab = sample_structure(s1, plan, tmp_path / "s", ev)
    assert structure_evidence("S1", ab, ev).rejected
    c = directed_stage(s1, ab, directed, tmp_path / "s", ev, block=plan.block)
    assert len(c) == 12 * 60 and set(c["stage"]) == {"C"}
    pool = __import__("pandas").concat([ab, c], ignore_index=True)
    se = structure_evidence("S1", pool, ev)
    assert not se.rejected and se.evidence.hits == 0 and se.evidence.n == 200
    again = directed_stage(s1, ab, directed, tmp_path / "s", ev, block=plan.block)
    assert again.equals(c)
    assert len(directed_stage(s1, pool, directed, tmp_path / "t", ev, block=plan.block)) == 0


def _thin_fake(ev):  # type: ignore[no-untyped-def]
    """The fake twin of the stage C and D tests: stands where the torque gain is in [1.5, 3] and the
    gear ratio below 10; meets Table 6.4's RMS pitch only where, besides, its gyro offset is
    within 2.8e-4 rad/s of 0.016. Its Z (``thin_z``) is known."""
    from mwip.calibration.runs import run_names

    key = "exp-hodosmc-balance/smc.case1.rms_theta"

    def fake(values: dict, **kw: object) -> dict:
        ok = ((values["firmware.torque_gain"] >= 1.5) & (values["firmware.torque_gain"] <= 3)
              & (values["drive.gear_ratio"] < 10.0))  # fmt: skip
        cols = {f"{r}.stands": ok.astype(float) for r in run_names()}
        for n in ev.numbers:
            cols[n.key] = np.where(ok, n.book, np.nan)
        d = np.abs(values["imu.gyro_bias"] - 0.016)
        cols[key] = np.where(ok, 0.0216 * np.exp(np.maximum(d - 2e-4, 0) * 5000), np.nan)
        return cols

    # P(torque gain in [1.5, 3]) = ln 2 / ln 16 (log-uniform on [0.25, 4]); P(gear < 10) =
    # 6.3 / 47.3; the RMS pitch within a factor 1.5 of the book's: |b - 0.016| <= 2e-4 +
    # ln 1.5 / 5000, of a range 0.04 (uniform on [-0.02, 0.02])
    thin_z = 0.25 * (6.3 / 47.3) * 2 * (2e-4 + np.log(1.5) / 5000) / 0.04
    return fake, thin_z


def test_stage_d_weighs_a_thin_set_by_importance_sampling(tmp_path: Path,
                                                          monkeypatch) -> None:  # fmt: skip
    """Synthetic truth for revision 9's stage D: on the thin set of the stage C test (Z = 4.7e-4,
    no prior draw of 200 meets it), the importance estimate of Z from a proposal fitted to
    stage C's twins covers the truth with its 95 % interval (8 of 10 seeds at least), the
    weighted posterior recovers a known conditional probability (the torque gain below its
    set's geometric middle: 1/2) and the offset's position, the weights are 1 / q (at most
    1 / defensive), and a rerun reads the stored blocks back."""
    from dataclasses import replace

    import pandas as pd

    import mwip.calibration.sample as sample
    from mwip.calibration.comparison import (
        _evidence_with_d,
        _facts,
        directed_stage,
        importance_stage,
        sample_structure,
    )
    from mwip.calibration.evidence import load_evidence
    from mwip.calibration.structures import load_importance

    ev = load_evidence()
    fake, truth = _thin_fake(ev)
    monkeypatch.setattr(sample, "evaluate", fake)
    s1 = load_structures()["S1"]
    plan = replace(load_plan(), prior_draws=200, kernel_draws=100, seed=7, block=500)
    directed = replace(load_directed(), generations=12, per_generation=60)
    ab = sample_structure(s1, plan, tmp_path / "s", ev)
    c = directed_stage(s1, ab, directed, tmp_path / "s", ev, block=plan.block)
    abc = pd.concat([ab, c], ignore_index=True)
    declared = load_importance()
    assert declared is not None and declared.draws > 0 and 0 < declared.defensive < 1
    covered, shares, med = 0, [], []
    for seed in range(10):
        imp = replace(declared, draws=1000, seed=100 + seed)
        d = importance_stage(s1, abc, imp, tmp_path / f"d{seed}", ev, block=plan.block)
        assert len(d) == 1000 and set(d["stage"]) == {"D"}
        w = d["weight"].to_numpy()
        assert np.all(w > 0) and w.max() <= 1 / imp.defensive + 1e-12
        df = pd.concat([abc, d], ignore_index=True)
        se = _evidence_with_d("S1", df, _facts(df, ev))
        e = se.evidence
        assert e.n == 1000 and e.hits > 0
        covered += e.lo <= truth <= e.hi
        sel = se.conditioned
        assert sel.sum() == e.hits and not np.any(sel[: len(abc)])  # the posterior is D's
        tg = s1.prior["firmware.torque_gain"].from_unit(df["u.firmware.torque_gain"].to_numpy())
        ws = se.weights[sel]
        shares.append(np.sum(ws * (tg[sel] < np.sqrt(4.5))) / ws.sum())
        b = s1.prior["imu.gyro_bias"].from_unit(df["u.imu.gyro_bias"].to_numpy())[sel]
        med.append(np.median(b))
        if seed == 0:
            again = importance_stage(s1, abc, imp, tmp_path / "d0", ev, block=plan.block)
            assert again.equals(d)
    assert covered >= 8, covered  # 95 % intervals: 9.5 of 10 expected
    assert abs(np.mean(shares) - 0.5) < 0.1, shares
    assert np.all(np.abs(np.array(med) - 0.016) < 2.8e-4)
