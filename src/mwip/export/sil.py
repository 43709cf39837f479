"""Software in the loop: the generated C compiled with the system compiler, run as a controller.

:func:`compile_c` builds a shared library from a :class:`~mwip.export.c_code.CCode` with the
system C compiler (``$CC``, else ``cc``/``gcc``/``clang``) in strict C99 without
floating-point contraction (``-ffp-contract=off``, so ``a * b + c`` is not fused and the C
arithmetic follows the Python kernels operation by operation). :class:`CController` loads it
through :mod:`ctypes` and is a :class:`mwip.core.Controller`: it runs in
:func:`mwip.sim.simulate` and on the digital twin like the Python controller it was generated
from, one C state per robot of the batch. :func:`verify` runs both closed loops side by side.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.export.c_code import CCode

__all__ = ["find_compiler", "compile_c", "CController", "verify", "VerifyReport", "NoCompiler"]


class NoCompiler(RuntimeError):
    """No C compiler was found (software in the loop needs one)."""


def find_compiler() -> str:
    """The C compiler to use: ``$CC`` or the first of cc, gcc, clang on PATH."""
    for cand in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if cand and shutil.which(cand):
            return str(shutil.which(cand))
    raise NoCompiler("no C compiler found: install one (e.g. gcc) or set CC")


def compile_c(code: CCode, folder: str | os.PathLike[str] | None = None) -> Path:
    """Compile ``code`` (plus a size query for the state struct) to a shared library; returns
    its path. ``folder``: where to build (default: a new temporary folder)."""
    cc = find_compiler()
    out = Path(folder) if folder is not None else Path(tempfile.mkdtemp(prefix="mwip-sil-"))
    out.mkdir(parents=True, exist_ok=True)
    for name, text in code.files().items():
        (out / name).write_text(text)
    shim = out / f"{code.prefix}_sil.c"
    shim.write_text(
        f'#include <stddef.h>\n#include "{code.prefix}.h"\n'
        f"size_t {code.prefix}_state_size(void) {{ return sizeof({code.prefix}_state); }}\n"
    )
    lib = out / f"lib{code.prefix}.so"
    cmd = [cc, "-std=c99", "-O2", "-fPIC", "-shared", "-ffp-contract=off", "-Wall", "-Wextra",
           "-Werror", "-pedantic", "-o", str(lib), str(out / f"{code.prefix}.c"), str(shim),
           "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"C compilation failed ({' '.join(cmd)}):\n{proc.stderr}")
    return lib


class CController:
    """A compiled controller (one C state per robot) behind the Controller protocol."""

    def __init__(self, code: CCode, *, static: bool = False, folder: str | None = None) -> None:
        self.code = code
        self.Ts = code.Ts
        self.static = static
        if folder is None:  # built in a temporary folder, removed once the library is loaded
            with tempfile.TemporaryDirectory(prefix="mwip-sil-") as tmp:
                self._lib = ctypes.CDLL(str(compile_c(code, tmp)))
        else:
            self._lib = ctypes.CDLL(str(compile_c(code, folder)))
        self._dtype = np.float32 if code.precision == "float" else np.float64
        real = ctypes.c_float if code.precision == "float" else ctypes.c_double
        p = code.prefix
        self._size = int(getattr(self._lib, f"{p}_state_size")())
        self._init = getattr(self._lib, f"{p}_init")
        self._step = getattr(self._lib, f"{p}_step")
        ptr = ctypes.POINTER(real)
        self._init.argtypes = [ctypes.c_void_p, ptr]
        self._step.argtypes = [ctypes.c_void_p, real, ptr, ptr]
        self._ptr = ptr
        self._states = ctypes.create_string_buffer(0)
        self._n = 0
        self.calls = 0
        self.seconds = 0.0

    def _row(self, arr: NDArray[Any], i: int) -> Any:
        return arr[i].ctypes.data_as(self._ptr)

    def reset(self, meas: Any) -> None:
        y = np.ascontiguousarray(meas.y, dtype=self._dtype)
        self._n = y.shape[0]
        self._states = ctypes.create_string_buffer(max(self._size, 1) * self._n)
        base = ctypes.addressof(self._states)
        for i in range(self._n):
            self._init(base + i * self._size, self._row(y, i))

    def __call__(self, t: float, meas: Any) -> NDArray[np.float64]:
        y = np.ascontiguousarray(meas.y, dtype=self._dtype)
        if y.shape[0] != self._n:
            self.reset(meas)
        u = np.zeros((self._n, 2), dtype=self._dtype)
        base = ctypes.addressof(self._states)
        t0 = time.perf_counter()
        for i in range(self._n):
            self._step(base + i * self._size, t, self._row(y, i), self._row(u, i))
        self.seconds += time.perf_counter() - t0
        self.calls += self._n
        return u.astype(np.float64)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return {}


@dataclass(frozen=True)
class VerifyReport:
    """Closed loops of the Python and the C controller: largest state and torque differences
    over the run (``max_state_diff`` over all states in their units, rad, rad/s and m;
    ``max_theta_diff`` the pitch alone), the statuses,
    the C step's mean time per call (s, including the ctypes call) and the Python loop's
    largest wheel torque delivered to the plant (N m; on the twin, what its drive delivers,
    not what the controller commands)."""

    max_state_diff: float
    max_theta_diff: float
    max_u_diff: float
    status_python: str
    status_c: str
    duration: float
    seconds_per_call: float
    peak_torque: float = float("nan")

    def ok(self, tol: float) -> bool:
        return self.status_python == self.status_c and self.max_state_diff <= tol


def verify(
    python_controller: Any,
    c_controller: CController,
    *,
    plant: Any = None,
    q0: Any = (0.0, 0.1, 0.0),
    duration: float = 10.0,
    twin: Any = None,
    case: int = 1,
    seed: int = 0,
) -> VerifyReport:
    """Run the same closed loop with the Python and the C controller (on ``plant``, default
    the real robot; on the digital twin ``twin`` if given, Chapter 6 ``case``) and compare
    the trajectories."""
    from mwip.params import REAL
    from mwip.sim import simulate

    plant = REAL if plant is None else plant

    def run(ctrl: Any) -> Any:
        if twin is not None:
            from mwip.hardware.twin import run_on_twin

            return run_on_twin(ctrl, case, twin=twin, plant=plant, q0=q0, duration=duration,
                               seed=seed)  # fmt: skip
        return simulate(ctrl, plant, q0=q0, duration=duration, Ts=c_controller.Ts, seed=seed)

    a, b = run(python_controller), run(c_controller)
    n = min(a.state.shape[-2], b.state.shape[-2])
    ds = np.abs(a.state[..., :n, :] - b.state[..., :n, :])
    du = np.abs(a.u[..., :n, :] - b.u[..., :n, :])
    per = c_controller.seconds / max(c_controller.calls, 1)
    status = (str(np.atleast_1d(a.status)[0]), str(np.atleast_1d(b.status)[0]))
    applied = (getattr(a, "logs", None) or {}).get("u_applied", a.u)
    return VerifyReport(
        float(np.nanmax(ds)), float(np.nanmax(ds[..., 1])), float(np.nanmax(du)), *status,
        float(duration), per, float(np.nanmax(np.abs(applied))),
    )  # fmt: skip
