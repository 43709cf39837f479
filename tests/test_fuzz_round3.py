"""Fuzzing the newer commands (issue 39): ``tune``, ``bench``, ``twin fit``, ``twin excite``,
``--evidence book`` and the files they read (objective files, settings files, logs), with
generated bad input (Hypothesis, derandomised: the same inputs on every run).

Every generated input is invalid by construction. The property (as tests/test_fuzz.py's):
exit code 2, exactly one line on stderr starting ``mwip: error:``, no traceback, and no file
created, changed or removed in the sandbox folder (outside the input files given).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import string
import tempfile
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mwip.cli import main

FUZZ = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow,
                                       HealthCheck.function_scoped_fixture])  # fmt: skip

TRIED: dict[str, set[str]] = defaultdict(set)


@pytest.fixture(scope="module", autouse=True)
def _report_count(request):
    yield
    total = sum(len(v) for v in TRIED.values())
    line = f"fuzz round 3: {total} distinct bad inputs (" + ", ".join(
        f"{k} {len(v)}" for k, v in sorted(TRIED.items())) + ")"  # fmt: skip
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    if reporter is not None:
        with capture.global_and_fixture_disabled() if capture else contextlib.nullcontext():
            reporter.write_line("")
            reporter.write_line(line)
    if len(TRIED) >= 8:  # the whole module ran
        assert total >= 250, line


def _tree(root: Path) -> dict[str, tuple[int, int, int]]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            s = os.lstat(p)
            out[str(p.relative_to(root))] = (s.st_mode, s.st_size, s.st_mtime_ns)
    return out


def _run(key: str, argv_of, files: dict[str, bytes] | None = None, needle: str | None = None):
    """Run ``mwip argv_of(root)`` in a fresh sandbox holding ``files``; check the refusal."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="mwip-fuzz3-") as tmp:
        root = Path(tmp)
        (root / "index.html").write_text("a user's page")
        for name, data in (files or {}).items():
            (root / name).write_bytes(data)
        os.chdir(root)
        try:
            before = _tree(root)
            argv = argv_of(root)
            TRIED[key].add(repr((argv, files)))
            err, out = io.StringIO(), io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                code = main(argv)
            text = err.getvalue()
            assert code == 2, (argv, code, text, out.getvalue()[-300:])
            lines = text.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("mwip: error:"), (argv, text)
            assert "Traceback" not in text
            if needle is not None:
                assert needle in lines[0], (argv, lines[0])
            assert _tree(root) == before, "files changed"
        finally:
            os.chdir(old)


NON_NUMBERS = st.text(alphabet=string.ascii_letters + "_-;:[]{}()", min_size=1,
                      max_size=6).filter(lambda s: s.lower() not in ("inf", "nan", "infinity")
                                         and not s.startswith("-"))  # fmt: skip
NON_FINITE = st.sampled_from(["nan", "inf", "-inf", "NaN", "1e999", "-1e999"])


def _outside(lo: float, hi: float) -> st.SearchStrategy[str]:
    """Text of a number outside [lo, hi], a non-finite one or no number."""
    return st.one_of(
        st.floats(max_value=lo, allow_nan=False, allow_infinity=False).filter(
            lambda x: x < lo).map(repr),
        st.floats(min_value=hi, allow_nan=False, allow_infinity=False).filter(
            lambda x: x > hi).map(repr),
        NON_FINITE, NON_NUMBERS)  # fmt: skip


# ---- twin excite ---------------------------------------------------------------------------------
EXCITE = {"--ts": _outside(1e-12, 0.1).filter(lambda v: v not in ("0.0",)),
          "--static": _outside(0.0, 600.0), "--step": _outside(0.0, 600.0),
          "--chirp": _outside(0.0, 600.0),
          "--max-samples": st.one_of(st.integers(max_value=0).map(str), NON_NUMBERS)}  # fmt: skip


@FUZZ
@given(opt=st.sampled_from(sorted(EXCITE)), data=st.data())
def test_twin_excite_bad_options(opt, data):
    value = data.draw(EXCITE[opt])
    _run("excite-option", lambda root: ["twin", "excite", "--out", "e.csv", opt, value])


@FUZZ
@given(Ts=st.floats(1e-6, 4e-5), part=st.floats(100.0, 600.0))
def test_twin_excite_too_long(Ts, part):
    _run("excite-size", lambda root: ["twin", "excite", "--out", "e.csv", "--ts", repr(Ts),
                                      "--chirp", repr(part)], needle="--max-samples")


