"""Property-based fuzzing of the CLI and the API with generated bad input (Hypothesis).

Every generated input is invalid by construction. The properties:

- CLI (in-process, ``mwip.cli.main``): exit code 2, exactly one line on stderr that starts
  with ``mwip: error:``, no traceback, and no file created, changed or removed in the
  sandbox folder it runs in (outside the input files it was given);
- API: a ``TypeError`` or ``ValueError`` whose message names the argument or field.

The runs are derandomised (the same inputs on every run) and the number of distinct inputs
tried is printed at the end of the module (``fuzz: N distinct bad inputs``); at least 500.
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

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mwip.cli import main

FUZZ = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    database=None,
)

#: distinct inputs tried, per property
TRIED: dict[str, set[str]] = defaultdict(set)


@pytest.fixture(scope="module", autouse=True)
def _report_count(request):
    yield
    total = sum(len(v) for v in TRIED.values())
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    line = f"fuzz: {total} distinct bad inputs (" + ", ".join(
        f"{k} {len(v)}" for k, v in sorted(TRIED.items())
    ) + ")"  # fmt: skip
    if reporter is not None:
        with capture.global_and_fixture_disabled() if capture else contextlib.nullcontext():
            reporter.write_line("")
            reporter.write_line(line)
    if len(TRIED) >= 15:  # the whole module ran (not a -k selection)
        assert total >= 500, line


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st_ = os.lstat(p)
            out[str(p.relative_to(root))] = (st_.st_mode, st_.st_size, st_.st_mtime_ns)
    return out


@contextlib.contextmanager
def _sandbox():
    """A fresh working folder; yields it and checks nothing in it changed on exit."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="mwip-fuzz-") as tmp:
        root = Path(tmp)
        (root / "index.html").write_text("a user's page")
        (root / "lqr-gain").mkdir()
        (root / "lqr-gain" / "notes.txt").write_text("a user's notes")
        os.chdir(root)
        try:
            before: dict[str, Any] = {}
            yield root, before
            after = _tree(root)
            assert after == before, "files outside OUT changed"
        finally:
            os.chdir(old)


def _cli(argv: list[str], key: str, needle: str | None = None, record: str | None = None):
    """Run ``mwip argv`` (in the sandbox) and check the properties of a refusal; ``record``
    is the input counted as tried (default: ``argv``)."""
    TRIED[key].add(record or repr(argv))
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    text = err.getvalue()
    assert code == 2, (argv, code, text, out.getvalue()[-500:])
    lines = text.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mwip: error:"), (argv, text)
    assert "Traceback" not in text
    if needle is not None:
        assert needle in lines[0], (argv, lines[0])


def _run_in_sandbox(argv_of, key, needle=None, files: dict[str, bytes] | None = None):
    with _sandbox() as (root, before):
        for name, data in (files or {}).items():
            (root / name).write_bytes(data)
        before.update(_tree(root))
        _cli(argv_of(root), key, needle, repr(files) if files else None)


# ---- value strategies -------------------------------------------------------------------------
NON_NUMBERS = st.text(alphabet=string.ascii_letters + "_-,;:[]{}()", min_size=1, max_size=8).filter(
    lambda s: s.lower() not in ("inf", "nan", "infinity") and not s.startswith("-")
)


def _floats_outside(lo: float, hi: float, lo_closed: bool = False):
    """Floats not in (lo, hi] (or [lo, hi]), as CLI text; plus nan, inf and non-numbers."""
    below = st.floats(max_value=lo, allow_nan=False, allow_infinity=True)
    if lo_closed:
        below = below.filter(lambda x: x < lo)
    above = st.floats(min_value=hi, allow_nan=False, allow_infinity=True).filter(lambda x: x > hi)
    return st.one_of(
        below.map(repr),
        above.map(repr),
        st.sampled_from(["nan", "inf", "-inf", "1e999", "-1e999", "NaN"]),
        NON_NUMBERS,
    )


