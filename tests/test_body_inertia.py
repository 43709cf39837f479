"""The body's three inertias (Iby pitch, Ibz roll, Iyaw yaw, about the centre of mass) against
references independent of :class:`mwip.params.Params`' derived coefficients.

(a) The mass matrix of (2.32) (``mwip.models.reduced.mass_matrix``) against the kinetic energy
    of the robot computed here from 3-D rigid-body kinematics: the body rotated by yaw then
    pitch with the inertia tensor ``diag(Ibz, Iby, Iyaw)`` about its centre of mass at ``l``
    along its own axis above the axle, and two wheels (mass ``mw`` at ``+-b`` on the axle, spin
    inertia ``Iwa``, diameter inertia ``Iwd``) whose spin follows from rolling without slip.
    ``M`` is read off ``T`` by polarisation at random pitches.
(b) Energy conservation of the plant (``reduced.accelerations``, no damping, no input) measured
    with the energy of (a), not the plant's own ``1/2 q'^T M q'``.
(c) MuJoCo (optional; skipped when absent): its rigid-body mass matrix and bias forces of the
    same robot, the rolling constraint applied by projection on its null space as (2.31) does.
    MuJoCo's own rolling contact is soft (a penetration-based model), so it would not give
    exact accelerations; the projection does.

Each check is shown to fail for a wrong placement of ``Iyaw`` (``test_checks_catch_mutants``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mwip.models import reduced, spatial
from mwip.params import REAL, Params, load_params, save_params, stack_params

# ---- an independent reference: kinetic energy from 3-D kinematics ---------------------------
EX, EY, EZ = np.eye(3)


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _drz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]])


def _ry(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _dry(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[-s, 0.0, c], [0.0, 0.0, 0.0], [-c, 0.0, -s]])


def kinetic_energy(p: Params, q: np.ndarray, qd: np.ndarray) -> float:
    """``T`` of the robot at ``q = [psi, theta, alpha]``, ``q' = [psi', theta', alpha']`` from
    the fields ``mb, mw, Iby, Ibz, Iyaw, Iwa, Iwd, l, b, r`` only (no derived coefficient).

    World axes: x forward at zero yaw, y to the left, z up. Body: ``R = Rz(alpha) Ry(theta)``
    (yaw, then pitch about the axle; positive pitch leans the body's axis forward), centre of
    mass at ``l R e_z`` above the axle's midpoint, principal inertias ``Ibz`` (body x, roll),
    ``Iby`` (body y, pitch), ``Iyaw`` (body z, its own axis). The axle's midpoint moves at
    ``r psi'`` along the heading ``Rz(alpha) e_x`` (``psi`` the mean wheel angle)."""
    _, th, al = (float(x) for x in q)
    psid, thd, ald = (float(x) for x in qd)
    R = _rz(al) @ _ry(th)
    Rdot = _drz(al) @ _ry(th) * ald + _rz(al) @ _dry(th) * thd
    heading = _rz(al) @ EX
    v_axle = p.r * psid * heading
    # body: angular velocity in body axes from R^T R' (skew), centre of mass velocity
    W = R.T @ Rdot
    assert np.allclose(W, -W.T, atol=1e-12)
    w_body = np.array([W[2, 1], W[0, 2], W[1, 0]])
    v_cm = v_axle + p.l * Rdot @ EZ
    T = 0.5 * p.mb * v_cm @ v_cm + 0.5 * w_body @ np.diag([p.Ibz, p.Iby, p.Iyaw]) @ w_body
    # wheels: centres at +-b along the axle (left +), spin from rolling without slip
    axle = _rz(al) @ EY
    axle_dot = _drz(al) @ EY * ald
    for side in (1.0, -1.0):
        v_c = v_axle + side * p.b * axle_dot
        # contact point at -r e_z: v_c + (phi axle + alpha' e_z) x (-r e_z) = 0, and
        # axle x e_z = heading, so v_c = r phi heading
        phi = v_c @ heading / p.r
        assert abs(v_c @ axle) < 1e-12  # no side slip: the wheel centre moves along heading
        w = phi * axle + ald * EZ
        inertia = p.Iwa * np.outer(axle, axle) + p.Iwd * (np.eye(3) - np.outer(axle, axle))
        T += 0.5 * p.mw * v_c @ v_c + 0.5 * w @ inertia @ w
    return float(T)


def reference_mass_matrix(p: Params, q: np.ndarray) -> np.ndarray:
    """``M(q)`` by polarisation of :func:`kinetic_energy`: ``M_ii = 2 T(e_i)``,
    ``M_ij = T(e_i + e_j) - T(e_i) - T(e_j)``."""
    e = np.eye(3)
    t1 = [kinetic_energy(p, q, e[i]) for i in range(3)]
    M = np.diag(2.0 * np.array(t1))
    for i in range(3):
        for j in range(i + 1, 3):
            M[i, j] = M[j, i] = kinetic_energy(p, q, e[i] + e[j]) - t1[i] - t1[j]
    return M


def reference_energy(p: Params, q: np.ndarray, qd: np.ndarray) -> float:
    """``T`` of :func:`kinetic_energy` plus the body's potential ``mb g l cos theta``."""
    return kinetic_energy(p, q, qd) + p.mb * p.g * p.l * np.cos(q[1])


def general_body(rng: np.random.Generator | None = None) -> Params:
    """A robot whose body has three different principal inertias (they satisfy the triangle
    inequalities of a real body, for MuJoCo) and no damping; every field scaled at random."""
    rng = np.random.default_rng(7) if rng is None else rng
    names = ("mb", "mw", "Iwa", "Iwd", "l", "b", "r")
    p = replace(REAL, Db=0.0, Dw=0.0,
                **{k: float(getattr(REAL, k)) * rng.uniform(0.7, 1.3) for k in names})  # fmt: skip
    return replace(p, Iby=1.8e-3 * rng.uniform(0.9, 1.1), Ibz=2.4e-3 * rng.uniform(0.9, 1.1),
                   Iyaw=1.1e-3 * rng.uniform(0.9, 1.1))  # fmt: skip


# ---- the three checks, as functions (the mutants below run them too) ------------------------
MASS_TOL = 1e-12  # relative to the largest entry: round-off of the polarisation


def mass_matrix_error(p: Params, n: int = 24, seed: int = 3) -> float:
    """Largest ``|M_(2.32) - M_ref|`` over random pitches (and random yaw, wheel angle),
    relative to the largest entry."""
    rng = np.random.default_rng(seed)
    err = 0.0
    for _ in range(n):
        q = np.array([rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.uniform(-3, 3)])
        M_ref = reference_mass_matrix(p, q)
        M = reduced.mass_matrix(p, q)
        err = max(err, float(np.abs(M - M_ref).max() / np.abs(M_ref).max()))
    return err


ENERGY_TOL = 1e-9  # DOP853 at rtol = atol = 1e-12 over 4 s


def energy_drift(p: Params, duration: float = 4.0) -> float:
    """``max |E(t) - E(0)| / max(T)`` of the plant without damping and input, ``E`` from the
    independent :func:`reference_energy`. The body starts 0.4 rad from upright, turning at
    2 rad/s, and falls through the horizontal: ``sin^2 theta`` sweeps [0, 1]."""
    assert p.Db == 0.0 and p.Dw == 0.0
    zero_u = np.zeros(2)

    def f(_t: float, s: np.ndarray) -> np.ndarray:
        return np.r_[s[3:], reduced.accelerations(p, s[:3], s[3:], zero_u)]

    s0 = np.array([0.0, 0.4, 0.0, 1.0, 0.5, 2.0])
    sol = solve_ivp(f, (0.0, duration), s0, method="DOP853", rtol=1e-12, atol=1e-12,
                    dense_output=True)  # fmt: skip
    s = sol.sol(np.linspace(0.0, duration, 201)).T
    assert np.ptp(np.sin(s[:, 1]) ** 2) > 0.9  # the pitch sweeps the yaw coefficient
    E = np.array([reference_energy(p, x[:3], x[3:]) for x in s])
    T = np.array([kinetic_energy(p, x[:3], x[3:]) for x in s])
    return float(np.abs(E - E[0]).max() / T.max())


# ---- (a) mass matrix -------------------------------------------------------------------------
def test_mass_matrix_equals_rigid_body_kinetic_energy() -> None:
    for seed in range(3):
        p = general_body(np.random.default_rng(seed))
        assert p.Iyaw > 0 and abs(p.Ibz - p.Iby) > 1e-4
        assert mass_matrix_error(p) < MASS_TOL
    # and the book's robot (Iyaw = 0) with its damping, which does not enter M
    assert mass_matrix_error(REAL) < MASS_TOL


def test_reference_energy_is_quadratic_in_the_rates() -> None:
    """The polarisation assumes ``T = 1/2 q'^T M q'``: check it at random rates."""
    rng = np.random.default_rng(11)
    p = general_body()
    for _ in range(10):
        q, qd = rng.uniform(-1.5, 1.5, 3), rng.uniform(-3, 3, 3)
        M = reference_mass_matrix(p, q)
        assert kinetic_energy(p, q, qd) == pytest.approx(0.5 * qd @ M @ qd, rel=1e-12)


# ---- (b) energy --------------------------------------------------------------------------------
def test_plant_conserves_the_independent_energy() -> None:
    assert energy_drift(general_body()) < ENERGY_TOL


# ---- (c) MuJoCo ------------------------------------------------------------------------------
def _mujoco_model(p: Params) -> str:
    """The robot as a MuJoCo tree (no geoms, no contacts): a base on slide x, slide y and a yaw
    hinge at the axle's midpoint; the body on a pitch hinge with its inertial at ``l``; two
    wheels on spin hinges at ``+-b``. The base carries 1e-9 kg (MuJoCo refuses a massless moving
    body): the comparison's floor, ~1e-9 relative."""
    wheel = f'mass="{p.mw!r}" diaginertia="{p.Iwd!r} {p.Iwa!r} {p.Iwd!r}"'
    return f"""
<mujoco>
  <option gravity="0 0 {-p.g!r}"/>
  <compiler inertiafromgeom="false" boundmass="0" boundinertia="0"/>
  <worldbody>
    <body name="base" pos="0 0 {p.r!r}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="alpha" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="1e-9" diaginertia="1e-12 1e-12 1e-12"/>
      <body name="body">
        <joint name="theta" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 {p.l!r}" mass="{p.mb!r}"
                  diaginertia="{p.Ibz!r} {p.Iby!r} {p.Iyaw!r}"/>
      </body>
      <body name="wheel_l" pos="0 {p.b!r} 0">
        <joint name="phi_l" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" {wheel}/>
      </body>
      <body name="wheel_r" pos="0 {-p.b!r} 0">
        <joint name="phi_r" type="hinge" axis="0 1 0"/>
        <inertial pos="0 0 0" {wheel}/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def mujoco_accelerations(mujoco: Any, p: Params) -> Callable[..., np.ndarray]:
    """``(q, q', u) -> q''`` from MuJoCo's mass matrix and bias forces, projected with the
    rolling constraint: joints ``[x, y, alpha, theta, phi_l, phi_r]`` move as ``S q'`` with
    ``x' = r psi' cos alpha``, ``y' = r psi' sin alpha``, ``phi = psi' -+ (b/r) alpha'``; then
    ``S^T M (S q'' + S' q') = S^T (tau - bias)`` (as (2.31))."""
    model = mujoco.MjModel.from_xml_string(_mujoco_model(p))
    data = mujoco.MjData(model)
    br = p.b / p.r

    def full_mass() -> np.ndarray:
        M = np.zeros((model.nv, model.nv))
        try:
            mujoco.mj_fullM(model, data, M)  # MuJoCo >= 3.4 / 4
        except TypeError:
            mujoco.mj_fullM(model, M, data.qM)  # older releases
        return M

    def acc(q: np.ndarray, qd: np.ndarray, u: np.ndarray) -> np.ndarray:
        psi, th, al = q
        psid, _, ald = qd
        S = np.zeros((6, 3))
        S[0, 0], S[1, 0] = p.r * np.cos(al), p.r * np.sin(al)
        S[2, 2] = S[3, 1] = 1.0
        S[4, 0], S[4, 2] = 1.0, -br
        S[5, 0], S[5, 2] = 1.0, br
        data.qpos[:] = [0.3, -0.2, al, th, psi - br * al, psi + br * al]
        data.qvel[:] = S @ qd
        mujoco.mj_forward(model, data)
        M, bias = full_mass(), data.qfrc_bias.copy()
        v = p.r * psid
        Sdot_qd = np.array([-v * ald * np.sin(al), v * ald * np.cos(al), 0.0, 0.0, 0.0, 0.0])
        ur, ul = u
        tau = np.array([0.0, 0.0, 0.0, -(ur + ul), ul, ur])  # motors between body and wheels
        return np.linalg.solve(S.T @ M @ S, S.T @ (tau - bias - M @ Sdot_qd))

    return acc


def mujoco_error(mujoco: Any, p: Params, n: int = 200, seed: int = 5) -> float:
    """Largest ``|q''_(2.32) - q''_MuJoCo|`` over ``n`` random states and torques, relative to
    ``max(1, |q''|)``."""
    rng = np.random.default_rng(seed)
    acc = mujoco_accelerations(mujoco, p)
    err = 0.0
    for _ in range(n):
        q = np.array([rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.uniform(-3, 3)])
        qd, u = rng.uniform(-3, 3, 3), rng.uniform(-1, 1, 2)
        a = reduced.accelerations(p, q, qd, u)
        err = max(err, float(np.abs(a - acc(q, qd, u)).max() / max(1.0, np.abs(a).max())))
    return err


MUJOCO_TOL = 1e-7  # the base's 1e-9 kg gives ~1e-9


def test_accelerations_equal_mujoco_rigid_body() -> None:
    mujoco = pytest.importorskip(
        "mujoco", reason="MuJoCo is not installed (optional: pip install mujoco); the "
        "independent references (a) and (b) above still run")  # fmt: skip
    for seed in range(2):
        assert mujoco_error(mujoco, general_body(np.random.default_rng(seed))) < MUJOCO_TOL


# ---- the checks fail for a wrong placement of Iyaw ------------------------------------------
def _ibl_plus(self: Params) -> Any:  # sign of Iyaw flipped in Ibl
    return self.Ibz + self.Iyaw + self.mb * self.l**2


def _m33_book(self: Params) -> Any:  # Iyaw left out of m33
    return 2.0 * self.Iwd + 2.0 * self.b**2 / self.r**2 * (self.Iwa + self.mw * self.r**2)


def _ibl_book(self: Params) -> Any:  # Iyaw left out of Ibl
    return self.Ibz + self.mb * self.l**2


def _m22_plus(self: Params) -> Any:  # Iyaw added to the pitch inertia
    return self.mb * self.l**2 + self.Iby + self.Iyaw


MUTANTS: dict[str, dict[str, Callable[[Params], Any]]] = {
    "Ibl with +Iyaw": {"Ibl": _ibl_plus},
    "m33 without Iyaw": {"m33": _m33_book},
    "Ibl without -Iyaw": {"Ibl": _ibl_book},
    "Iyaw ignored (the book's (2.32))": {"Ibl": _ibl_book, "m33": _m33_book},
    "Iyaw in m22 instead of m33": {"m22": _m22_plus, "m33": _m33_book, "Ibl": _ibl_book},
}


@pytest.mark.parametrize("name", list(MUTANTS))
def test_checks_catch_mutants(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    p = general_body()
    for attr, fn in MUTANTS[name].items():
        monkeypatch.setattr(Params, attr, property(fn))
    assert mass_matrix_error(p) > 1e6 * MASS_TOL
    assert energy_drift(p) > 1e4 * ENERGY_TOL
    try:
        import mujoco
    except ImportError:
        return
    assert mujoco_error(mujoco, p, n=20) > 1e2 * MUJOCO_TOL


# ---- the spatial model (2.24)-(2.31) keeps the same yaw term ---------------------------------
def test_spatial_model_maps_iyaw_to_izz() -> None:
    p = general_body()
    sp = spatial.SpatialParams.from_params(p)
    assert (sp.Ixx, sp.Iyy, sp.Izz) == (p.Ibz, p.Iby, p.Iyaw)
    assert spatial.SpatialParams.from_params(p, Izz=0.0).Izz == 0.0


# ---- Params: fields, validation, files ------------------------------------------------------
def test_iyaw_is_the_last_field_and_defaults_to_the_book() -> None:
    assert REAL.Iyaw == 0.0
    book = Params(2.58, 0.14, 1.77e-3, 1.77e-3, 1.4e-4, 8.4e-4, 0.0622, 0.15, 0.04, 8e-4,
                  1.28e-3, 9.81)  # positional, the book's twelve symbols  # fmt: skip
    assert book == REAL
    p = replace(REAL, Iyaw=1e-3)
    assert p.Ibl == pytest.approx(REAL.Ibl - 1e-3, rel=1e-14)
    assert p.m33 == pytest.approx(REAL.m33 + 1e-3, rel=1e-14)
    # the yaw inertia upright is m33, lying flat m33 + Ibl: Iyaw moves the first only
    assert p.m33 + p.Ibl == pytest.approx(REAL.m33 + REAL.Ibl, rel=1e-14)


def test_iyaw_validation() -> None:
    with pytest.raises(ValueError, match=r"'Iyaw' must be finite and in \[0, inf\)"):
        replace(REAL, Iyaw=-1e-3)
    with pytest.raises(ValueError, match="'Iyaw' must be in"):
        replace(REAL, Iyaw=1e-300)
    # a flat, wide body (a horizontal plate: Iyaw = Ibz + Iby): Ibl < 0 is allowed, the yaw
    # inertia stays positive at every pitch
    flat = replace(REAL, Ibz=0.025, Iby=0.025, Iyaw=0.05, l=0.01)
    assert flat.Ibl < 0 and flat.m33 + flat.Ibl > 0


def test_yaw_inertia_guard(monkeypatch: pytest.MonkeyPatch) -> None:
    """The guard ``m33 + min(Ibl, 0) > 0`` (unreachable with fields in range, since
    ``m33 + Ibl = 2 Iwd + wheels + Ibz + mb l^2``) fires with one line naming the fields."""
    monkeypatch.setattr(Params, "m33", property(lambda self: 1e-6))
    with pytest.raises(ValueError, match=r"yaw inertia m33 \+ min\(Ibl, 0\).*Iyaw"):
        replace(REAL, Ibz=1e-4, Iyaw=0.05, l=0.01)


def test_iyaw_in_files_batches_and_indexing(tmp_path: Any) -> None:
    path = tmp_path / "robot.toml"
    p = replace(REAL, Iyaw=1.2e-3)
    save_params(p, path)
    assert "Iyaw = 0.0012" in path.read_text() and load_params(path) == p
    # a file written before Iyaw existed (and without g) loads with Iyaw = 0
    old = {k: v for k, v in REAL.to_dict().items() if k not in ("Iyaw", "g")}
    path.write_text("[params]\n" + "".join(f"{k} = {v!r}\n" for k, v in old.items()))
    assert load_params(path) == REAL
    assert load_params(path, base=p).Iyaw == pytest.approx(1.2e-3)
    batch = stack_params([REAL, p])
    np.testing.assert_allclose(batch.Iyaw, [0.0, 1.2e-3])
    np.testing.assert_allclose(batch.m33, [REAL.m33, p.m33])
    assert batch[1] == p
    np.testing.assert_allclose(reduced.coefficients(batch)[:, 3], [REAL.m33, p.m33])


def test_params_show_names_iyaw(capsys: pytest.CaptureFixture[str]) -> None:
    from mwip.cli import main

    assert main(["params", "show", "real"]) == 0
    out = capsys.readouterr().out
    assert any(line.split()[:4] == ["Iyaw", "=", "0", "kg"] for line in out.splitlines())
    assert "the book's (2.32) is the case Iyaw = 0" in out
    assert main(["params", "show", "real", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["params"]["Iyaw"] == 0.0 and doc["units"]["Iyaw"] == "kg m^2"