# ---- twin fit: options and modes -----------------------------------------------------------------
GOOD_LOG = ("t,theta,theta_rate,enc_r,enc_l,duty_r,duty_l\n"
            + "".join(f"{0.005 * i},{0.01 * math.sin(0.005 * i)},{0.01 * math.cos(0.005 * i)},"
                      f"{0.0005 * i},{0.0005 * i},{0.2 * math.sin(0.045 * i)},"
                      f"{0.2 * math.cos(0.045 * i)}\n" for i in range(60))).encode()  # fmt: skip

COMPARE_ONLY = {"--structures": st.sampled_from(["S0", "S0,S1"]),
                "--draws": st.integers(1, 9).map(str),
                "--kernel-draws": st.integers(0, 9).map(str),
                "--directed-draws": st.integers(0, 9).map(str), "--replay": st.just("log.csv")}
RECORD_ONLY = {"--samples": st.integers(1, 100).map(str), "--seed": st.integers(0, 9).map(str),
             "--stage2-draws": st.integers(0, 9).map(str),
             "--chain-steps": st.integers(0, 9).map(str),
             "--mixture-draws": st.integers(0, 9).map(str),
             "--envelope-draws": st.integers(0, 9).map(str)}  # fmt: skip


@FUZZ
@given(book=st.booleans(), data=st.data())
def test_twin_calibrate_options_of_the_other_mode(book, data):
    table = COMPARE_ONLY if book else RECORD_ONLY
    opts = data.draw(st.lists(st.sampled_from(sorted(table)), min_size=1, max_size=3,
                              unique=True))  # fmt: skip
    extra = [x for o in opts for x in (o, data.draw(table[o]))]
    head = ["--record"] if book else []
    _run("calibrate-mode", lambda root: ["twin", "calibrate", "book", *head, "--out", "cal",
                                         *extra], {"log.csv": GOOD_LOG})  # fmt: skip


@FUZZ
@given(
    opt=st.sampled_from(["--free", "--fix", "--segment", "--max-rows"]),
    value=st.one_of(st.sampled_from(["", ",", "nosuch", "firmware.delay,firmware.delay",
                                     "firmware.delay=", "=1", "firmware.delay=nan",
                                     "firmware.delay=1e999", "firmware.delay=x", "gear=2", "4",
                                     "401", "0", "2", "delay"]), NON_NUMBERS),
)  # fmt: skip
def test_twin_fit_bad_option_values(opt, value):
    from mwip.identify.bounds import NAMES

    if opt == "--free" and all(n.strip() in NAMES for n in value.split(",") if n.strip()) \
            and value.strip(", ") and len(set(value.split(","))) == len(value.split(",")):
        return  # a valid list of names
    if opt == "--segment" and value.isdigit() and 5 <= int(value) <= 400:
        return
    if opt == "--max-rows" and value.isdigit() and int(value) >= 60:
        return
    _run("fit-option", lambda root: ["twin", "fit", "log.csv", "--out", "fit", opt, value],
         {"log.csv": GOOD_LOG})  # fmt: skip


# ---- twin fit: corrupted logs --------------------------------------------------------------------
def _good_rows() -> tuple[list[str], list[list[str]]]:
    lines = GOOD_LOG.decode().strip().splitlines()
    return lines[0].split(","), [r.split(",") for r in lines[1:]]