SIM_OPTIONS = {
    "--theta0": _floats_outside(-math.pi / 2, math.pi / 2),
    "--duration": _floats_outside(0.0, 3600.0),
    "--Ts": _floats_outside(0.0, 1.0),
    "--alpha0": _floats_outside(-1000.0, 1000.0),
    "--v0": _floats_outside(-1000.0, 1000.0),
    "--max-steps": _floats_outside(0.0, 1e18),
    "--max-memory": _floats_outside(0.0, 1e6),
}


# ---- CLI --------------------------------------------------------------------------------------
@FUZZ
@given(opt=st.sampled_from(sorted(SIM_OPTIONS)), data=st.data())
def test_cli_simulate_bad_numbers(opt, data):
    value = data.draw(SIM_OPTIONS[opt])
    _run_in_sandbox(lambda root: ["simulate", opt, value, "--out", "o"], "simulate-number")


@FUZZ
@given(
    Ts=st.floats(min_value=1e-12, max_value=2e-6),
    duration=st.floats(min_value=1000.0, max_value=3600.0),
)
def test_cli_simulate_over_budget(Ts, duration):
    argv = ["simulate", "--Ts", repr(Ts), "--duration", repr(duration), "--out", "o"]
    _run_in_sandbox(lambda root: argv, "simulate-budget", "would need")


@FUZZ
@given(dt=st.floats(min_value=1e-15, max_value=1e-10))
def test_cli_simulate_tiny_steps(dt):
    _run_in_sandbox(lambda root: ["simulate", "--dt", repr(dt)], "simulate-dt", "would need")


@FUZZ
@given(
    items=st.lists(
        st.one_of(
            st.just(""),
            NON_NUMBERS,
            st.floats(max_value=0.0).map(repr),
            st.sampled_from(["nan", "inf", "-1"]),
            st.floats(min_value=0.1, max_value=10.0).map(repr),
        ),
        min_size=1,
        max_size=6,
    ).filter(lambda xs: not (len(xs) in (3, 4) and all(_positive(x) for x in xs)))
)
def test_cli_check_smc_bad_lambdas(items):
    text = ",".join(items)
    _run_in_sandbox(lambda root: ["check", "smc", "--lambdas", text], "check-lambdas", "--lambdas")


def _positive(x: str) -> bool:
    try:
        v = float(x)
    except ValueError:
        return False
    return math.isfinite(v) and v > 0


PARAM_NAMES = ["mb", "mw", "Iby", "Ibz", "Iwa", "Iwd", "l", "b", "r", "Db", "Dw", "g"]
BAD_PARAM_VALUES = st.one_of(
    st.booleans(),
    st.text(max_size=5),
    st.lists(st.floats(min_value=0.1, max_value=2.0), min_size=1, max_size=3),
    st.dictionaries(st.sampled_from(["x", "y"]), st.integers(0, 3), min_size=1, max_size=2),
    st.floats(max_value=-1e-9, allow_infinity=False),
    st.floats(min_value=1e7, allow_infinity=False),
    st.floats(min_value=1e-320, max_value=1e-13),
)


@FUZZ
@given(key=st.sampled_from(PARAM_NAMES), value=BAD_PARAM_VALUES, table=st.booleans())
def test_cli_bad_parameter_files(key, value, table):
    doc = {"params": {key: value}} if table else {key: value}
    files = {"robot.toml": tomli_w.dumps(doc).encode()}
    _run_in_sandbox(lambda root: ["params", "show", "robot.toml"], "param-file", "robot.toml",
                    files)  # fmt: skip


@FUZZ
@given(data=st.binary(min_size=1, max_size=40))
def test_cli_unparsable_files(data):
    try:
        import tomllib

        tomllib.loads(data.decode("utf-8"))
        return  # valid TOML by chance: not this property's input
    except (UnicodeDecodeError, ValueError):
        pass
    files = {"robot.toml": data}
    _run_in_sandbox(lambda root: ["params", "show", "robot.toml"], "unparsable", "robot.toml",
                    files)  # fmt: skip


