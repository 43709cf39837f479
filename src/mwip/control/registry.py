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
from collections.abc import Callable, Mapping, Sequence
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


def _need_period(name: str, Ts: float | None) -> float:
    if Ts is None:
        raise ValueError(
            f"controller {name!r} has internal state and needs a sample period "
            "(mode 'continuous' runs static laws only: lqr, smc, tsmc, it2, t1)"
        )
    return Ts


# ---------------------------------------------------------------------------------------------
# the book's controllers
# ---------------------------------------------------------------------------------------------
def _lqr_settings(with_design: bool) -> tuple[Setting, ...]:
    out: tuple[Setting, ...] = (
        Setting("Q_diag", (1000.0, 100.0, 100.0, 100.0, 1000.0),
                "state weights on [theta, alpha, theta', v, alpha'] (Sec. 4.4.2)",
                size=5, lo=0.0),
        Setting("R_diag", (0.01, 0.01), "input weights on [u_r, u_l] (Sec. 4.4.2)", size=2,
                lo=0.0, lo_open=True),
        Setting("v_d", 0.0, "speed reference (m/s) of x_ref = [0, 0, 0, v_d, 0] (ours)",
                lo=-10.0, hi=10.0),
    )  # fmt: skip
    if with_design:
        out += (Setting("design", "auto",
                        "auto: continuous Riccati gain in continuous mode, zero-order-hold "
                        "discrete gain when sampled (SPEC.md section 2); or force either",
                        choices=("auto", "continuous", "sampled")),)  # fmt: skip
    return out


def _lqr_factory(discrete: bool) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        import numpy as np

        from mwip.control.lqr import LQR, design_lqr

        how = "sampled" if discrete else s["design"]
        if how == "auto":
            how = "continuous" if Ts is None else "sampled"
        if how == "sampled" and Ts is None:
            raise ValueError("a sampled (discrete Riccati) LQR needs a sample period")
        Q, R = np.diag(s["Q_diag"]), np.diag(s["R_diag"])
        design = design_lqr(nominal, Q, R, Ts=Ts if how == "sampled" else None)
        return LQR(design, reference=(0.0, 0.0, 0.0, s["v_d"], 0.0))

    return make


register(ControllerSpec(
    "lqr", "linear-quadratic regulator about upright, the book's weights",
    "Sec. 4.4.2 (Q, R)", _lqr_settings(True), _lqr_factory(False),
))  # fmt: skip
register(ControllerSpec(
    "dlqr", "LQR for the sample period: discrete Riccati on the zero-order-hold model",
    "Sec. 4.4.2 (Q, R); SPEC.md section 2", _lqr_settings(False), _lqr_factory(True),
))  # fmt: skip

# ---- sliding-mode family (Sec. 3.5; Table 6.3) ---------------------------------------------
_SMC_K = {"smc": (25.0, 21.0), "do1smc": (17.3, 14.0), "hodosmc": (6.3, 4.0)}


def _smc_settings(kind: str) -> tuple[Setting, ...]:
    out: tuple[Setting, ...] = (
        Setting("lambdas", (3.0, 0.01, 0.1, 3.0),
                "sliding-surface coefficients l1..l4 of (3.49) (Table 6.3)", size=4, lo=0.0,
                lo_open=True),
        Setting("K", _SMC_K[kind], f"switching gains K1, K2 of (3.50), rad/s^2 (Table 6.3, "
                f"{kind})", size=2, lo=0.0),
        Setting("switching", "sat", "sat(s/phi) (the robot, Sec. 6.2.1) or sign (Sec. 3.5)",
                choices=("sat", "sign")),
        Setting("phi", 0.05, "boundary layer of sat (ours: the book prints no width)",
                lo=0.0, lo_open=True),
        Setting("psi_dot_d", 0.0, "wheel-speed target q1d' (rad/s) of (3.49)", lo=-100.0,
                hi=100.0),
        Setting("alpha_d", 0.0, "yaw target q3d (rad) of (3.49)", lo=-100.0, hi=100.0),
    )  # fmt: skip
    if kind == "do1smc":
        out += (Setting("L", 50.0, "first-order observer gain L I3 (1/s; ours: the book "
                        "prints none, docs/smc.md)", lo=0.0, lo_open=True),)  # fmt: skip
    if kind == "hodosmc":
        out += (Setting("v", (22.9778, 357.2853, 1831.5, 5737.7),
                        "4th-order observer gains L_i = v_i I3 (Sec. 3.6.1)", size=4,
                        lo=0.0, lo_open=True),)  # fmt: skip
    return out


