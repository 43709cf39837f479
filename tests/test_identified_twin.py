"""The default twin is the most probable member of the book calibration's most probable twin
structure (issues 23, 38; revision 9): the packaged robot file's twin is the member of the
packaged status document, it does what the document says it does, and `mwip robot show`, the
run record and the report say where it comes from."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mwip.cli import main
from mwip.hardware.identified import IDENTIFIED_FILE, STATUS_FILE, default_twin, status
from mwip.hardware.twin import Twin
from mwip.robot import load_robot

DOC = json.loads(STATUS_FILE.read_text(encoding="utf-8"))


def test_the_default_twin_is_the_posteriors_most_probable_member() -> None:
    tw = default_twin()
    assert tw == load_robot(IDENTIFIED_FILE).twin
    values = tw.values()
    recorded = DOC["map_values"]
    assert set(recorded) == set(values) == set(DOC["prior"]["names"])
    for name, v in recorded.items():
        assert values[name] == v, name
    # the member is a twin of the most probable structure: its firmware's torque gain is an
    # unknown there, not the record's 1
    sampler = DOC["posterior"]["sampler"]
    assert sampler["kind"] == "importance" and sampler["probability"] == max(
        sampler["structures"].values())
    assert values["firmware.torque_gain"] != 1.0
    # and it is not the data-sheet twin the prior is centred on
    assert tw != Twin()
    assert DOC["posterior"]["map_index"] >= 0


def test_the_default_twin_does_what_the_posterior_records() -> None:
    """Rerun a few of the calibration's runs on the default twin itself: standing and the
    calibration numbers as recorded for the member (same code, one row)."""
    from mwip.calibration.runs import RUNS, run_batch

    standing = DOC["map_standing"]
    assert all(standing.values()) and len(standing) == 25  # every fact met: every run stands
    pick = [r for r in RUNS if r.name in ("exp-hodosmc-balance/smc.case1",
                                          "exp-hodosmc-balance/do1smc.case1")]  # fmt: skip
    tw = default_twin()
    values = {k: np.array([v]) for k, v in DOC["map_values"].items()}
    cols = run_batch(values, runs=tuple(pick), twin=tw)
    for r in pick:
        assert bool(cols[f"{r.name}.stands"][0] == 1.0) == standing[r.name], r.name
    for num in DOC["calibration_numbers"]:
        if num["key"] in cols and num["map"] is not None:
            assert cols[num["key"]][0] == pytest.approx(num["map"], rel=1e-9), num["key"]


def test_the_status_documents_verdicts_are_the_comparisons() -> None:
    """One verdict per claim: the default twin's document judges each Chapter 6 claim as the
    shipped comparison does over the structures (same fraction, same word)."""
    from pathlib import Path

    docs = Path(__file__).resolve().parents[1] / "docs" / "book_calibration"
    comp = json.loads((docs / "structures.json").read_text())
    assert len(DOC["claims"]) == len(comp["claims"])
    for a, c in zip(DOC["claims"], comp["claims"], strict=True):
        assert f"{a['study']}/{a['id']}" == c["claim"]
        assert a["verdict"] == c["verdict"]
        assert a["fraction"] == pytest.approx(c["p_holds"], rel=1e-9, abs=1e-12)
        assert a["interval"][0] <= a["fraction"] <= a["interval"][1]
    assert len(DOC["members"]) == 256


def test_robot_show_prints_the_identified_twin_with_its_provenance(capsys) -> None:
    # `mwip robot show` replaces `mwip twin show`: the twin's provenance is the robot's notes
    # and each value's source (a data-sheet guess is an unknown with its prior)
    assert main(["robot", "show"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# mwip robot file")
    assert 'notes = """\nThe book\'s robot: Tables 6.1' in out
    assert "the most probable member of the most probable twin structure" in out
    assert "identified: most probable member of structure S1" in out
    assert main(["robot", "show", "--datasheet"]) == 0
    ds = capsys.readouterr().out
    assert "identified:" not in ds and "unknown (prior): MAXON GP 32 A 23:1" in ds


def test_status_says_which_twin_ran() -> None:
    st = status()
    size = DOC["posterior"]["size"]
    kind = (DOC["posterior"].get("sampler") or {}).get("kind")
    if kind == "importance":  # revision 9: the most probable structure's member
        sampler = DOC["posterior"]["sampler"]
        which = (f"the most probable member of twin structure {sampler['structure']}, the "
                 "most probable given the book's calibration facts")
    elif kind == "mixture":  # stages 4-5: a weighted pool with a most probable member
        which = f"the most probable of the {size:,} twins consistent"
    elif "sampler" in DOC["posterior"]:  # stage 3's chains: every state ties for most probable
        which = ("the first twin found consistent with the book's calibration facts, of "
                 f"{size:,} twins from Markov chains")
    else:
        which = ("the only twin found" if size == 1 else f"the most probable of {size:,} twins")
        which += " consistent"
    assert st["identified"] and st["text"].startswith(f"the default twin is {which}")
    assert st["claim_counts"] == DOC["claim_counts"]
    n_up = sum(DOC["map_standing"].values())
    assert f"{n_up} of {len(DOC['map_standing'])} Chapter 6 runs stand" in st["text"]
    other = status(Twin())
    assert not other["identified"] and "--robot FILE" in other["text"]


def test_the_report_headline_states_the_twins_status(tmp_path) -> None:
    from mwip.report.html import twin_headline

    text = twin_headline({"twin_status": status()})
    c = DOC["claim_counts"]
    assert text.startswith(f"Chapter 6, judged across the identified twins: {c['holds']} ")
    assert f"{c['fails']} fail, {c['undecided']} undecided" in text
    assert twin_headline({}) == ""


def test_the_drive_limit_reported_by_simulate_is_the_default_twins() -> None:
    from mwip.hardware.identified import wheel_torque_limit

    tw = default_twin()
    assert wheel_torque_limit() == pytest.approx(tw.drive.wheel_torque_limit(tw.motor),
                                                 rel=1e-12)  # fmt: skip