SCENARIO_FIELDS = {
    ("scenario", "duration"): st.one_of(
        st.text(max_size=4),
        st.booleans(),
        st.floats(max_value=0.0, allow_infinity=False),
        st.floats(min_value=3600.5, allow_infinity=False),
        st.lists(st.integers(1, 5), min_size=1),
    ),  # fmt: skip
    ("scenario", "Ts"): st.one_of(
        st.text(max_size=4), st.booleans(), st.floats(min_value=1.01, allow_infinity=False)
    ),  # fmt: skip
    ("scenario", "mode"): st.one_of(
        st.integers(), st.text(max_size=6).filter(lambda s: s not in ("sampled", "continuous"))
    ),  # fmt: skip
    ("scenario", "controller"): st.one_of(
        st.integers(), st.text(max_size=6).filter(lambda s: s != "lqr")
    ),  # fmt: skip
    ("initial", "theta"): st.one_of(
        st.text(max_size=4),
        st.booleans(),
        st.floats(min_value=1.58, allow_infinity=False),
        st.lists(st.floats(0, 1), min_size=1, max_size=2),
    ),  # fmt: skip
    ("initial", "v"): st.one_of(
        st.text(max_size=4), st.floats(min_value=1001, allow_infinity=False)
    ),  # fmt: skip
    ("plant", "mb"): BAD_PARAM_VALUES,
    ("plant", "r"): BAD_PARAM_VALUES,
    ("design", "l"): BAD_PARAM_VALUES,
    ("plant", "base"): st.one_of(
        st.integers(), st.booleans(), st.lists(st.just("real"), min_size=1)
    ),  # fmt: skip
    ("disturbance", "kind"): st.one_of(
        st.integers(),
        st.text(max_size=5).filter(lambda s: s.lower() not in ("book", "sinusoid", "pulse")),
    ),  # fmt: skip
}


@FUZZ
@given(field=st.sampled_from(sorted(SCENARIO_FIELDS)), data=st.data())
def test_cli_bad_scenario_files(field, data):
    table, key = field
    value = data.draw(SCENARIO_FIELDS[field])
    doc = {table: {key: value}}
    files = {"sc.toml": tomli_w.dumps(doc).encode()}
    _run_in_sandbox(lambda root: ["simulate", "--scenario", "sc.toml", "--out", "o"],
                    "scenario-file", "sc.toml", files)  # fmt: skip


@FUZZ
@given(
    shape=st.sampled_from(["value-for-table", "table-for-value"]),
    table=st.sampled_from(["scenario", "plant", "design", "initial", "disturbance"]),
    value=st.one_of(st.integers(), st.text(max_size=4), st.lists(st.integers(), max_size=2)),
)
def test_cli_scenario_tables_and_values_swapped(shape, table, value):
    if shape == "value-for-table":
        doc: dict[str, Any] = {table: value}
    else:
        key = {"scenario": "duration", "plant": "mb", "design": "r", "initial": "theta",
               "disturbance": "omega"}[table]  # fmt: skip
        doc = {table: {key: {"x": value}}}
    files = {"sc.toml": tomli_w.dumps(doc).encode()}
    _run_in_sandbox(lambda root: ["simulate", "--scenario", "sc.toml"], "scenario-swap",
                    "sc.toml", files)  # fmt: skip


def _study_settings():
    from mwip.studies import settings, study_names

    out = []
    for name in study_names():
        for key, default in settings.defaults(name).items():
            out.append((name, key, default))
    return out


STUDY_SETTINGS = _study_settings()


def _bad_for(default: Any, key: str, name: str):
    from mwip.studies.settings import ranges

    iv = ranges(name).get(key)
    wrong_kind = st.one_of(st.text(max_size=4), st.dictionaries(st.just("a"), st.integers(),
                                                                min_size=1))  # fmt: skip
    if isinstance(default, bool):
        return st.one_of(wrong_kind, st.integers())
    if isinstance(default, list):
        n = len(default)
        return st.one_of(
            wrong_kind,
            st.lists(st.floats(0.1, 1.0), min_size=n + 1, max_size=n + 2),
            st.lists(st.floats(0.1, 1.0), max_size=max(n - 1, 0)),
            _bad_number(iv, isinstance(default[0], int)).map(lambda x: [x] * n),
        )
    return st.one_of(wrong_kind, st.booleans(), _bad_number(iv, isinstance(default, int)))


