"""Hardening (issue 26, item 9): the public entry points (``simulate``, the registry's build,
the controller and observer constructors) check their arguments and raise ``TypeError`` /
``ValueError`` naming the argument, instead of an ``AttributeError``, ``IndexError`` or a
NumPy message from deep inside (or an ``OverflowError`` for a value in a documented range)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mwip.laws import LQR, design_lqr, registry
from mwip.laws.asta.controller import ASMC, ASTA
from mwip.laws.smc.controller import SlidingModeController
from mwip.laws.tsmc.controller import TSMC
from mwip.observers import FirstOrderDO, SecondOrderDO
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate

CTRL = LQR(design_lqr(NOMINAL, Ts=0.005))


def _cases():
    sim = lambda **kw: simulate(CTRL, REAL, duration=0.05, **kw)  # noqa: E731
    return {
        # simulate: was "truth value of an array is ambiguous", AttributeError, "not callable"
        "mode": lambda: sim(mode=np.array(["sampled", "x"])),
        "integrator": lambda: sim(integrator=["rk4"]),
        "compiled": lambda: sim(compiled=np.zeros(2)),
        "disturbance": lambda: sim(disturbance="book"),
        "sensor": lambda: sim(sensor="ideal"),
        "actuator": lambda: sim(actuator=object()),
        # the registry: was AttributeError on 'batch_shape', 'items'; "must be real number"
        "nominal": lambda: registry.build("smc", None),
        "settings": lambda: registry.build("smc", NOMINAL, "K=1"),
        "Ts": lambda: registry.build("hodosmc", NOMINAL, Ts=1e308),  # was "A must be finite"
        "name": lambda: registry.build(3),
        # constructors: was AttributeError 'm11', reshape / isfinite / float() messages
        "params": lambda: ASTA(None),
        "lam": lambda: ASMC(NOMINAL, lam=None),
        "eps": lambda: ASTA(NOMINAL, eps=None),
        "theta_ref": lambda: ASTA(NOMINAL, theta_ref=[1, 2]),
        "Tf": lambda: TSMC(NOMINAL, Tf=1e308),  # was OverflowError
        "D": lambda: TSMC(NOMINAL, D=[]),
        "Ftilde_ratio": lambda: TSMC(NOMINAL, Ftilde_ratio=None),
        "speed": lambda: TSMC(NOMINAL, speed=np.array(["none", "lean"])),
        "C": lambda: TSMC(NOMINAL, C=np.zeros((7, 7))),
        "v_ref": lambda: TSMC(NOMINAL, v_ref=None),
        "discretization": lambda: FirstOrderDO(NOMINAL, 10.0, 0.005,
                                               discretization=np.array(["a", "b"])),  # fmt: skip
        "model_hold": lambda: SecondOrderDO(NOMINAL, 10.0, 20.0, 0.005, model_hold=[]),
        "substeps": lambda: FirstOrderDO(NOMINAL, 10.0, 0.005, substeps=1.5),
        "gains": lambda: SlidingModeController("gains"),
    }


@pytest.mark.parametrize("arg", list(_cases()))
def test_api_arguments_are_checked_and_named(arg):
    with pytest.raises((TypeError, ValueError)) as info:
        _cases()[arg]()
    assert arg in str(info.value), str(info.value)
    assert type(info.value).__module__ in ("builtins", "mwip.budget"), type(info.value)


def test_observer_params_and_ts_are_named():
    with pytest.raises(TypeError, match="params"):
        FirstOrderDO(None, 10.0, 0.005)
    with pytest.raises(TypeError, match="Ts"):
        FirstOrderDO(NOMINAL, 10.0, [])
    with pytest.raises(ValueError, match="Ts"):
        SecondOrderDO(NOMINAL, 10.0, 20.0, math.inf)


def test_huge_weights_and_gains_are_refused_not_overflowed():
    with pytest.raises(ValueError, match="Q must have entries"):
        design_lqr(NOMINAL, Q=np.eye(5) * 1e300)  # was OverflowError
    with pytest.raises(ValueError, match="gains must be finite"):
        FirstOrderDO(NOMINAL, 1e300, 0.005)  # was LinAlgError naming no argument


def test_good_arguments_still_work():
    """The checks keep every form the library itself uses (numbers broadcast, tuples)."""
    ASTA(NOMINAL, K=10.0, rate=(5.0, 5.0), Gamma0=0.0)
    TSMC(NOMINAL, C=2.5, D=np.diag([0.4, 0.3]), Ts=0.005)
    for name in registry.names():
        assert registry.build(name, NOMINAL) is not None
    res = simulate(CTRL, REAL, duration=0.05, mode="sampled", integrator="rk4", compiled=False)
    assert res.status[0] == "ok"
