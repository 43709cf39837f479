"""The integer codes shared by the engine and its compiled kernels, without loading the
compiler (a plain ``simulate`` that runs the ahead-of-time loop never imports Numba).

- run status of a plant: ``OK`` (still running), ``FELL`` (``|theta| >= pi/2``), ``DIVERGED``
  (a non-finite state); names in :data:`STATUS_NAMES`;
- integrators (:mod:`mwip.sim.kernel`): ``ROS2W``, the linearly implicit Rosenbrock-W method
  for stiff plants, and ``RK4``, classical Runge-Kutta for non-stiff ones; names in
  :data:`METHOD_NAMES`; ``GAMMA = 1 + 1/sqrt(2)``, ROS2's stage coefficient;
- ``PARALLEL_MIN``: batches of at least this many robots run the threaded loop.
"""

import math

__all__ = [
    "GAMMA", "OK", "FELL", "DIVERGED", "STATUS_NAMES", "ROS2W", "RK4", "METHOD_NAMES",
    "PARALLEL_MIN",
]  # fmt: skip

GAMMA = 1.0 + 1.0 / math.sqrt(2.0)
OK, FELL, DIVERGED = 0, 1, 2
STATUS_NAMES = ("ok", "fell", "diverged")
ROS2W, RK4 = 0, 1
METHOD_NAMES = ("ROS2-W", "RK4")
#: Batches of at least this many robots run on all threads (:func:`mwip.sim.loop.run_parallel`).
PARALLEL_MIN = 64
