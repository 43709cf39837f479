from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from mwip.params import (
    NOMINAL,
    NOMINAL_LITERAL,
    REAL,
    REAL_LITERAL,
    Params,
    load_params,
    save_params,
    stack_params,
)


def test_tables():
    # Table 3.1 / 6.1 and Table 3.2 / 6.2, damping as printed (the literal reading)
    assert (REAL.mb, REAL.mw, REAL.l, REAL.b, REAL.r, REAL_LITERAL.Db, REAL_LITERAL.Dw) == (
        2.58,
        0.14,
        0.0622,
        0.15,
        0.04,
        0.5,
        0.8,
    )
    assert (REAL.Iby, REAL.Ibz, REAL.Iwa, REAL.Iwd) == (1.77e-3, 1.77e-3, 1.4e-4, 8.4e-4)
    assert (NOMINAL.mb, NOMINAL.mw, NOMINAL.l, NOMINAL.b, NOMINAL.r) + (
        NOMINAL_LITERAL.Db,
        NOMINAL_LITERAL.Dw,
    ) == (
        2.50,
        0.12,
        0.0582,
        0.14,
        0.03,
        0.4,
        0.6,
    )
    assert (NOMINAL.Iby, NOMINAL.Ibz, NOMINAL.Iwa, NOMINAL.Iwd) == (
        1.57e-3,
        1.57e-3,
        1.2e-4,
        8.1e-4,
    )
    assert REAL.g == NOMINAL.g == 9.81


def test_derived_coefficients_by_hand():
    p = REAL
    assert p.m11 == pytest.approx((2.58 + 0.28) * 0.04**2 + 2 * 1.4e-4, rel=1e-14)
    assert p.m12 == pytest.approx(2.58 * 0.0622 * 0.04, rel=1e-14)
    assert p.m22 == pytest.approx(2.58 * 0.0622**2 + 1.77e-3, rel=1e-14)
    assert p.Ibl == pytest.approx(1.77e-3 + 2.58 * 0.0622**2, rel=1e-14)
    assert p.Gb == pytest.approx(2.58 * 9.81 * 0.0622, rel=1e-14)
    assert p.m33 == pytest.approx(2 * 8.4e-4 + 2 * 0.15**2 / 0.04**2 * (1.4e-4 + 0.14 * 0.04**2))


@pytest.mark.parametrize(
    ("field", "value", "allowed"),
    [
        ("mb", -1.0, "(0, inf)"),
        ("r", 0.0, "(0, inf)"),
        ("Db", -0.1, "[0, inf)"),
        ("l", math.nan, "(0, inf)"),
        ("Iby", math.inf, "(0, inf)"),
        ("mw", "heavy", "(0, inf)"),
    ],
)
def test_invalid_values_name_field_and_range(field, value, allowed):
    with pytest.raises(ValueError) as exc:
        replace(REAL, **{field: value})
    msg = str(exc.value)
    assert repr(field) in msg and allowed in msg and "\n" not in msg


def test_zero_damping_allowed():
    p = replace(REAL, Db=0.0, Dw=0.0)
    assert p.Db == 0.0


def test_toml_round_trip(tmp_path):
    path = tmp_path / "robot.toml"
    save_params(NOMINAL, path)
    assert load_params(path) == NOMINAL
    # partial file over a base
    path.write_text("[params]\nmb = 3.0\n")
    assert load_params(path, base=REAL) == replace(REAL, mb=3.0)
    path.write_text('base = "nominal"\n[params]\nl = 0.07\n')
    assert load_params(path) == replace(NOMINAL, l=0.07)


def test_toml_errors(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[params]\nmass = 3.0\n")
    with pytest.raises(ValueError, match="unknown parameter 'mass'"):
        load_params(path, base=REAL)
    path.write_text("[params]\nmb = 3.0\n")
    with pytest.raises(ValueError, match="is missing"):
        load_params(path)
    path.write_text("mb = = 3\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_params(path)
    path.write_text("[params]\nmb = -3.0\n")
    with pytest.raises(ValueError, match="'mb' must be finite and in"):
        load_params(path, base=REAL)


def test_with_payload_geometry():
    p = REAL.with_payload(mass=0.5, height=0.1, pan_radius=0.08)
    hp = 2 * REAL.l + 0.1
    assert p.mb == pytest.approx(3.08)
    l2 = (2.58 * 0.0622 + 0.5 * hp) / 3.08
    assert p.l == pytest.approx(l2)
    # inertia about the new centre of mass: parallel axis theorem, both parts
    iby = 1.77e-3 + 2.58 * (0.0622 - l2) ** 2 + 0.5 * (hp - l2) ** 2 + 0.5 * 0.08**2 / 4
    assert p.Iby == pytest.approx(iby)
    assert p.Gb > REAL.Gb and p.m22 > REAL.m22  # heavier, higher: harder to balance
    # a massless payload changes nothing
    assert REAL.with_payload(mass=0.0, pan_radius=0.0) == REAL
    with pytest.raises(ValueError, match="'mass'"):
        REAL.with_payload(mass=-1.0)


def test_batched_params():
    p = stack_params([REAL, NOMINAL, REAL.with_payload()])
    assert p.batch_shape == (3,)
    np.testing.assert_allclose(p.m11, [REAL.m11, NOMINAL.m11, REAL.with_payload().m11])
    assert p[1] == NOMINAL
    with pytest.raises(ValueError, match="'mb'"):
        Params(**{**REAL.to_dict(), "mb": np.array([1.0, -1.0])})
