"""C export and software in the loop (issue 17 items 1-2).

The generated C (compiled with the system compiler, strict C99, -Wall -Wextra -Werror) runs as
the controller of the same closed loop as the Python controller it came from: the
trajectories must agree to 1e-9 over 10 s in double precision, on the plain simulation and on
the digital twin.
"""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from mwip.cli import main
from mwip.export import CController, ExportError, generate_c, verify
from mwip.export.transpile import to_c_function
from mwip.laws import registry
from mwip.params import NOMINAL

pytestmark = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                                reason="software in the loop needs a C compiler (gcc)")  # fmt: skip

NAMES = registry.names()


@pytest.mark.parametrize("name", NAMES)
def test_c_closed_loop_equals_python(name):
    code = generate_c(registry.build(name, NOMINAL), prefix=f"t_{name}")
    rep = verify(registry.build(name, NOMINAL), CController(code), q0=(0.0, 0.1, 0.0),
                 duration=10.0)  # fmt: skip
    assert rep.status_python == rep.status_c == "ok"
    assert rep.max_state_diff <= 1e-9, rep


@pytest.mark.parametrize("name", [n for n in NAMES if registry.get(n).robot])
def test_c_on_the_twin_equals_python(name):
    from mwip.hardware.twin import Twin

    code = generate_c(registry.build(name, NOMINAL), prefix=f"tw_{name}")
    rep = verify(registry.build(name, NOMINAL), CController(code), q0=(0.0, 0.1, 0.0),
                 duration=4.0, twin=Twin())  # fmt: skip
    assert rep.status_python == rep.status_c
    assert rep.max_state_diff <= 1e-9, rep


def test_non_default_settings_are_baked_in():
    """A changed setting changes the C law the same way (here sgn instead of the default
    saturation, and a wheel-speed target): still equal to the Python controller."""
    settings = {"switching": "sign", "psi_dot_d": -3.0}
    spec = registry.get("hodosmc")
    code = generate_c(spec.build(NOMINAL, settings), prefix="t_custom")
    default = generate_c(spec.build(NOMINAL), prefix="t_custom")
    assert "mwip_sgn(s1)" in code.source and "mwip_sgn(s1)" not in default.source
    assert "Q1D = -3.0" in code.source
    rep = verify(spec.build(NOMINAL, settings), CController(code), duration=5.0)
    assert rep.status_c == "ok" and rep.max_state_diff <= 1e-9


@pytest.mark.parametrize("name", ["lqr", "hodosmc", "it2"])
def test_float_version_runs_close(name):
    """Single precision: compiles and balances; its deviation from double is small for these
    smooth or observer-filtered laws (recorded in docs/export.md for all)."""
    code = generate_c(registry.build(name, NOMINAL), prefix=f"f_{name}", precision="float")
    assert "typedef float mwip_real;" in code.header
    rep = verify(registry.build(name, NOMINAL), CController(code), duration=10.0)
    assert rep.status_c == "ok" and rep.max_theta_diff < 1e-4


def test_generated_code_is_plain_c99():
    for name in NAMES:
        code = generate_c(registry.build(name, NOMINAL), prefix="p")
        includes = re.findall(r"#include\s+[<\"]([^>\"]+)[>\"]", code.source + code.header)
        assert set(includes) <= {"math.h", "p.h"}
        for banned in ("malloc", "calloc", "free(", "printf", "static mwip_real *"):
            assert banned not in code.source
        assert "void p_step(p_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2]);" in (
            code.header
        )


def test_transpiler_rejects_what_it_cannot_translate():
    def loop(a):
        for _ in range(3):
            a = a + 1
        return a, a

    def call(a):
        x = np.exp(a)
        return x, a

    with pytest.raises(ValueError, match="cannot translate"):
        to_c_function(loop, "loop")
    with pytest.raises(ValueError, match="cannot translate"):
        to_c_function(call, "call")


def test_transpiled_model_equals_python_on_random_states(tmp_path):
    """The C f_g (translated from f_g_terms) equals the Python closed forms of (2.36) bit for
    bit on random states (a direct check, beside the closed loops)."""
    import ctypes
    import subprocess

    from mwip.export.sil import find_compiler
    from mwip.models.reduced import coefficients, f_g_terms

    src = (
        "#include <math.h>\ntypedef double mwip_real;\n#define MWIP_SIN sin\n#define MWIP_COS cos\n"
    )
    src += to_c_function(f_g_terms, "f_g").replace("static void", "void")
    (tmp_path / "fg.c").write_text(src)
    lib = tmp_path / "libfg.so"
    subprocess.run([find_compiler(), "-std=c99", "-O2", "-shared", "-fPIC", "-ffp-contract=off",
                    "-o", str(lib), str(tmp_path / "fg.c"), "-lm"], check=True)  # fmt: skip
    fn = ctypes.CDLL(str(lib)).f_g
    d = ctypes.c_double
    fn.argtypes = [d] * 14 + [ctypes.POINTER(d)] * 6
    rng = np.random.default_rng(0)
    c = coefficients(NOMINAL)
    for _ in range(200):
        x = rng.uniform(-2, 2, 4)
        outs = [d() for _ in range(6)]
        fn(*c, *x, *[ctypes.byref(o) for o in outs])
        ref = f_g_terms(*c, *x)
        assert [o.value for o in outs] == [float(v) for v in ref]


def test_cli_export_and_verify(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["export", "c", "--controller", "do1smc", "--out", str(out), "--verify",
                 "--duration", "3"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert (out / "mwip_do1smc.h").is_file() and (out / "mwip_do1smc.c").is_file()
    assert "software in the loop" in text and "status python ok, C ok" in text


@pytest.mark.parametrize(
    "args, hint",
    [
        (["--controller", "nope"], "--controller"),
        (["--controller", "smc", "--set", "K=a"], "--set"),
        (["--controller", "lqr", "--Ts", "0"], "--Ts"),
        (["--controller", "lqr", "--prefix", "9bad"], "prefix"),
        (["--controller", "lqr", "--robot", "/nonexistent.toml"], "--robot"),
    ],
)
def test_cli_bad_input(args, hint, tmp_path, capsys):
    assert main(["export", "c", *args, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mwip: error:") and hint in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_cli_no_compiler(tmp_path, capsys, monkeypatch):
    import mwip.export.sil as sil

    monkeypatch.setattr(sil.shutil, "which", lambda _name: None)
    assert main(["export", "c", "--controller", "lqr", "--out", str(tmp_path / "o"),
                 "--verify"]) == 2  # fmt: skip
    assert "no C compiler" in capsys.readouterr().err


def test_unexportable_controller():
    class Other:
        Ts = 0.005

    with pytest.raises(ExportError, match="no C export"):
        generate_c(Other())
