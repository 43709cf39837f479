"""The report of ``mwip reproduce``: summary from metrics.json, HTML page, safe output folder.

Most tests render a synthetic results folder written here (claims as data: ids, book flags,
causes, evidence; a comparison folder under the other damping reading; a wide figure; a run
for the poster frame); the others use a quick reproduction of every study.

The browser tests render ``index.html`` in headless Chromium (Debian's ``chromium``, driven by
Playwright); ``.ci/run`` installs both. Where either is missing locally they are skipped with a
message saying what to install. Their screenshots (1280 px and phone width) are kept in
``test-artifacts/``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from mwip.cli import main
from mwip.report import Staging, load_results, summary_lines
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
    assert record["damping"] == "units" and not (out / "compare-literal").exists()
    # the one-screen summary: the book-claim count first, one line per study, a failing book
    # claim with its cause and evidence, the extras last
    docs = [json.loads((out / n / "metrics.json").read_text()) for n in STUDIES]
    for name in STUDIES:
        assert f"] {name} (" in stdout
    # a Chapter 6 claim judged across the calibration's twins counts by that one verdict
    across = {(c["study"], c["id"]): c["verdict"] for c in record["twin_status"]["claims"]}
    book = [(n, c) for n, d in zip(STUDIES, docs, strict=True) for c in d["claims"] if c["book"]]
    held = sum(across[(n, c["id"])] == "holds" if (n, c["id"]) in across else c["holds"]
               for n, c in book)  # fmt: skip
    lines = stdout.splitlines()
    assert lines[0].startswith(f"Book claims: {held} of {len(book)} reproduce ({len(across)} "
                               "Chapter 6 claims judged across the calibration's twins: ")
    assert lines[0].endswith("; damping reading units)")
    extras = [c for d in docs for c in d["claims"] if not c["book"]]
    assert f"extras of ours (not the book's claims): {sum(c['holds'] for c in extras)} of " \
        f"{len(extras)} hold; {len(STUDIES)} studies" in stdout  # fmt: skip
    assert len(lines) <= 3 * len(STUDIES) + 4


CLAIMS = {
    "lqr-gain": [
        {"id": "yaw", "text": "the yaw gains match the printed K (book)", "holds": True,
         "book": True, "values": {"k.yaw": 70.71}},
        {"id": "pitch", "text": "the pitch gains match the printed K", "holds": False,
         "book": True, "cause": "damping-reading", "values": {"k.pitch": -223.99},
         "evidence": "Our pitch gain is -223.99 against the printed -207.87 (+7.8 %)."},
        {"id": "held", "text": "the 5 ms design balances", "holds": True, "book": False},
    ],
    "do-comparison": [
        {"id": "order", "text": "higher order is more accurate", "holds": False, "book": True,
         "cause": "book-inconsistency",
         "evidence": "|H_2(j2)| = 4.1e-4 is below |H_4(j2)| = 2.9e-3 for the printed gains."},
        {"id": "old", "text": "an unlabelled claim that cites the book", "holds": True},
        {"id": "nocause", "text": "a failing book claim that names no cause", "holds": False,
         "book": True},
    ],
}  # fmt: skip
#: Verdicts under the other reading (compare-literal): the pitch claim holds there.
LITERAL = {("lqr-gain", "pitch"): True}


def _synthetic(out: Path, damping: str = "units", flips: dict | None = None) -> Path:
    """A results folder as `mwip reproduce` writes it, with the claims above."""
    from matplotlib.figure import Figure

    from mwip.laws import LQR, design_lqr
    from mwip.params import NOMINAL, REAL
    from mwip.sim import simulate
    from mwip.studies.common import save_figure

    studies = {}
    for name, claims in CLAIMS.items():
        folder = out / name
        folder.mkdir(parents=True)
        claims = [dict(c, holds=(flips or {}).get((name, c["id"]), c["holds"])) for c in claims]
        doc = {
            "study": name,
            "source": f"Sec. {name}",
            "metrics": {"k.yaw": 70.71},
            "published": {"k.yaw": 70.71},
            "claims": claims,
            "runs": {"continuous": {"status": "ok", "t_end": 0.3}},
            "settings": {"Ts": 0.005},
        }
        (folder / "metrics.json").write_text(json.dumps(doc))
        fig = Figure(figsize=(14, 6))  # wider than the page: drawn at 1440 px
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1])
        ax.set_xlabel("t (s)")
        save_figure(fig, folder / f"{name}.png")
        studies[name] = {"wall_s": 1.0, "error": None, "settings": {}}
    res = simulate(LQR(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0, 0.1, 0), duration=0.3)
    res.to_npz(out / "lqr-gain" / "continuous.npz")  # the catalog's main run: a poster
    record = {
        "damping": damping,
        "studies": studies,
        "wall_s": 2.0,
        "quick": True,
        "params": {"plant": REAL.to_dict(), "nominal (design)": NOMINAL.to_dict()},
    }
    (out / "run.json").write_text(json.dumps(record))
    return out


@pytest.fixture
def synthetic(tmp_path) -> Path:
    out = _synthetic(tmp_path / "out")
    _synthetic(out / "compare-literal", "literal", LITERAL)
    return out


def test_claims_lacking_the_book_field_count_with_the_extras(synthetic):
    from mwip.report.claims import counts

    n = counts(load_results(synthetic))
    assert n == {"book_held": 1, "book": 4, "extra_held": 2, "extra": 2, "unlabelled": 1,
                 "across": 0}  # no run.json twin_status: no claim judged across twins


def test_summary_leads_with_the_book_claims_and_shows_cause_and_evidence(synthetic):
    from mwip.report.claims import load_comparison
    from mwip.report.summary import MARKS

    results = load_results(synthetic)
    cmp = load_comparison(synthetic / "compare-literal")
    lines = summary_lines(results, width=120, damping="units", compare=cmp)
    assert (
        lines[0] == "Book claims: 1 of 4 reproduce (damping reading units; literal reading: 2 of 4)"
    )
    assert lines[1] == MARKS and "[no]" in MARKS
    assert lines[2] == "[no] lqr-gain (Sec. lqr-gain): book claims 1/2, extras 1/1; runs ok"
    assert lines[3] == "     fails: the pitch gains match the printed K"
    assert lines[4] == ("            [damping-reading] Our pitch gain is -223.99 against the "
                        "printed -207.87 (+7.8 %).")  # fmt: skip
    assert lines[5].startswith(
        "[no] do-comparison (Sec. do-comparison): book claims 0/2, extras 1/1"
    )
    assert lines[6] == "     fails: higher order is more accurate (+1 more)"
    assert lines[7].startswith("            [book-inconsistency] |H_2(j2)| = 4.1e-4")
    assert lines[-1] == ("extras of ours (not the book's claims): 2 of 2 hold (1 claims carry no "
                         "'book' field and are counted here); 2 studies")  # fmt: skip
    verbose = summary_lines(results, width=120, verbose=True, compare=cmp)
    assert "     [no] the pitch gains match the printed K  <k.pitch=-224> [literal: ok]" in verbose
    assert "     [ok] (ours) the 5 ms design balances [literal: ok]" in verbose


def test_html_leads_with_the_book_claims_grouped_by_cause(synthetic):
    import re

    from mwip.report import write_report

    page = write_report(synthetic).read_text()  # finds OUT/compare-literal; draws the poster
    head = re.search(r'<p class="headline" id="headline">(.*?)</p>', page).group(1)
    assert head == "Book claims: 1 of 4 reproduce (damping reading units; literal reading: 2 of 4)"
    assert page.index('id="headline"') < page.index('id="book-claims"') < page.index("Overview")
    section = page[page.index('id="book-claims"') : page.index("<h2>Overview")]
    groups = re.findall(r"<tbody class='(\w+)'(?: data-cause='([\w -]+)')?>", section)
    assert groups == [("holds", ""), ("cause", "damping-reading"),
                      ("cause", "book-inconsistency"), ("cause", "not given")]  # fmt: skip
    bodies = section.split("<tbody")[1:]
    assert "the yaw gains match" in bodies[0] and "k.yaw = 70.71" in bodies[0]
    assert "Our pitch gain is -223.99" in bodies[1] and "decided by how the tables" in bodies[1]
    assert "|H_2(j2)| = 4.1e-4" in bodies[2] and "the book&#x27;s printed numbers" in bodies[2]
    pitch = bodies[1][bodies[1].index("the pitch gains") :]
    assert pitch.index("does not hold") < pitch.index("holds</span>")  # here no, literal yes
    assert "unlabelled claim" not in section and "5 ms design" not in section  # extras apart
    assert "Extras of ours (checks the book does not make), counted separately: 2 of 2" in page
    # figures: natural width, a link to the full-size file; a poster of the main run
    lqr = page[page.index('<section class="study" id="lqr-gain">') :]
    lqr = lqr[: lqr.index("</section>")]
    assert '<a href="lqr-gain/lqr-gain.png"' in lqr
    assert '<a href="lqr-gain/poster/continuous.png"' in lqr
    assert (synthetic / "lqr-gain" / "poster" / "continuous.png").is_file()
    assert "mwip animate OUT/lqr-gain --run continuous" in lqr


def test_report_command_compares_with_another_reading(synthetic, tmp_path, capsys):
    assert main(["report", "--out", str(synthetic)]) == 0  # finds OUT/compare-literal
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("(damping reading units; literal reading: 2 of 4)")
    page = (synthetic / "index.html").read_text()
    assert "literal reading" in page and (synthetic / "lqr-gain/poster/continuous.png").is_file()
    other = _synthetic(tmp_path / "other", "literal", {("do-comparison", "order"): True})
    assert main(["report", "--out", str(synthetic), "--compare", str(other)]) == 0
    assert capsys.readouterr().out.splitlines()[0].endswith("literal reading: 2 of 4)")
    assert main(["report", "--out", str(synthetic), "--compare", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--compare" in err[0]


@pytest.mark.parametrize("reading", ["units", "literal"])
def test_reproduce_runs_the_other_damping_reading_too(tmp_path, monkeypatch, capsys, reading):
    """The verdicts of each reading come from a run on that reading's robot."""
    from mwip.studies import registry
    from mwip.studies.study import Study

    def study(ctx):
        folder = ctx.out.parent
        dw = float(ctx.plant.Dw)  # units: 1.28e-3, literal: 0.8 N m s/rad
        holds = dw < 0.01
        claim = {"id": "speed", "text": "the robot reaches -7 rad/s", "holds": holds,
                 "book": True}  # fmt: skip
        if not holds:
            claim |= {"cause": "damping-reading", "evidence": f"Dw = {dw:g} caps the speed."}
        (folder / "lqr-gain").mkdir(parents=True)
        doc = {"study": "lqr-gain", "source": "x", "claims": [claim], "runs": {}, "metrics": {},
               "published": {}, "settings": {}}  # fmt: skip
        (folder / "lqr-gain" / "metrics.json").write_text(json.dumps(doc))
        return doc

    declared = {"lqr-gain": Study("lqr-gain", "x", study, place=(1,))}
    monkeypatch.setattr(registry, "_discover", lambda: declared)
    out = tmp_path / "out"
    assert main(["reproduce", "--quick", "--out", str(out), "-j", "1", "--damping", reading]) == 0
    other = "literal" if reading == "units" else "units"
    first = capsys.readouterr().out.splitlines()[0]
    mine, theirs = (1, 0) if reading == "units" else (0, 1)
    assert first == (f"Book claims: {mine} of 1 reproduce (damping reading {reading}; "
                     f"{other} reading: {theirs} of 1)")  # fmt: skip
    assert json.loads((out / f"compare-{other}" / "run.json").read_text())["damping"] == other
    assert json.loads((out / "run.json").read_text())["damping"] == reading
    assert f"{other} reading" in (out / "index.html").read_text()
    assert main(["reproduce", "--quick", "--out", str(tmp_path / "b"), "--no-compare"]) == 0
    assert not list((tmp_path / "b").glob("compare-*"))