@FUZZ
@given(
    how=st.sampled_from(["text", "nan", "empty", "scale-theta", "scale-enc", "scale-rate",
                         "time-back", "time-repeat", "time-ms", "drop-column", "extra-field",
                         "dup-header", "duty-percent", "big-field"]),
    col=st.integers(0, 6), row=st.integers(0, 59), word=NON_NUMBERS,
)  # fmt: skip
def test_twin_fit_corrupted_logs(how, col, row, word):
    head, rows = _good_rows()
    rows = [list(r) for r in rows]
    if how == "text":
        rows[row][col] = word
    elif how == "nan":
        rows[row][col] = "nan"
    elif how == "empty":
        rows[row][col] = ""
    elif how == "scale-theta":
        for r in rows:
            r[1] = repr(float(r[1]) * 2000)  # (|theta| > 1.6 rad: a short log's bound)
    elif how == "scale-enc":
        for r in rows:
            r[3] = repr(float(r[3]) * 1e5)
    elif how == "scale-rate":
        for r in rows:
            r[2] = repr(float(r[2]) * 1e4)
    elif how == "time-back":
        i = max(row, 1)
        rows[i][0], rows[i - 1][0] = rows[i - 1][0], rows[i][0]
    elif how == "time-repeat":
        rows[max(row, 1)][0] = rows[max(row, 1) - 1][0]
    elif how == "time-ms":
        for r in rows:
            r[0] = repr(float(r[0]) * 1000)
    elif how == "drop-column":
        head = head[:col] + head[col + 1:]
        rows = [r[:col] + r[col + 1:] for r in rows]
    elif how == "extra-field":
        rows[row].append("1")
    elif how == "dup-header":
        head[col] = head[(col + 1) % 7]
    elif how == "duty-percent":
        for r in rows:
            r[5] = repr(float(r[5]) * 100)
    elif how == "big-field":
        rows[row][col] = "1" * 140_000
    text = ",".join(head) + "\n" + "".join(",".join(r) + "\n" for r in rows)
    _run("fit-log", lambda root: ["twin", "fit", "log.csv", "--out", "fit"],
         {"log.csv": text.encode()}, needle="log.csv")  # fmt: skip


# ---- tune: objective files -----------------------------------------------------------------------
BAD_VALUE = st.one_of(st.text(max_size=4), st.booleans(), st.lists(st.integers(), max_size=2),
                      st.sampled_from([math.nan, math.inf, -math.inf, -1, 0, 10**12]))  # fmt: skip
OBJECTIVE_FIELDS = {
    ("objective", "mode"): st.one_of(st.text(max_size=5).filter(
        lambda s: s not in ("scalar", "pareto")), st.integers()),
    ("objective", "success_theta"): BAD_VALUE.filter(lambda v: not (isinstance(v, int | float)
                                                                    and 0 < v <= 1.5)),
    ("objective", "torque_limit"): BAD_VALUE.filter(lambda v: v not in ("drive", "none")
                                                    and not (isinstance(v, int | float)
                                                             and not isinstance(v, bool)
                                                             and 0 < v <= 1e4)),
    ("objective", "terms"): st.one_of(st.just([]), st.text(max_size=3), st.lists(
        st.fixed_dictionaries({"metric": st.text(max_size=5)}), min_size=1, max_size=2)),
    ("robots", "samples"): BAD_VALUE.filter(lambda v: not (type(v) is int and 1 <= v <= 10**5)),
    ("robots", "plant"): st.text(max_size=5).filter(lambda s: s not in ("twin", "plain",
                                                                         "campaign")),
    ("robots", "duration"): BAD_VALUE.filter(lambda v: not (isinstance(v, int | float)
                                                            and not isinstance(v, bool)
                                                            and 0 < v <= 3600)),
    ("robots", "seed"): st.one_of(st.integers(max_value=-1), st.floats(0.5, 9.5),
                                  st.text(max_size=3)),
    ("space", "tune"): st.one_of(st.just([]), st.text(max_size=4),
                                 st.lists(st.text(max_size=4), min_size=1, max_size=2)),
    ("space", "ratio"): BAD_VALUE.filter(lambda v: not (isinstance(v, int | float)
                                                        and not isinstance(v, bool)
                                                        and 1 < v <= 1e6)),
    ("space", "ranges"): st.one_of(st.just({}), st.text(max_size=3)),
    ("validation", "samples"): BAD_VALUE.filter(lambda v: not (type(v) is int and v >= 1)),
}  # fmt: skip


