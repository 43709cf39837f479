"""Type-1 and interval type-2 (IT2) triangular fuzzy sets, t-norm and rule firing (Chapter 5).

Everything is vectorised: memberships broadcast over any leading axes of the input.

- :func:`triangle` - the triangular membership ``(a, b, c)`` (apex ``b``), with shoulders
  allowed (``a == b`` or ``b == c``).
- :class:`TriangularSet` - a type-1 triangular set (frozen, validated).
- :class:`TriangularIT2Set` - an IT2 set given by its lower and upper membership functions
  (both triangular, the lower one inside the upper one); its footprint of uncertainty (FOU)
  is the region between them. :meth:`TriangularIT2Set.middle` is the type-1 set "at the
  middle of the footprint" (mean of the two triangles' corner points), the type-1
  counterpart used by the T1 baselines (SPEC.md section 1, "Type-1 FLS baseline").
- :class:`UniformPartition` - ``n`` (default 7: NB, NM, NS, ZO, PS, PM, PB) evenly spaced
  triangular IT2 sets over a symmetric range, as in Section 5.3.2 / Fig. 5.2.
- :func:`min_tnorm` and :func:`firing_grid` - the minimum t-norm and the firing intervals of a
  two-input complete rule grid (Section 5.3.2: "the minimum t-norm ... was used").

Footprint choice (the book shows Fig. 5.2 but prints no numbers; documented in
``docs/fuzzy.md``): for a partition with apex spacing ``h`` the upper MF of every set is the
triangle of half-width ``(1 + fou) h`` and the lower MF the triangle of half-width
``(1 - fou) h``, both of height 1 and centred on the apex; default ``fou = 0.25``. The type-1
counterpart (the middle of the footprint) is then the triangle of half-width ``h``, i.e. the
classic partition of unity.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "LABELS7",
    "triangle",
    "TriangularSet",
    "TriangularIT2Set",
    "UniformPartition",
    "min_tnorm",
    "firing_grid",
]

#: Linguistic labels of the seven sets of Section 5.3.2, from negative big to positive big.
LABELS7: tuple[str, ...] = ("NB", "NM", "NS", "ZO", "PS", "PM", "PB")


def triangle(x: ArrayLike, a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Triangular membership with feet ``a, c`` and apex ``b`` (height 1), vectorised.

    ``a == b`` (left shoulder) or ``b == c`` (right shoulder) give a vertical edge at the apex;
    ``a == b == c`` is a singleton. All arguments broadcast.
    """
    x = np.asarray(x, dtype=float)
    a, b, c = (np.asarray(v, dtype=float) for v in (a, b, c))
    with np.errstate(divide="ignore", invalid="ignore"):
        rise = np.where(b > a, (x - a) / np.where(b > a, b - a, 1.0), (x >= b).astype(float))
        fall = np.where(c > b, (c - x) / np.where(c > b, c - b, 1.0), (x <= b).astype(float))
    return np.clip(np.minimum(rise, fall), 0.0, 1.0)


@dataclass(frozen=True)
class TriangularSet:
    """Type-1 triangular fuzzy set ``(a, b, c)`` scaled by ``height`` in (0, 1]."""

    a: float
    b: float
    c: float
    height: float = 1.0

    def __post_init__(self) -> None:
        vals = (self.a, self.b, self.c, self.height)
        if not all(np.isfinite(v) for v in vals):
            raise ValueError(f"triangle parameters must be finite, got {vals}")
        if not (self.a <= self.b <= self.c):
            raise ValueError(f"need a <= b <= c, got {(self.a, self.b, self.c)}")
        if not (0.0 < self.height <= 1.0):
            raise ValueError(f"height must be in (0, 1], got {self.height}")

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        return self.height * triangle(x, self.a, self.b, self.c)

    @property
    def centroid(self) -> float:
        """Centroid of the triangle, ``(a + b + c) / 3``."""
        return (self.a + self.b + self.c) / 3.0


