"""Texts true to their tables (issue 40, item 5): one test per page whose sentences state a
result; each fails when a sentence and the numbers it describes disagree."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path

import pytest

from mwip.report.html import runs_outcome

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "src" / "mwip" / "studies" / "scenarios"
CHAPTER6 = ["exp-hodosmc-balance", "exp-hodosmc-speed", "exp-hodosmc-obstacle", "exp-asta",
            "exp-it2"]  # fmt: skip


# ---- the report's study pages: the runs' outcome is generated from the runs table --------


def test_the_runs_outcome_is_the_runs_table_in_words():
    ok = {"status": "ok", "t_end": 10.0}
    assert runs_outcome({"runs": {"a": ok, "b": ok}}) == (
        "All 2 runs stand for their whole duration (10 s).")
    doc = {"runs": {"a": ok, "b": {"status": "fell", "t_end": 0.534},
                    "c": {"status": "fell", "t_end": 0.58}, "d": {"status": "diverged",
                                                                  "t_end": 2.0}}}  # fmt: skip
    assert runs_outcome(doc) == ("1 of 4 runs stand for their whole duration (10 s); diverged: "
                                 "d at 2 s; fell: b at 0.534 s, c at 0.58 s.")  # fmt: skip
    none = runs_outcome({"runs": {"a": {"status": "fell", "t_end": 0.4}}})
    assert none.startswith("None of the 1 runs stands") and "a at 0.4 s" in none
    assert runs_outcome({"runs": {}}) == ""


def test_a_study_page_says_how_its_runs_ended_beside_its_runs_table(tmp_path):
    from mwip.report import write_report

    out = tmp_path / "out"
    (out / "exp-asta").mkdir(parents=True)
    runs = {"asmc.case1": {"status": "ok", "t_end": 10.0},
            "asta.case2": {"status": "fell", "t_end": 1.248}}  # fmt: skip
    doc = {"study": "exp-asta", "source": "Sec. 6.2.2", "metrics": {}, "published": {},
           "claims": [], "runs": runs, "settings": {}}  # fmt: skip
    (out / "exp-asta" / "metrics.json").write_text(json.dumps(doc))
    (out / "run.json").write_text(json.dumps({"studies": {"exp-asta": {"wall_s": 1.0}}}))
    page = write_report(out, ["exp-asta"]).read_text()
    assert "1 of 2 runs stand for their whole duration (10 s); fell: asta.case2 at 1.248 s." \
        in page  # fmt: skip
    assert "<td>asta.case2</td><td>fell</td>" in page  # the table it describes


@pytest.mark.parametrize("study", CHAPTER6)
def test_chapter6_study_texts_state_no_outcome_of_the_default_twin(study):
    """The outcome on the twin in use is generated (above); a study file's fixed texts may
    tell what happened on the data-sheet twin, never what happens on the default twin (that
    changes with the identification: "every run falls within 0.6 s" stood under a table where
    the runs stood)."""
    texts = tomllib.loads((SCENARIOS / f"{study}.toml").read_text())["report"]
    for key in ("setup", "gaps"):
        for sentence in re.split(r"(?<=[.;])\s", " ".join(texts.get(key, "").split())):
            if re.search(r"\b(fall|falls|fell|stand|stands|balance|balances)\b", sentence):
                assert not re.search(r"\bdefault twin\b", sentence), (study, key, sentence)
        assert "23:1" not in texts["setup"] or "data-sheet" in texts["setup"]


# ---- the benchmark page: its axis titles name the identified twin's values ---------------


def _sig(x: float, digits: int = 2) -> float:
    return float(f"{x:.{digits}g}")


def test_bench_axis_titles_and_docs_give_the_identified_twin_values():
    from mwip.bench.spec import load_bench
    from mwip.hardware.identified import default_twin
    from mwip.hardware.prior import PRIOR

    tw = default_twin()
    axes = {a.name: a for a in load_bench(None, False).axes}
    noise = axes["measurement_noise"]
    accel, gyro = (float(v) for v in re.search(r"accel ([\d.]+) m/s\^2, gyro ([\d.]+) mrad/s",
                                               noise.title).groups())  # fmt: skip
    assert accel == _sig(tw.imu.accel_sigma) and gyro == _sig(1e3 * tw.imu.gyro_sigma)
    hi = {u.name: u.high for u in PRIOR.unknowns}
    reach = re.search(r"reaches x([\d.]+) \(accel\) and x([\d.]+) \(gyro\)", noise.source)
    assert reach is not None
    assert float(reach.group(1)) == _sig(hi["imu.accel_sigma"] / tw.imu.accel_sigma)
    assert float(reach.group(2)) == _sig(hi["imu.gyro_sigma"] / tw.imu.gyro_sigma)
    dead = re.search(r"the twin: ([\d.]+)\)", axes["deadband"].title)
    assert dead is not None and float(dead.group(1)) == _sig(tw.drive.deadband)
    delay = re.search(r"the twin: ([\d.]+)\)", axes["delay"].title)
    assert delay is not None and float(delay.group(1)) == _sig(tw.firmware.delay)
    page = (ROOT / "docs" / "bench.md").read_text()
    assert f"accelerometer {_sig(tw.imu.accel_sigma):g} m/s^2" in page
    assert f"gyro {_sig(1e3 * tw.imu.gyro_sigma):g} mrad/s" in page
    assert f"the prior reaches x{reach.group(1)} / x{reach.group(2)}" in page
    assert f"the twin's {_sig(tw.drive.deadband):g}" in page


def test_the_two_torques_are_named_and_explained_where_they_appear():
    from mwip.campaign.report import torque_note
    from mwip.hardware.identified import wheel_torque_limit

    note = torque_note()
    assert "peak_torque" in note and f"{wheel_torque_limit():.3g} N m per wheel" in note
    assert "drive limit" in note and "commanded" in note
    page = (ROOT / "src" / "mwip" / "bench" / "page.py").read_text()
    assert "peak_torque: the largest |torque|" in page and "drive limit" in page


# ---- docs/report.md: its example summary is the summary's shape and today's counts -------


def _block(page: str, first: str) -> list[str]:
    text = (ROOT / page).read_text()
    body = next(b for b in re.findall(r"^```\n(.*?)^```", text, re.S | re.M)
                if b.startswith(first))  # fmt: skip
    return body.splitlines()


def test_docs_report_example_has_the_summarys_lines_and_its_counts(quick_reproduction):
    from mwip.report import load_results
    from mwip.report.claims import counts
    from mwip.report.summary import MARKS
    from mwip.studies import study_names

    lines = _block("docs/report.md", "Book claims:")
    assert lines[1] == MARKS
    head = re.fullmatch(r"Book claims: (\d+) of (\d+) reproduce \((?:\d+ Chapter 6 claims "
                        r"judged across the calibration's twins: [^;]*; )?damping reading "
                        r"units; literal reading: (\d+) of (\d+)\)", lines[0])  # fmt: skip
    tail = re.fullmatch(r"extras of ours \(not the book's claims\): (\d+) of (\d+) hold; "
                        r"(\d+) studies", lines[-1])  # fmt: skip
    assert head is not None and tail is not None
    out, code, _ = quick_reproduction  # every study (quick runs: the same book claims)
    n = counts(load_results(out, study_names()))
    assert int(head.group(2)) == int(head.group(4)) == n["book"]
    assert int(tail.group(3)) == len(study_names())  # (quick runs make fewer extras)
    assert int(head.group(1)) <= n["book"] and int(tail.group(1)) <= int(tail.group(2))


# ---- README: the default twin's standing runs -------------------------------------------


def test_readme_counts_the_default_twins_standing_runs():
    from mwip.hardware.identified import status

    stand = status()["standing"]
    text = " ".join((ROOT / "README.md").read_text().split())
    m = re.search(r"(\d+) of its (\d+) runs stand on it", text)
    assert m is not None
    assert (int(m.group(1)), int(m.group(2))) == (sum(map(bool, stand.values())), len(stand))


# ---- docs/twin_fit.md and the ablation example -------------------------------------------


def test_twin_fit_page_names_the_key_the_file_holds():
    from mwip.robot import default_robot, robot_to_toml

    text_file = robot_to_toml(default_robot())
    assert "\n[firmware]\n" in text_file and "\nemf_compensation = " in text_file
    text = (ROOT / "docs" / "twin_fit.md").read_text()
    assert "`firmware.emf_compensation`" in text
    assert "`emf_feedforward = " not in text  # the old boolean is named only as read


def test_the_ablation_example_runs_on_the_twin_it_names_and_writes_where_asked():
    source = (ROOT / "examples" / "twin_ablation.py").read_text()
    assert "/tmp" not in source
    assert "default_twin()" in source and "Twin()" not in source
    assert "on the default twin" in source.split('"""')[1]
