"""Small dense linear algebra in NumPy alone: ``expm``, the Riccati and Lyapunov solvers.

Why not SciPy: issue 18 asks that a plain ``mwip simulate`` of any registered controller
import only what it uses, with a start-up target of 0.5 s. The controllers' design steps
(LQR gains, the zero-order-hold model, the disturbance observer's discretisation and its
impulse-to-energy gain) need four SciPy functions, and ``import scipy.linalg`` alone costs
about 0.12 s (more on a loaded machine). The matrices here are small (n <= 12 on the paths
that use them), so short NumPy implementations of published algorithms do the job:

- :func:`expm`: scaling and squaring with Pade approximants of degree 3 .. 13
  (Al-Mohy & Higham 2009, which refines Higham 2005), module :mod:`mwip.linalg.expm`;
- :func:`solve_continuous_are`, :func:`solve_discrete_are`: the structure-preserving
  doubling algorithm (Chu, Fan, Lin 2005; Chu, Fan, Lin, Wang 2004), or the matrix sign
  function (Byers 1987) where ``(A, Q)`` is not detectable, followed by Newton refinement
  (Kleinman 1968; Hewer 1971), module :mod:`mwip.linalg.riccati`;
- :func:`solve_continuous_lyapunov`, :func:`solve_discrete_lyapunov`: the Kronecker
  (vec) form, module :mod:`mwip.linalg.lyapunov`.

Call conventions are SciPy's (``scipy.linalg`` functions of the same names, without their
optional descriptor / cross-term / balancing arguments); failures raise ``ValueError`` with a
one-line reason. tests/test_linalg.py compares every function with SciPy on seeded random
systems and on the robot's linearisations, and checks the equations' residuals.
"""

from __future__ import annotations

from mwip.linalg.expm import expm
from mwip.linalg.lyapunov import solve_continuous_lyapunov, solve_discrete_lyapunov
from mwip.linalg.riccati import solve_continuous_are, solve_discrete_are

__all__ = [
    "expm",
    "solve_continuous_are",
    "solve_discrete_are",
    "solve_continuous_lyapunov",
    "solve_discrete_lyapunov",
]