@dataclass(frozen=True)
class TriangularIT2Set:
    """IT2 fuzzy set with triangular lower and upper membership functions.

    Valid when the lower MF lies under the upper MF everywhere: ``upper.a <= lower.a``,
    ``lower.c <= upper.c``, ``lower.height <= upper.height`` and both apexes equal (the
    shapes used in Chapter 5). Calling it returns ``(lower, upper)`` memberships.
    """

    lower: TriangularSet
    upper: TriangularSet

    def __post_init__(self) -> None:
        lo, up = self.lower, self.upper
        if not (up.a <= lo.a and lo.c <= up.c and lo.height <= up.height and lo.b == up.b):
            raise ValueError(
                f"lower MF {lo} must lie under upper MF {up} (nested supports, same apex)"
            )

    def __call__(self, x: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.lower(x), self.upper(x)

    def middle(self) -> TriangularSet:
        """Type-1 set at the middle of the footprint (mean corner points and height)."""
        lo, up = self.lower, self.upper
        return TriangularSet(
            (lo.a + up.a) / 2, lo.b, (lo.c + up.c) / 2, (lo.height + up.height) / 2
        )

    @property
    def centroid_interval(self) -> tuple[float, float]:
        """Centroid interval ``[c_l, c_r]`` of the continuous IT2 set, exact (Karnik-Mendel).

        The centroid of an IT2 set is the interval of the centroids of its embedded type-1
        sets (Karnik and Mendel, 2001). Its ends switch between the MFs at one point ``y``:

        ``c_l = min_y (int_{x<y} x U + int_{x>y} x L) / (int_{x<y} U + int_{x>y} L)``

        and ``c_r`` the same with ``L`` and ``U`` exchanged (max). At the optimum the switch
        point equals the centroid, ``y = c_l`` (the continuous Karnik-Mendel fixed point), which
        is solved here with the moments of the piecewise-linear MFs in closed form and a
        bracketing root finder. Symmetric sets give ``c_r = -c_l`` about the apex (e.g.
        lower ``(-0.5, 0, 0.5)``, upper ``(-1, 0, 1)``: ``(-0.167715, 0.167715)``). A lower MF
        of zero area (a singleton) leaves the whole upper support: ``(upper.a, upper.c)``.
        """
        lo, up = self.lower, self.upper
        if up.a == up.c:
            return (up.b, up.b)
        L0, L1 = _moments(lo, math.inf)
        U0, U1 = _moments(up, math.inf)
        if L0 == 0.0:
            return (up.a, up.c)

        def left(y: float) -> float:  # y - centroid of "U left of y, L right of y"
            u0, u1 = _moments(up, y)
            l0, l1 = _moments(lo, y)
            return y - (u1 + L1 - l1) / (u0 + L0 - l0)

        def right(y: float) -> float:  # y - centroid of "L left of y, U right of y"
            u0, u1 = _moments(up, y)
            l0, l1 = _moments(lo, y)
            return y - (l1 + U1 - u1) / (l0 + U0 - u0)

        return (_root(left, up.a, up.c), _root(right, up.a, up.c))


def _moments(s: TriangularSet, y: float) -> tuple[float, float]:
    """``(int_{-inf}^{y} mu, int_{-inf}^{y} x mu)`` of a triangular set, in closed form."""
    m0 = m1 = 0.0
    for x0, h0, x1, h1 in ((s.a, 0.0, s.b, s.height), (s.b, s.height, s.c, 0.0)):
        if x1 <= x0 or y <= x0:
            continue
        z = min(y, x1)
        k = (h1 - h0) / (x1 - x0)  # mu = h0 + k (x - x0) on [x0, x1]
        m0 += h0 * (z - x0) + k * (z - x0) ** 2 / 2.0
        m1 += h0 * (z * z - x0 * x0) / 2.0 + k * (
            (z**3 - x0**3) / 3.0 - x0 * (z * z - x0 * x0) / 2.0
        )
    return m0, m1


def _root(g: Callable[[float], float], a: float, b: float) -> float:
    """The single root of ``g`` on ``[a, b]`` by bisection to machine precision. ``g(y)`` is
    ``y`` minus a Karnik-Mendel centroid that stays inside ``[a, b]``: ``g(a) <= 0 <= g(b)``,
    negative below the fixed point and positive above it."""
    ga, gb = g(a), g(b)
    if ga >= 0.0:
        return a
    if gb <= 0.0:
        return b
    for _ in range(200):
        m = 0.5 * (a + b)
        if m in (a, b):
            break
        if g(m) > 0.0:
            b = m
        else:
            a = m
    return 0.5 * (a + b)


@dataclass(frozen=True)
class UniformPartition:
    """``n`` evenly spaced triangular IT2 sets on ``[-half_range, half_range]`` (Sec. 5.3.2).

    Apexes ``c_k = -R + k h`` with ``h = 2R / (n - 1)``; upper half-width ``(1 + fou) h``,
    lower half-width ``(1 - fou) h`` (module docstring). Inputs are saturated to the range
    before evaluation, so the end sets act as shoulders. ``fou = 0`` gives the type-1
    partition of unity (lower = upper).
    """

    half_range: float
    n: int = 7
    fou: float = 0.25
    labels: Sequence[str] = LABELS7

    def __post_init__(self) -> None:
        if not (np.isfinite(self.half_range) and self.half_range > 0):
            raise ValueError(f"half_range must be finite and > 0, got {self.half_range!r}")
        if int(self.n) != self.n or self.n < 3 or self.n % 2 == 0:
            raise ValueError(f"n must be an odd integer >= 3, got {self.n!r}")
        if not (0.0 <= self.fou < 0.5):
            raise ValueError(
                f"fou must be in [0, 0.5) (the lower MFs must cover the range), got {self.fou!r}"
            )
        if len(self.labels) != self.n:
            raise ValueError(f"need {self.n} labels, got {len(self.labels)}")

    @property
    def spacing(self) -> float:
        return 2.0 * self.half_range / (self.n - 1)

    @property
    def centers(self) -> NDArray[np.float64]:
        """Apexes of the sets (also the centroids of the symmetric consequents), (n,)."""
        return np.linspace(-self.half_range, self.half_range, self.n)

    def sets(self) -> tuple[TriangularIT2Set, ...]:
        """The IT2 sets as objects (for inspection and plotting)."""
        h = self.spacing
        wl, wu = (1.0 - self.fou) * h, (1.0 + self.fou) * h
        return tuple(
            TriangularIT2Set(TriangularSet(c - wl, c, c + wl), TriangularSet(c - wu, c, c + wu))
            for c in self.centers
        )

    def clip(self, x: ArrayLike) -> NDArray[np.float64]:
        """Saturate the input to the partition's range."""
        return np.clip(np.asarray(x, dtype=float), -self.half_range, self.half_range)

    def memberships(self, x: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper memberships of the (saturated) input, each (..., n)."""
        xc = self.clip(x)[..., None]
        h = self.spacing
        c = self.centers
        lo = triangle(xc, c - (1.0 - self.fou) * h, c, c + (1.0 - self.fou) * h)
        up = triangle(xc, c - (1.0 + self.fou) * h, c, c + (1.0 + self.fou) * h)
        return lo, up

    def type1(self) -> UniformPartition:
        """Type-1 counterpart: the sets at the middle of each footprint (``fou = 0``)."""
        return UniformPartition(self.half_range, self.n, 0.0, tuple(self.labels))


def min_tnorm(*grades: ArrayLike) -> NDArray[np.float64]:
    """Minimum t-norm of any number of membership arrays (broadcast element-wise)."""
    if not grades:
        raise ValueError("min_tnorm needs at least one argument")
    out = np.asarray(grades[0], dtype=float)
    for g in grades[1:]:
        out = np.minimum(out, np.asarray(g, dtype=float))
    return out


def firing_grid(
    lower1: ArrayLike, upper1: ArrayLike, lower2: ArrayLike, upper2: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Firing intervals of the complete two-input rule grid with the minimum t-norm.

    Inputs (..., n1) and (..., n2); returns lower and upper firing strengths (..., n1, n2),
    ``f[..., i, j] = min(mu1_i, mu2_j)`` for the rule "if x1 is A_i and x2 is B_j".
    """
    l1, u1 = np.asarray(lower1, dtype=float), np.asarray(upper1, dtype=float)
    l2, u2 = np.asarray(lower2, dtype=float), np.asarray(upper2, dtype=float)
    return (
        min_tnorm(l1[..., :, None], l2[..., None, :]),
        min_tnorm(u1[..., :, None], u2[..., None, :]),
    )
