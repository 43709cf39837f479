"""The ahead-of-time compiled loop (mwip.sim.aot): same numbers as the JIT loop, keyed by the
sources it is compiled from, off and load-only modes, a failed build falling back to the JIT
loop, and a plain ``mwip simulate`` that imports neither Numba nor SciPy, cvxpy, matplotlib.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.laws import registry
from mwip.params import NOMINAL, REAL, REAL_LITERAL
from mwip.sim import BOOK_SINUSOIDS, aot, simulate

SRC = Path(aot.__file__).resolve().parents[1]


def _compiled_names() -> list[str]:
    return [n for n in registry.names()
            if hasattr(registry.build(n, NOMINAL, Ts=0.005), "packed_law")]  # fmt: skip


def _run(name, mode, monkeypatch, plant=REAL, Ts=0.005, **kw):
    monkeypatch.setenv("MWIP_AOT", mode)
    ctrl = registry.build(name, NOMINAL, Ts=Ts)
    return simulate(ctrl, plant, Ts=Ts, **kw)


def _identical(a, b):
    assert a.settings == b.settings and a.settings["compiled"]
    assert list(a.status) == list(b.status)
    for x, y in [(a.t_end, b.t_end), (a.states, b.states), (a.inputs, b.inputs),
                 (a.final_state, b.final_state)]:  # fmt: skip
        np.testing.assert_array_equal(x, y)
    assert list(a.logs) == list(b.logs)
    for k in a.logs:
        np.testing.assert_array_equal(a.logs[k], b.logs[k])


@pytest.mark.parametrize("name", _compiled_names())
def test_aot_run_is_bit_identical_to_the_jit_loop(name, monkeypatch):
    kw = dict(q0=(0.0, 0.15, 0.1), qdot0=(0.5, 0.0, 0.2), duration=2.0)
    a = _run(name, "on", monkeypatch, **kw)
    assert aot.load() is not None, "the single run should have built and used the module"
    b = _run(name, "off", monkeypatch, **kw)
    _identical(a, b)


def test_aot_batch_disturbance_stiff_plant_and_a_fall(monkeypatch):
    """Three plants (one falls), the book's sinusoids, ROS2-W on the literal-reading plant,
    the 4th-order observer at 1 ms, records every 7th sample."""
    plants = [replace(REAL_LITERAL, mb=REAL_LITERAL.mb * f) for f in (0.9, 1.0, 1.2)]
    from mwip.params import stack_params

    q0 = np.array([[0.0, 0.05, 0.0], [0.0, -0.1, 0.2], [0.0, 1.4, 0.0]])
    kw = dict(q0=q0, duration=1.5, disturbance=BOOK_SINUSOIDS, record_every=7)
    a = _run("hodosmc", "on", monkeypatch, plant=stack_params(plants), Ts=0.001, **kw)
    b = _run("hodosmc", "off", monkeypatch, plant=stack_params(plants), Ts=0.001, **kw)
    assert a.settings["integrator"] == "ROS2-W" and "fell" in list(a.status)
    _identical(a, b)


def test_sources_are_exactly_what_the_loop_imports():
    """The key hashes every mwip file compiled into the loop: importing mwip.sim.loop loads
    exactly SOURCES (plus this module's own build code, sim/aot.py) with the twin's compiled
    loop, mwip.hardware.loop, which inlines the same kernels."""
    code = ("import sys, mwip.sim.loop, mwip.hardware.loop, pathlib; "
            "root = pathlib.Path(mwip.__file__).parent; "
            "print('\\n'.join(sorted(str(pathlib.Path(m.__file__).relative_to(root)) "
            "for n, m in list(sys.modules.items()) if n.startswith('mwip') "
            "and getattr(m, '__file__', None))))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()  # fmt: skip
    loaded = {p for p in out if not p.endswith("__init__.py") and p != "lazy.py"}
    assert loaded | {"sim/aot.py"} == set(aot.SOURCES)


def test_key_follows_the_sources(tmp_path, monkeypatch):
    for rel in aot.SOURCES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(SRC / rel, tmp_path / rel)
    monkeypatch.setattr(aot, "_ROOT", tmp_path)
    monkeypatch.setattr(aot, "_KEY", [])
    k0 = aot.key()
    assert k0 == aot.key()
    kernel = tmp_path / "laws/smc/kernel.py"
    kernel.write_text(kernel.read_text().replace("1.0", "1.0000000000000002", 1))
    monkeypatch.setattr(aot, "_KEY", [])
    k1 = aot.key()
    assert k1 != k0 and aot.module_path(k1) != aot.module_path(k0)


def test_off_and_load_only(tmp_path, monkeypatch):
    monkeypatch.setenv("MWIP_CACHE_DIR", str(tmp_path / "empty"))
    monkeypatch.setenv("MWIP_AOT", "off")
    assert aot.run_function() is None
    monkeypatch.setenv("MWIP_AOT", "load")
    monkeypatch.setattr(aot, "_LOADED", {})
    assert aot.run_function() is None
    assert not (tmp_path / "empty").exists()  # load-only never builds


def test_failed_build_warns_once_and_runs_the_jit_loop(tmp_path, monkeypatch):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("x")
    monkeypatch.setenv("MWIP_CACHE_DIR", str(blocker / "cache"))
    monkeypatch.setattr(aot, "_LOADED", {})
    monkeypatch.setattr(aot, "LAST_ERROR", None)
    monkeypatch.setattr(aot, "_WARNED", [False])
    monkeypatch.setenv("MWIP_AOT", "on")
    ctrl = registry.build("lqr", NOMINAL, Ts=0.005)
    with pytest.warns(UserWarning, match="using the JIT loop"):
        a = simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=1.0)
    assert aot.LAST_ERROR and a.settings["compiled"] and a.status[0] == "ok"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once
        simulate(ctrl, REAL, q0=(0, 0.1, 0), duration=1.0)


def test_kernels_command(monkeypatch, capsys):
    from mwip.cli import main

    assert main(["kernels", "build"]) == 0
    assert main(["kernels", "status", "--json"]) == 0
    info = json.loads(capsys.readouterr().out.split("\n", 1)[1])
    assert info["built"] and info["key"] == aot.key()
    assert Path(info["module"]).is_file()


HEAVY = ("numba", "scipy", "cvxpy", "matplotlib")


@pytest.mark.parametrize("name", registry.names())
def test_plain_simulate_imports_only_what_it_uses(name, tmp_path):
    """Issue 18: a plain ``mwip simulate`` with warm caches (the built loop; for the fuzzy
    controllers the solved LMI design, mwip.cache) loads neither the compiler nor SciPy, cvxpy
    or matplotlib."""
    from mwip.cli import main

    assert main(["kernels", "build"]) == 0
    registry.build(name, NOMINAL, Ts=0.005)  # warms the design cache (the fuzzy LMIs)
    code = ("import sys; from mwip.cli import main; "
            f"code = main(['simulate', '--controller', '{name}', '--duration', '1', "
            f"'--out', r'{tmp_path / 'o'}']); "
            f"print(code, ' '.join(m for m in {HEAVY!r} if m in sys.modules))")  # fmt: skip
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=os.environ.copy())  # fmt: skip
    code_s, *loaded = res.stdout.strip().splitlines()[-1].split()
    assert code_s == "0"
    assert loaded == [], f"{name} imported {loaded}"


def test_every_compiled_kernel_is_hashed_and_uses_the_keyed_cache_folder():
    """Numba reuses a cached function while its own file is unchanged; the loop inlines
    kernels of other files. Every mwip module that compiles with Numba is in SOURCES and
    compiles with mwip.jit_cache.njit, whose cache folder is named after jit_cache.key(), the
    hash of SOURCES: an edit of any kernel gives a new folder. No private Numba class is
    patched (Numba's own locator list is as Numba ships it)."""
    from numba.core import caching

    from mwip import jit_cache
    from mwip.sim import loop

    compiled = {str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
                if "from mwip.jit_cache import njit" in p.read_text()}  # fmt: skip
    assert compiled and compiled <= set(jit_cache.SOURCES) == set(aot.SOURCES)
    assert not [p for p in SRC.rglob("*.py")
                if "numba.njit(" in p.read_text() and p.name != "jit_cache.py"]  # fmt: skip
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")  # noqa: B009
    assert all(c.__module__.startswith("numba.") for c in impl._locator_classes)
    folder = jit_cache.folder()
    assert folder is not None and folder.name == jit_cache.key()
    for fn in (loop.run, loop.run_parallel):
        locator = fn._cache._impl._locator
        assert isinstance(locator, caching.UserProvidedCacheLocator)
        assert Path(locator.get_cache_path()).is_relative_to(folder)


def test_jit_key_follows_the_sources(tmp_path, monkeypatch):
    from mwip import jit_cache

    for rel in jit_cache.SOURCES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(SRC / rel, tmp_path / rel)
    monkeypatch.setattr(jit_cache, "_ROOT", tmp_path)
    monkeypatch.setattr(jit_cache, "_KEY", [])
    k0 = jit_cache.key()
    kernel = tmp_path / "observers/_hodo_kernel.py"
    kernel.write_text(kernel.read_text() + "\n# edited\n")
    monkeypatch.setattr(jit_cache, "_KEY", [])
    assert jit_cache.key() != k0


def test_unwritable_cache_folder_compiles_without_cache(tmp_path, monkeypatch):
    """A folder that cannot be written turns caching off (never ``__pycache__``)."""
    from mwip import jit_cache

    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("MWIP_CACHE_DIR", str(blocker / "cache"))
    assert jit_cache.folder() is None

    @jit_cache.njit
    def twice(x):  # noqa: ANN001, ANN202
        return 2 * x

    assert twice(3) == 6 and twice._cache.__class__.__name__ == "NullCache"

def test_numba_pycc_is_used_by_one_module_only():
    """``numba.pycc`` is pending deprecation in Numba (docs/engine.md): only mwip.sim.aot uses
    it, behind the JIT fallback (test_failed_build_warns_once_and_runs_the_jit_loop)."""
    users = {str(p.relative_to(SRC)) for p in SRC.rglob("*.py") if "pycc" in p.read_text()
             and "import CC" in p.read_text()}  # fmt: skip
    assert users == {"sim/aot.py"}