def _smc_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.control.smc import make_smc
        from mwip.control.switching import Switching
        from mwip.observers.design import published_gain_sets

        period = _need_period(kind, Ts) if kind != "smc" else (0.005 if Ts is None else Ts)
        obs: Sequence[Any] | None = None
        if kind == "do1smc":
            obs = [s["L"]]
        elif kind == "hodosmc":
            published = published_gain_sets()["do4"]
            obs = published.gains if tuple(s["v"]) == tuple(published.v) else list(s["v"])
        # check=False: Table 6.3's lambdas fail (3.52) on the nominal model (docs/smc.md);
        # `mwip check smc --lambdas ...` reports the conditions
        return make_smc(kind, tuple(s["lambdas"]), K=tuple(s["K"]), observer_gains=obs,
                        params=nominal, Ts=period, switching=Switching(s["switching"], s["phi"]),
                        q1d_dot=s["psi_dot_d"], q3d=s["alpha_d"], check=False)  # fmt: skip

    return make


_SMC_TITLES = {
    "smc": "sliding-mode control (3.49)-(3.51), no observer",
    "do1smc": "sliding-mode control with a first-order disturbance observer",
    "hodosmc": "sliding-mode control with the 4th-order disturbance observer (HODOSMC)",
}
for _kind in ("smc", "do1smc", "hodosmc"):
    register(ControllerSpec(
        _kind, _SMC_TITLES[_kind], "Sec. 3.5, (3.49)-(3.51); Table 6.3",
        _smc_settings(_kind), _smc_factory(_kind), robot=True,
    ))  # fmt: skip


# ---- adaptive super-twisting and adaptive SMC (Sec. 4.2; (6.1)-(6.2), Table 6.7) -----------
def _asta_settings() -> tuple[Setting, ...]:
    return (
        Setting("lam", (10.0, 0.3, 3.0), "surface (4.1) lambda_1..3, constraints (4.2) "
                "((6.1)-(6.2))", size=3, lo=0.0, lo_open=True),
        Setting("K", (10.0, 10.0), "super-twisting gains K1, K2 of (4.3) ((6.1)-(6.2))",
                size=2, lo=0.0, lo_open=True),
        Setting("rate", (5.0, 5.0), "adaptation rates 1/partial_i of (4.5), the book's "
                "Gamma_1,2 ((6.1)-(6.2))", size=2, lo=0.0),
        Setting("Gamma0", (0.0, 0.0), "initial adaptive gains Gamma(0) (Remark 4.1)", size=2,
                lo=0.0),
        Setting("eps", 0.01, "boundary layer of the adaptive law (4.5) (ours)", lo=0.0),
        Setting("psi_dot_d", 0.0, "wheel-speed target (rad/s) of (4.1)", lo=-100.0, hi=100.0),
        Setting("theta_d", 0.0, "pitch target (rad) of (4.1)", lo=-0.5, hi=0.5),
        Setting("alpha_d", 0.0, "yaw target (rad) of (4.1)", lo=-100.0, hi=100.0),
    )  # fmt: skip


def _asta_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.control.asta import ASMC, ASTA

        cls = ASTA if kind == "asta" else ASMC
        return cls(nominal, lam=s["lam"], K=s["K"], rate=s["rate"], Gamma0=s["Gamma0"],
                   eps=s["eps"], psi_dot_ref=s["psi_dot_d"], theta_ref=s["theta_d"],
                   alpha_ref=s["alpha_d"], Ts=_need_period(kind, Ts))  # fmt: skip

    return make


register(ControllerSpec(
    "asta", "adaptive super-twisting control (4.1), (4.3)-(4.5), (4.7)",
    "Sec. 4.2; (6.1)-(6.2), Table 6.7", _asta_settings(), _asta_factory("asta"), robot=True,
))  # fmt: skip
register(ControllerSpec(
    "asmc", "adaptive sliding-mode control, the ASTA baseline (same surface and gains)",
    "Sec. 4.2; (6.1)-(6.2), Table 6.7", _asta_settings(), _asta_factory("asmc"), robot=True,
))  # fmt: skip