def _toml_value(v: Any) -> str:
    """``v`` as a TOML value (inline tables and arrays; nan and inf as TOML writes them)."""
    from mwip.io import toml_key, toml_str

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, str):
        return toml_str(v)
    if isinstance(v, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return "[" + ", ".join(_toml_value(x) for x in v) + "]"


@FUZZ
@given(field=st.sampled_from(sorted(OBJECTIVE_FIELDS)), data=st.data())
def test_tune_bad_objective_files(field, data):
    pytest.importorskip("optuna")
    table, key = field
    value = data.draw(OBJECTIVE_FIELDS[field])
    if field == ("space", "tune") and isinstance(value, list) and value and all(
            v in ("K", "phi", "lambdas", "psi_dot") for v in value):  # fmt: skip
        return
    text = ("[robots]\nsamples = 8\nchunk = 8\nplant = \"plain\"\n" if table != "robots"
            else "[robots]\nchunk = 8\n")  # fmt: skip
    body = f"[{table}]\n{key} = {_toml_value(value)}\n"
    if table == "robots":
        text = f"[robots]\n{key} = {_toml_value(value)}\n" + ("chunk = 8\n" if key != "chunk"
                                                              else "")  # fmt: skip
    else:
        text += body
    _run("tune-objective", lambda root: ["tune", "hodosmc", "--objective", "o.toml", "--out",
                                         "t"], {"o.toml": text.encode()})  # fmt: skip


TUNE_OPTIONS = {"--trials": st.one_of(st.integers(max_value=0).map(str), NON_NUMBERS,
                                      st.just("1000001")),
                "--seed": st.one_of(st.integers(max_value=-1).map(str), NON_NUMBERS),
                "--sampler": NON_NUMBERS, "--objective": st.just("nosuch"),
                "--storage": st.sampled_from(["", "sqlite://", "sqlite:///:memory:",
                                              "nosuchdb://x", "sqlite:///no/such/dir/x.db",
                                              "postgresql+nosuchdriver://h/db"])}  # fmt: skip


@FUZZ
@given(opt=st.sampled_from(sorted(TUNE_OPTIONS)), data=st.data())
def test_tune_bad_options(opt, data):
    pytest.importorskip("optuna")
    value = data.draw(TUNE_OPTIONS[opt])
    _run("tune-option", lambda root: ["tune", "hodosmc", "--out", "t", opt, value])


# ---- bench and settings files --------------------------------------------------------------------
BENCH_OPTIONS = {"--samples": st.one_of(st.integers(max_value=0).map(str), NON_NUMBERS),
                 "--jobs": st.one_of(st.integers(max_value=0).map(str), NON_NUMBERS,
                                     st.just("100000")),
                 "--max-hours": st.one_of(_outside(1e-300, 1e300),
                                          st.floats(max_value=0.0).map(repr)),
                 "--scheduler": st.sampled_from(["", " ", "nosuch://x", "tcp://127.0.0.1:1",
                                                 "tcp://127.0.0.1:notaport"]),
                 "--definition": st.just("nosuch.toml")}  # fmt: skip


@FUZZ
@given(opt=st.sampled_from(sorted(BENCH_OPTIONS)), data=st.data())
def test_bench_bad_options(opt, data):
    value = data.draw(BENCH_OPTIONS[opt])
    if opt == "--max-hours":
        try:
            if float(value) > 0 and math.isfinite(float(value)):
                return
        except ValueError:
            pass
    _run("bench-option", lambda root: ["bench", "lqr", "--quick", "--out", "b", opt, value])


SETTINGS_VALUES = st.one_of(
    st.text(max_size=6).map(lambda s: ("K", s)),
    st.lists(st.floats(allow_nan=True, allow_infinity=True).filter(lambda x: not math.isfinite(x)),
             min_size=2, max_size=2).map(lambda v: ("K", v)),
    st.lists(st.floats(0.1, 5.0), min_size=3, max_size=4).map(lambda v: ("K", v)),
    st.floats(max_value=-0.001, allow_nan=False, allow_infinity=False).map(lambda v: ("phi", v)),
    st.booleans().map(lambda v: ("phi", v)),
    st.text(alphabet=string.ascii_lowercase, min_size=1, max_size=5).filter(
        lambda k: k not in ("k", "phi")).map(lambda k: (k, 1.0)),
)  # fmt: skip


@FUZZ
@given(item=SETTINGS_VALUES, cmd=st.sampled_from(["simulate", "bench", "export"]))
def test_bad_settings_files(item, cmd):
    key, value = item
    text = "[controller]\nname = \"hodosmc\"\n[settings]\n" + f"{key} = {_toml_value(value)}\n"
    argv = {"simulate": ["simulate", "--settings", "s.toml"],
            "bench": ["bench", "--settings", "s.toml", "--out", "b"],
            "export": ["export", "c", "--controller", "hodosmc", "--settings", "s.toml",
                       "--out", "c"]}[cmd]  # fmt: skip
    _run("settings-file", lambda root: argv, {"s.toml": text.encode()}, needle="s.toml")


def test_the_good_log_is_good(tmp_path):
    """The base of the corrupted logs passes the checks (so each corruption is what fails)."""
    from mwip.identify.logs import read_log

    p = tmp_path / "log.csv"
    p.write_bytes(GOOD_LOG)
    assert read_log(p).n == 60
    assert np.isfinite(read_log(p).columns["theta"]).all()
