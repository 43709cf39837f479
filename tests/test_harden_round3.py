"""Hardening round 3 (issue 39, items 4, 7 and 8): the audit's silent acceptances, sizes and
internal errors of the newer commands, each as the class it stands for.

- No option silently ignored: options of the other mode of ``twin fit``, an option given
  twice (any command), a non-finite number (any command), empty files and lists, text for a
  list of numbers, an empty ``--scheduler``, ``--free ''``;
- sizes before work: ``twin excite``, campaigns and benchmarks (hours of one core);
- internal errors: a C compiler that fails, a UTF-8 BOM, ``MemoryError`` (bad input: exit 2);
- the API raises its own kinds (``TypeError`` / ``ValueError`` naming the argument).

Every refusal: exit 2 (1 for the machine's failures), one line, no traceback, nothing written.
"""

from __future__ import annotations

import math
import os

import click
import pytest

from mwip.cli import cli, main


def _refused(capsys, argv: list[str], needle: str, code: int = 2) -> str:
    got = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert got == code, (argv, err)
    assert len(err) == 1 and err[0].startswith("mwip: error:"), err
    assert "Traceback" not in err[0] and needle in err[0], (needle, err[0])
    return err[0]


# ---- 4. no option silently ignored ---------------------------------------------------------------
@pytest.mark.parametrize(
    "extra",
    [["--structures", "S0"], ["--draws", "3"], ["--kernel-draws", "0"],
     ["--directed-draws", "0"]],
)  # fmt: skip
def test_the_record_refuses_the_comparison_options(tmp_path, capsys, extra):
    """The audit: the calibration of record (then --evidence book) dropped options silently
    and started hours of work."""
    out = tmp_path / "cal"
    _refused(capsys, ["twin", "calibrate", "book", "--record", "--out", str(out), *extra],
             f"{extra[0]}: not used by --record")  # fmt: skip
    assert not out.exists()


@pytest.mark.parametrize(
    "extra",
    [["--samples", "3"], ["--seed", "1"], ["--stage2-draws", "0"], ["--chain-steps", "0"],
     ["--mixture-draws", "0"], ["--envelope-draws", "0"]],
)  # fmt: skip
def test_the_comparison_refuses_the_record_options(tmp_path, capsys, extra):
    _refused(capsys, ["twin", "calibrate", "book", "--out", str(tmp_path / "o"), *extra],
             f"{extra[0]}: only used with --record")  # fmt: skip
    assert not (tmp_path / "o").exists()


def _single_valued_options() -> list[tuple[list[str], str, str]]:
    """(command path, option, a value) of every option taking one value, in every command."""
    out = []

    def walk(cmd: click.Command, path: list[str]) -> None:
        if isinstance(cmd, click.Group):
            for name, sub in sorted(cmd.commands.items()):
                walk(sub, [*path, name])
            return
        for p in cmd.params:
            if (isinstance(p, click.Option) and not p.multiple and not p.is_flag
                    and not p.count and p.nargs == 1):  # fmt: skip
                out.append((path, max(p.opts, key=len), "1"))

    walk(cli, [])
    return out


@pytest.mark.parametrize(("path", "opt", "value"), _single_valued_options(),
                         ids=lambda x: x if isinstance(x, str) else " ".join(x))  # fmt: skip
def test_an_option_given_twice_is_refused_in_every_command(tmp_path, capsys, monkeypatch, path,
                                                            opt, value):  # fmt: skip
    """The audit: a repeated --settings kept the last silently."""
    monkeypatch.chdir(tmp_path)
    _refused(capsys, [*path, opt, value, opt, value], f"{opt} is given twice")
    assert sorted(os.listdir(tmp_path)) == []


def _float_options() -> list[tuple[list[str], str]]:
    out = []

    def walk(cmd: click.Command, path: list[str]) -> None:
        if isinstance(cmd, click.Group):
            for name, sub in sorted(cmd.commands.items()):
                walk(sub, [*path, name])
            return
        for p in cmd.params:
            if isinstance(p, click.Option) and isinstance(p.type, click.types.FloatParamType):
                out.append((path, max(p.opts, key=len)))

    walk(cli, [])
    return out


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN"])
@pytest.mark.parametrize(("path", "opt"), _float_options(),
                         ids=lambda x: x if isinstance(x, str) else " ".join(x))  # fmt: skip
def test_non_finite_numbers_are_refused_in_every_command(tmp_path, capsys, monkeypatch, path,
                                                         opt, value):  # fmt: skip
    """The audit: --evidence book --duration nan ran, conditioned on 0 facts and wrote NaN."""
    monkeypatch.chdir(tmp_path)
    _refused(capsys, [*path, opt, value], "must be a finite number")
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.parametrize("free", ["", ",", " , "])
def test_an_empty_free_list_is_refused(tmp_path, capsys, free):
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    _refused(capsys, ["twin", "fit", str(log), "--free", free, "--out", str(tmp_path / "o")],
             "--free: is an empty list")  # fmt: skip


