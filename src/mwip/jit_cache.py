"""Numba's on-disk cache for mwip's kernels, invalidated when *any* kernel's source changes.

Numba keeps a compiled function's machine code beside its source file (``__pycache__``) and
reuses it as long as *that file* is unchanged. The compiled loop (:mod:`mwip.sim.loop`)
inlines kernels from other files (the plant, the laws, the observer): after an edit of a
kernel, or an upgrade of mwip that changes one, Numba would run the *old* kernel from the
cache. The locators below, put first in Numba's list for mwip's own files only, stamp every
cache entry with :func:`mwip.sim.aot.key` as well, the hash of every source compiled into the
loop (and of the Python, NumPy and Numba versions): any change recompiles. Other code's
caches are untouched.

A damaged entry of mwip's (a truncated index, a garbage data file: Numba raises
``UnpicklingError`` from inside the call, on every run) is a cache miss instead: the index is
removed, the function compiled again and the entry rewritten (:func:`_tolerant`).

Imported by every module that defines a compiled kernel, right after ``import numba``.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from numba.core import caching

from mwip.sim.aot import key

__all__ = ["LOCATORS"]

_ROOT = Path(__file__).resolve().parent


def _ours(py_file: str) -> bool:
    try:
        Path(py_file).resolve().relative_to(_ROOT)
    except ValueError:
        return False
    return True


class _Stamped:
    """Numba's stamp of the function's own file, plus the hash of every kernel source."""

    def get_source_stamp(self) -> Any:
        return (super().get_source_stamp(), key())  # type: ignore[misc]

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> Any:
        if not _ours(py_file):
            return None
        return super().from_function(py_func, py_file)  # type: ignore[misc]


class UserProvidedLocator(_Stamped, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR`` when set (as Numba's own first choice)."""


class InTreeLocator(_Stamped, caching.InTreeCacheLocator):
    """``__pycache__`` beside the source (Numba's default)."""


class UserWideLocator(_Stamped, caching.UserWideCacheLocator):
    """The user's cache folder when the source tree is read-only."""


LOCATORS = (UserProvidedLocator, InTreeLocator, UserWideLocator)

_IMPL: Any = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")  # noqa: B009
if LOCATORS[0] not in _IMPL._locator_classes:
    _IMPL._locator_classes[0:0] = list(LOCATORS)

_GUARD = caching.Cache._guard_against_spurious_io_errors


@contextlib.contextmanager
def _tolerant(self: Any) -> Iterator[None]:
    """Numba's guard around loading and saving a cache entry; for mwip's own entries, any
    failure (a damaged index or data file) is swallowed as a miss and the index removed, so
    that the recompiled function writes a fresh entry."""
    if not isinstance(getattr(self._impl, "_locator", None), LOCATORS):
        with _GUARD(self):
            yield
        return
    try:
        with _GUARD(self):
            yield
    except Exception:  # noqa: BLE001 - pickle, EOF, attribute errors of a damaged file alike
        with contextlib.suppress(OSError):
            os.unlink(self._cache_file._index_path)


if getattr(caching.Cache._guard_against_spurious_io_errors, "__name__", "") != "_tolerant":
    caching.Cache._guard_against_spurious_io_errors = _tolerant  # type: ignore[method-assign]
