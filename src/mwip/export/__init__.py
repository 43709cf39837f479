"""Code for the robot: controllers as plain C99, verified in the loop.

- :func:`generate_c` (:mod:`mwip.export.c_code`): header + source of a designed controller.
- :class:`CController`, :func:`verify` (:mod:`mwip.export.sil`): the generated code compiled
  with the system C compiler and run as a controller in simulations and on the twin.
- :class:`PILController`, :func:`run_pil`, :func:`delay_from_pil` (:mod:`mwip.export.pil`):
  the code cross-compiled for the board's Cortex-M3 (:mod:`mwip.export.firmware`) and run on
  an emulated processor, with its cost per sample; :class:`BoardController`
  (:mod:`mwip.export.board`): the same object code as firmware on QEMU's lm3s6965evb.
- ``mwip export c --controller NAME [--set k=v ...] --out DIR [--float] [--verify] [--pil]``.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["generate_c", "CCode", "ExportError", "PRECISIONS", "CController", "compile_c",
           "verify", "VerifyReport", "NoCompiler", "build_firmware", "Firmware", "NoToolchain",
           "PILController", "PILReport", "run_pil", "delay_from_pil",
           "BoardController"]  # fmt: skip

__getattr__, __dir__ = exports(
    __name__,
    {**dict.fromkeys(("PRECISIONS", "CCode", "ExportError", "generate_c"), "mwip.export.c_code"),
     **dict.fromkeys(("CController", "NoCompiler", "VerifyReport", "compile_c", "verify"),
                     "mwip.export.sil"),
     **dict.fromkeys(("build_firmware", "Firmware", "NoToolchain"), "mwip.export.firmware"),
     **dict.fromkeys(("PILController", "PILReport", "run_pil", "delay_from_pil"),
                     "mwip.export.pil"),
     "BoardController": "mwip.export.board"},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.export.board import BoardController
    from mwip.export.c_code import PRECISIONS, CCode, ExportError, generate_c
    from mwip.export.firmware import Firmware, NoToolchain, build_firmware
    from mwip.export.pil import PILController, PILReport, delay_from_pil, run_pil
    from mwip.export.sil import CController, NoCompiler, VerifyReport, compile_c, verify