@pytest.mark.parametrize("fix", ["firmware.delay=nan", "firmware.delay=inf", "=1",
                                 "firmware.delay"])
def test_bad_fixes_are_refused(tmp_path, capsys, fix):
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    _refused(capsys, ["twin", "fit", str(log), "--fix", fix, "--out", str(tmp_path / "o")],
             "--fix")  # fmt: skip


@pytest.mark.parametrize(
    ("value", "words"),
    [('"7,3"', "got the text '7,3'"), ('"7"', "got the text '7'"), ('"0.1"', "got the text")],
)  # fmt: skip
@pytest.mark.parametrize("where", ["simulate", "bench", "export", "scenario"])
def test_text_for_numbers_in_a_settings_file_is_refused(tmp_path, capsys, value, words, where):
    """The audit: ``K = "7,3"`` (the command line's syntax, a string) was read as a list."""
    key = "phi" if value == '"0.1"' else "K"
    settings = tmp_path / "s.toml"
    settings.write_text(f'[controller]\nname = "hodosmc"\n[settings]\n{key} = {value}\n')
    scenario = tmp_path / "sc.toml"
    scenario.write_text(f'[scenario]\ncontroller = "hodosmc"\n[controller]\n{key} = {value}\n')
    argv = {"simulate": ["simulate", "--settings", str(settings)],
            "bench": ["bench", "--settings", str(settings), "--out", str(tmp_path / "o")],
            "export": ["export", "c", "--controller", "hodosmc", "--settings", str(settings),
                       "--out", str(tmp_path / "o")],
            "scenario": ["simulate", "--scenario", str(scenario)]}[where]  # fmt: skip
    _refused(capsys, argv, words)
    assert not (tmp_path / "o").exists()


def test_words_and_lists_in_a_settings_file_still_work(tmp_path, capsys):
    settings = tmp_path / "s.toml"
    settings.write_text('[controller]\nname = "hodosmc"\n[settings]\nK = [7.0, 3.0]\n'
                        'switching = "sign"\n')  # fmt: skip
    assert main(["simulate", "--settings", str(settings), "--duration", "0.05"]) in (0, 1)
    assert "error" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "needle"),
    [("", "is empty"), ("\n# only a comment\n", "is empty"),
     ("[objective]\nterms = []\n[robots]\nsamples = 8\nchunk = 8\n", "empty list"),
     ("[robots]\nsamples = 8\nchunk = 8\n[space]\ntune = []\n", "non-empty list"),
     ("[robots]\nsamples = 8\nchunk = 8\n[space]\nranges = {}\n", "empty table"),
     ("[objective]\nsuccess_theta = nan\n", "success_theta"),
     ("[robots]\nduration = inf\n", "robots.duration")],
)  # fmt: skip
def test_empty_and_non_finite_objective_files_are_refused(tmp_path, capsys, text, needle):
    """The audit: an empty objective file meant "every default"."""
    pytest.importorskip("optuna")
    obj = tmp_path / "o.toml"
    obj.write_text(text)
    _refused(capsys, ["tune", "hodosmc", "--objective", str(obj), "--out", str(tmp_path / "t")],
             needle)  # fmt: skip
    assert not (tmp_path / "t").exists()


def test_a_bom_is_named(tmp_path, capsys):
    for name, argv in (("p.toml", ["params", "show"]), ("c.toml", ["campaign", "run"])):
        f = tmp_path / name
        f.write_bytes(b"\xef\xbb\xbf" + b'[params]\nmb = 1.0\n')
        extra = ["--out", str(tmp_path / "o")] if argv[0] == "campaign" else []
        _refused(capsys, [*argv, str(f), *extra], "byte-order mark (BOM)")


# ---- 7. sizes before work ------------------------------------------------------------------------
def test_an_excitation_too_long_is_refused_before_it_is_made(tmp_path, capsys):
    """The audit: within the documented ranges, a MemoryError after 34 s."""
    out = tmp_path / "e.csv"
    _refused(capsys, ["twin", "excite", "--out", str(out), "--ts", "0.0001", "--static", "600",
                      "--step", "600", "--chirp", "600"], "--max-samples raises it")  # fmt: skip
    assert not out.exists()
    _refused(capsys, ["twin", "excite", "--out", str(out), "--max-samples", "10"],
             "more than 10")  # fmt: skip
    assert main(["twin", "excite", "--out", str(out), "--static", "0.1", "--step", "0.01",
                 "--chirp", "0.1", "--max-samples", "1000"]) == 0  # fmt: skip


def test_campaigns_and_benchmarks_state_their_hours(tmp_path, capsys):
    camp = tmp_path / "c.toml"
    camp.write_text('[campaign]\nsamples = 10000000\nblock = 100\nduration = 100\n'
                    '[[controllers]]\nname = "lqr"\n')  # fmt: skip
    line = _refused(capsys, ["campaign", "run", str(camp), "--out", str(tmp_path / "o")],
                    "hours of one core")  # fmt: skip
    assert "--max-hours" in line and not (tmp_path / "o").exists()
    _refused(capsys, ["bench", "--samples", "100000", "--out", str(tmp_path / "b")],
             "hours of one core")  # fmt: skip
    assert not (tmp_path / "b").exists()
    _refused(capsys, ["campaign", "run", str(camp), "--out", str(tmp_path / "o"),
                      "--max-hours", "-1"], "--max-hours")  # fmt: skip


