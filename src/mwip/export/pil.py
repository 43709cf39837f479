"""Processor in the loop: the exported controller on an emulated Cortex-M3, its cost per sample.

The book's robot runs every law on a TI LM3S2965, a 50 MHz Cortex-M3 without floating-point
unit, every 5 ms. :class:`PILController` runs the controller's C, cross-compiled for that
processor (:func:`mwip.export.firmware.build_firmware`), in the `unicorn` CPU emulator (in
process): each sample it writes ``t`` and the measurement ``y`` into the emulated SRAM, calls
the step function and reads the torques ``u`` back, and it counts the instructions the
processor executes (soft-float and ``libm`` routines included) and an upper bound of their
cycles (:func:`mwip.export.firmware.cycle_bound`). It is a :class:`mwip.core.Controller`:
it runs in :func:`mwip.sim.simulate` and on the digital twin like the host's software in the
loop (:class:`mwip.export.sil.CController`), one emulated state per robot.

:func:`run_pil` runs the closed loop of :data:`COST_RUN` (a lean of 0.1 rad: the transient;
then the steady state; a push at 5 s: the sliding-mode laws' switching functions at their
bound) with the emulated processor and with the host's build, and returns a
:class:`PILReport`: the largest state and torque differences, and the instructions and the
cycle bound of every step. :func:`delay_from_pil` turns the report into the twin's
computation delay (a fraction of ``Ts``, with its source).

Instruction counts: a unicorn block hook adds, for each translated block the processor
executes, the number of instructions in it (from the image's disassembly). That counts every
issued instruction, including those in an IT block whose condition fails (which a per-
instruction hook does not see; tested against one).
"""

from __future__ import annotations

import math
import statistics
import time
from bisect import bisect_left
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.export.c_code import CCode
from mwip.export.firmware import FLASH, SRAM, Firmware, NoToolchain, build_firmware

__all__ = ["PILController", "PILError", "PILReport", "CostRun", "COST_RUN", "Emulator",
           "run_pil", "delay_from_pil", "load_unicorn", "CLOCK_HZ", "CONTROL_SHARE",
           "MAX_INSTRUCTIONS", "math_probe", "PROBED",
           "uses_libm", "without_libm"]  # fmt: skip

#: The LM3S2965's clock (Hz).
CLOCK_HZ = 50e6
#: The share of the sample period the control law may take: the rest is the room for the
#: sensor fusion (the twin's complementary or Kalman filter, in soft float too), the I/O (the
#: IMU read over I2C, about 0.4 ms polled at 400 kHz; encoders and PWM registers), interrupts
#: and a margin.
CONTROL_SHARE = 0.5
#: A call that has not returned after this many instructions (0.4 s at 50 MHz) is stuck.
MAX_INSTRUCTIONS = 20_000_000


class PILError(RuntimeError):
    """The emulated processor failed (a fault, an access outside memory, a step that did not
    return)."""


def load_unicorn() -> Any:
    """The ``unicorn`` module; :class:`~mwip.export.firmware.NoToolchain` naming the extra to
    install when it is missing."""
    try:
        import unicorn
    except ImportError:
        raise NoToolchain("processor in the loop needs the unicorn CPU emulator: "
                          "pip install 'mwip[pil]' (unicorn>=2)") from None  # fmt: skip
    return unicorn


_PAINT = b"\xa5\x5a\xc3\x3c"


