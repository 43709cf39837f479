"""The compiled closed loop, ahead of time: :func:`mwip.sim.loop.run` as an extension module
that loads without Numba.

Why (issue 18): Numba's on-disk cache keeps the machine code of the JIT-compiled loop, but a
process still imports Numba (~0.2 s) and initialises its typing and code generation to load
it (~0.2-0.3 s): a 25 s ``mwip simulate`` whose simulation takes ~2 ms took ~1 s in all.
Numba's ahead-of-time compiler (:mod:`numba.pycc`) compiles the same Python source
(:func:`mwip.sim.loop.run` and every kernel it calls, one implementation) into a CPython
extension module that needs only NumPy at run time; importing it takes well under 1 ms.

- **Key.** The module is named after a hash of every source file compiled into the loop
  (:data:`SOURCES`) and of the Python, NumPy and Numba versions and the machine: an edit of a
  kernel gives a new name, so a stale module is never loaded.
- **Where.** :func:`mwip.cache.cache_dir`: ``$MWIP_CACHE_DIR``, else
  ``$XDG_CACHE_HOME/mwip``, else ``~/.cache/mwip``.
- **When.** Built once (~10 s, one process at a time under a file lock, written atomically) by
  the first single compiled run that finds no module for its key (:func:`run_function`), or
  by ``mwip kernels build``. ``MWIP_AOT=off`` turns the module off (the JIT loop runs, as for
  batches, whose threaded loop :func:`mwip.sim.loop.run_parallel` is JIT-compiled);
  ``MWIP_AOT=load`` loads a built module but never builds one.
- **Same numbers.** Both are compiled by LLVM from the same source without fast-math, and
  call the same libm: a run through the module is bit-identical to the JIT loop's
  (tests/test_aot.py).
- **No compiler.** If the build fails (no C compiler, no setuptools), the reason is kept in
  :data:`LAST_ERROR`, a warning says it once, and the JIT loop runs.

The exported function has one signature, :data:`RUN_SIGNATURE`: the engine passes every array
as a fresh float64 (or int64) C-contiguous array of a fixed number of dimensions
(:func:`mwip.sim.engine._call`).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

from mwip.cache import cache_dir, versions
from mwip.jit_cache import SOURCES  # the sources compiled into the loop, one list

__all__ = [
    "SOURCES", "RUN_SIGNATURE", "key", "module_path", "load", "build",
    "run_function", "status", "LAST_ERROR",
]  # fmt: skip

#: The one signature of :func:`mwip.sim.loop.run` (Numba's type syntax): the argument order of
#: :func:`mwip.sim.engine._call`.
RUN_SIGNATURE = (
    "i8(f8[:, ::1], f8[:, ::1], f8[:, :, :, ::1], i8, f8, i8, i8, f8, i8[::1], i8, "
    "f8[:, ::1], f8[::1], f8[::1], f8[::1], f8[::1], f8[:, ::1], f8[:, ::1], f8[::1], "
    "f8[::1], f8[::1], f8[:, ::1], f8[:, ::1], f8[::1], f8[:, :, ::1], f8[:, ::1], f8[:, ::1], "
    "f8[:, :, ::1], f8[:, :, ::1], f8[:, :, ::1], i8[::1], f8[::1])"
)

#: Why the last build failed (``None``: no failure in this process).
LAST_ERROR: str | None = None

_ROOT = Path(__file__).resolve().parent.parent
_LOADED: dict[str, ModuleType] = {}
_WARNED: list[bool] = [False]


def _mode() -> str:
    mode = os.environ.get("MWIP_AOT", "on").strip().lower()
    return mode if mode in ("on", "off", "load") else "on"


def _versions() -> str:
    """Python, NumPy and Numba versions and the machine, without importing Numba."""
    import numpy as np

    (nb,) = versions(["numba"])
    return f"{sys.version}|{np.__version__}|{nb}|{platform.machine()}|{RUN_SIGNATURE}"


_KEY: list[str] = []


def key() -> str:
    """Hex digest naming the module of the current sources and versions."""
    if not _KEY:
        h = hashlib.sha256(_versions().encode())
        for rel in SOURCES:
            h.update(rel.encode())
            h.update((_ROOT / rel).read_bytes())
        _KEY.append(h.hexdigest()[:20])
    return _KEY[0]


def _name(k: str) -> str:
    return f"_mwip_loop_{k}"


def module_path(k: str | None = None) -> Path:
    """The extension module's file for key ``k`` (default: the current key)."""
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    return cache_dir() / f"{_name(k or key())}{suffix}"