def test_the_hours_limit_can_be_raised(tmp_path):
    from mwip.campaign.execute import check_work
    from mwip.campaign.spec import parse_campaign

    c = parse_campaign({"campaign": {"samples": 100_000, "block": 100, "duration": 100.0},
                        "controllers": [{"name": "lqr"}]})  # fmt: skip
    with pytest.raises(ValueError, match="more than 1 h"):
        check_work(c, 1, max_hours=1.0)
    check_work(c, 1, max_hours=10.0)


def test_memory_errors_are_bad_input(capsys):
    """What the machine cannot give is what the input asked: exit 2, one line."""
    from mwip.cli._errors import run_guarded

    @click.command()
    def greedy() -> None:
        raise MemoryError

    assert run_guarded(greedy, []) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "MemoryError" in err[0] and "reduce the sizes" in err[0]


# ---- 8. internal errors --------------------------------------------------------------------------
def test_a_failing_c_compiler_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CC", "/bin/false")
    out = tmp_path / "c"
    line = _refused(capsys, ["export", "c", "--controller", "lqr", "--out", str(out),
                             "--verify"], "the C compiler failed", code=1)  # fmt: skip
    assert "/bin/false" in line and "internal error" not in line


def test_bench_out_that_cannot_be_a_folder(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    _refused(capsys, ["bench", "lqr", "--quick", "--out", str(f / "sub")],
             "--out: cannot create the folder")  # fmt: skip
    _refused(capsys, ["bench", "lqr", "--quick", "--out", ""], "the name is empty")


# ---- the API's own exceptions --------------------------------------------------------------------
def _api_cases():
    from mwip.identify.excite import schedule
    from mwip.laws.registry import get
    from mwip.tune.evaluate import robot_set
    from mwip.tune.space import build_space

    spec = get("hodosmc")
    return {
        "schedule Ts": (lambda: schedule(Ts=math.nan), "Ts"),
        "schedule static": (lambda: schedule(static=-1.0), "static"),
        "schedule amplitude nan": (lambda: schedule(amplitude=math.nan), "amplitude"),
        "schedule amplitude -": (lambda: schedule(amplitude=-0.2), "amplitude"),
        "schedule f0": (lambda: schedule(f0=-1.0), "f0"),
        "schedule f1": (lambda: schedule(f1=math.inf), "f1"),
        "schedule f0 > f1": (lambda: schedule(f0=20.0, f1=10.0), "f0"),
        "schedule text": (lambda: schedule(step="0.1"), "step"),
        "schedule max": (lambda: schedule(max_samples=0), "max_samples"),
        "space spec": (lambda: build_space(None), "spec"),
        "space spec name": (lambda: build_space("hodosmc"), "spec"),
        "space tune": (lambda: build_space(spec, "K"), "tune"),
        "space tune empty": (lambda: build_space(spec, []), "tune"),
        "space ranges": (lambda: build_space(spec, None, [1]), "ranges"),
        "space ratio nan": (lambda: build_space(spec, ratio=math.nan), "ratio"),
        "space ratio -1": (lambda: build_space(spec, ratio=-1.0), "ratio"),
        "space ratio text": (lambda: build_space(spec, ratio="4"), "ratio"),
        "robots campaign": (lambda: robot_set(None, 8, 4, 0), "campaign"),
        "robots samples": (lambda: robot_set("robustness", -8, 4, 0), "samples"),
        "robots samples nan": (lambda: robot_set("robustness", math.nan, 4, 0), "samples"),
        "robots chunk 0": (lambda: robot_set("robustness", 8, 0, 0), "chunk"),
        "robots chunk text": (lambda: robot_set("robustness", 8, "4", 0), "chunk"),
        "robots seed": (lambda: robot_set("robustness", 8, 4, -1), "seed"),
        "robots duration": (lambda: robot_set("robustness", 8, 4, 0, duration=-1.0),
                            "duration"),
        "robots success": (lambda: robot_set("robustness", 8, 4, 0, success_theta=math.nan),
                           "success_theta"),
    }  # fmt: skip


@pytest.mark.parametrize("case", list(_api_cases()))
def test_the_api_raises_its_own_kinds_naming_the_argument(case):
    call, name = _api_cases()[case]
    with pytest.raises((TypeError, ValueError)) as info:
        call()
    assert name in str(info.value), str(info.value)
    assert type(info.value).__module__ in ("builtins", "mwip.budget"), type(info.value)


def test_calibrate_book_refuses_a_non_finite_duration(tmp_path):
    from mwip.calibration.book import calibrate_book

    with pytest.raises(ValueError, match="duration"):
        calibrate_book(tmp_path / "c", duration=math.nan)
    assert not (tmp_path / "c").exists()