def test_html_has_a_section_figure_and_tables_per_study(quick_reproduction):
    out, _, _ = quick_reproduction
    page = (out / "index.html").read_text()
    assert "http://" not in page and "https://" not in page and "<script" not in page
    assert (out / "index.html").stat().st_size < 1_000_000  # issue 25: under 1 MB
    for res in load_results(out):
        start = page.index(f'<section class="study" id="{res.name}">')
        section = page[start : page.index("</section>", start)]
        poster = 1 if (res.folder / "poster").is_dir() else 0
        assert section.count("<img ") == len(res.figures) + poster
        for src in re.findall(r'<img [^>]*src="([^"]+)"', section):
            assert (out / src).is_file(), src  # linked, not embedded (issue 25)
        assert len(res.figures) >= 1
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
    # (run's folder: reproduce would refuse it, issue 25)
    assert main(["run", "lqr-gain", "--quick", "--out", str(out), "-j", "1"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert (out / "lqr-gain" / "metrics.json").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_study_file_and_params_run_a_study_on_another_robot(tmp_path, capsys):
    robot = tmp_path / "robot.toml"
    robot.write_text('base = "real"\n[params]\nr = 0.05\nmb = 3.0\n')
    study = tmp_path / "study.toml"
    # [robot] file (a parameter file loads as a robot file's body) replaces [robot] params
    study.write_text('[study]\nname = "lqr-gain"\nquick = true\n[robot]\nfile = "robot.toml"\n')
    out = tmp_path / "out"
    assert main(["run", "--scenario", str(study), "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["params"]["plant"]["r"] == 0.05 and record["params"]["plant"]["mb"] == 3.0
    assert record["params"]["nominal (design)"]["r"] == 0.03
    study.write_text('[study]\nname = "lqr-gain"\n[robot]\nparms = "robot.toml"\n')
    assert main(["run", "--scenario", str(study), "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        f"mwip: error: study file {str(study)!r}: [robot] parms: unknown key; "
        "allowed: file, damping"
    )


def test_report_command_rebuilds_the_page(quick_reproduction, tmp_path, capsys):
    out, _, _ = quick_reproduction
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    (copy / "index.html").unlink()
    assert main(["report", "--out", str(copy)]) == 0
    assert (copy / "index.html").is_file()
    assert capsys.readouterr().out.startswith("Book claims: ")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["report", "--out", str(empty)]) == 2


def _browse(index: Path, studies: list[str], shot: str) -> None:
    """Render ``index`` in headless Chromium at 1280 px and at a phone's 390 px: the headline
    is the book-claim count; every study has its section, decoded images and claims table;
    each image is shown at most 1.25x smaller than drawn (at 1280 px) and links to its
    full-size file; no text under 10 px; no console error or failed request. Screenshots go
    to ``ARTIFACTS/<shot>.png`` and ``<shot>-phone.png``."""
    import re

    if CHROMIUM is None:
        pytest.skip("headless Chromium not found: apt-get install chromium (.ci/run does)")
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="playwright not installed: pip install -e '.[test]'"
    )
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    errors: list[str] = []
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync"],
        )  # fmt: skip
        for width, suffix in ((1280, ""), (390, "-phone")):
            page = browser.new_page(viewport={"width": width, "height": 1400})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))
            page.goto(index.resolve().as_uri())
            page.wait_for_load_state("load")
            assert page.title() == "mwip: reproduction report"
            head = page.locator("#headline").inner_text()
            assert re.fullmatch(r"Book claims: \d+ of \d+ reproduce( \(.*\))?", head), head
            assert page.locator("#book-claims table.bookclaims").count() == 1
            assert page.locator("#overview tr").count() == len(studies) + 1
            for name in studies:
                section = page.locator(f"section#{name}")
                assert section.count() == 1, name
                assert section.locator("img").count() >= 1, name
                assert section.locator("table.claims tr").count() >= 2, name
            images = page.evaluate(
                "Array.from(document.images).map(i => ({alt: i.alt, complete: i.complete,"
                " natural: i.naturalWidth, shown: i.getBoundingClientRect().width,"
                " href: i.closest('a') && i.closest('a').getAttribute('href')}))"
            )
            assert images
            for img in images:
                assert img["complete"] and img["natural"] > 0, img
                assert img["href"] and (index.parent / img["href"]).is_file(), img
                if width == 1280:  # drawn for the width it is shown at
                    assert img["natural"] / img["shown"] <= 1.25, img
            smallest = page.evaluate(
                "Math.min(...Array.from(document.querySelectorAll('p,td,th,figcaption,code,a,"
                "summary')).filter(e => e.offsetParent).map(e =>"
                " parseFloat(getComputedStyle(e).fontSize)))"
            )
            assert smallest >= 10, smallest
            page.screenshot(path=str(ARTIFACTS / f"{shot}{suffix}.png"), full_page=False)
            page.close()
        browser.close()
    assert errors == []
    assert (ARTIFACTS / f"{shot}.png").stat().st_size > 10_000


