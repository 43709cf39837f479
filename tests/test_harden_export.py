"""Hardening (issue 26, items 2 and 3): ``mwip export c`` follows the output-folder rule of every
other command and ``--verify`` leaves no temporary folder; a constant that C cannot hold (one
that overflows ``float``, a huge or tiny one in ``double``) is refused naming the setting."""

from __future__ import annotations

import shutil
import tempfile

import pytest

from mwip.cli import main
from mwip.export.c_code import ExportError, generate_c
from mwip.export.transpile import c_literal
from mwip.laws.registry import get
from mwip.outdir import MARKER
from mwip.params import NOMINAL

HAVE_CC = shutil.which("cc") is not None or shutil.which("gcc") is not None


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


def test_a_users_file_is_never_overwritten(tmp_path, capsys):
    board = tmp_path / "board"
    board.mkdir()
    (board / "mwip_lqr.c").write_text("mine")
    assert main(["export", "c", "--controller", "lqr", "--out", str(board)]) == 2
    line = _err_line(capsys)
    assert "--out" in line and "--force" in line and "not empty" in line
    assert (board / "mwip_lqr.c").read_text() == "mine"
    assert sorted(p.name for p in board.iterdir()) == ["mwip_lqr.c"]


def test_root_and_the_empty_name_are_refused(capsys):
    for out in ("/", ""):
        assert main(["export", "c", "--controller", "lqr", "--out", out]) == 2
        assert "--out" in _err_line(capsys)


def test_new_own_and_forced_folders_are_written(tmp_path, capsys):
    out = tmp_path / "new" / "deep"
    assert main(["export", "c", "--controller", "lqr", "--out", str(out)]) == 0
    assert (out / MARKER).is_file() and (out / "mwip_lqr.c").is_file()
    assert main(["export", "c", "--controller", "lqr", "--out", str(out)]) == 0  # its own
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("x")
    assert main(["export", "c", "--controller", "lqr", "--out", str(mine), "--force"]) == 0
    assert (mine / "notes.txt").read_text() == "x" and (mine / "mwip_lqr.h").is_file()
    capsys.readouterr()


@pytest.mark.parametrize(
    "sets, single, why",
    [
        (["rate=1e40,1e40"], True, "1e+06"),  # the case (now beyond the setting's range)
        (["rate=1e20,1"], True, "1e+06"),
        (["rate=1e300,1e300"], False, "1e+06"),
        (["rate=1e-320,1"], False, "C constant"),  # subnormal
        (["rate=1e-40,1"], True, "C constant"),  # flushed to zero in float
    ],
)
def test_constants_c_cannot_hold_are_refused_naming_the_setting(sets, single, why, tmp_path,
                                                                 capsys):  # fmt: skip
    argv = ["export", "c", "--controller", "asta", "--out", str(tmp_path / "b")]
    argv += [a for s in sets for a in ("--set", s)] + (["--float"] if single else [])
    assert main(argv) == 2
    line = _err_line(capsys)
    assert "--set" in line and "rate" in line and why in line
    assert not (tmp_path / "b").exists()


def test_c_literal_and_generate_c_refuse_what_c_cannot_hold():
    assert c_literal(3.0e38, "double") == "3e+38"
    for x, p in ((3.0e38, "float"), (float("inf"), "double"), (1e200, "double")):
        with pytest.raises(ValueError, match="C"):
            c_literal(x, p)
    assert c_literal(0.0, "float") == "0.0f"
    from mwip.laws.asta.controller import ASTA

    ctrl = ASTA(NOMINAL, rate=(1e30, 1e30), Ts=0.005)  # the API allows what --set does not
    with pytest.raises(ExportError, match="float C constant"):
        generate_c(ctrl, precision="float")


@pytest.mark.skipif(not HAVE_CC, reason="needs a C compiler")
def test_accepted_float_settings_compile_with_werror(tmp_path):
    """A constant near the largest accepted one compiles under -Werror (the check is the C
    rule), as does the largest value --set accepts."""
    from mwip.export.sil import compile_c
    from mwip.laws.asta.controller import ASTA

    compile_c(generate_c(ASTA(NOMINAL, rate=(1e18, 1e18), Ts=0.005), prefix="big",
                         precision="float"), tmp_path / "a")  # fmt: skip
    ctrl = get("asta").build(NOMINAL, {"rate": "1e6,1e6"}, 0.005)
    compile_c(generate_c(ctrl, prefix="big", precision="float"), tmp_path / "b")


@pytest.mark.skipif(not HAVE_CC, reason="needs a C compiler")
def test_verify_leaves_no_temporary_folder(tmp_path, monkeypatch, capsys):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    out = tmp_path / "o"
    assert main(["export", "c", "--controller", "lqr", "--out", str(out), "--verify",
                 "--duration", "0.2"]) == 0  # fmt: skip
    assert "software in the loop" in capsys.readouterr().out
    assert list(tmp.iterdir()) == []

