"""Controllers (Chapters 3-5) behind one protocol, :class:`mwip.control.base.Controller`."""

from mwip.control.base import Controller
from mwip.control.lqr import LQR, LQRDesign, design_lqr, dlqr, lqr

__all__ = ["Controller", "LQR", "LQRDesign", "design_lqr", "lqr", "dlqr"]
