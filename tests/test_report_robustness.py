"""The claims campaign's "holds in X % of plausible settings" beside each claim (issue 15)."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from mwip.cli import main
from mwip.report.html import CLAIMS_CAMPAIGN, claim_robustness_note, render_html


def _study(out, name="asta-balance"):
    folder = out / name
    folder.mkdir(parents=True)
    doc = {
        "study": name, "source": "Figs. 4.2-4.4", "metrics": {"x": 1.0}, "published": {},
        "claims": [
            {"id": "settling", "text": "ASTA settles first", "holds": False, "book": True,
             "cause": "unprinted-setting", "evidence": "0.886 s vs 0.872 s"},
            {"id": "balance", "text": "both balance", "holds": True, "book": True},
        ],
        "runs": {"asta": {"status": "ok", "t_end": 1.0}}, "settings": {},
    }  # fmt: skip
    (folder / "metrics.json").write_text(json.dumps(doc))


def _campaign(folder, holds):
    folder.mkdir(parents=True)
    rows = [
        {"study": "asta-balance", "sample": i, "claim_index": 0, "claim": "settling",
         "book": "true", "text": "ASTA settles first", "holds": h, "error": "", "settings": "{}"}
        for i, h in enumerate(holds)
    ]  # fmt: skip
    pd.DataFrame(rows).to_parquet(folder / "results.parquet")


def test_note_counts_the_campaign_verdicts(tmp_path):
    _campaign(tmp_path / "c", [True, False, False, False])
    note = claim_robustness_note(tmp_path / "c")
    text = note("asta-balance", {"id": "settling"})
    assert text.startswith("holds in 25 % of plausible settings") and "n = 4" in text
    assert note("asta-balance", {"id": "balance"}) == ""  # no draws for that claim
    assert claim_robustness_note(None)("asta-balance", {"id": "settling"}) == ""


def test_report_shows_it_beside_the_verdict(tmp_path, capsys):
    out = tmp_path / "out"
    _study(out)
    _campaign(out / CLAIMS_CAMPAIGN, [True, True, False, True])
    page = render_html(out, ["asta-balance"], claims_campaign=out / CLAIMS_CAMPAIGN)
    assert page.count("holds in 75 % of plausible settings") == 2  # book table + study table
    assert main(["report", "--out", str(out)]) == 0
    assert "holds in 75 %" in (out / "index.html").read_text()


def test_report_rejects_a_folder_without_results(tmp_path, capsys):
    out = tmp_path / "out"
    _study(out)
    (tmp_path / "empty").mkdir()
    assert main(["report", "--out", str(out), "--claims", str(tmp_path / "empty")]) == 2
    err = capsys.readouterr().err
    assert "--claims" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(AssertionError):
        assert "holds in" in render_html(out, ["asta-balance"])


def test_report_embeds_the_twin_ablation_and_the_twin_assumptions(tmp_path):
    """A Chapter 6 study's ablation table (settings.ablation_table) is shown in its section,
    and the page states the twin's payload and stick assumptions with their sensitivity."""
    out = tmp_path / "out"
    _study(out, "exp-asta")
    folder = out / "exp-asta"
    doc = json.loads((folder / "metrics.json").read_text())
    doc["settings"]["ablation_table"] = {"md": "ablation.md", "html": "ablation.html"}
    (folder / "metrics.json").write_text(json.dumps(doc))
    (folder / "ablation.html").write_text("<table><tr><td>+ inertia</td><td>fell</td></tr></table>")
    page = render_html(out, ["exp-asta"])
    assert "the twin's ablation" in page and "<td>+ inertia</td><td>fell</td>" in page
    assert "Payload (Case 2)" in page and "Stick (Case 3)" in page
    doc["settings"].pop("ablation_table")
    (folder / "metrics.json").write_text(json.dumps(doc))
    page = render_html(out, ["exp-asta"])
    assert "the twin's ablation" not in page and "Payload (Case 2)" not in page
