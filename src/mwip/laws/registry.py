"""Every controller by name: its book source, its settings and a factory.

A :class:`ControllerSpec` says what a controller is (``title``, book ``source``), what can be
set (:class:`Setting`: default = the book's value, allowed range, meaning and unit) and how to
build it: ``factory(nominal, settings, Ts) -> Controller`` from the *nominal* parameters (the
controller never sees the plant), the validated settings and the sample period it runs at
(``None``: inside the plant's right-hand side, ``mode="continuous"``, static laws only).

>>> spec = get("smc")
>>> spec.resolve({"K": "20,15"})["K"]
(20.0, 15.0)
>>> get("smc").resolve({"phi": -1})
Traceback (most recent call last):
ValueError: controller 'smc': setting 'phi' must be a number in (0, 1e+06], got -1

Defaults: the book's values. Where the book gives a set for the 5 ms robot loop (Chapter 6,
Tables 6.3 and 6.7) that set is the default, since every controller runs at the robot's 5 ms
by default; otherwise the set of the chapter's simulations (LQR and TSMC: Sec. 4.4.2; the
fuzzy controller: Chapter 5). Each setting's help names its source; our readings where the
book prints nothing are marked "ours" (e.g. the saturation width ``phi``).

Adding a controller: a module with the controller class (the :class:`mwip.core.Controller`
protocol) and one :func:`register` call with its spec; see docs/extending.md.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from mwip.core import Controller
from mwip.params import NOMINAL, Params

__all__ = [
    "Setting",
    "ControllerSpec",
    "CONTROLLERS",
    "register",
    "get",
    "names",
    "build",
]

#: ``factory(nominal, settings, Ts) -> Controller``
Factory = Callable[[Params, Mapping[str, Any], "float | None"], Controller]


def _fmt(x: float) -> str:
    return "inf" if math.isinf(x) else ("-inf" if x == -math.inf else f"{x:g}")


#: The largest magnitude of any numeric setting whose range is otherwise open-ended: beyond it
#: the designs overflow (``Tf = 1e308``, ``epsilon = 1e308``) or the solvers give up after long
#: searches (``rho = 1e12``), and no setting of the book comes near it.
MAGNITUDE = 1e6


def _excerpt(value: Any, n: int = 60) -> str:
    """``repr(value)``, cut to ``n`` characters (an error line quotes a short excerpt)."""
    text = repr(value)
    return text if len(text) <= n else f"{text[: n - 15]}... ({len(text)} characters)"


@dataclass(frozen=True)
class Setting:
    """One setting of a controller: its name, the book's default, meaning and allowed values.

    A number (``size = 0``), ``size`` numbers (a vector, written ``a,b,c`` on the command
    line), or a word from ``choices``. ``optional``: may be unset (``None``, "none").
    Numbers must lie in ``lo .. hi`` (open or closed ends), an open-ended side within
    :data:`MAGNITUDE`.
    """

    name: str
    default: Any
    help: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    size: int = 0
    choices: tuple[str, ...] = ()
    optional: bool = False

    def allowed(self) -> str:
        """The allowed values in words, e.g. ``2 numbers in [0, inf)``."""
        if self.choices:
            text = "one of " + ", ".join(self.choices)
        else:
            lo_v, hi_v = max(self.lo, -MAGNITUDE), min(self.hi, MAGNITUDE)
            lo = f"{'(' if self.lo_open and lo_v == self.lo else '['}{_fmt(lo_v)}"
            hi = f"{_fmt(hi_v)}{')' if self.hi_open and hi_v == self.hi else ']'}"
            what = "a number" if self.size == 0 else f"{self.size} numbers"
            text = f"{what} in {lo}, {hi}"
        return text + (" or none" if self.optional else "")

    def _in_range(self, x: float) -> bool:
        if not math.isfinite(x) or abs(x) > MAGNITUDE:
            return False
        above = x > self.lo if self.lo_open else x >= self.lo
        below = x < self.hi if self.hi_open else x <= self.hi
        return above and below

    def parse(self, value: Any, owner: str = "") -> Any:
        """``value`` (a command-line string or a TOML value) checked against the range.

        Raises ``ValueError`` in one line naming the controller, the setting and what is
        allowed.
        """

        def bad() -> ValueError:
            who = f"controller {owner!r}: " if owner else ""
            return ValueError(f"{who}setting {self.name!r} must be {self.allowed()}, "
                              f"got {_excerpt(value)}")  # fmt: skip

        if self.choices:
            word = str(value).strip()
            if word not in self.choices:
                raise bad()
            return word
        if value is None or (isinstance(value, str) and value.strip().lower() == "none"):
            if self.optional:
                return None
            raise bad()
        items: list[Any]
        if isinstance(value, str):
            items = [v for v in value.replace(" ", "").strip("[]()").split(",") if v != ""]
        elif isinstance(value, list | tuple):
            items = list(value)
        else:
            items = [value]
        if isinstance(value, bool) or any(isinstance(v, bool) for v in items):
            raise bad()
        try:
            nums = [float(v) for v in items]
        except (TypeError, ValueError):
            raise bad() from None
        if len(nums) != max(self.size, 1) or not all(self._in_range(x) for x in nums):
            raise bad()
        return nums[0] if self.size == 0 else tuple(nums)


@dataclass(frozen=True)
class ControllerSpec:
    """A registered controller: ``name``, ``title``, book ``source``, ``settings``, ``factory``.

    ``Ts``: the sample period it runs at by default (s). ``robot``: the book runs it on the
    robot in Chapter 6 (it runs on the digital twin, ``mwip simulate --twin``).
    """

    name: str
    title: str
    source: str
    settings: tuple[Setting, ...]
    factory: Factory = field(repr=False)
    Ts: float = 0.005
    robot: bool = False

    def setting(self, key: str) -> Setting:
        """The setting ``key``; ``ValueError`` listing the allowed names otherwise."""
        for s in self.settings:
            if s.name == key:
                return s
        allowed = ", ".join(s.name for s in self.settings) or "(none)"
        raise ValueError(f"controller {self.name!r} has no setting {key!r}; allowed: {allowed}")

    def defaults(self) -> dict[str, Any]:
        """The book's settings."""
        return {s.name: s.default for s in self.settings}

    def resolve(self, given: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The defaults with ``given`` applied, every given value validated."""
        out = self.defaults()
        for key, value in (given or {}).items():
            out[key] = self.setting(key).parse(value, self.name)
        return out

    def build(
        self,
        nominal: Params = NOMINAL,
        settings: Mapping[str, Any] | None = None,
        Ts: float | None | Literal["default"] = "default",
    ) -> Controller:
        """The controller designed on ``nominal`` with ``settings`` (validated) for sample
        period ``Ts`` (default: :attr:`Ts`; ``None``: continuous mode)."""
        if not isinstance(nominal, Params):
            raise TypeError(f"nominal must be a mwip.params.Params, got {type(nominal).__name__}")
        if settings is not None and not isinstance(settings, Mapping):
            raise TypeError(f"settings must be a mapping of setting names to values, got "
                            f"{type(settings).__name__}")  # fmt: skip
        period = self.Ts if isinstance(Ts, str) and Ts == "default" else Ts
        if period is not None and (isinstance(period, bool)
                                   or not isinstance(period, numbers.Real)):
            raise TypeError(f"Ts must be a number (s), None or 'default', got "
                            f"{type(period).__name__}")  # fmt: skip
        if period is not None and not (math.isfinite(period) and 0 < period <= 1.0):
            raise ValueError(f"Ts must be in (0, 1] s, got {period!r}")
        return self.factory(nominal, self.resolve(settings), period)


#: The registry, by name (insertion order = the order ``mwip controllers`` lists them).
CONTROLLERS: dict[str, ControllerSpec] = {}


def register(spec: ControllerSpec) -> ControllerSpec:
    """Add ``spec`` to :data:`CONTROLLERS` (a name may be registered once)."""
    if spec.name in CONTROLLERS:
        raise ValueError(f"controller {spec.name!r} is already registered")
    CONTROLLERS[spec.name] = spec
    return spec


def names() -> list[str]:
    """The registered names."""
    return list(CONTROLLERS)


def get(name: str) -> ControllerSpec:
    """The spec of ``name``; ``ValueError`` listing the registered names otherwise."""
    try:
        return CONTROLLERS[name]
    except KeyError:
        raise ValueError(
            f"unknown controller {name!r}; choose from: {', '.join(CONTROLLERS)}"
        ) from None


def build(
    name: str,
    nominal: Params = NOMINAL,
    settings: Mapping[str, Any] | None = None,
    Ts: float | None | Literal["default"] = "default",
) -> Controller:
    """Shorthand for ``get(name).build(nominal, settings, Ts)``."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a registered controller's name, got {type(name).__name__}")
    return get(name).build(nominal, settings, Ts)


def need_period(name: str, Ts: float | None) -> float:
    if Ts is None:
        raise ValueError(
            f"controller {name!r} has internal state and needs a sample period "
            "(mode 'continuous' runs static laws only: lqr, smc, tsmc, it2, t1)"
        )
    return Ts


def _discover() -> None:
    """Import every law family's ``spec`` module (``mwip/laws/<family>/spec.py``), in the
    order of their ``ORDER``: each registers its controllers, so a new family is its folder,
    with no list here to edit."""
    import importlib
    import pkgutil
    from pathlib import Path

    here = Path(__file__).resolve().parent
    found = []
    for info in pkgutil.iter_modules([str(here)]):
        if info.ispkg and (here / info.name / "spec.py").is_file():
            found.append(importlib.import_module(f"mwip.laws.{info.name}.spec"))
    rank = {m.__name__: getattr(m, "ORDER", 100) for m in found}
    ordered = dict(sorted(CONTROLLERS.items(),
                          key=lambda kv: rank.get(kv[1].factory.__module__, 1000)))
    CONTROLLERS.clear()
    CONTROLLERS.update(ordered)


_discover()
