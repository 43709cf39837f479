"""Dynamic models of the MWIP (Chapter 2).

- :mod:`mwip.models.reduced` - the reduced model with lumped uncertainties (2.32)-(2.36),
  the plant of every simulation;
- :mod:`mwip.models.spatial` - the 3D model with nonholonomic constraints (2.24)-(2.31);
- :mod:`mwip.models.planar` - the 2D model on a slope (2.12);
- :mod:`mwip.models.linear` - the linearisation about upright (Section 4.4),
  :func:`~mwip.models.linear.linearize` (also ``mwip.linearize``).

The submodules are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["linear", "planar", "reduced", "spatial"]

__getattr__, __dir__ = exports(__name__, {n: f"mwip.models.{n}" for n in __all__})

if TYPE_CHECKING:
    from mwip.models import linear, planar, reduced, spatial
