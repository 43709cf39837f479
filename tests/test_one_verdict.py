"""One verdict per claim (issue 38, item 5): a Chapter 6 claim judged across the calibration's
twins is counted by that verdict in the headline, the summary and every claims table, with
the run's own result on the default twin beside it as a value (:mod:`mwip.report.verdict`).

The folder is synthetic: the studies' metrics.json as a run on the default twin writes them,
and the run record's ``twin_status`` with the across-twins verdicts."""

from __future__ import annotations

import html
import json
import re
import tomllib
from pathlib import Path

import pytest

from mwip.report import load_results, summary_lines
from mwip.report.html import render_html

#: this run's claims on the default twin (``holds``) ...
CLAIMS = {
    "exp-it2": [
        {"id": "exp1", "text": "Exp 1: T1 oscillates; IT2 stable", "holds": True, "book": True},
        {"id": "exp1.t1", "text": "Exp 1: T1 oscillates [extra]", "holds": True, "book": False},
    ],
    "exp-asta": [
        {"id": "order.rms_s1.case1", "text": "ASTA < ASMC in rms_s1, Case 1", "holds": False,
         "book": True, "cause": "twin-model", "evidence": "ASTA 0.2 against ASMC 0.1"},
        {"id": "order.rms_theta.case1", "text": "ASTA < ASMC in rms_theta, Case 1",
         "holds": True, "book": True},
    ],
    "lqr-gain": [
        {"id": "yaw", "text": "the yaw gains match the printed K", "holds": True, "book": True},
    ],
}  # fmt: skip
#: ... and the calibration's verdicts across the posterior's twins
ACROSS = [("exp-it2", "exp1", "fails", False), ("exp-asta", "order.rms_s1.case1", "holds", True),
          ("exp-asta", "order.rms_theta.case1", "undecided", True)]  # fmt: skip


def _folder(out: Path, damping: str = "units") -> Path:
    studies = {}
    for name, claims in CLAIMS.items():
        (out / name).mkdir(parents=True)
        doc = {"study": name, "source": "Sec. 6", "claims": claims, "metrics": {},
               "runs": {"a": {"status": "ok", "t_end": 10.0}}, "settings": {}}  # fmt: skip
        (out / name / "metrics.json").write_text(json.dumps(doc))
        studies[name] = {"wall_s": 1.0, "error": None}
    claims = [{"study": s, "id": i, "text": i, "verdict": v, "fraction": 0.5,
               "interval": [0.4, 0.6], "default_twin": d} for s, i, v, d in ACROSS]  # fmt: skip
    status = {"identified": True, "text": "the default twin is a twin", "dropped": [],
              "claims": claims, "claim_counts": {"holds": 1, "fails": 1, "undecided": 1}}
    record = {"damping": damping, "studies": studies, "wall_s": 1.0, "twin_status": status}
    (out / "run.json").write_text(json.dumps(record))
    return out


@pytest.fixture
def folder(tmp_path) -> Path:
    return _folder(tmp_path / "out")


def _headline(page: str) -> str:
    m = re.search(r'<p class="headline" id="headline">(.*?)</p>', page)
    assert m
    return html.unescape(m.group(1))


def _twin_table(page: str) -> list[list[str]]:
    """The identified-twin table's rows: study, claim, share, verdict, default twin, by."""
    sec = page[page.index('id="identified-twin"') :]
    sec = sec[: sec.index("</section>")]
    rows = re.findall(r"<tr><td>(.*?)</tr>", sec)
    return [re.findall(r"<td[^>]*>(.*?)</td>", "<td>" + r) for r in rows]


def test_the_headline_counts_each_chapter6_claim_by_its_across_twins_verdict(folder) -> None:
    page = render_html(folder)
    head = _headline(page)
    twins = _twin_table(page)
    m = re.search(r"(\d+) Chapter 6 claims? judged across the calibration's twins", head)
    assert m, head
    assert int(m.group(1)) == len(twins) == len(ACROSS)  # one verdict per claim
    # held: the yaw gains (not judged across twins) and order.rms_s1.case1 (holds across)
    assert head.startswith("Book claims: 2 of 4 reproduce")
    assert "1 holds, 1 fails, 1 undecided" in head
    lines = summary_lines(load_results(folder), width=200, damping="units")
    assert lines[0] == head  # the terminal says the same


