"""mwip: robust and intelligent control of mobile wheeled inverted pendulums.

Models (Chapter 2), disturbance observers (Chapter 3), controllers (Chapters 3-5) and a fast
batch simulation engine, after Huang et al., *Robust and Intelligent Control of a Typical
Underactuated Robot: Mobile Wheeled Inverted Pendulum* (2023).

The names below are imported on first use (:mod:`mwip.lazy`): ``import mwip`` costs nothing.
"""

import sys
import types
from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["Params", "REAL", "NOMINAL", "linearize", "__version__"]
__version__ = "0.1.0"

__getattr__, __dir__ = exports(
    __name__,
    {"Params": "mwip.params", "REAL": "mwip.params", "NOMINAL": "mwip.params",
     "linearize": "mwip.linearize"},
)  # fmt: skip


class _Package(types.ModuleType):
    """``mwip.linearize`` is both a submodule and the function it defines; importing the
    submodule sets the package attribute to the module, so the function is put there instead
    (what ``from mwip.linearize import linearize`` in this file used to leave)."""

    def __setattr__(self, name: str, value: object) -> None:
        if name == "linearize" and isinstance(value, types.ModuleType):
            value = value.linearize
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package

if TYPE_CHECKING:
    from mwip.linearize import linearize
    from mwip.params import NOMINAL, REAL, Params
