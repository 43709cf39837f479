"""The whole-board check: the controller's firmware on QEMU's ``lm3s6965evb``, over its UART.

The same object code as the processor-in-the-loop image (:mod:`mwip.export.firmware`) is
linked into a minimal firmware (``mcu/board_uart.c``: start-up, UART0 at 0x4000C000, a loop
that serves ``init`` and ``step`` in binary frames) and run on QEMU's model of an LM3S6965
evaluation board (the same Stellaris LM3S family as the book's LM3S2965; Debian's
``qemu-system-arm``). :class:`BoardController` is a :class:`mwip.core.Controller` (one board:
batches of one robot) whose every sample is a frame to the emulated board and its reply: the
whole board (start-up code, peripherals, serial link) rather than a function call into the
processor.

QEMU runs as a child process with its serial port on a Unix socket in a private temporary
folder; every read has a timeout (:data:`TIMEOUT_S`), and :meth:`BoardController.close` (also
on leaving a ``with`` block, on garbage collection and at exit) asks the firmware to stop
(semihosting exit), then terminates and kills QEMU if it does not, and removes the folder. On
Linux QEMU is also told to die with its parent (``PR_SET_PDEATHSIG``), so a killed Python
leaves no QEMU behind.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
import weakref
from collections.abc import Mapping
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.export.firmware import Firmware, NoToolchain

__all__ = ["BoardController", "BoardError", "qemu_available", "TIMEOUT_S", "QEMU"]

#: The emulator and the machine it emulates.
QEMU = "qemu-system-arm"
MACHINE = "lm3s6965evb"
#: The longest wait for the board's start or for one reply (s).
TIMEOUT_S = 20.0


class BoardError(RuntimeError):
    """The emulated board did not answer as the protocol says (or QEMU failed)."""


def qemu_available() -> bool:
    """Whether ``qemu-system-arm`` is on PATH."""
    return shutil.which(QEMU) is not None


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    with contextlib.suppress(Exception):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def _stop(proc: subprocess.Popen[bytes] | None, conn: socket.socket | None,
          folder: str | None) -> None:  # fmt: skip
    """Stop QEMU (politely first) and remove the folder: idempotent, never raises."""
    if conn is not None:
        with contextlib.suppress(OSError):
            conn.settimeout(1.0)
            conn.sendall(b"Q")
            conn.recv(1)
        with contextlib.suppress(OSError):
            conn.close()
    if proc is not None and proc.poll() is None:
        try:
            proc.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            proc.terminate()
            try:
                proc.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    if proc is not None:
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)


class BoardController:
    """The controller's firmware on an emulated LM3S6965 board, exchanging frames over its
    UART (module docstring). ``firmware``: the built images (its ``board_elf``); one robot
    (a batch of several is a ``ValueError``). Use as a context manager, or call
    :meth:`close`."""

    def __init__(self, firmware: Firmware, *, static: bool = False,
                 timeout: float = TIMEOUT_S) -> None:  # fmt: skip
        qemu = shutil.which(QEMU)
        if qemu is None:
            raise NoToolchain("the whole-board check needs QEMU: install Debian's "
                              "qemu-system-arm (apt-get install qemu-system-arm)")  # fmt: skip
        self.firmware = firmware
        self.code = firmware.code
        self.Ts = firmware.code.Ts
        self.static = static
        self.timeout = float(timeout)
        self._dtype: type[np.floating[Any]] = (np.float32 if firmware.precision == "float"
                                               else np.float64)  # fmt: skip
        self._size = np.dtype(self._dtype).itemsize
        self._folder: str | None = tempfile.mkdtemp(prefix="mwip-board-")
        self._proc: subprocess.Popen[bytes] | None = None
        self._conn: socket.socket | None = None
        self._finalizer = weakref.finalize(self, _stop, None, None, self._folder)
        self.calls = 0
        self.seconds = 0.0
        self._n = 0
        try:
            self._start(qemu)
        except BaseException:
            self.close()
            raise

    def _start(self, qemu: str) -> None:
        assert self._folder is not None
        image = os.path.join(self._folder, "board.elf")
        with open(image, "wb") as fh:
            fh.write(self.firmware.board_elf)
        path = os.path.join(self._folder, "uart0.sock")
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            server.bind(path)
            server.listen(1)
            server.settimeout(self.timeout)
            cmd = [qemu, "-M", MACHINE, "-nographic", "-monitor", "none", "-serial",
                   f"unix:{path}", "-semihosting-config", "enable=on,target=native",
                   "-kernel", image]  # fmt: skip
            self._proc = subprocess.Popen(
                cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE, preexec_fn=_die_with_parent if os.name == "posix" else None,
            )  # fmt: skip
            self._finalizer.detach()
            self._finalizer = weakref.finalize(self, _stop, self._proc, None, self._folder)
            try:
                conn, _ = server.accept()
            except TimeoutError:
                raise BoardError(f"QEMU did not connect to the board's UART within "
                                 f"{self.timeout:g} s{self._qemu_said()}") from None  # fmt: skip
        finally:
            server.close()
        conn.settimeout(self.timeout)
        self._conn = conn
        self._finalizer.detach()
        self._finalizer = weakref.finalize(self, _stop, self._proc, conn, self._folder)
        hello = self._recv(5, "the board's greeting")
        if hello[:4] != b"MWIP" or hello[4] != self._size:
            raise BoardError(f"the board greeted with {hello!r}, expected b'MWIP' and "
                             f"{self._size} (the {self.firmware.precision} build)")  # fmt: skip

    def _qemu_said(self) -> str:
        proc = self._proc
        if proc is None or proc.poll() is None or proc.stderr is None:
            return ""
        with contextlib.suppress(OSError, ValueError):
            text = proc.stderr.read().decode("utf-8", "replace").strip()
            if text:
                return f" (QEMU exited {proc.returncode}: {text.splitlines()[-1]})"
        return f" (QEMU exited {proc.returncode})"

    def _recv(self, n: int, what: str) -> bytes:
        if self._conn is None:
            raise BoardError("the board is closed")
        buf = b""
        deadline = time.monotonic() + self.timeout
        while len(buf) < n:
            try:
                chunk = self._conn.recv(n - len(buf))
            except TimeoutError:
                chunk = None
            if not chunk or time.monotonic() > deadline:
                why = "closed the link" if chunk == b"" else f"did not answer in {self.timeout:g} s"
                raise BoardError(f"the emulated board {why} while sending {what}"
                                 f"{self._qemu_said()}")  # fmt: skip
            buf += chunk
        return buf

    def _send(self, data: bytes) -> None:
        if self._conn is None:
            raise BoardError("the board is closed")
        try:
            self._conn.sendall(data)
        except OSError as exc:
            raise BoardError(
                f"cannot write to the board's UART: {exc}{self._qemu_said()}"
            ) from None

    def _y(self, meas: Any) -> NDArray[Any]:
        y = np.ascontiguousarray(meas.y, dtype=self._dtype)
        if y.ndim != 2 or y.shape[0] != 1:
            raise ValueError(f"the emulated board runs one robot; got a batch of "
                             f"{y.shape[0] if y.ndim == 2 else '?'}")  # fmt: skip
        return y

    def reset(self, meas: Any) -> None:
        y = self._y(meas)
        self._send(b"I" + y[0].tobytes())
        if self._recv(1, "the init reply") != b"i":
            raise BoardError("the board answered init with a wrong frame")
        self._n = 1

    def __call__(self, t: float, meas: Any) -> NDArray[np.float64]:
        y = self._y(meas)
        if self._n != 1:
            self.reset(meas)
        stamp = np.array([t], dtype=self._dtype).tobytes()
        t0 = time.perf_counter()
        self._send(b"S" + stamp + y[0].tobytes())
        reply = self._recv(1 + 2 * self._size, "a step reply")
        if reply[:1] != b"s":
            raise BoardError(f"the board answered a step with {reply[:1]!r}, expected b's'")
        self.seconds += time.perf_counter() - t0
        self.calls += 1
        return np.frombuffer(reply[1:], dtype=self._dtype).astype(np.float64).reshape(1, 2)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return {}

    @property
    def running(self) -> bool:
        """Whether the QEMU process is alive."""
        return self._proc is not None and self._proc.poll() is None

    @property
    def returncode(self) -> int | None:
        """QEMU's exit status once it has ended (0 after a clean stop)."""
        return None if self._proc is None else self._proc.poll()

    def close(self) -> None:
        """Stop the board and QEMU, remove the temporary folder (idempotent)."""
        self._finalizer()
        self._conn = None

    def __enter__(self) -> BoardController:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        self.close()