def test_a_study_claims_table_shows_one_verdict_per_claim(folder) -> None:
    page = render_html(folder)
    across = {(r[0], r[1]): (r[3], r[4]) for r in _twin_table(page)}
    for study, claims in CLAIMS.items():
        sec = page[page.index(f'<section class="study" id="{study}">') :]
        sec = sec[sec.index("<h3>Claims</h3>") : sec.index("</table>", sec.index("<h3>Claims"))]
        for c in claims:
            row = sec[sec.index(f"<td>{html.escape(c['text'])}</td>") :]
            cell = re.search(r"<td data-label='verdict'>(.*?)</td>", row)
            assert cell
            shown = re.findall(r'<span class="(?:ok|no|na)">(.*?)</span>', cell.group(1))
            assert len(shown) == 1, (study, c["id"], cell.group(1))  # never two verdicts
            if (study, c["id"]) in across:
                verdict, default = across[(study, c["id"])]
                assert shown == [verdict]  # the twin table's verdict, the same words
                # the run's own result is a value beside it, the twin table's value too
                assert f"this run&#x27;s twin: {str(c['holds']).lower()}" in cell.group(1)
                assert default == str(c["holds"]).lower()
            else:
                assert shown == ["holds" if c["holds"] else "does not hold"]


def test_the_book_claims_table_and_the_summary_use_the_same_verdict(folder) -> None:
    page = render_html(folder)
    section = page[page.index('id="book-claims"') : page.index("<h2>Overview")]
    held = section[: section.index("</tbody>")]
    assert "ASTA &lt; ASMC in rms_s1" in held and "Exp 1: T1 oscillates; IT2" not in held
    lines = summary_lines(load_results(folder), width=200)
    it2 = next(i for i, s in enumerate(lines) if "] exp-it2 (" in s)
    assert lines[it2].startswith("[no] exp-it2 (Sec. 6): book claims 0/1, extras 1/1")
    assert lines[it2 + 1].startswith("     fails across twins: Exp 1: T1 oscillates; IT2 stable")


def test_another_damping_reading_keeps_the_runs_verdicts(tmp_path) -> None:
    """The calibration ran on the units reading: under the literal one its verdicts are not
    about the robot that ran, and the run's own verdicts stay."""
    out = _folder(tmp_path / "lit", damping="literal")
    head = _headline(render_html(out))
    assert head.startswith("Book claims: 3 of 4 reproduce") and "Chapter 6" not in head


def test_the_twins_status_is_said_in_plain_words() -> None:
    from mwip.hardware.identified import status
    from mwip.robot import default_robot

    text = status()["text"]
    for jargon in ("stages", "stage ", "effective", "pooled", "ESS", "R-hat"):
        assert jargon not in text, jargon
    assert re.search(r"[\d,]+ twins drawn, [\d,]+ consistent with the calibration facts", text)
    notes = default_robot().notes
    for jargon in ("stages", "Stage ", "effective", "ESS", "R-hat"):
        assert jargon not in notes, jargon


SCENARIOS = Path(__file__).parent.parent / "src" / "mwip" / "studies" / "scenarios"


@pytest.mark.parametrize("study", ["exp-hodosmc-balance", "exp-hodosmc-speed",
                                   "exp-hodosmc-obstacle", "exp-asta", "exp-it2"])
def test_a_fixed_text_on_falls_says_it_is_about_the_data_sheet_twin(study) -> None:
    gaps = " ".join(tomllib.loads((SCENARIOS / f"{study}.toml").read_text())["report"]["gaps"]
                    .split())  # fmt: skip
    first = gaps.index("fell")
    assert "not the robot of this run" in gaps[:first] and "data-sheet twin" in gaps[:first]