def test_synthetic_report_renders_in_headless_chromium(synthetic):
    from mwip.report import write_report

    _browse(write_report(synthetic), list(CLAIMS), "report-synthetic")


def test_report_renders_in_headless_chromium(quick_reproduction):
    out, _, _ = quick_reproduction
    _browse(out / "index.html", list(STUDIES), "report")


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


def test_study_figures_are_drawn_for_the_width_the_report_shows(tmp_path):
    """At most 1440 px wide; no text under 10 px once shrunk to the report's 1200 px."""
    from matplotlib.figure import Figure
    from matplotlib.text import Text
    from PIL import Image

    from mwip.studies.common import save_figure

    for width_in, dpi in ((14.0, 1440 / 14.0), (9.0, 120.0)):
        fig = Figure(figsize=(width_in, 5))
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1], label="a")
        ax.legend(fontsize=6)
        ax.tick_params(labelsize=5)
        ax.set_title("t", fontsize=12)
        path = tmp_path / f"fig-{width_in:g}.png"
        save_figure(fig, path)
        with Image.open(path) as im:
            assert im.size[0] == round(width_in * dpi) <= 1440
        shrink = max(1.0, width_in * dpi / 1200)
        sizes = [t.get_fontsize() * dpi / 72 / shrink for t in fig.findobj(Text) if t.get_text()]
        assert min(sizes) >= 10.0 - 1e-9
        assert max(sizes) == pytest.approx(12 * dpi / 72 / shrink)  # larger text untouched


def test_an_evidence_text_is_shown_once_per_study() -> None:
    """Issue 25: the same evidence paragraph repeated six times per study; now once, and the
    later claims refer to it."""
    from mwip.report.html import _claims_table
    from mwip.report.results import StudyResult

    text = "Every run fell within 0.4 s on the twin: no number to compare."
    claims = [{"id": f"c{i}", "text": f"claim {i}", "book": True, "holds": False,
               "cause": "twin", "evidence": text} for i in range(3)]  # fmt: skip
    claims.append({"id": "c3", "text": "claim 3", "book": True, "holds": False,
                   "cause": "twin", "evidence": "another text"})  # fmt: skip
    html_ = _claims_table(StudyResult("exp-x", Path("."), {"claims": claims}), None)
    assert html_.count(text) == 1 and html_.count("(the same evidence as above)") == 2
    assert "another text" in html_


def test_the_twin_tables_give_every_column_a_unit() -> None:
    from mwip.hardware.sensitivity import payload_sensitivity, stick_sensitivity
    from mwip.params import REAL
    from mwip.report.html import _unit

    for rows in (payload_sensitivity(base=REAL), stick_sensitivity(plant=REAL.with_payload())):
        for key in rows[0]:
            assert _unit(key).startswith(" ["), key
