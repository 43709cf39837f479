"""Code for the robot: controllers as plain C99, verified in the loop.

- :func:`generate_c` (:mod:`mwip.export.c_code`): header + source of a designed controller.
- :class:`CController`, :func:`verify` (:mod:`mwip.export.sil`): the generated code compiled
  with the system C compiler and run as a controller in simulations and on the twin.
- ``mwip export c --controller NAME [--set k=v ...] --out DIR [--float] [--verify]``.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["generate_c", "CCode", "ExportError", "PRECISIONS", "CController", "compile_c",
           "verify", "VerifyReport", "NoCompiler"]  # fmt: skip

__getattr__, __dir__ = exports(
    __name__,
    {**dict.fromkeys(("PRECISIONS", "CCode", "ExportError", "generate_c"), "mwip.export.c_code"),
     **dict.fromkeys(("CController", "NoCompiler", "VerifyReport", "compile_c", "verify"),
                     "mwip.export.sil")},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.export.c_code import PRECISIONS, CCode, ExportError, generate_c
    from mwip.export.sil import CController, NoCompiler, VerifyReport, compile_c, verify
