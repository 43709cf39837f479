"""mwip: robust and intelligent control of mobile wheeled inverted pendulums.

Models (Chapter 2), disturbance observers (Chapter 3), controllers (Chapters 3-5) and a fast
batch simulation engine, after Huang et al., *Robust and Intelligent Control of a Typical
Underactuated Robot: Mobile Wheeled Inverted Pendulum* (2023).

The names below are imported on first use (:mod:`mwip.lazy`): ``import mwip`` costs nothing.
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["Params", "REAL", "NOMINAL", "linearize", "__version__"]
__version__ = "0.1.0"

__getattr__, __dir__ = exports(
    __name__,
    {"Params": "mwip.params", "REAL": "mwip.params", "NOMINAL": "mwip.params",
     "linearize": "mwip.models.linear"},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.models.linear import linearize
    from mwip.params import NOMINAL, REAL, Params
