"""Hardening round 3 (issue 39, item 2): every file mwip writes is escaped for its format.

Each writer is fed names and values with newlines, quotes, brackets, control characters and
(where numbers go) non-finite numbers, and the file it writes must load back with its own
format's reader, holding the same names and values (or, for a number JSON cannot hold,
``null``): the audit's case was a log named ``x\\ndelay = 0.99`` whose name, written into
the fit's file's header (then ``twin.toml``, now ``robot.toml``), became a TOML line (the fit
exited 0 with a file mwip then refused).
"""

from __future__ import annotations

import csv
import io
import json
import math
import tomllib
from html.parser import HTMLParser

import numpy as np
import pytest

from mwip.cli import main
from mwip.io import (
    html_text,
    json_text,
    toml_comment,
    toml_key,
    toml_str,
    write_json_atomic,
)

#: names and values that break a format written without escaping
NASTY = [
    "plain",
    'quote " and \' apostrophe',
    "back\\slash",
    "new\nline = 1",
    "x\ndelay = 0.99\n[twin]\n",
    "cr\r\nlf",
    "[bracket]] [[table]]",
    "tab\tand \x00 nul \x1b[31m escape \x7f del \x0b\x0c",
    "<script>alert('x')</script> & &amp;",
    "ünïcödé \u2028 line separator",
    "# not a comment",
    "",
]


def _strict_json(text: str) -> object:
    def refuse(name: str) -> float:
        raise AssertionError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


# ---- JSON ---------------------------------------------------------------------------------------
def test_json_has_no_nan_or_infinity_and_keeps_every_string(tmp_path):
    doc = {
        "values": [math.nan, math.inf, -math.inf, 1.5, np.float64("nan"), np.float32(2.5)],
        "array": np.array([[1.0, np.nan], [np.inf, 3.0]]),
        "names": {s: s for s in NASTY},
        7: (math.nan, "x"),
    }
    path = write_json_atomic(tmp_path / "a.json", doc)
    back = _strict_json(path.read_text(encoding="utf-8"))
    assert back["values"] == [None, None, None, 1.5, None, 2.5]
    assert back["array"] == [[1.0, None], [None, 3.0]]
    assert back["names"] == {s: s for s in NASTY}
    assert back["7"] == [None, "x"]
    assert _strict_json(json_text(math.nan)) is None


def test_cli_json_output_has_no_nan(capsys):
    """What the commands print with ``--json`` goes through the same writer."""
    assert main(["simulate", "--duration", "0.05", "--json"]) in (0, 1)
    _strict_json(capsys.readouterr().out)
    assert main(["design", "lqr", "--json"]) == 0
    _strict_json(capsys.readouterr().out)


# ---- TOML ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("text", NASTY)
def test_toml_strings_keys_and_comments_read_back(text):
    doc = f"{toml_comment(text)}\nk = {toml_str(text)}\n{toml_key(text or 'e')} = 1\n"
    back = tomllib.loads(doc)
    assert back == {"k": text, text or "e": 1}


@pytest.mark.parametrize("text", NASTY[1:-1])
def test_settings_file_escapes_names_values_and_comments(tmp_path, text):
    from mwip.schema.settings import read_settings_file, write_settings_file

    path = write_settings_file(tmp_path / "s.toml", "hodosmc", {"K": [7.5, 3.25], text: text,
                                                                "phi": 0.04},
                               comment=f"mwip tune: {text}", label=text.strip() or "x")  # fmt: skip
    sf = read_settings_file(path)
    assert sf.name == "hodosmc" and sf.label == (text.strip() or "x")
    assert sf.settings_dict() == {"K": [7.5, 3.25], text: text, "phi": 0.04}
    assert "delay" not in tomllib.loads(path.read_text(encoding="utf-8"))


def test_settings_file_refuses_non_finite_numbers(tmp_path):
    from mwip.schema.settings import write_settings_file

    for bad in (math.nan, math.inf, [1.0, -math.inf]):
        with pytest.raises(ValueError, match="finite"):
            write_settings_file(tmp_path / "s.toml", "hodosmc", {"K": bad})
    assert not (tmp_path / "s.toml").exists()


