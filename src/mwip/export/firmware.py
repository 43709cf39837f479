"""The exported controller compiled for the book's board: a Cortex-M3 without FPU (LM3S2965).

:func:`build_firmware` cross-compiles a :class:`~mwip.export.c_code.CCode` with the GNU Arm
toolchain (Debian's ``gcc-arm-none-eabi`` and ``libnewlib-arm-none-eabi``; ``$MWIP_ARM_CC``
names another ``arm-none-eabi-gcc``) and links the same object code into two freestanding
images with the board's memory map (``mcu/lm3s2965.ld``: 128 KB flash at 0, 64 KB SRAM
at 0x20000000) and a minimal start-up (``mcu/startup.c``):

- the processor-in-the-loop image (``mcu/pil_harness.c``): the host writes ``t, y`` into
  ``mwip_pil_io``, calls ``mwip_pil_step`` and reads ``u`` (:mod:`mwip.export.pil`, unicorn);
- the whole-board image (``mcu/board_uart.c``): the step served over UART0 in binary
  frames, for QEMU's ``lm3s6965evb`` (:mod:`mwip.export.board`).

Flags (:data:`CPU_FLAGS`, :data:`OPT_FLAGS`): Thumb-2 for the Cortex-M3, soft float (the
double and float arithmetic and ``sin``/``cos``/``sqrt`` are libgcc's and newlib's routines,
executed instruction by instruction), ``-O2`` as the host's software in the loop, and no
floating-point contraction (``-ffp-contract=off``). The controller's source is compiled as
strictly as on the host (C99, ``-Wall -Wextra -Werror -pedantic``).

:func:`instruction_table` reads the linked image's disassembly (``arm-none-eabi-objdump``):
each instruction's address, size and an upper bound of its cycles on the Cortex-M3 from the
processor's instruction timings (:func:`cycle_bound`; ARM DDI 0337, Cortex-M3 Technical
Reference Manual, "Processor instruction timings"), with zero flash wait states (the
LM3S2965's flash is single-cycle at its 50 MHz).
"""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess
import tempfile
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from mwip.export.c_code import CCode

__all__ = ["CPU_FLAGS", "OPT_FLAGS", "CODE_FLAGS", "FLASH", "SRAM", "Toolchain", "Firmware",
           "NoToolchain", "FirmwareError", "find_toolchain", "build_firmware", "read_elf",
           "instruction_table", "cycle_bound"]  # fmt: skip

#: The board's processor: Cortex-M3, Thumb-2, no floating-point unit.
CPU_FLAGS = ("-mcpu=cortex-m3", "-mthumb", "-mfloat-abi=soft")
#: Optimisation as the host's software in the loop (-O2), no fused multiply-add, and each
#: function in its own section so that the linker keeps only what is called.
OPT_FLAGS = ("-O2", "-ffp-contract=off", "-ffunction-sections", "-fdata-sections")
#: The controller's source is compiled as on the host (mwip.export.sil).
CODE_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")
#: (origin, length) of the LM3S2965's flash and SRAM (mcu/lm3s2965.ld).
FLASH = (0x00000000, 128 * 1024)
SRAM = (0x20000000, 64 * 1024)

_FIRMWARE = "mwip.export.mcu"
_ENTRY_POINTS = ("mwip_pil_init", "mwip_pil_step", "mwip_pil_halt", "mwip_pil_io",
                 "mwip_pil_state", "mwip_pil_state_size", "mwip_pil_real_size")  # fmt: skip


class NoToolchain(RuntimeError):
    """The GNU Arm toolchain (or newlib for it) is not installed."""


class FirmwareError(RuntimeError):
    """The cross-compilation or the link failed (the message names the tool and the file)."""