class Emulator:
    """One emulated LM3S2965 with the processor-in-the-loop image in flash, booted (its reset
    handler run up to ``main``). :meth:`call` runs a function of the image and returns the
    instructions it executed and their cycle bound."""

    def __init__(self, firmware: Firmware) -> None:
        uc_mod = load_unicorn()
        from unicorn import arm_const

        self.firmware = firmware
        self._uc_error = uc_mod.UcError
        uc = uc_mod.Uc(uc_mod.UC_ARCH_ARM, uc_mod.UC_MODE_THUMB | uc_mod.UC_MODE_MCLASS)
        uc.mem_map(FLASH[0], FLASH[1], uc_mod.UC_PROT_READ | uc_mod.UC_PROT_EXEC)
        uc.mem_map(SRAM[0], SRAM[1], uc_mod.UC_PROT_ALL)
        for addr, data in firmware.segments:
            uc.mem_write(addr, data)
        self._uc = uc
        self._pc, self._sp, self._lr = (arm_const.UC_ARM_REG_PC, arm_const.UC_ARM_REG_SP,
                                        arm_const.UC_ARM_REG_LR)  # fmt: skip
        sym = firmware.symbols
        self._stack_top = int.from_bytes(uc.mem_read(0, 4), "little")
        reset = int.from_bytes(uc.mem_read(4, 4), "little")
        self._halt = sym["mwip_pil_halt"]
        addrs = sorted(firmware.instructions)
        self._addrs = addrs
        self._cache: dict[int, int] = {}
        acc = [0]
        self._acc = acc
        cache, cost = self._cache, self._block_cost

        def on_block(_uc: Any, address: int, size: int, _data: Any) -> None:
            key = (address << 16) | size
            v = cache.get(key)
            if v is None:
                v = cache[key] = cost(address, size)
            acc[0] += v

        uc.hook_add(uc_mod.UC_HOOK_BLOCK, on_block)
        uc.reg_write(self._sp, self._stack_top)  # as the processor does at reset
        self._run(reset, sym["main"], "the reset handler")
        self._stack_bottom = sym["_ebss"]
        span = self._stack_top - self._stack_bottom
        uc.mem_write(self._stack_bottom, _PAINT * (span // 4))

    def _block_cost(self, address: int, size: int) -> int:
        """Instructions | cycle bound << 32 of the block ``[address, address + size)``."""
        i, j = bisect_left(self._addrs, address), bisect_left(self._addrs, address + size)
        table = self.firmware.instructions
        addrs = self._addrs[i:j]
        if not addrs or addrs[0] != address or sum(table[a][0] for a in addrs) != size:
            raise PILError(f"the block at 0x{address:x} ({size} bytes) does not match the "
                           "image's disassembly")  # fmt: skip
        return len(addrs) | (sum(table[a][1] for a in addrs) << 32)

    def _run(self, start: int, until: int, what: str) -> tuple[int, int]:
        self._acc[0] = 0
        try:
            self._uc.emu_start(start | 1, until, count=MAX_INSTRUCTIONS)
        except self._uc_error as exc:
            pc = self._uc.reg_read(self._pc)
            raise PILError(f"the emulated Cortex-M3 stopped in {what} at 0x{pc:x}: {exc}") from None
        pc = self._uc.reg_read(self._pc) & ~1
        if pc != until:
            raise PILError(f"{what} did not return within {MAX_INSTRUCTIONS:,} instructions "
                           f"(stopped at 0x{pc:x})")  # fmt: skip
        v = self._acc[0]
        return v & 0xFFFFFFFF, v >> 32

    def call(self, name: str) -> tuple[int, int]:
        """Run the image's function ``name`` (no arguments) until it returns: (instructions
        executed, their cycle bound)."""
        self._uc.reg_write(self._sp, self._stack_top)
        self._uc.reg_write(self._lr, self._halt | 1)
        return self._run(self.firmware.symbols[name], self._halt, name)

    def trace(self, name: str) -> tuple[list[int], int]:
        """Call ``name`` with a per-instruction hook as well: (the addresses that hook saw, in
        order; the instructions the block count gives). The per-instruction hook does not see
        an IT block's instructions whose condition fails; tests/test_pil.py rebuilds the count
        from it to check the block count."""
        uc_mod = load_unicorn()
        seen: list[int] = []

        def on_code(_uc: Any, address: int, _size: int, _data: Any) -> None:
            seen.append(address)

        hook = self._uc.hook_add(uc_mod.UC_HOOK_CODE, on_code)
        self._uc.ctl_flush_tb()  # blocks translated before the hook would not call it
        try:
            n, _ = self.call(name)
        finally:
            self._uc.hook_del(hook)
            self._uc.ctl_flush_tb()
        return seen, n

    def write(self, address: int, data: bytes) -> None:
        self._uc.mem_write(address, data)

    def read(self, address: int, size: int) -> bytes:
        return bytes(self._uc.mem_read(address, size))

    def stack_used(self) -> int:
        """The most stack (bytes) any call has used since boot (the painted words that
        changed)."""
        data = self.read(self._stack_bottom, self._stack_top - self._stack_bottom)
        for k in range(0, len(data), 4):
            if data[k : k + 4] != _PAINT:
                return len(data) - k
        return 0


class PILController:
    """The controller's C on the emulated Cortex-M3 behind the Controller protocol.

    ``firmware``: a built image (:func:`~mwip.export.firmware.build_firmware`) or the
    :class:`~mwip.export.c_code.CCode` to build. One emulated state per robot of the batch
    (swapped in and out of the emulated SRAM). ``instructions`` and ``cycles`` hold, per step
    call since the last :meth:`reset`, the executed instructions and their cycle bound;
    ``init_instructions`` those of the init calls; ``emulator`` the :class:`Emulator`.
    """

    def __init__(self, firmware: Firmware | CCode, *, static: bool = False) -> None:
        fw = firmware if isinstance(firmware, Firmware) else build_firmware(firmware)
        self.firmware = fw
        self.code = fw.code
        self.Ts = fw.code.Ts
        self.static = static
        self.emulator = Emulator(fw)
        self._dtype: type[np.floating[Any]] = (np.float32 if fw.precision == "float"
                                               else np.float64)  # fmt: skip
        size = np.dtype(self._dtype).itemsize
        sym = fw.symbols
        real = int.from_bytes(self.emulator.read(sym["mwip_pil_real_size"], 4), "little")
        if real != size:
            raise PILError(f"the image's mwip_real has {real} bytes, the {fw.precision} build "
                           f"{size}")  # fmt: skip
        self._io = sym["mwip_pil_io"]
        self._u_at = self._io + 9 * size
        self._state_at = sym["mwip_pil_state"]
        size_at = sym["mwip_pil_state_size"]
        self._state_size = int.from_bytes(self.emulator.read(size_at, 4), "little")
        self._states: list[bytes] = []
        self._n = 0
        self.instructions: list[int] = []
        self.cycles: list[int] = []
        self.init_instructions: list[int] = []
        self.calls = 0
        self.seconds = 0.0

    def stack_used(self) -> int:
        """The most stack (bytes) a call has used so far."""
        return self.emulator.stack_used()

    def reset(self, meas: Any) -> None:
        y = np.ascontiguousarray(meas.y, dtype=self._dtype)
        self._n = y.shape[0]
        self._states = []
        self.instructions, self.cycles, self.init_instructions = [], [], []
        for i in range(self._n):
            self.emulator.write(self._io + y.itemsize, y[i].tobytes())
            self.init_instructions.append(self.emulator.call("mwip_pil_init")[0])
            self._states.append(self.emulator.read(self._state_at, self._state_size))

    def __call__(self, t: float, meas: Any) -> NDArray[np.float64]:
        y = np.ascontiguousarray(meas.y, dtype=self._dtype)
        if y.shape[0] != self._n:
            self.reset(meas)
        n = self._n
        u = np.zeros((n, 2), dtype=self._dtype)
        stamp = np.array([t], dtype=self._dtype).tobytes()
        t0 = time.perf_counter()
        emu = self.emulator
        for i in range(n):
            if n > 1:
                emu.write(self._state_at, self._states[i])
            emu.write(self._io, stamp + y[i].tobytes())
            k, c = emu.call("mwip_pil_step")
            self.instructions.append(k)
            self.cycles.append(c)
            u[i] = np.frombuffer(emu.read(self._u_at, 2 * y.itemsize), dtype=self._dtype)
            if n > 1:
                self._states[i] = emu.read(self._state_at, self._state_size)
        self.seconds += time.perf_counter() - t0
        self.calls += n
        return u.astype(np.float64)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return {}


# ---------------------------------------------------------------------------------------------
# The cost run and its report


@dataclass(frozen=True)
class CostRun:
    """The closed loop of a processor-in-the-loop run: from a lean of ``theta0`` (rad, the
    transient), through the steady state, to a push of ``push`` N m on the pitch for
    ``push_width`` s at ``push_start`` (0: none), over ``duration`` s.

    With the defaults the sliding-mode laws' switching functions sat(s / phi) are at their
    bound in the transient (|s| up to 0.3, phi = 0.05) and in the push (|s| 4 to 10), and
    inside the boundary layer in the steady state (docs/export.md)."""

    theta0: float = 0.1
    duration: float = 10.0
    push: float = 0.5
    push_start: float = 5.0
    push_width: float = 0.1

    def __post_init__(self) -> None:
        for name, lo, hi in (("theta0", -1.5, 1.5), ("duration", 1e-3, 600.0),
                             ("push", -10.0, 10.0), ("push_start", 0.0, 600.0),
                             ("push_width", 1e-3, 10.0)):  # fmt: skip
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not (
                    math.isfinite(v) and lo <= v <= hi):  # fmt: skip
                raise ValueError(f"{name} must be a number in [{lo:g}, {hi:g}], got {v!r}")

    def disturbance(self) -> Any:
        """The push as a :class:`mwip.sim.disturbance.Pulse` (``None`` without one)."""
        from mwip.sim.disturbance import Pulse

        if self.push == 0:
            return None
        return Pulse((0.0, float(self.push), 0.0), float(self.push_start), float(self.push_width))

    def phases(self, Ts: float, n: int) -> dict[str, slice]:
        """Step ranges of the run's ``n`` steps: ``transient`` (the first 40 % of the time
        before the push), ``steady`` (the rest before it), ``push`` (the push and what follows
        it, a fifth of the time after it) and ``after``; the defaults give 0-2 s, 2-5 s,
        5-6 s, 6-10 s. Without a push: ``transient`` (the first 20 %) and ``steady``."""
        k = lambda s: min(n, max(0, int(round(s / Ts))))  # noqa: E731
        if self.push == 0 or self.push_start >= self.duration:
            return {"transient": slice(0, k(0.2 * self.duration)),
                    "steady": slice(k(0.2 * self.duration), n)}  # fmt: skip
        a, b = k(0.4 * self.push_start), k(self.push_start)
        c = k(self.push_start + 0.2 * (self.duration - self.push_start))
        return {"transient": slice(0, a), "steady": slice(a, b), "push": slice(b, c),
                "after": slice(c, n)}  # fmt: skip


#: The run of ``mwip export c --pil`` and of the tables in docs/export.md.
COST_RUN = CostRun()


@dataclass(frozen=True)
class PILReport:
    """A processor-in-the-loop run of one controller (:func:`run_pil`).

    ``instructions``, ``cycles``: per step (executed instructions; their cycle bound); the
    closed-loop differences of the emulated processor from the host's build of the same C
    (``max_state_diff`` in the states' units, rad, rad/s, m; ``max_theta_diff`` the pitch;
    ``max_u_diff`` N m), bit-identical when 0; the step computation alone: the host's build fed
    the measurements of the emulated run (``step_u_diff``, N m, and ``steps_differing``, the
    number of steps whose commands differ); for the float build also its deviation from
    the double-precision Python controller on the same run (``float_state_diff``,
    ``float_theta_diff``), the bound the docs' table states for the float build.
    ``libm_calls``: whether the C calls ``sin``/``cos`` (:func:`uses_libm`), the only
    functions whose results differ between the board's C library and the host's.
    """

    controller: str
    precision: str
    flags: str
    compiler: str
    flash_bytes: int
    ram_bytes: int
    stack_bytes: int
    Ts: float
    run: CostRun
    on_twin: bool
    libm_calls: bool
    instructions: tuple[int, ...] = field(repr=False)
    cycles: tuple[int, ...] = field(repr=False)
    init_instructions: int
    max_state_diff: float
    max_theta_diff: float
    max_u_diff: float
    status_host: str
    status_pil: str
    step_u_diff: float
    steps_differing: int
    float_state_diff: float | None
    float_theta_diff: float | None
    seconds: float

    @property
    def first(self) -> int:
        """Instructions of the first step."""
        return self.instructions[0]

    @property
    def median(self) -> float:
        return float(statistics.median(self.instructions))

    @property
    def max(self) -> int:
        return max(self.instructions)

    @property
    def max_cycles(self) -> int:
        """The largest cycle bound of a step."""
        return max(self.cycles)

    @property
    def cpi_bound(self) -> float:
        """Cycles per instruction of the step with the largest cycle bound."""
        k = int(np.argmax(self.cycles))
        return self.cycles[k] / max(self.instructions[k], 1)

    def phase_max(self) -> dict[str, int]:
        """The most instructions of a step in each phase of the run (:meth:`CostRun.phases`)."""
        out = {}
        for name, sl in self.run.phases(self.Ts, len(self.instructions)).items():
            part = self.instructions[sl]
            if part:
                out[name] = max(part)
        return out

    def time_s(self, clock_hz: float = CLOCK_HZ) -> float:
        """The largest step's time bound (s) at ``clock_hz``."""
        return self.max_cycles / clock_hz

    def fits(self, clock_hz: float = CLOCK_HZ, share: float = CONTROL_SHARE) -> bool:
        """Whether the largest step's bound takes at most ``share`` of the sample period."""
        return self.time_s(clock_hz) <= share * self.Ts

    @property
    def identical(self) -> bool:
        return self.max_state_diff == 0 and self.max_u_diff == 0

    def to_dict(self, clock_hz: float = CLOCK_HZ, share: float = CONTROL_SHARE) -> dict[str, Any]:
        """The report as JSON data (``pil.json``), the per-step counts apart."""
        delay, source = delay_from_pil(self, Ts=self.Ts, clock_hz=clock_hz)
        t = self.time_s(clock_hz)
        return {
            "controller": self.controller,
            "precision": self.precision,
            "processor": "Cortex-M3 (LM3S2965), emulated by unicorn",
            "flags": self.flags,
            "compiler": self.compiler,
            "memory": {
                "flash_bytes": self.flash_bytes,
                "ram_bytes": self.ram_bytes,
                "stack_bytes": self.stack_bytes,
            },  # fmt: skip
            "run": {
                "theta0": self.run.theta0,
                "duration": self.run.duration,
                "push": self.run.push,
                "push_start": self.run.push_start,
                "push_width": self.run.push_width,
                "twin": self.on_twin,
                "steps": len(self.instructions),
            },  # fmt: skip
            "instructions": {
                "init": self.init_instructions,
                "first": self.first,
                "median": self.median,
                "max": self.max,
                "max_by_phase": self.phase_max(),
            },  # fmt: skip
            "cycle_bound": {
                "max": self.max_cycles,
                "cpi": round(self.cpi_bound, 4),
                "clock_hz": clock_hz,
                "time_s": t,
                "share_of_Ts": t / self.Ts,
                "allowed_share": share,
                "fits": self.fits(clock_hz, share),
            },  # fmt: skip
            "vs_host": {
                "libm_calls": self.libm_calls,
                "max_state_diff": self.max_state_diff,
                "max_theta_diff": self.max_theta_diff,
                "max_u_diff": self.max_u_diff,
                "identical": self.identical,
                "step_u_diff": self.step_u_diff,
                "steps_differing": self.steps_differing,
                "status_host": self.status_host,
                "status_pil": self.status_pil,
            },  # fmt: skip
            "float_vs_double": None
            if self.float_state_diff is None
            else {
                "max_state_diff": self.float_state_diff,
                "max_theta_diff": self.float_theta_diff,
            },  # fmt: skip
            "twin_delay": {"delay": delay, "source": source},
            "seconds": self.seconds,
        }


def _closed_loop(ctrl: Any, plant: Any, run: CostRun, Ts: float | None, twin: Any, case: int,
                 progress: Callable[[int], None] | None) -> Any:  # fmt: skip
    q0 = (0.0, run.theta0, 0.0)
    if twin is not None:
        from mwip.hardware.twin import run_on_twin

        return run_on_twin(ctrl, case, twin=twin, plant=plant, q0=q0, duration=run.duration,
                           record_every=1, seed=0, disturbance=run.disturbance(),
                           progress=progress)  # fmt: skip
    from mwip.sim import simulate

    return simulate(ctrl, plant, q0=q0, duration=run.duration, Ts=Ts, seed=0,
                    disturbance=run.disturbance(), progress=progress)  # fmt: skip


def _diff(a: Any, b: Any) -> tuple[float, float, float]:
    n = min(a.state.shape[-2], b.state.shape[-2])
    ds = np.abs(a.state[..., :n, :] - b.state[..., :n, :])
    du = np.abs(a.u[..., :n, :] - b.u[..., :n, :])
    return float(np.nanmax(ds)), float(np.nanmax(ds[..., 1])), float(np.nanmax(du))


def _replay(host: Any, res: Any, n_steps: int, twin: bool) -> tuple[float, int]:
    """Feed the measurements of the run ``res`` to ``host`` (a fresh controller) and compare
    its commands with the run's: the largest difference and the number of steps that differ
    (the step computation alone, without the closed loop's amplification)."""
    from mwip.core import Measurement

    y = np.asarray(res.logs["y_meas"] if twin else res.state, dtype=float).reshape(-1, 8)
    u = np.asarray(res.u, dtype=float).reshape(-1, 2)
    t = np.asarray(res.t, dtype=float).ravel()
    host.reset(Measurement(float(t[0]), y[:1]))
    worst, count = 0.0, 0
    for k in range(min(n_steps, len(t), len(y), len(u))):  # a run that fell ends early
        d = float(np.max(np.abs(host(float(t[k]), Measurement(float(t[k]), y[k : k + 1]))[0]
                                - u[k])))  # fmt: skip
        worst, count = max(worst, d), count + (d != 0)
    return worst, count


def run_pil(
    name: str,
    controller: Any,
    code: CCode,
    *,
    plant: Any = None,
    run: CostRun = COST_RUN,
    twin: Any = None,
    case: int = 1,
    firmware: Firmware | None = None,
    progress: Callable[[int], None] | None = None,
) -> PILReport:
    """Run ``code`` (generated from ``controller``, registered as ``name``) in the closed loop
    ``run`` on ``plant`` (default the real robot; on the digital twin ``twin`` if given,
    Chapter 6 ``case``) through the emulated Cortex-M3 and through the host's build (software
    in the loop, :class:`mwip.export.sil.CController`), and for a float build also the Python
    controller in double; compare them and count each step's cost. ``firmware``: an image
    already built from ``code``. ``progress(k)`` is called as PIL samples complete."""
    from mwip.export.sil import CController
    from mwip.params import REAL

    plant = REAL if plant is None else plant
    fw = firmware if firmware is not None else build_firmware(code)
    static = bool(getattr(controller, "static", False))
    pil = PILController(fw, static=static)
    host = CController(code, static=static)
    a = _closed_loop(host, plant, run, code.Ts, twin, case, None)
    b = _closed_loop(pil, plant, run, code.Ts, twin, case, progress)
    ds, dth, du = _diff(a, b)
    fs = fth = None
    if code.precision == "float":
        fs, fth, _ = _diff(_closed_loop(controller, plant, run, code.Ts, twin, case, None), a)
    n_steps = len(pil.instructions)  # every sample instant of the run, the last one included
    step_diff, step_count = _replay(CController(code, static=static), b, n_steps, twin is not None)
    return PILReport(
        controller=name, precision=code.precision, flags=fw.flags_text, compiler=fw.compiler,
        flash_bytes=fw.flash_bytes, ram_bytes=fw.ram_bytes, stack_bytes=pil.stack_used(),
        Ts=float(code.Ts if code.Ts is not None else 0.005), run=run, on_twin=twin is not None,
        libm_calls=uses_libm(code),
        instructions=tuple(pil.instructions[:n_steps]), cycles=tuple(pil.cycles[:n_steps]),
        init_instructions=pil.init_instructions[0], max_state_diff=ds, max_theta_diff=dth,
        max_u_diff=du, status_host=str(np.atleast_1d(a.status)[0]),
        status_pil=str(np.atleast_1d(b.status)[0]), step_u_diff=step_diff,
        steps_differing=step_count, float_state_diff=fs, float_theta_diff=fth,
        seconds=pil.seconds,
    )  # fmt: skip


_PROBE_H = """\
#ifndef MWIP_PROBE_H
#define MWIP_PROBE_H
typedef {real} mwip_real;
typedef struct {{ int unused; }} mwip_probe_state;
void mwip_probe_init(mwip_probe_state *s, const mwip_real y[8]);
void mwip_probe_step(mwip_probe_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2]);
#endif
"""
_PROBE_C = """\
#include <math.h>
#include "mwip_probe.h"
void mwip_probe_init(mwip_probe_state *s, const mwip_real y[8]) {{ (void)s; (void)y; }}
void mwip_probe_step(mwip_probe_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    (void)s; (void)t;
    u[0] = {op0};
    u[1] = {op1};
}}
"""
#: The C library's functions the exported laws call (``MWIP_SIN`` ... in :mod:`c_code`), and
#: the addition (``add``: libgcc's soft-float ``__aeabi_dadd``/``__aeabi_fadd`` on the board).
PROBED = ("sin", "cos", "sqrt", "add")


def math_probe(function: str, precision: str = "double") -> CCode:
    """A "controller" whose step returns ``function(y[0]), function(y[1])`` (``sin``,
    ``cos`` or ``sqrt``; ``sinf`` ... in float), or for ``add`` the sums ``y[0] + y[1]``,
    ``y[2] + y[3]``: the board's C library (newlib) and soft-float arithmetic (libgcc)
    against the host's (glibc, the FPU) on the same arguments, through
    :class:`PILController` and :class:`~mwip.export.sil.CController` (docs/export.md: why a
    double closed loop is not always bit-identical)."""
    if function not in PROBED:
        raise ValueError(f"function must be one of {', '.join(PROBED)}, got {function!r}")
    if precision not in ("double", "float"):
        raise ValueError(f"precision must be double or float, got {precision!r}")
    real, fn = ("float", function + "f") if precision == "float" else ("double", function)
    ops = ("y[0] + y[1]", "y[2] + y[3]") if function == "add" else (f"{fn}(y[0])", f"{fn}(y[1])")
    return CCode("mwip_probe", _PROBE_H.format(real=real),
                 _PROBE_C.format(op0=ops[0], op1=ops[1]), precision, f"probe of {function}",
                 0.005)  # fmt: skip


_POLY = """
/* mwip.export.pil.without_libm: sin and cos as fixed polynomials of + - * / only (Taylor to
 * x^11 and x^12; for the test of bit-identity, not for the robot) */
static inline mwip_real mwip_poly_sin(mwip_real x)
{
    const mwip_real x2 = x * x;
    return x * ((mwip_real)1 + x2 * ((mwip_real)-0.16666666666666666 + x2 * (
        (mwip_real)0.008333333333333333 + x2 * ((mwip_real)-0.0001984126984126984 + x2 * (
        (mwip_real)2.7557319223985893e-06 + x2 * (mwip_real)-2.505210838544172e-08)))));
}
static inline mwip_real mwip_poly_cos(mwip_real x)
{
    const mwip_real x2 = x * x;
    return (mwip_real)1 + x2 * ((mwip_real)-0.5 + x2 * ((mwip_real)0.041666666666666664 + x2 * (
        (mwip_real)-0.001388888888888889 + x2 * ((mwip_real)2.48015873015873e-05 + x2 * (
        (mwip_real)-2.755731922398589e-07 + x2 * (mwip_real)2.08767569878681e-09)))));
}
"""


def uses_libm(code: CCode) -> bool:
    """Whether the generated C calls ``sin`` or ``cos`` (the functions whose results differ
    between the board's C library and the host's; ``sqrt`` and ``fabs`` are exact in both)."""
    body = "\n".join(ln for ln in code.source.splitlines() if not ln.startswith("#define"))
    return "MWIP_SIN(" in body or "MWIP_COS(" in body


def without_libm(code: CCode) -> CCode:
    """``code`` with ``sin`` and ``cos`` replaced by fixed polynomials of ``+ - * /`` (the
    same on every IEEE machine): its closed loop on the emulated processor must equal the
    host's bit for bit, which shows that a difference of the real code comes from the C
    libraries' ``sin``/``cos`` alone (tests/test_pil.py)."""
    src = code.source
    for name in ("SIN", "COS"):
        low = name.lower()
        for fn in (low, low + "f"):
            src = src.replace(
                f"#define MWIP_{name} {fn}\n", f"#define MWIP_{name} mwip_poly_{low}\n"
            )
    marker = "#endif\n"
    at = src.index(marker) + len(marker)
    return CCode(code.prefix, code.header, src[:at] + _POLY + src[at:], code.precision,
                 code.kind, code.Ts)  # fmt: skip


def delay_from_pil(
    report: PILReport | Mapping[str, Any],
    Ts: float = 0.005,
    clock_hz: float = CLOCK_HZ,
    cpi: float | None = None,
) -> tuple[float, str]:
    """The twin's computation delay from a processor-in-the-loop run: ``(fraction of Ts,
    source text)``.

    The largest step of the run at ``clock_hz``: its cycle bound (the Cortex-M3 timings,
    :func:`mwip.export.firmware.cycle_bound`), or with ``cpi`` its instructions times
    ``cpi``. ``report``: a :class:`PILReport` or its :meth:`~PILReport.to_dict` (``pil.json``).
    The controller's computation only: time the firmware spends before it (sensor fusion,
    I/O) adds to it. A ``ValueError`` for a bad argument or a step longer than ``Ts``.

    >>> r = {"controller": "lqr", "precision": "double", "flags": "-O2",
    ...      "instructions": {"max": 1000}, "cycle_bound": {"max": 2500}}
    >>> delay_from_pil(r, Ts=0.005, clock_hz=50e6)[0]
    0.01
    >>> delay_from_pil(r, Ts=0.005, clock_hz=50e6, cpi=1.25)[0]
    0.005
    """
    for label, value in (("Ts", Ts), ("clock_hz", clock_hz)):
        if isinstance(value, bool) or not isinstance(value, int | float) or not (
                math.isfinite(value) and value > 0):  # fmt: skip
            raise ValueError(f"{label} must be a positive number, got {value!r}")
    if cpi is not None and (isinstance(cpi, bool) or not isinstance(cpi, int | float)
                            or not (math.isfinite(cpi) and 1.0 <= cpi <= 100.0)):  # fmt: skip
        raise ValueError(f"cpi must be a number in [1, 100] (cycles per instruction), got {cpi!r}")
    if isinstance(report, PILReport):
        name, precision, flags = report.controller, report.precision, report.flags
        n_max, c_max = report.max, report.max_cycles
    else:
        try:
            name, precision = str(report["controller"]), str(report["precision"])
            flags = str(report.get("flags", ""))
            n_max = int(report["instructions"]["max"])
            c_max = int(report["cycle_bound"]["max"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"not a processor-in-the-loop report (pil.json): {exc}") from None
    cycles = c_max if cpi is None else n_max * cpi
    seconds = cycles / clock_hz
    fraction = round(seconds / Ts, 6)  # 5 ns at 5 ms: far below the bound's own accuracy
    if not fraction <= 1.0:
        raise ValueError(f"{name} ({precision}) takes {seconds * 1e3:.3g} ms per step at "
                         f"{clock_hz / 1e6:g} MHz, more than Ts = {Ts * 1e3:g} ms")  # fmt: skip
    how = (f"<= {c_max:,} cycles by the Cortex-M3 instruction timings (CPI <= "
           f"{c_max / max(n_max, 1):.2f}, zero flash wait states)" if cpi is None
           else f"x {cpi:g} cycles per instruction")  # fmt: skip
    source = (f"MEASURED by processor in the loop (mwip export c --pil): {name}, {precision}, "
              f"{flags}; largest step {n_max:,} instructions on the emulated Cortex-M3, {how}, "
              f"at {clock_hz / 1e6:g} MHz: {seconds * 1e3:.3f} ms of computation")  # fmt: skip
    return fraction, source
