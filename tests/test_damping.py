"""The damping readings of the book's tables (SPEC.md section 2, issue 12).

The tables print Db, Dw in N s/m; (2.32) multiplies them with angular rates, so the default
("units") reading enters them as D r^2 with each set's own r. The literal reading is kept by
name for comparison.
"""

from __future__ import annotations

import json
from dataclasses import fields

import numpy as np
import pytest

from mwip.cli import main
from mwip.models.linear import linearize
from mwip.params import (
    BOOK_TABLES,
    NOMINAL,
    NOMINAL_LITERAL,
    REAL,
    REAL_LITERAL,
    book_params,
    load_params,
    save_params,
    steady_speed_cap,
)


def test_default_sets_use_the_units_reading():
    assert REAL.Db == pytest.approx(0.5 * 0.04**2, rel=1e-15)  # 8.0e-4 N m s/rad
    assert REAL.Dw == pytest.approx(0.8 * 0.04**2, rel=1e-15)  # 1.28e-3
    assert NOMINAL.Db == pytest.approx(0.4 * 0.03**2, rel=1e-15)  # 3.6e-4
    assert NOMINAL.Dw == pytest.approx(0.6 * 0.03**2, rel=1e-15)  # 5.4e-4
    assert (REAL_LITERAL.Db, REAL_LITERAL.Dw, NOMINAL_LITERAL.Db, NOMINAL_LITERAL.Dw) == (
        0.5,
        0.8,
        0.4,
        0.6,
    )
    # only the damping differs between the readings
    for f in fields(REAL):
        if f.name not in ("Db", "Dw"):
            assert getattr(REAL, f.name) == getattr(REAL_LITERAL, f.name)
            assert getattr(NOMINAL, f.name) == getattr(NOMINAL_LITERAL, f.name)


def test_book_params_rejects_unknown_names():
    with pytest.raises(ValueError, match="damping reading must be one of units, literal"):
        book_params("real", "hybrid-typo")
    with pytest.raises(ValueError, match="'real', 'nominal'"):
        book_params("heavy")
    assert BOOK_TABLES["real"]["Dw"] == 0.8  # the table as printed is not mutated


def test_steady_speed_cap_readings():
    # Gb / (2 Dw): above the book's 7 rad/s under the units reading, below 1 rad/s literally
    assert steady_speed_cap(REAL) > 7.0
    assert steady_speed_cap(NOMINAL) > 7.0
    assert steady_speed_cap(REAL_LITERAL) < 1.0
    assert steady_speed_cap(REAL_LITERAL) == pytest.approx(REAL.Gb / 1.6, rel=1e-15)


def test_steady_speed_cap_is_the_plants_steady_state():
    """Independent check of the cap formula: the linearised plant's steady rolling speed for
    a held lean theta_s satisfies Gb theta_s = 2 Dw psi' (first + second row of (2.32))."""
    from mwip.models.reduced import accelerations

    for p in (REAL, REAL_LITERAL):
        th = 0.01
        psid = p.Gb * np.sin(th) / (2 * p.Dw)
        # at (theta = th, theta' = 0, psi' = psid) with the wheel torque that holds theta'' = 0,
        # psi'' must be 0: solve for u_A from the pitch row and check the wheel row
        q = np.array([0.0, th, 0.0])
        qd = np.array([psid, 0.0, 0.0])
        ua = p.Gb * np.sin(th) + 2 * p.Db * psid  # second row of (2.32) at rest in theta
        acc = accelerations(p, q, qd, np.array([ua / 2, ua / 2]))
        assert np.allclose(acc, 0.0, atol=1e-9 * max(1.0, psid))


def test_linearisation_eigenvalues_units_reading():
    # SPEC.md section 2: about -24, -4.9, -0.85, 0, +20.1 rad/s for the real parameters
    A, _ = linearize(REAL)
    eig = np.sort(np.linalg.eigvals(A).real)
    assert np.allclose(eig, [-24.12, -4.909, -0.8511, 0.0, 20.11], atol=0.01)
    # the literal reading is stiff: damping modes near -3000 rad/s, pitch mode near +2.4
    A, _ = linearize(REAL_LITERAL)
    eig = np.sort(np.linalg.eigvals(A).real)
    assert eig[0] < -1000 and 2.0 < eig[-1] < 3.0


def test_file_damping_is_rotational(tmp_path):
    """A user's file gives Db, Dw as the rotational coefficients: they round-trip unchanged
    (no second multiplication by r^2, the old `alt.*` defect) and the file says its units."""
    path = tmp_path / "robot.toml"
    save_params(REAL, path)
    text = path.read_text()
    assert "N m s/rad" in text
    back = load_params(path)
    assert (back.Db, back.Dw) == (REAL.Db, REAL.Dw)
    (tmp_path / "r.toml").write_text("base = 'real'\n[params]\nmb = 3.0\n")
    mine = load_params(tmp_path / "r.toml")
    assert (mine.Db, mine.Dw, mine.mb) == (REAL.Db, REAL.Dw, 3.0)


@pytest.mark.parametrize("reading, dw", [("units", 0.8 * 0.04**2), ("literal", 0.8)])
def test_cli_damping_option(reading, dw, capsys, tmp_path):
    assert main(["params", "show", "real", "--json", "--damping", reading]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["params"]["Dw"] == pytest.approx(dw, rel=1e-15)
    assert doc["units"]["Dw"] == "N m s/rad" and doc["damping"] == reading
    out = tmp_path / f"{reading}.toml"
    assert main(["params", "save", "nominal", str(out), "--damping", reading]) == 0
    assert load_params(out).Dw == pytest.approx(book_params("nominal", reading).Dw)


def test_cli_damping_bad_value(capsys):
    assert main(["params", "show", "real", "--damping", "hybrid"]) == 2
    err = capsys.readouterr().err
    assert "--damping" in err and "units" in err and "literal" in err


def test_simulate_damping_changes_the_plant(tmp_path):
    """`simulate --damping literal` runs the literal plant: the LQR's steady speed error
    differs (a direct physical difference, not a label)."""
    codes = {}
    for reading in ("units", "literal"):
        out = tmp_path / reading
        codes[reading] = main(
            ["simulate", "--theta0", "0.05", "--duration", "2", "--damping", reading,
             "--out", str(out), "--json"]
        )  # fmt: skip
    assert codes == {"units": 0, "literal": 0}
    a = np.load(tmp_path / "units" / "timeseries.npz")
    b = np.load(tmp_path / "literal" / "timeseries.npz")
    assert a["states"].shape == b["states"].shape
    assert not np.allclose(a["states"], b["states"])