def test_robot_file_escapes_the_text_it_writes(tmp_path):
    """A robot file's words (a prior entry's unit and source, the robot's notes) with
    newlines, quotes and control characters are written escaped: the file reads back to the
    same robot (the twin file is gone: the robot file holds the twin)."""
    from mwip.robot import load_robot, robot_to_toml, save_robot

    default = tmp_path / "default.toml"
    default.write_text(robot_to_toml(_default_robot()), encoding="utf-8")
    base = load_robot(default)
    entries = base.prior.to_dict()
    name = next(iter(entries))
    text = "\n".join(NASTY[1:-1])
    edited = tomllib.loads(default.read_text(encoding="utf-8"))
    edited["prior"][name]["source"] = text
    edited["robot"]["notes"] = text
    import tomli_w

    src = tmp_path / "edited.toml"
    src.write_text(tomli_w.dumps(edited), encoding="utf-8")
    robot = load_robot(src)
    assert robot.prior.to_dict()[name]["source"] == text and robot.notes == text
    save_robot(robot, tmp_path / "again.toml")
    again = load_robot(tmp_path / "again.toml")
    assert again.prior.to_dict()[name]["source"] == text and again.notes == text
    assert again == robot


def _default_robot():  # noqa: ANN202
    from mwip.robot import default_robot

    return default_robot()


def test_twin_fit_writes_log_names_as_text(tmp_path):
    """The audit: a log named ``x\\ndelay = 0.99`` injected ``delay = 0.99`` into the fit's
    file (now robot.toml, where the log names are the notes' and the provenance's text)."""
    from mwip.identify import excite, synth
    from mwip.robot import load_robot

    t, duty, mode = excite.schedule(static=0.3, step=0.06, chirp=0.5)
    truth = synth.draw_truth(7)
    name = 'x\ndelay = 0.99\n[twin.drive]\ngear_ratio = 1e9\n"\x1b.csv'
    p = synth.write_csv(tmp_path / name, synth.stand_log(truth, duty, mode, seed=7))
    out = tmp_path / "fit"
    assert main(["twin", "fit", str(p), "--out", str(out), "--fix", "firmware.delay=0.5"]) == 0
    text = (out / "robot.toml").read_text(encoding="utf-8")
    robot = load_robot(out / "robot.toml")  # reads back: nothing injected
    assert robot.twin.firmware.delay == 0.5 and robot.twin.drive.gear_ratio < 1000
    assert name in robot.notes  # the name is text, whole
    tables = tomllib.loads(text)
    assert "twin" not in tables and "delay" not in tables["robot"]
    header = text.split("[robot]")[0]
    assert all(line.startswith("#") or not line for line in header.splitlines()), header
    assert _strict_json((out / "fit.json").read_text())["logs"][0]["file"] == name


# ---- CSV ----------------------------------------------------------------------------------------
def test_tune_trials_csv_quotes_names_and_drops_non_finite_numbers():
    from types import SimpleNamespace

    from mwip.tune.run import _csv
    from mwip.tune.space import Dim, Space

    names = NASTY[1:-1]
    space = Space("x", tuple(Dim(n, n, None, 0.1, 1.0, False, 0.5) for n in names))
    plan = SimpleNamespace(space=space, objective=SimpleNamespace(n_objectives=2))
    rows = [{"number": 0, "state": "COMPLETE", "values": [0.5, math.nan],
             "success_rate": math.inf, "params": {n: 0.25 for n in names}}]  # fmt: skip
    back = list(csv.reader(io.StringIO(_csv(rows, plan))))  # type: ignore[arg-type]
    assert back[0] == ["number", "state", "value0", "value1", "success_rate", *names]
    assert back[1] == ["0", "COMPLETE", "0.5", "", "", *["0.25"] * len(names)]