def load() -> ModuleType | None:
    """The built module of the current key, or ``None`` if there is none (or it won't load)."""
    k = key()
    if k in _LOADED:
        return _LOADED[k]
    path = module_path(k)
    if not path.is_file():
        return None
    try:
        spec = importlib.util.spec_from_file_location(_name(k), path)
        if spec is None or spec.loader is None:
            return None
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    except ImportError:
        return None
    _LOADED[k] = mod
    return mod


@contextlib.contextmanager
def _lock(path: Path) -> Any:
    """An exclusive lock on ``path`` (other processes building the same module wait)."""
    import fcntl

    with open(path, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def build(force: bool = False) -> Path:
    """Compile :func:`mwip.sim.loop.run` ahead of time into :func:`module_path` and return it
    (a no-op when it exists, unless ``force``). Raises ``RuntimeError`` naming the cause if the
    toolchain fails."""
    k = key()
    target = module_path(k)
    target.parent.mkdir(parents=True, exist_ok=True)
    with _lock(target.parent / f"{_name(k)}.lock"):
        if target.is_file() and not force:
            return target
        _import_pycc()
        from numba.pycc import CC

        from mwip.sim import loop

        with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
            cc = CC(_name(k))
            cc.output_dir = tmp
            cc.export("run", RUN_SIGNATURE)(loop.run.py_func)
            try:
                with (open(os.devnull, "w") as null, contextlib.redirect_stdout(null),
                      warnings.catch_warnings()):  # fmt: skip
                    warnings.simplefilter("ignore")  # the toolchain's chatter (not pycc's news)
                    cc.compile()
            except Exception as exc:  # noqa: BLE001 - the toolchain's many failure types
                raise RuntimeError(f"ahead-of-time build failed: {exc}") from exc
            built = Path(tmp) / target.name
            if not built.is_file():
                raise RuntimeError(f"ahead-of-time build wrote no {target.name}")
            os.replace(built, target)
    return target


def _import_pycc() -> None:
    """Import :mod:`numba.pycc` and say once, on stderr (:mod:`mwip.notice`), that Numba marks
    it pending deprecation: Python's default filters hide a ``PendingDeprecationWarning``, and
    the user should know what the ahead-of-time build stands on (pyproject.toml bounds Numba
    to the versions tested; without pycc the JIT loop runs)."""
    from mwip.notice import once

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PendingDeprecationWarning)
        import numba.pycc  # noqa: F401
    for w in caught:
        if issubclass(w.category, PendingDeprecationWarning) and "pycc" in str(w.message):
            (numba_version,) = versions(["numba"])
            text = str(w.message).splitlines()[0]
            once("pycc", f"Numba {numba_version}: {text} mwip builds its ahead-of-time loop "
                 "with numba.pycc (pyproject.toml bounds Numba to the versions tested); "
                 "should it go, the JIT loop runs instead (MWIP_AOT=off)")  # fmt: skip
            break


def run_function() -> Callable[..., int] | None:
    """The ahead-of-time ``run`` for the current sources, built on first need; ``None`` when
    ``MWIP_AOT=off``, when ``MWIP_AOT=load`` finds no module, or when the build fails."""
    global LAST_ERROR
    mode = _mode()
    if mode == "off":
        return None
    mod = load()
    if mod is None and mode == "on" and LAST_ERROR is None:
        from mwip.notice import once

        once(
            "aot",
            f"building the compiled simulation loop into {module_path().parent} (first use "
            "after installing or changing mwip; it happens once, ~10 s or more)",
        )
        try:
            build()
        except (RuntimeError, OSError, ImportError) as exc:
            LAST_ERROR = str(exc)
            if not _WARNED[0]:
                _WARNED[0] = True
                warnings.warn(f"mwip: {LAST_ERROR}; using the JIT loop", stacklevel=2)
            return None
        mod = load()
    return None if mod is None else mod.run


def status() -> dict[str, Any]:
    """What ``mwip kernels status`` prints: key, file, whether it is built, mode, last error."""
    path = module_path()
    return {
        "key": key(),
        "module": str(path),
        "built": path.is_file(),
        "mode": _mode(),
        "last_error": LAST_ERROR,
    }
