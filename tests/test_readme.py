"""Every command line of the README and of the docs' command blocks runs as printed, at small
sizes (issue 40, item 3).

The lines are read from the pages themselves (the README's set-up and "Use" blocks, every
```` ```bash ```` block of docs/, and the plain blocks whose lines start with ``mwip`` or
``PYTHONPATH=src .venv/bin/python -m mwip``), so a line added to a page is run here or the
test names it. Each page runs in order in a fresh folder holding a copy of ``examples/``
(the pages' relative paths are the clone's), through :func:`mwip.cli.main` in this process
(``> FILE`` written from the captured output). "At small sizes" is a fixed, named list of
options appended to a line (:data:`SMALL`: ``--quick``, ``--samples``, ``--trials``, ``--jobs
1``, ...), or put in place of the value of the same option where the line gives one (an
option may be given once); nothing else is changed.

Expected outcomes other than success are named too: a line whose point is a fall says so
beside it on the page (exit 1), and a line that needs the user's own inputs (logs of their
robot, another results folder) ends with one line ``mwip: error: ...`` and exit 2. Lines that
cannot run here (a Dask cluster at ``tcp://host``, the test suite itself) are listed in
:data:`NOT_RUN` with the reason.
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
import shutil
from pathlib import Path

import pytest

from mwip.cli import main

ROOT = Path(__file__).resolve().parents[1]

#: Options appended to a line (matched by its start) to run it at a small size.
SMALL: dict[str, list[str]] = {
    "mwip reproduce": ["--quick", "--jobs", "1"],
    "mwip run ": ["--quick", "--jobs", "1"],
    "mwip campaign run robustness": ["--samples", "20", "--jobs", "1"],
    "mwip campaign run claims": ["--samples", "1", "--jobs", "1"],
    "mwip campaign run mine.toml --out runs/mine --samples": ["--samples", "20"],
    "mwip campaign run mine.toml --out runs/mine --jobs 1": ["--samples", "20"],
    "mwip tune ": ["--trials", "1"],
    "mwip bench": ["--quick", "--jobs", "1"],
    "mwip twin calibrate book --out": ["--draws", "4", "--kernel-draws", "2", "--duration", "1",
                                       "--directed-draws", "2",
                                       "--structures", "S0,S1"],  # fmt: skip
    "mwip twin calibrate book --record": ["--samples", "4", "--stage2-draws", "0",
                                          "--chain-steps", "0", "--mixture-draws", "0",
                                          "--duration", "1"],  # fmt: skip
    "mwip twin calibrate examples/my_robot_facts.toml": ["--draws", "12", "--kernel-draws", "6",
                                                         "--duration", "2"],  # fmt: skip
    "mwip export c": ["--duration", "1"],
    "mwip animate": ["--fps", "2"],
}
#: Lines whose exit code is not 0, and why (the page says so beside the line).
EXPECT: dict[str, tuple[int, str]] = {
    "mwip twin fit log1.csv log2.parquet --out fit": (2, "log1.csv"),  # your robot's logs
    "mwip twin fit static_and_stand.csv --validate other_day.csv --out myrobot":
        (2, "static_and_stand.csv"),  # fmt: skip
    "mwip report --out out --compare other": (2, "other"),  # another results folder of yours
}
#: Lines not run here, and why.
NOT_RUN: dict[str, str] = {
    "mwip campaign run mine.toml --out runs/mine --scheduler tcp://host:8786":
        "needs a Dask cluster at tcp://host:8786",  # fmt: skip
    "mwip run exp-asta --robot myrobot/robot.toml": "needs the robot fitted from your logs",
}
#: Files a page takes as the reader's own, made here before its lines run.
GIVEN: dict[str, dict[str, str]] = {
    "docs/bench.md": {
        "best.toml": '[controller]\nname = "hodosmc"\n[settings]\nK = [8.0, 5.0]\n',
        "mine.toml": "@examples/balance.toml",
    },
    "docs/export.md": {"my_robot.toml": "@examples/my_robot.toml"},
}
PAGES = ["README.md", "docs/bench.md", "docs/campaigns.md", "docs/export.md", "docs/robot.md",
         "docs/tune.md", "docs/twin.md", "docs/twin_fit.md"]  # fmt: skip
_PREFIX = re.compile(r"^PYTHONPATH=src \S*python -m (mwip|pytest)\b")


def command_lines(page: str) -> list[str]:
    """The command lines of ``page``, comments and line continuations removed, ``PYTHONPATH=src
    .venv/bin/python -m mwip`` written ``mwip``."""
    text = (ROOT / page).read_text(encoding="utf-8")
    out = []
    for lang, body in re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M):
        if lang not in ("bash", ""):
            continue
        for line in body.replace("\\\n", " ").splitlines():
            line = _PREFIX.sub(lambda m: m.group(1), line.strip())
            parts: list[str] = []
            for cmd in line.split(" && "):
                words = shlex.split(cmd, comments=True)
                if words and words[0] == "mwip":
                    parts.append(shlex.join(words).replace("'>'", ">"))
            out.extend(parts)
    return out


def test_every_page_has_commands_and_every_named_line_exists():
    found = {line for page in PAGES for line in command_lines(page)}
    assert {p: len(command_lines(p)) for p in PAGES if not command_lines(p)} == {}
    for line in [*EXPECT, *NOT_RUN]:
        assert line in found, f"{line!r} is no longer on a page: remove it here"


#: Short names of the options :data:`SMALL` sets.
_ALIASES = {"-j": "--jobs"}


def small(words: list[str], extra: list[str]) -> list[str]:
    """``words`` with the options ``extra`` of :data:`SMALL`: an option the line already gives
    takes the small value in its place (an option may be given once), the others are
    appended."""
    words, tail = list(words), []
    i = 0
    while i < len(extra):
        opt = extra[i]
        has_value = i + 1 < len(extra) and not extra[i + 1].startswith("--")
        at = next((j for j, w in enumerate(words) if _ALIASES.get(w, w) == opt), None)
        if at is not None and has_value:
            words[at + 1] = extra[i + 1]
        elif at is None:
            tail += extra[i : i + 1 + has_value]
        i += 1 + has_value
    return words + tail


def _run(line: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    words = shlex.split(line)
    target = None
    if ">" in words:  # `mwip ... > FILE`: the printed output into FILE
        target, words = words[words.index(">") + 1], words[: words.index(">")]
    extra = next((v for k, v in SMALL.items() if line.startswith(k)), [])
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(small(words, extra)[1:])
    err = capsys.readouterr().err
    if target is not None:
        Path(target).write_text(buf.getvalue(), encoding="utf-8")
    return code, buf.getvalue(), err


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES)
def test_every_command_line_runs_as_printed(page, tmp_path, monkeypatch, capsys):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    for name, content in GIVEN.get(page, {}).items():
        source = content[1:] if content.startswith("@") else None
        text = (ROOT / source).read_text() if source else content
        (tmp_path / name).write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "100")
    failures = []
    for line in command_lines(page):
        if line in NOT_RUN:
            continue
        if line.startswith("mwip animate") and line.rstrip().endswith("--speed 2") \
                and shutil.which("ffmpeg") is None:  # fmt: skip
            expected: tuple[int, str] = (2, "ffmpeg")
        else:
            expected = EXPECT.get(line, (0, ""))
        code, out, err = _run(line, capsys)
        errors = [e for e in err.splitlines() if e.startswith("mwip: error")]
        if code != expected[0]:
            failures.append(f"{line}: exit {code} (expected {expected[0]}): {err[-300:]}")
        elif code == 2 and (len(errors) != 1 or expected[1] not in errors[0]):
            failures.append(f"{line}: not one error line naming {expected[1]!r}: {err[-300:]}")
        elif "Traceback" in err or "internal error" in err:
            failures.append(f"{line}: {err[-300:]}")
    assert failures == []


def test_a_fall_on_the_readme_is_said_beside_its_line():
    """A README line that exits 1 by design says so in its comment (or the next line's)."""
    text = (ROOT / "README.md").read_text()
    for line, (code, word) in EXPECT.items():
        if code != 1:
            continue
        at = text.index(line)
        beside = text[at : text.index("\n", text.index("\n", at) + 1)]
        assert word in beside and "exit 1" in beside, beside