def test_excite_csv_reads_back(tmp_path):
    f = tmp_path / "ex.csv"
    assert main(["twin", "excite", "--out", str(f), "--static", "0.1", "--step", "0.02",
                 "--chirp", "0.1"]) == 0  # fmt: skip
    rows = list(csv.DictReader(f.open()))
    assert rows and all(math.isfinite(float(r["duty_r"])) for r in rows)


# ---- HTML ---------------------------------------------------------------------------------------
class _Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)

    def handle_data(self, data):
        self.text.append(data)


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    page.close()
    return page


def _check_page(text: str, names: list[str]) -> None:
    page = _parse(text)
    assert "script" not in page.tags, "markup injected"
    assert not any(ord(c) < 0x20 and c not in "\t\n\r" for c in text), "control character"
    body = "".join(page.text)
    for n in names:
        shown = html_text(n)  # the visible form: markup as text, control characters as \xNN
        assert _parse(shown).text == [] or "".join(_parse(shown).text) in body, n


def test_html_text_escapes_markup_and_control_characters():
    for s in NASTY:
        page = _parse(f"<p title='{html_text(s)}'>{html_text(s)}</p>")
        assert page.tags == ["p"]


def test_tune_page_escapes(tmp_path):
    from mwip.tune.page import write_page

    names = NASTY[1:-1]
    summary = {n: n for n in names}
    summary["value"] = math.nan
    val = {n: {"robots": 2, "book": _val_row(), "tuned": _val_row(),
               "difference": {"success_rate": 0.0, "interval": [0.0, 0.0]}}
           for n in names[:2]}  # fmt: skip
    write_page(tmp_path, title="\n".join(names), summary=summary, trials=[], labels=["a", "b"],
               importances={}, validation=val, best_settings={n: 1.0 for n in names})  # fmt: skip
    _check_page((tmp_path / "index.html").read_bytes().decode("utf-8"), names)


def _val_row() -> dict:
    return {"successes": 1, "robots": 2, "success_rate": 0.5, "success_interval": [0.1, 0.9],
            "cost": math.nan, "terms": {"rms_theta": {"mean": math.nan,
                                                      "interval": [math.nan, math.nan]}}}


def test_bench_page_escapes_an_entrants_label(tmp_path):
    """A settings file's label is any text: it reaches the leaderboard page escaped."""
    import tomllib as tl

    from mwip.bench.entrants import resolve_entrants
    from mwip.bench.finish import run_bench
    from mwip.bench.run import BenchRun
    from mwip.bench.spec import parse_bench
    from mwip.schema.settings import write_settings_file

    label = "<b>bold</b> \"q\" 'a'\n[x] \x1b &amp;"
    f = write_settings_file(tmp_path / "s.toml", "dlqr", {}, label=label)
    spec = parse_bench(tl.loads('[bench]\nseed = 5\nsamples = 2\nduration = 0.3\nblock = 4\n'
                                '[[axis]]\nname = "nominal"\n[[axis.level]]\nlabel = "twin"\n'))
    work = BenchRun(spec, resolve_entrants(["lqr"], [f]))
    run_bench(work, tmp_path / "out", jobs=1, progress=lambda *a: None)
    page = (tmp_path / "out" / "index.html").read_bytes().decode("utf-8")
    _check_page(page, [label])
    assert "<b>" not in page


def test_campaign_report_escapes_title_and_labels(tmp_path):
    title = "T <i>x</i>\n\x1b[1m \"q\""
    label = "L <script>x</script> [y]\n\x07"
    camp = tmp_path / "c.toml"
    camp.write_text("[campaign]\n" + f"title = {toml_str(title)}\n"
                    "samples = 2\nblock = 2\nduration = 0.2\nsensors = \"ideal\"\n"
                    f"[[controllers]]\nname = \"lqr\"\nlabel = {toml_str(label)}\n")  # fmt: skip
    out = tmp_path / "out"
    assert main(["campaign", "run", str(camp), "--out", str(out), "--jobs", "1"]) == 0
    assert main(["campaign", "report", str(out)]) == 0
    _check_page((out / "report.html").read_bytes().decode("utf-8"), [title, label])
