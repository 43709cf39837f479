"""Argument checks for the public API: a bad value is a ``TypeError`` (wrong kind: a string,
a bool, an array where a number belongs) or a ``ValueError`` (right kind, outside its range)
that names the argument and what is allowed, raised before any NumPy work can fail deep
inside with a message that names neither.

>>> real("duration", 10)
10.0
>>> real("duration", "10")
Traceback (most recent call last):
...
TypeError: duration must be a real number, got '10' (str)
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["real", "interval_text", "finite_array", "integer", "vector", "choice", "params_arg"]


def interval_text(lo: float, hi: float, lo_closed: bool = False, hi_closed: bool = True) -> str:
    """``(lo, hi]`` and the like, with ``inf`` for an open end."""
    left = "[" if lo_closed and math.isfinite(lo) else "("
    right = "]" if hi_closed and math.isfinite(hi) else ")"
    return f"{left}{lo:g}, {hi:g}{right}"


def _is_real(value: Any) -> bool:
    if isinstance(value, bool | np.bool_):
        return False
    return isinstance(value, numbers.Real)


def real(
    name: str,
    value: Any,
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    lo_closed: bool = False,
    hi_closed: bool = True,
) -> float:
    """``value`` as a float, if it is a real number (not a bool, string or array) that is
    finite and in the interval; otherwise ``TypeError``/``ValueError`` naming ``name``."""
    if not _is_real(value):
        raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
    x = float(value)
    ok = math.isfinite(x)
    ok = ok and (x >= lo if lo_closed else x > lo) and (x <= hi if hi_closed else x < hi)
    if not ok:
        raise ValueError(
            f"{name} must be finite and in {interval_text(lo, hi, lo_closed, hi_closed)}, "
            f"got {value!r}"
        )
    return x


def integer(name: str, value: Any, lo: int, hi: int) -> int:
    """``value`` as an int in ``[lo, hi]`` (a bool or a float is a ``TypeError``)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name} must be in [{lo}, {hi}], got {value!r}")
    return int(value)


def finite_array(name: str, value: Any) -> NDArray[np.float64]:
    """``value`` as a float array with finite entries (strings, bools, objects refused)."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):  # ragged nested sequences
        raise ValueError(f"{name} must be a regular array of numbers, got {value!r}") from None
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got {value!r} (dtype {arr.dtype})")
    out = arr.astype(float)
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def vector(name: str, value: Any, n: int, lo: float = -math.inf, hi: float = math.inf, *,
           lo_closed: bool = True, hi_closed: bool = True) -> NDArray[np.float64]:  # fmt: skip
    """``value`` as ``n`` floats: one number (the same for each) or exactly ``n`` numbers, finite
    and in the interval; otherwise ``TypeError``/``ValueError`` naming ``name``."""
    arr = finite_array(name, value)
    if arr.shape not in ((), (n,)):
        raise ValueError(f"{name} must be a number or {n} numbers, got shape {arr.shape}")
    out = np.broadcast_to(arr, (n,)).copy()
    below = out < lo if lo_closed else out <= lo
    above = out > hi if hi_closed else out >= hi
    if np.any(below) or np.any(above):
        raise ValueError(f"{name} must be in {interval_text(lo, hi, lo_closed, hi_closed)}, "
                         f"got {out.tolist()}")  # fmt: skip
    return out


def choice(name: str, value: Any, allowed: tuple[str, ...]) -> str:
    """``value`` if it is one of the words ``allowed``; otherwise a ``ValueError`` naming
    ``name`` (an array or a number is never compared element-wise)."""
    if not isinstance(value, str) or value not in allowed:
        shown = repr(value) if isinstance(value, str) else type(value).__name__
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {shown}")
    return value


def params_arg(name: str, value: Any) -> Any:
    """``value`` if it is a :class:`mwip.params.Params`; otherwise a ``TypeError`` naming
    ``name``."""
    from mwip.params import Params

    if not isinstance(value, Params):
        raise TypeError(f"{name} must be a mwip.params.Params (e.g. mwip.NOMINAL), got "
                        f"{type(value).__name__}")  # fmt: skip
    return value