@dataclass(frozen=True)
class Toolchain:
    """``gcc``: the cross compiler; ``objdump``: its disassembler; ``version``: gcc's first
    line of ``--version``; ``env``: whether ``$MWIP_ARM_CC`` named the compiler."""

    gcc: str
    objdump: str
    version: str
    env: bool = False

    @property
    def what(self) -> str:
        """The compiler as a user names it (with the variable that chose it)."""
        return f"{self.gcc} (MWIP_ARM_CC)" if self.env else self.gcc


_INSTALL = (
    "install Debian's gcc-arm-none-eabi and libnewlib-arm-none-eabi "
    "(apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi) or set MWIP_ARM_CC"
)


def find_toolchain() -> Toolchain:
    """The cross compiler ``$MWIP_ARM_CC`` or ``arm-none-eabi-gcc`` on PATH and its
    ``objdump``; :class:`NoToolchain` naming what to install when either is missing, or
    newlib (the compiler finds no ``libm.a`` for the Cortex-M3)."""
    given = os.environ.get("MWIP_ARM_CC", "").strip()
    gcc = shutil.which(given or "arm-none-eabi-gcc")
    if gcc is None:
        where = f"MWIP_ARM_CC={given!r} is not an executable" if given else (
            "no arm-none-eabi-gcc on PATH")  # fmt: skip
        raise NoToolchain(f"processor in the loop needs the GNU Arm toolchain: {where}; {_INSTALL}")
    base = os.path.basename(gcc)
    sibling = os.path.join(os.path.dirname(gcc), base.replace("gcc", "objdump")) if (
        "gcc" in base) else ""  # fmt: skip
    objdump = (sibling if sibling and os.access(sibling, os.X_OK) else None) or shutil.which(
        "arm-none-eabi-objdump"
    )
    if objdump is None:
        raise NoToolchain(f"processor in the loop needs arm-none-eabi-objdump beside {gcc}; "
                          f"{_INSTALL}")  # fmt: skip
    try:
        proc = subprocess.run([gcc, "--version"], capture_output=True, text=True, timeout=30,
                              check=False)  # fmt: skip
        version = (proc.stdout.splitlines() or ["?"])[0].strip()
        libm = subprocess.run([gcc, *CPU_FLAGS, "-print-file-name=libm.a"], capture_output=True,
                              text=True, timeout=30, check=False)  # fmt: skip
    except (OSError, subprocess.TimeoutExpired):
        version, libm = "?", None
    if libm is not None and libm.returncode == 0 and libm.stdout.strip() == "libm.a":
        raise NoToolchain(f"{gcc} finds no C library for the Cortex-M3 (newlib's libm.a); "
                          f"{_INSTALL}")  # fmt: skip
    return Toolchain(gcc, objdump, version, env=bool(given))


@dataclass(frozen=True)
class Firmware:
    """The controller built for the board: the two images (ELF bytes), the processor-in-the-
    loop image's symbols (name -> address), its loadable segments (load address, bytes) and
    its instruction table (address -> (size, cycle bound)), the flags and
    the compiler, and the memory the image needs on the LM3S2965 (``flash_bytes``: code,
    constants and initial data; ``ram_bytes``: data and bss, the stack apart)."""

    code: CCode
    pil_elf: bytes
    board_elf: bytes
    symbols: dict[str, int]
    segments: tuple[tuple[int, bytes], ...]
    instructions: dict[int, tuple[int, int]] = field(repr=False)
    flags: tuple[str, ...]
    compiler: str
    flash_bytes: int
    ram_bytes: int

    @property
    def precision(self) -> str:
        return self.code.precision

    @property
    def flags_text(self) -> str:
        """The compile flags as a user would type them."""
        return " ".join(self.flags)


def _data(name: str) -> str:
    return resources.files(_FIRMWARE).joinpath(name).read_text(encoding="utf-8")