def _in_iv(iv, x) -> bool:
    lo, hi, lo_in, hi_in = iv
    return (x > lo or (x == lo and lo_in)) and (x < hi or (x == hi and hi_in))


def _bad_number(iv, integer: bool):
    if iv is None:
        return st.one_of(st.floats(min_value=1.01e6, max_value=1e300),
                         st.floats(min_value=-1e300, max_value=-1.01e6))  # fmt: skip
    lo, hi, lo_in, hi_in = iv
    parts = [st.floats(max_value=lo, allow_infinity=False, allow_nan=False).filter(
                 lambda x: x < lo or (x == lo and not lo_in)),
             st.floats(min_value=hi, allow_infinity=False, allow_nan=False).filter(
                 lambda x: x > hi or (x == hi and not hi_in))]  # fmt: skip
    if integer:
        parts = [p.map(lambda x: int(max(min(x, 1e18), -1e18))) for p in parts]
        parts = [p.filter(lambda x: not (_in_iv(iv, x))) for p in parts]
    return st.one_of(*parts)


@FUZZ
@given(which=st.sampled_from(STUDY_SETTINGS), data=st.data())
def test_cli_bad_study_settings(which, data):
    name, key, default = which
    value = data.draw(_bad_for(default, key, name))
    doc = {"study": {"name": name, "quick": True}, "settings": {key: value}}
    files = {"st.toml": tomli_w.dumps(doc).encode()}
    _run_in_sandbox(lambda root: ["run", "--scenario", "st.toml", "--out", "o"],
                    "study-settings", f"[settings] {key}", files)  # fmt: skip


@FUZZ
@given(
    cmd=st.sampled_from([["simulate"], ["run", "lqr-gain"], ["reproduce"],
                         ["export", "c", "--controller", "lqr"]]),  # fmt: skip
    where=st.sampled_from(["", "index.html", "lqr-gain", ".", "./"]),
    extra=st.sampled_from([[], ["--quick"]]),
)
def test_cli_out_into_a_users_folder_or_file(cmd, where, extra):
    if cmd[0] == "export":
        extra = []
    argv = [*cmd, "--out", where, *(["--duration", "0.1"] if cmd == ["simulate"] else extra)]
    _run_in_sandbox(lambda root: argv, "out-folder", "--out")


@FUZZ
@given(
    cmd=st.sampled_from(
        [
            ["design", "hodo", "--order"],
            ["design", "hodo", "-n", "2", "--radius"],
            ["design", "it2", "--rho", "1", "--epsilon"],
            ["design", "lqr", "--Ts"],
            ["check", "smc", "--lambdas", "3,0.2,0.3", "--theta-max"],
            ["run", "lqr-gain", "-j"],
        ]
    ),  # fmt: skip
    value=st.one_of(
        st.sampled_from(["nan", "inf", "-1", "0", "1e999", "-0"]),
        NON_NUMBERS,
        st.integers(min_value=65, max_value=10**6).map(str),
    ),  # fmt: skip
)
def test_cli_design_and_check_bad_numbers(cmd, value):
    if cmd[-1] == "--radius" and value.isdigit():
        return  # a radius in (0, 1e9]: valid
    if cmd[-1] == "-j" and value in ("0", "-0"):
        return  # 0 is "one per CPU": valid
    if cmd[-1] in ("--theta-max",) and value in ("0", "-0"):
        return  # [0, pi/2): valid
    _run_in_sandbox(lambda root: [*cmd, value], "design-check")


@FUZZ
@given(
    cmd=st.sampled_from([["simulate"], ["design", "lqr"], ["params", "show"], ["run"],
                         ["reproduce"], ["check", "smc"], ["report"], ["scenario"]]),
    opt=st.text(alphabet=string.ascii_lowercase + "-", min_size=2, max_size=10).map(
        lambda s: "--x" + s),
)  # fmt: skip
def test_cli_unknown_options(cmd, opt):
    _run_in_sandbox(lambda root: [*cmd, opt], "unknown-option")


