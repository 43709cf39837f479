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
- **Verified before loading.** A build writes, after the module, a manifest
  (``_mwip_loop_<key>.sha256``, atomically) with the module's size and SHA-256; :func:`load`
  imports the module only when the file matches it. A module that is truncated, empty,
  garbage, a folder, or has no manifest is *corrupt* (importing a truncated shared object
  dies by SIGBUS): a run rebuilds it (``MWIP_AOT=load``: one notice, then the JIT loop),
  ``mwip kernels status`` says so and ``mwip kernels build`` rebuilds it. The build works in
  a private folder beside the module (the toolchain's temporary folders included), removed
  when it ends, whatever the outcome.

The exported function has one signature, :data:`RUN_SIGNATURE`: the engine passes every array
as a fresh float64 (or int64) C-contiguous array of a fixed number of dimensions
(:func:`mwip.sim.engine._call`).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import platform
import shutil
import stat
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
    "SOURCES", "RUN_SIGNATURE", "key", "module_path", "manifest_path", "verify", "load",
    "build", "run_function", "status", "folder_problem", "LAST_ERROR",
]  # fmt: skip

#: The one signature of :func:`mwip.sim.loop.run` (Numba's type syntax): the argument order of
#: :func:`mwip.sim.engine._call`.
RUN_SIGNATURE = (
    "i8(f8[:, ::1], f8[:, ::1], f8[:, :, :, ::1], i8, f8, i8, i8, f8, i8[::1], i8, "
    "f8[:, ::1], f8[:, ::1], f8[:, :, ::1], f8[:, :, ::1], f8[:, :, ::1], i8[::1], f8[::1])"
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


def manifest_path(k: str | None = None) -> Path:
    """The manifest of key ``k``'s module: its size and SHA-256, written after the module."""
    return cache_dir() / f"{_name(k or key())}.sha256"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def verify(k: str | None = None) -> str | None:
    """Why key ``k``'s module must not be loaded, or ``None`` when it matches its manifest.

    ``"missing"`` when there is no module at all; otherwise a short reason (``"corrupt: ..."``)
    for a module that is not a regular file, has no readable manifest, or whose size or
    SHA-256 differs from the manifest's.
    """
    path = module_path(k)
    try:
        mode = os.lstat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "missing"
    except OSError as exc:
        return f"corrupt: cannot read the module ({exc.strerror or exc})"
    if not stat.S_ISREG(mode):
        return "corrupt: the module's path is not a regular file"
    try:
        manifest = json.loads(manifest_path(k).read_text())
        size, digest = int(manifest["size"]), str(manifest["sha256"])
    except (OSError, ValueError, KeyError, TypeError):
        return "corrupt: no valid manifest (an interrupted build or a copied cache)"
    try:
        if path.stat().st_size != size:
            return f"corrupt: {path.stat().st_size} bytes, the build wrote {size}"
        if _sha256(path) != digest:
            return "corrupt: the module's SHA-256 differs from the build's"
    except OSError as exc:
        return f"corrupt: cannot read the module ({exc.strerror or exc})"
    return None


def load() -> ModuleType | None:
    """The built module of the current key, or ``None`` if there is none, it does not match
    its manifest (:func:`verify`), or it won't load."""
    k = key()
    if k in _LOADED:
        return _LOADED[k]
    if verify(k) is not None:
        return None
    path = module_path(k)
    try:
        spec = importlib.util.spec_from_file_location(_name(k), path)
        if spec is None or spec.loader is None:
            return None
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    except (ImportError, OSError):
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


def _remove(path: Path) -> None:
    """Remove ``path`` whatever it is (a corrupt entry: a file, a link or a folder)."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    if stat.S_ISDIR(mode):
        shutil.rmtree(path)
    else:
        path.unlink()


def build(force: bool = False) -> Path:
    """Compile :func:`mwip.sim.loop.run` ahead of time into :func:`module_path`, write its
    manifest and return it (a no-op when a module that matches its manifest exists, unless
    ``force``; a corrupt one is replaced). Raises ``RuntimeError`` naming the cause if the
    toolchain fails."""
    k = key()
    target = module_path(k)
    manifest = manifest_path(k)
    target.parent.mkdir(parents=True, exist_ok=True)
    with _lock(target.parent / f"{_name(k)}.lock"):
        if not force and verify(k) is None:
            return target
        prefix = f".{_name(k)}.build-"
        for stale in target.parent.glob(prefix + "*"):  # left by a killed build of this key
            shutil.rmtree(stale, ignore_errors=True)
        from mwip.io import write_text_atomic

        with tempfile.TemporaryDirectory(prefix=prefix, dir=target.parent) as tmp:
            # the toolchain's own temporary folders (Numba's compiler probe never removes its
            # own) go into ours, removed with it
            saved, tempfile.tempdir = tempfile.tempdir, tmp
            try:
                _compile(_name(k), Path(tmp))
            except Exception as exc:  # noqa: BLE001 - the toolchain's many failure types
                raise RuntimeError(f"ahead-of-time build failed: {exc}") from exc
            finally:
                tempfile.tempdir = saved
            built = Path(tmp) / target.name
            if not built.is_file():
                raise RuntimeError(f"ahead-of-time build wrote no {target.name}")
            size, digest = built.stat().st_size, _sha256(built)
            # manifest last: an interruption in between leaves a module without a manifest,
            # which verify() calls corrupt and the next build replaces
            _remove(manifest)
            _remove(target)
            os.replace(built, target)
            write_text_atomic(manifest, json.dumps({"size": size, "sha256": digest}) + "\n")
    return target


def _compile(name: str, out: Path) -> None:
    """Numba's ahead-of-time compiler: the extension module ``name`` into folder ``out``."""
    _import_pycc()
    from numba.pycc import CC

    from mwip.sim import loop

    cc = CC(name)
    cc.output_dir = str(out)
    cc.export("run", RUN_SIGNATURE)(loop.run.py_func)
    with (open(os.devnull, "w") as null, contextlib.redirect_stdout(null),
          warnings.catch_warnings()):  # fmt: skip
        warnings.simplefilter("ignore")  # the toolchain's chatter (not pycc's news)
        cc.compile()


def _import_pycc() -> None:
    """Import :mod:`numba.pycc` without its ``PendingDeprecationWarning`` (issue 40: no
    deprecation warning reaches a user; what the build stands on, and why, is said in the
    README and docs/engine.md; without pycc the build fails and the JIT loop runs)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=PendingDeprecationWarning)
        import numba.pycc  # noqa: F401


def run_function() -> Callable[..., int] | None:
    """The ahead-of-time ``run`` for the current sources, built on first need (or rebuilt when
    the cached one is corrupt); ``None`` when ``MWIP_AOT=off``, when ``MWIP_AOT=load`` finds no
    sound module, or when the build fails."""
    global LAST_ERROR
    mode = _mode()
    if mode == "off":
        return None
    mod = load()
    if mod is None and mode == "load":
        problem = verify()
        if problem not in (None, "missing"):
            _warn(f"the compiled loop in the cache is {problem} (MWIP_AOT=load does not "
                  "rebuild; run 'mwip kernels build')")  # fmt: skip
    if mod is None and mode == "on" and LAST_ERROR is None:
        from mwip.notice import once

        once(
            "aot",
            f"building the compiled simulation loop into {module_path().parent} (first use "
            "after installing or changing mwip; it happens once, ~10 s or more)",
        )
        try:
            build()
        except (RuntimeError, OSError, ImportError, ValueError) as exc:
            LAST_ERROR = str(exc)
            _warn(LAST_ERROR)
            return None
        mod = load()
        if mod is None:
            LAST_ERROR = f"the rebuilt module does not load ({verify()})"
            _warn(LAST_ERROR)
    return None if mod is None else mod.run


def _warn(why: str) -> None:
    """Say once per process why the JIT loop runs instead."""
    if not _WARNED[0]:
        _WARNED[0] = True
        warnings.warn(f"mwip: {why}; using the JIT loop", stacklevel=3)


def folder_problem() -> str | None:
    """Why the cache folder (:func:`mwip.cache.cache_dir`) cannot hold a module (it, or the
    first of its parents that exists, is not a writable folder), or ``None``."""
    folder = cache_dir()
    for p in (folder, *folder.absolute().parents):
        if p.exists():
            if not p.is_dir():
                return f"{str(p)!r} is not a folder"
            if not os.access(p, os.W_OK | os.X_OK):
                return f"{str(p)!r} is not writable"
            return None
    return None


def status() -> dict[str, Any]:
    """What ``mwip kernels status`` prints: key, file, whether it is built (and sound), its
    state (``built``, ``missing``, ``corrupt: ...`` or ``unusable cache folder: ...``), mode,
    last error."""
    path = module_path()
    problem = verify()
    if problem == "missing" and folder_problem():
        problem = f"unusable cache folder: {folder_problem()}"
    return {
        "key": key(),
        "module": str(path),
        "built": problem is None,
        "state": problem or "built",
        "mode": _mode(),
        "last_error": LAST_ERROR,
    }