def _run(cmd: list[str], tc: Toolchain, what: str) -> None:
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise FirmwareError(f"the Arm cross compiler {tc.what} could not {what}: {exc}") from None
    if proc.returncode != 0:
        lines = [ln.strip() for ln in (proc.stderr or proc.stdout).splitlines() if ln.strip()]
        detail = next((ln for ln in lines if "error" in ln.lower()), lines[0] if lines else "")
        hint = (" (is libnewlib-arm-none-eabi installed?)"
                if "cannot find -l" in (proc.stderr or "") else "")  # fmt: skip
        detail = f": {detail}" if detail else ""
        raise FirmwareError(f"the Arm cross compiler {tc.what} failed to {what} (exit "
                            f"{proc.returncode}){detail}{hint}")  # fmt: skip


def build_firmware(code: CCode, toolchain: Toolchain | None = None,
                   folder: str | os.PathLike[str] | None = None) -> Firmware:  # fmt: skip
    """Cross-compile ``code`` and link the two images (module docstring). ``folder``: where
    to build (default: a temporary folder, removed afterwards). :class:`NoToolchain` when the
    toolchain is missing, :class:`FirmwareError` when a step fails."""
    tc = toolchain or find_toolchain()
    if folder is None:
        with tempfile.TemporaryDirectory(prefix="mwip-pil-") as tmp:
            return _build(code, tc, Path(tmp))
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    return _build(code, tc, out)


def _build(code: CCode, tc: Toolchain, d: Path) -> Firmware:
    for name, text in code.files().items():
        (d / name).write_text(text)
    for name in ("lm3s2965.ld", "startup.c", "pil_harness.c", "board_uart.c"):
        (d / name).write_text(_data(name))
    flags = [*CPU_FLAGS, *OPT_FLAGS]
    p = code.prefix
    harness = [f"-DMWIP_PREFIX={p}", "-include", str(d / f"{p}.h"), "-Wall", "-Wextra", "-Werror"]
    _run([tc.gcc, *flags, *CODE_FLAGS, "-c", str(d / f"{p}.c"), "-o", str(d / "ctrl.o")], tc,
         f"compile {p}.c")  # fmt: skip
    _run([tc.gcc, *flags, "-Wall", "-Wextra", "-Werror", "-c", str(d / "startup.c"), "-o",
          str(d / "startup.o")], tc, "compile the start-up code")  # fmt: skip
    for src in ("pil_harness", "board_uart"):
        _run([tc.gcc, *flags, *harness, "-c", str(d / f"{src}.c"), "-o", str(d / f"{src}.o")],
             tc, f"compile {src}.c")  # fmt: skip
    link = [tc.gcc, *flags, "-nostartfiles", "-T", str(d / "lm3s2965.ld"), "-Wl,--gc-sections",
            "--specs=nano.specs"]  # fmt: skip
    keep = [f"-Wl,--undefined={s}" for s in _ENTRY_POINTS]
    _run(
        [
            *link,
            *keep,
            "-o",
            str(d / "pil.elf"),
            str(d / "startup.o"),
            str(d / "pil_harness.o"),
            str(d / "ctrl.o"),
            "-lm",
            "-lc",
            "-lgcc",
        ],
        tc,
        "link the processor-in-the-loop image",
    )
    _run(
        [
            *link,
            "-o",
            str(d / "board.elf"),
            str(d / "startup.o"),
            str(d / "board_uart.o"),
            str(d / "ctrl.o"),
            "-lm",
            "-lc",
            "-lgcc",
        ],
        tc,
        "link the whole-board image",
    )
    pil = (d / "pil.elf").read_bytes()
    segments, symbols = read_elf(pil)
    missing = [s for s in _ENTRY_POINTS if s not in symbols]
    if missing:
        raise FirmwareError(f"the processor-in-the-loop image lacks {missing[0]}")
    table = instruction_table(d / "pil.elf", tc)
    flash = sum(len(data) for _, data in segments)
    ram = sum(mem for addr, _, _, mem in _vm_segments(pil) if addr >= SRAM[0])
    return Firmware(code, pil, (d / "board.elf").read_bytes(), symbols, segments, table,
                    (*CPU_FLAGS, *OPT_FLAGS), tc.version, flash, ram)  # fmt: skip


