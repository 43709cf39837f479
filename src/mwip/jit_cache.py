"""Numba's on-disk cache for mwip's kernels, in a folder named after *every* kernel source.

Numba keeps a compiled function's machine code and reuses it as long as *that function's file*
is unchanged. The compiled loop (:mod:`mwip.sim.loop`) inlines kernels from other files (the
plant, the laws, the observer): after an edit of a kernel, or an upgrade of mwip that changes
one, Numba would run the *old* kernel from its cache. So mwip's kernels are compiled by
:func:`njit`, which is ``numba.njit(cache=True, ...)`` with Numba's cache folder
(``NUMBA_CACHE_DIR``, Numba's public setting ``numba.config.CACHE_DIR``) set, while the function
is decorated, to ``<mwip cache>/numba/<key>``: :func:`key` hashes every source compiled into
the loop (:data:`SOURCES`) and the Python, NumPy and Numba versions, so any change gives a new,
empty folder and recompiles. Only mwip's own functions are affected: the setting is restored
right after, and Numba's cache of other code stays where the user put it. A cache folder that
cannot be written turns caching off for mwip's kernels (they compile in each process) rather
than falling back to ``__pycache__``, where a stale kernel could be found.

A damaged entry of mwip's (a truncated index, a garbage data file; Numba would raise
``UnpicklingError`` from inside every later call) is dropped before Numba sees it
(:func:`drop_damaged`): the function compiles again and its entry is rewritten.

Ground floor: imports neither Numba (until :func:`njit` is called) nor the engine; the
ahead-of-time loop (:mod:`mwip.sim.aot`) names its module after the same :data:`SOURCES`.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import platform
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mwip.cache import cache_dir, versions

__all__ = ["SOURCES", "key", "folder", "njit", "drop_damaged"]

def _law_sources() -> list[str]:
    """``laws/<family>/kernel.py`` and ``packing.py`` of every law folder (a new law is found
    without editing this list)."""
    laws = Path(__file__).resolve().parent / "laws"
    return [f"laws/{d.name}/{part}.py" for d in sorted(laws.iterdir())
            if (d / "kernel.py").is_file() for part in ("kernel", "packing")]  # fmt: skip


def _hardware_sources() -> list[str]:
    """The twin's compiled modules: every ``hardware/*.py`` with a kernel (a new element is
    found without editing this list), the layouts they read (the signal bus's offsets are
    compiled into the kernels), the declarations every element module imports and the motor's
    data sheet (:mod:`mwip.hardware.motor_data`, imported by the motor element)."""
    hw = Path(__file__).resolve().parent / "hardware"
    kernels = [f"hardware/{f.name}" for f in sorted(hw.glob("*.py"))
               if "@njit" in f.read_text(encoding="utf-8")]  # fmt: skip
    return ["layout.py", "hardware/bus.py", "hardware/element.py", "hardware/unknown.py",
            "hardware/motor_data.py", *kernels]  # fmt: skip


#: The source files compiled into :func:`mwip.sim.loop.run`, relative to the package
#: (tests/test_aot.py checks that every mwip module the loop imports is listed).
SOURCES: tuple[str, ...] = (
    "sim/aot.py",
    "jit_cache.py",
    "cache.py",
    "sim/loop.py",
    "sim/kernel.py",
    "sim/codes.py",
    "models/reduced.py",
    "models/_compiled.py",
    "core.py",
    "params.py",
    "damping.py",
    "io.py",
    "laws/packing.py",
    "laws/dispatch.py",
    *_law_sources(),
    "observers/_hodo_kernel.py",
    "fuzzy/_kernel.py",
    "fuzzy/ts_model.py",
    "fuzzy/layout.py",
    *_hardware_sources(),
)

_ROOT = Path(__file__).resolve().parent
_KEY: list[str] = []


def key() -> str:
    """Hex digest of :data:`SOURCES` and the Python, NumPy and Numba versions and the machine
    (read from metadata: Numba is not imported)."""
    if not _KEY:
        import numpy as np

        (nb,) = versions(["numba"])
        h = hashlib.sha256(f"{sys.version}|{np.__version__}|{nb}|{platform.machine()}".encode())
        for rel in SOURCES:
            h.update(rel.encode())
            h.update((_ROOT / rel).read_bytes())
        _KEY.append(h.hexdigest()[:20])
    return _KEY[0]


def folder() -> Path | None:
    """Numba's cache folder for mwip's kernels, ``<mwip cache>/numba/<key>`` (created), or
    ``None`` if it cannot be written."""
    path = cache_dir() / "numba" / key()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return path if os.access(path, os.W_OK | os.X_OK) else None


def njit(*args: Any, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` with the cache in :func:`folder`; use as
    ``@njit`` or ``@njit(inline="always")`` (or ``njit(...)(function)``)."""
    if args and callable(args[0]) and len(args) == 1 and not options:
        return njit()(args[0])
    if args:
        raise TypeError("njit takes keyword options only (no signatures for mwip's kernels)")

    def decorate(fn: Callable[..., Any]) -> Any:
        import numba

        config: Any = numba.config
        path = folder()
        if path is None:
            return numba.njit(**options)(fn)
        drop_damaged(path, fn)
        old = config.CACHE_DIR
        config.CACHE_DIR = str(path)
        try:  # Numba picks the cache folder here, when caching is enabled for the function
            return numba.njit(cache=True, **options)(fn)
        finally:
            config.CACHE_DIR = old

    return decorate


def _sound_pickle(data: bytes) -> bool:
    """A cheap structural check of a pickle: protocol 2+ header and the STOP opcode at the
    end (a truncated or overwritten file fails it)."""
    return len(data) > 3 and data[:1] == b"\x80" and data[-1:] == b"."


def drop_damaged(path: Path, fn: Callable[..., Any]) -> None:
    """Remove ``fn``'s cache index under ``path`` when it, or a data file it names, is damaged.

    Numba's index (``<file>.<qualname>-<line>.py<ver>.nbi``) is a pickled version followed by a
    pickled ``(stamp, overloads)``; each overload names a data file (``.nbc``, a pickle). The
    index is read as Numba reads it, the data files checked structurally; on any failure the
    index goes, so Numba sees a miss, compiles and writes a sound entry."""
    code = getattr(fn, "__code__", None)
    if code is None:
        return
    stem = f"{Path(code.co_filename).stem}.{fn.__qualname__}-"
    for index in path.rglob(f"{stem}*.nbi"):
        try:
            with open(index, "rb") as fh:
                pickle.load(fh)  # Numba's version stamp
                _stamp, overloads = pickle.loads(fh.read())
            names = list(overloads.values())
            ok = all(_sound_pickle((index.parent / str(n)).read_bytes()) for n in names)
        except Exception:  # noqa: BLE001 - pickle, EOF, OS and shape errors alike
            ok = False
        if not ok:
            with contextlib.suppress(OSError):
                index.unlink()