# ---- API --------------------------------------------------------------------------------------
BAD_SCALARS = st.one_of(
    st.text(max_size=5),
    st.booleans(),
    st.none(),
    st.lists(st.floats(0.1, 1.0), min_size=1, max_size=3),
    st.complex_numbers(allow_nan=False, allow_infinity=False).filter(lambda z: z.imag != 0),
    st.sampled_from([math.nan, math.inf, -math.inf]),
    st.floats(max_value=0.0, allow_nan=False, allow_infinity=False),
)


@pytest.fixture(scope="module")
def ctrl():
    from mwip.laws import LQR, design_lqr
    from mwip.params import NOMINAL

    return LQR(design_lqr(NOMINAL, Ts=0.005))


def _api(key: str, arg: str, call, value):
    TRIED[key].add(f"{arg}={value!r}")
    with pytest.raises((TypeError, ValueError)) as info:
        call()
    assert arg in str(info.value), (arg, value, str(info.value))


@FUZZ
@given(arg=st.sampled_from(["duration", "Ts", "dt", "record_every", "seed"]), value=BAD_SCALARS)
def test_api_simulate_bad_scalars(ctrl, arg, value):
    from mwip.params import REAL
    from mwip.sim import simulate

    if arg == "seed" and value is None:
        return  # seed=None: no seed, valid
    if arg in ("Ts", "dt") and value is None:
        return  # the defaults
    kwargs = {"duration": 0.05, arg: value}
    if arg == "Ts":
        kwargs["mode"] = "continuous"  # a sampled controller fixes Ts
    _api("api-simulate", arg, lambda: simulate(ctrl, REAL, **kwargs), value)


@FUZZ
@given(
    arg=st.sampled_from(["q0", "qdot0", "pos0"]),
    value=st.one_of(
        st.text(max_size=3),
        st.lists(st.text(max_size=2), min_size=3, max_size=3),
        st.lists(st.sampled_from([math.nan, math.inf, 1.0]), min_size=3, max_size=3).filter(
            lambda v: not all(math.isfinite(x) for x in v)),
        st.just([[0.0], [1.0, 2.0]]),
        st.lists(st.floats(-1, 1), min_size=4, max_size=6),
        st.lists(st.booleans(), min_size=3, max_size=3),
    ),
)  # fmt: skip
def test_api_simulate_bad_initial_states(ctrl, arg, value):
    from mwip.params import REAL
    from mwip.sim import simulate

    _api("api-initial", arg, lambda: simulate(ctrl, REAL, duration=0.05, **{arg: value}), value)


@FUZZ
@given(field=st.sampled_from(PARAM_NAMES), value=BAD_PARAM_VALUES)
def test_api_params_bad_fields(field, value):
    from dataclasses import replace

    from mwip.params import REAL

    if isinstance(value, list):
        return  # an array is a batch of robots in the API
    if field in ("Iwd", "Db", "Dw") and isinstance(value, float) and value == 0.0:
        return
    _api("api-params", f"'{field}'", lambda: replace(REAL, **{field: value}), value)


@FUZZ
@given(
    arg=st.sampled_from(["Ts", "reference", "Q", "R"]),
    value=st.one_of(BAD_SCALARS, st.just("diag"), st.lists(st.text(max_size=2), min_size=5,
                                                           max_size=5)),
)  # fmt: skip
def test_api_lqr_bad_arguments(arg, value):
    from mwip.laws import LQR, design_lqr
    from mwip.params import NOMINAL

    if arg == "Ts" and value is None:
        return  # the continuous design
    if arg == "reference":
        _api("api-lqr", arg, lambda: LQR(design_lqr(NOMINAL), reference=value), value)
    else:
        _api("api-lqr", arg, lambda: design_lqr(NOMINAL, **{arg: value}), value)


@FUZZ
@given(which=st.sampled_from(STUDY_SETTINGS), data=st.data())
def test_api_settings_validate(which, data):
    from mwip.studies import settings

    name, key, default = which
    value = data.draw(_bad_for(default, key, name))
    _api("api-settings", key, lambda: settings.validate(name, {key: value}), value)
