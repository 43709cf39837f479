"""The report of ``mwip reproduce``: summary from metrics.json, HTML page, safe output folder.

The browser test renders ``index.html`` in headless Chromium (Debian's ``chromium``, driven by
Playwright); ``.ci/run`` installs both. Where either is missing locally it is skipped with a
message saying what to install. Its screenshot is kept in ``test-artifacts/report.png``.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from mwip.cli import main
from mwip.report import Staging, load_results, render_html, summary_lines
from mwip.studies import study_names

STUDIES = study_names()

ARTIFACTS = Path(
    os.environ.get("MWIP_TEST_ARTIFACTS", Path(__file__).parent.parent / "test-artifacts")
)
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def test_reproduce_writes_every_study_the_record_and_the_report(quick_reproduction):
    out, code, stdout = quick_reproduction
    assert code == 0
    record = json.loads((out / "run.json").read_text())
    assert list(record["studies"]) == list(STUDIES)
    assert all(s["error"] is None and s["wall_s"] > 0 for s in record["studies"].values())
    assert record["quick"] is True and record["mwip_version"]
    assert (
        record["params"]["plant"]["r"] == 0.04 and record["params"]["nominal (design)"]["r"] == 0.03
    )
    assert (out / "index.html").is_file()
    assert not [p for p in out.parent.iterdir() if ".partial-" in p.name]  # staging removed
    # the one-screen summary: one line per study, a failing book claim and its numbers, totals
    docs = [json.loads((out / n / "metrics.json").read_text()) for n in STUDIES]
    for name in STUDIES:
        assert f"] {name} (" in stdout
    held = sum(c["holds"] for d in docs for c in d["claims"])
    n_claims = sum(len(d["claims"]) for d in docs)
    assert f"all claims (with our extra readings): {held}/{n_claims}; over 14 studies" in stdout
    assert len(stdout.splitlines()) <= 4 * len(STUDIES) + 2


def test_summary_verdicts_come_from_metrics_json(quick_reproduction, tmp_path):
    out, _, _ = quick_reproduction
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    path = copy / "lqr-gain" / "metrics.json"
    doc = json.loads(path.read_text())
    doc["claims"] = [
        {"text": "a planted claim (book)", "holds": False, "values": {"k.x": 2.5}},
        {"text": "our extra check", "holds": True},
    ]
    path.write_text(json.dumps(doc))
    lines = summary_lines(load_results(copy, ["lqr-gain"]))
    assert lines[0].startswith("[no] lqr-gain (Sec. 4.4.2): book claims 0/1, all 1/2; runs ")
    assert lines[1:3] == ["     fails: a planted claim (book)", "            k.x=2.5"]
    verbose = summary_lines(load_results(copy, ["lqr-gain"]), verbose=True)
    assert verbose[1] == "     [no] a planted claim (book)  <k.x=2.5>"
    assert verbose[2] == "     [ok] our extra check"
    page = render_html(copy, ["lqr-gain"])
    assert "a planted claim" in page and "does not hold" in page and "k.x = 2.5" in page


def test_html_has_a_section_figure_and_tables_per_study(quick_reproduction):
    out, _, _ = quick_reproduction
    page = (out / "index.html").read_text()
    assert "http://" not in page and "https://" not in page and "<script" not in page
    for res in load_results(out):
        start = page.index(f'<section class="study" id="{res.name}">')
        section = page[start : page.index("</section>", start)]
        assert section.count("data:image/png;base64,") == len(res.figures) >= 1
        assert '<table class="claims">' in section
        published = json.loads((out / res.name / "metrics.json").read_text())["published"]
        assert ('<table class="comparison">' in section) == bool(published)


def test_staging_discards_on_interrupt_and_keeps_unrelated_files(tmp_path):
    out = tmp_path / "out"
    (out / "study").mkdir(parents=True)
    (out / "study" / "old.txt").write_text("old")
    (out / "mine.txt").write_text("a user's file")
    with pytest.raises(KeyboardInterrupt), Staging(out) as stage:
        (stage.path / "study").mkdir()
        (stage.path / "study" / "new.txt").write_text("new")
        raise KeyboardInterrupt
    assert (out / "study" / "old.txt").read_text() == "old"
    assert not (out / "study" / "new.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # staging folder gone
    with Staging(out) as stage:
        (stage.path / "study").mkdir()
        (stage.path / "study" / "new.txt").write_text("new")
        stage.commit()
    assert sorted(p.name for p in (out / "study").iterdir()) == ["new.txt"]
    assert (out / "mine.txt").read_text() == "a user's file"
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt", "study"]


def test_interrupted_reproduce_leaves_earlier_results(tmp_path, monkeypatch, capsys):
    from mwip.studies import registry
    from mwip.studies.study import Study

    out = tmp_path / "out"
    assert main(["run", "lqr-gain", "--quick", "--out", str(out)]) == 0
    before = (out / "lqr-gain" / "metrics.json").read_bytes()

    def interrupted(ctx):
        ctx.out.mkdir(parents=True)
        (ctx.out / "metrics.json").write_text("half")
        raise KeyboardInterrupt

    declared = {"lqr-gain": Study("lqr-gain", "x", interrupted, place=(1,))}
    monkeypatch.setattr(registry, "_discover", lambda: declared)
    assert main(["reproduce", "--quick", "--out", str(out), "-j", "1"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert (out / "lqr-gain" / "metrics.json").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_study_file_and_params_run_a_study_on_another_robot(tmp_path, capsys):
    robot = tmp_path / "robot.toml"
    robot.write_text('base = "real"\n[params]\nr = 0.05\nmb = 3.0\n')
    study = tmp_path / "study.toml"
    study.write_text('[study]\nname = "lqr-gain"\nquick = true\n[robot]\nparams = "robot.toml"\n')
    out = tmp_path / "out"
    assert main(["run", "--scenario", str(study), "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["params"]["plant"]["r"] == 0.05 and record["params"]["plant"]["mb"] == 3.0
    assert record["params"]["nominal (design)"]["r"] == 0.03
    study.write_text('[study]\nname = "lqr-gain"\n[robot]\nparms = "robot.toml"\n')
    assert main(["run", "--scenario", str(study), "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "mwip: error: [robot] parms: unknown key; allowed: params, nominal"
    )


def test_report_command_rebuilds_the_page(quick_reproduction, tmp_path, capsys):
    out, _, _ = quick_reproduction
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    (copy / "index.html").unlink()
    assert main(["report", "--out", str(copy)]) == 0
    assert (copy / "index.html").is_file() and "book claims holding:" in capsys.readouterr().out
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["report", "--out", str(empty)]) == 2


def test_report_renders_in_headless_chromium(quick_reproduction):
    """Every study's section, figure and table is on the rendered page; no console errors."""
    if CHROMIUM is None:
        pytest.skip("headless Chromium not found: apt-get install chromium (.ci/run does)")
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="playwright not installed: pip install -e '.[test]'"
    )
    out, _, _ = quick_reproduction
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    errors: list[str] = []
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync"],
        )  # fmt: skip
        page = browser.new_page(viewport={"width": 1280, "height": 1600})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))
        page.goto((out / "index.html").resolve().as_uri())
        page.wait_for_load_state("load")
        assert page.title() == "mwip: reproduction report"
        assert page.locator("#overview tr").count() == len(STUDIES) + 1
        for name in STUDIES:
            section = page.locator(f"section#{name}")
            assert section.count() == 1, name
            imgs = section.locator("img")
            assert imgs.count() >= 1, name
            for i in range(imgs.count()):  # decoded, non-empty images
                assert imgs.nth(i).evaluate("e => e.complete && e.naturalWidth > 0"), name
            assert section.locator("table.claims tr").count() >= 2, name
        page.screenshot(path=str(ARTIFACTS / "report.png"), full_page=False)
        browser.close()
    assert errors == []
    assert (ARTIFACTS / "report.png").stat().st_size > 10_000


@pytest.mark.parametrize("jobs", [1, 2])
def test_runner_reports_each_simulation_run(tmp_path, jobs):
    """The per-run progress: every simulate() of a study is reported, in-process or from a
    worker process, and the engine's hook list is left as it was."""
    from mwip.sim.engine import RUN_END_HOOKS
    from mwip.studies.runner import run_studies

    before = list(RUN_END_HOOKS)
    seen: list[str] = []
    run_studies(["lqr-gain", "do-comparison"], tmp_path / "out", quick=True, jobs=jobs,
                on_run=seen.append)  # fmt: skip
    assert seen.count("lqr-gain") == 3  # continuous, sampled, continuous gain held
    assert seen.count("do-comparison") >= 1
    assert RUN_END_HOOKS == before
