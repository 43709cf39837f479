"""Dynamic models of the MWIP (Chapter 2).

- :mod:`mwip.models.reduced` - the reduced model with lumped uncertainties (2.32)-(2.36),
  the plant of every simulation;
- :mod:`mwip.models.spatial` - the 3D model with nonholonomic constraints (2.24)-(2.31);
- :mod:`mwip.models.planar` - the 2D model on a slope (2.12).
"""

from mwip.models import planar, reduced, spatial

__all__ = ["planar", "reduced", "spatial"]