# ---------------------------------------------------------------------------------------------
# ELF (32-bit little-endian, as arm-none-eabi-ld writes it)


def _header(elf: bytes) -> tuple[int, int, int, int, int, int]:
    if len(elf) < 52 or elf[:4] != b"\x7fELF" or elf[4] != 1 or elf[5] != 1:
        raise FirmwareError("not a 32-bit little-endian ELF image")
    (_, _, _, _, phoff, shoff, _, _, phentsize, phnum, shentsize,
     shnum, _) = struct.unpack_from("<HHIIIIIHHHHHH", elf, 16)  # fmt: skip
    return phoff, phentsize, phnum, shoff, shentsize, shnum


def _vm_segments(elf: bytes) -> list[tuple[int, int, bytes, int]]:
    """Loadable segments as (virtual address, load address, file bytes, size in memory)."""
    phoff, phentsize, phnum, *_ = _header(elf)
    out = []
    for i in range(phnum):
        ptype, off, vaddr, paddr, filesz, memsz, _, _ = struct.unpack_from(
            "<8I", elf, phoff + i * phentsize
        )
        if ptype == 1:  # PT_LOAD
            out.append((vaddr, paddr, elf[off : off + filesz], memsz))
    return out


def read_elf(elf: bytes) -> tuple[tuple[tuple[int, bytes], ...], dict[str, int]]:
    """The loadable segments of ``elf`` as the board's flash holds them, (load address,
    bytes), with ``.data``'s initial values at its load address in flash (the start-up
    code copies them to SRAM), and its symbols (name -> value; functions with their Thumb bit
    cleared)."""
    _, _, _, shoff, shentsize, shnum = _header(elf)
    segs = tuple((paddr, data) for _, paddr, data, _ in _vm_segments(elf) if data)
    sections = [struct.unpack_from("<10I", elf, shoff + i * shentsize) for i in range(shnum)]
    symbols: dict[str, int] = {}
    for sec in sections:
        if sec[1] != 2:  # SHT_SYMTAB
            continue
        strtab = sections[sec[6]][4]
        for k in range(sec[5] // 16):
            name_off, value, _, info, _, _ = struct.unpack_from("<IIIBBH", elf, sec[4] + 16 * k)
            end = elf.index(b"\0", strtab + name_off)
            name = elf[strtab + name_off : end].decode("ascii", "replace")
            if name and not name.startswith("$"):
                symbols[name] = value & ~1 if info & 0xF == 2 else value  # STT_FUNC
    return segs, symbols


# ---------------------------------------------------------------------------------------------
# Instruction timings of the Cortex-M3 (ARM DDI 0337, "Processor instruction timings")

_COND = r"(?:eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)?"
#: Pipeline refill after a taken branch or a write to the PC: P = 1 to 3 cycles (TRM).
P_MAX = 3
#: A load or store whose address depends on the result of the instruction before it stalls
#: one cycle (no forwarding path, TRM); the bound charges it to every memory access.
ADDRESS_STALL = 1
_RULES: tuple[tuple[re.Pattern[str], int], ...] = tuple(
    (re.compile(pattern), cycles)
    for pattern, cycles in (
        (r"(?:tbb|tbh)", 2 + 1 + P_MAX),  # load 2, add 1, refill (TRM note: >= 6)
        (r"(?:b|bl|bx|blx)" + _COND, 1 + P_MAX),  # 1 + P, taken or not (bound: taken)
        (r"(?:cbz|cbnz)", 1 + P_MAX),
        (r"(?:umull|smull)" + _COND, 5),  # 3 to 5 (early termination)
        (r"(?:umlal|smlal)" + _COND, 7),  # 4 to 7
        (r"(?:udiv|sdiv)" + _COND, 12),  # 2 to 12
        (r"(?:mla|mls)" + _COND, 2),
        (r"(?:ldrd|strd)" + _COND, 1 + 2 + ADDRESS_STALL),  # 1 + N, N = 2
        (r"(?:ldr|str)[a-z]*", 2 + ADDRESS_STALL),  # 2 (LDR from PC: fetch contention, +1)
    )
)
_MULTIPLE = re.compile(r"(?:ldm|stm|push|pop)[a-z]*")


def _registers(operands: str) -> list[str]:
    inside = operands[operands.find("{") + 1 : operands.find("}")] if "{" in operands else ""
    regs: list[str] = []
    for part in (p.strip() for p in inside.split(",") if p.strip()):
        m = re.fullmatch(r"r(\d+)-r(\d+)", part)
        regs += [f"r{i}" for i in range(int(m[1]), int(m[2]) + 1)] if m else [part]
    return regs


def cycle_bound(mnemonic: str, operands: str) -> int:
    """An upper bound of the cycles one Cortex-M3 instruction takes (zero wait states).

    From the Cortex-M3 TRM's instruction timings, each at its worst: data processing 1
    (``+P`` when it writes the PC), ``MUL`` 1, ``MLA``/``MLS`` 2, ``UMULL``/``SMULL`` 5,
    ``UMLAL``/``SMLAL`` 7, ``UDIV``/``SDIV`` 12; a branch ``1 + P`` taken or not; a single load or
    store 2, ``LDRD``/``STRD`` 3, ``LDM``/``STM``/``PUSH``/``POP`` ``1 + N`` (``+P`` when it
    loads the PC), each memory access one more for an address that depends on the previous
    instruction; ``TBB``/``TBH`` ``3 + P``; ``P = 3``. An instruction in an IT block whose
    condition fails is charged as if it passed.

    >>> cycle_bound("umlal", "lr, r5, r1, r2"), cycle_bound("pop", "{r4, r5, pc}")
    (7, 8)
    >>> cycle_bound("bne.n", "2230 <x>"), cycle_bound("adds", "r0, r1")
    (4, 1)
    """
    m = mnemonic.lower().split(".")[0]
    ops = operands.lower()
    if _MULTIPLE.fullmatch(m):
        regs = _registers(ops)
        return 1 + len(regs) + ADDRESS_STALL + (P_MAX if "pc" in regs and m[0] in "lp" else 0)
    for pattern, cycles in _RULES:
        if pattern.fullmatch(m):
            if m.startswith("ldr") and ops.split(",")[0].strip() == "pc":
                return cycles + P_MAX
            return cycles
    dest = ops.split(",")[0].strip()
    return 1 + (P_MAX if dest == "pc" and not m.startswith(("cmp", "cmn", "tst", "teq")) else 0)


_LINE = re.compile(r"\s*([0-9a-f]+):\s+((?:[0-9a-f]{4} ?){1,2})\s+(\S+)\s*([^;@]*)")


def instruction_table(elf_path: str | os.PathLike[str],
                      toolchain: Toolchain) -> dict[int, tuple[int, int]]:  # fmt: skip
    """Address -> (size in bytes, :func:`cycle_bound`) of every instruction of the image's
    code, from ``objdump -d`` (literal pools, ``.word``, are data and left out)."""
    try:
        raw = subprocess.run([toolchain.objdump, "-d", str(elf_path)], capture_output=True,
                             text=True, timeout=120, check=False)  # fmt: skip
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise FirmwareError(f"{toolchain.objdump} could not disassemble the image: {exc}") from None
    if raw.returncode != 0:
        raise FirmwareError(f"{toolchain.objdump} failed to disassemble the image")
    table: dict[int, tuple[int, int]] = {}
    for line in raw.stdout.splitlines():
        m = _LINE.match(line)
        if m is None or m[3].startswith("."):
            continue
        size = 2 * len(m[2].split())
        table[int(m[1], 16)] = (size, cycle_bound(m[3], m[4]))
    if not table:
        raise FirmwareError(f"{toolchain.objdump} listed no instructions")
    return table