# ---- terminal SMC (Sec. 4.3) ---------------------------------------------------------------
def _tsmc_factory(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
    from mwip.control.switching import Switching
    from mwip.control.tsmc import TSMC

    return TSMC(nominal, C=s["C"], Gamma=s["Gamma"], D=s["D"], Ftilde_ratio=s["Ftilde_ratio"],
                Tf=s["Tf"], switching=Switching(s["switching"], s["phi"]),
                theta_ref=s["theta_d"], alpha_ref=s["alpha_d"],
                alpha_dot_ref=s["alpha_dot_d"], v_ref=s["v_d"], speed=s["speed"],
                Ts=Ts)  # fmt: skip


register(ControllerSpec(
    "tsmc", "terminal sliding-mode control with augmented surfaces (4.30)-(4.32), (4.43)",
    "Sec. 4.3, Sec. 4.4.2",
    (
        Setting("C", (2.5, 2.5), "surface slopes C = diag(c1, c2) (Sec. 4.4.2)", size=2,
                lo=0.0, lo_open=True),
        Setting("Gamma", (10.0, 10.0), "reaching margins (Sec. 4.4.2)", size=2, lo=0.0,
                lo_open=True),
        Setting("D", 0.4, "input-gain uncertainty bound D = d I, ||D|| < 1 (4.29), "
                "(Sec. 4.4.2)", lo=0.0, hi=1.0, hi_open=True),
        Setting("Ftilde_ratio", 0.8, "F~ = ratio |F^| (4.28) (Sec. 4.4.2)", lo=0.0),
        Setting("Tf", 1.0, "convergence time T_f of (4.43), s (Sec. 4.4.2)", lo=1e-3),
        Setting("switching", "sat", "sat(s/phi) (Sec. 4.4.2) or sign",
                choices=("sat", "sign")),
        Setting("phi", 0.05, "boundary layer of sat (ours)", lo=0.0, lo_open=True),
        Setting("theta_d", 0.0, "pitch target theta* (rad)", lo=-0.5, hi=0.5),
        Setting("alpha_d", 0.0, "yaw target alpha*(0) (rad)", lo=-100.0, hi=100.0),
        Setting("alpha_dot_d", 0.0, "yaw-rate target alpha'* (rad/s): alpha*(t) ramps",
                lo=-10.0, hi=10.0),
        Setting("speed", "none", "none (the book: v left to the internal dynamics) or lean "
                "(pitch target from v_d, docs/chapter4.md)", choices=("none", "lean")),
        Setting("v_d", 0.0, "speed target (m/s) with speed = lean", lo=-10.0, hi=10.0),
    ),
    _tsmc_factory,
))  # fmt: skip


# ---- the Fig. 5.3 fuzzy controller (Chapter 5; Sec. 6.2.3) ----------------------------------
def _fuzzy_factory(kind: str) -> Factory:
    def make(nominal: Params, s: Mapping[str, Any], Ts: float | None) -> Controller:
        from mwip.fuzzy.fig53 import Fig53Controller
        from mwip.fuzzy.pdc import design_pdc, uncertainty_models

        if s["uncertainty"] > 0:
            models = uncertainty_models(nominal, s["uncertainty"])
            design = design_pdc(models, epsilon=s["epsilon"], rho=s["rho"])
        else:
            design = design_pdc(epsilon=s["epsilon"], rho=s["rho"], params=nominal)
        return Fig53Controller([design], [kind], [s["p_d"]], [s["alpha_d"]], params=nominal,
                               Ts=Ts)  # fmt: skip

    return make


def _fuzzy_settings() -> tuple[Setting, ...]:
    return (
        Setting("epsilon", 0.2, "radius of Lemma 5.2's ball ||x0|| <= epsilon (rad; Sec. 5.4)",
                lo=0.0, lo_open=True, hi=10.0),  # as `mwip design it2 --epsilon`
        Setting("rho", 20.0, "input bound of Lemma 5.2 (N m; Sec. 5.4)", lo=0.0, lo_open=True),
        Setting("uncertainty", 0.0, "0: Lemma 5.1/5.2 on the nominal TS model (the book); "
                "u > 0: also on r, mb, l scaled by 1 +- u (ours, docs/fuzzy.md)",
                lo=0.0, hi=1.0, hi_open=True),
        Setting("p_d", None, "position target (m) of the position FLS (Sec. 5.3.2)",
                lo=-100.0, hi=100.0, optional=True),
        Setting("alpha_d", None, "heading target (rad) of the direction FLS (Sec. 5.3.2)",
                lo=-100.0, hi=100.0, optional=True),
    )  # fmt: skip


register(ControllerSpec(
    "it2", "IT2 fuzzy control of Fig. 5.3: PDC balance (5.10) + Mamdani position/direction",
    "Sec. 5.3, Fig. 5.3, Tables 5.1-5.2; Sec. 6.2.3", _fuzzy_settings(), _fuzzy_factory("it2"),
    robot=True,
))  # fmt: skip
register(ControllerSpec(
    "t1", "type-1 counterpart of it2 (same rules and gains, sets at the footprints' middle)",
    "Sec. 6.2.3", _fuzzy_settings(), _fuzzy_factory("t1"), robot=True,
))  # fmt: skip
