"""The twin against physics: motor data through the gear, back-EMF, delay, accelerometer,
reflected inertia, friction, backlash; its configuration file and the ablation."""

from __future__ import annotations

import tomllib
import warnings
from dataclasses import replace

import numpy as np
import pytest

from mwip.hardware import Twin, imu, run_on_twin
from mwip.hardware.ablation import ablation_steps, rms_metrics, run_ablation
from mwip.hardware.bus import BUS
from mwip.hardware.drivetrain import GearboxSpec, derive_plant, relative_mobility
from mwip.hardware.element import PackContext
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.firmware import FirmwareSpec
from mwip.hardware.imu import ImuNoise
from mwip.hardware.motor import RE25, RPM, DriveSpec
from mwip.hardware.sensitivity import input_gains, payload_sensitivity, pitch_pole
from mwip.hardware.twin import TwinActuator
from mwip.laws.smc.controller import make_smc
from mwip.models.reduced import accelerations, mass_matrix
from mwip.params import REAL
from mwip.robot import RobotFileError, default_robot, load_robot, robot_from_dict, robot_to_toml
from mwip.robot.spec import Robot
from mwip.sim import simulate

TS = 0.005


def _drive(drive: DriveSpec, n: int = 1, elements: tuple[str, ...] = ("motor",),
           masks: np.ndarray | None = None) -> TwinActuator:  # fmt: skip
    """The twin's compiled drive chain (the firmware's torque-to-duty map, the driver and the
    motors) for ``drive`` and ``n`` robots, reset."""
    act = TwinActuator(REAL, Twin(drive=drive, elements=frozenset(elements)), masks=masks)
    act.reset(n)
    return act


def _wheel_run(drive: DriveSpec, u_cmd: float, load: float, n: int = 400) -> tuple:
    """One wheel behind the gearbox with only the rotor's inertia ``N^2 J`` (no load other
    than ``load`` N m): the actuator's held torque plus the plant's back-EMF damping
    ``c w`` (what the twin puts in ``Db``), integrated exactly over each sample."""
    act = _drive(drive)
    jw = drive.gear_ratio**2 * RE25.rotor_inertia
    c = drive.emf_damping(RE25) if drive.mode == "voltage" else 0.0
    w = 0.0
    torques = []
    for _ in range(n):
        state = np.zeros((1, 8))
        state[0, 3] = w
        u = act(0.0, np.array([[u_cmd, u_cmd]]), state)[0, 0] - load
        torques.append(act.last["drive_torque"][0, 0])
        if c > 0:  # J w' = u - c w over the sample, exactly
            w_inf = u / c
            w = w_inf + (w - w_inf) * np.exp(-c * TS / jw)
        else:
            w += TS * u / jw
    return w, np.array(torques)


def _bare_drive(**kw: object) -> DriveSpec:
    base = dict(deadband=0.0, pwm_levels=0, supply_resistance=0.0, current_limit=1e3)
    base.update(kw)
    return DriveSpec(**base)  # type: ignore[arg-type]


def test_locked_rotor_and_no_load_reproduce_re25_through_the_gear() -> None:
    drive = _bare_drive()
    n, eta = drive.gear_ratio, drive.gear_efficiency
    # locked rotor at full duty: wheel torque = N eta tau_stall (243 mN m, Table 2.1)
    act = _drive(drive)
    big = np.array([[100.0, 100.0]])
    act(0.0, big, np.zeros((1, 8)))
    act(TS, big, np.zeros((1, 8)))
    assert act.last["drive_torque"][0] == pytest.approx(n * eta * 0.243, rel=1e-9)
    # no load at full duty: wheel speed = no-load speed / N (9560 rpm, Table 2.1)
    w, torques = _wheel_run(drive, 100.0, 0.0)
    assert w == pytest.approx(9560 * RPM / n, rel=1e-6)
    assert torques[-1] == pytest.approx(0.0, abs=1e-6)  # held part + EMF in Db = the line


def test_back_emf_limits_the_top_wheel_speed_at_24v() -> None:
    drive = _bare_drive()
    w_top = RE25.rated_voltage / (RE25.k_e * drive.gear_ratio)
    assert w_top == pytest.approx(43.53, abs=0.01)
    # any torque command: the speed never passes the no-load speed; a load lowers it along
    # the speed-torque line w = (V - R tau / (eta N k_t)) / (k_e N)
    for load in (0.0, 0.5, 1.0):
        w, _ = _wheel_run(drive, 1e3, load)
        tau_m = load / (drive.gear_ratio * drive.gear_efficiency)
        expect = (24.0 - RE25.resistance * tau_m / RE25.k_t) / (RE25.k_e * drive.gear_ratio)
        assert w == pytest.approx(expect, rel=1e-6)
        assert w <= w_top + 1e-9
    # a current-mode driver holds the torque until the supply binds at the same top speed
    w, _ = _wheel_run(_bare_drive(mode="torque"), 1e3, 0.0, n=2000)
    assert w == pytest.approx(w_top, rel=2e-3)


class _Step:
    """Torque step of 0.05 N m per wheel at sample ``k0``."""

    Ts = TS
    static = True

    def __init__(self, k0: int) -> None:
        self.k0 = k0

    def reset(self, meas: object) -> None:
        pass

    def __call__(self, t: float, meas: object) -> np.ndarray:
        return np.full((1, 2), 0.05 if t >= self.k0 * TS - 1e-12 else 0.0)


def test_one_sample_delay_shifts_a_step_response_by_exactly_one_sample() -> None:
    kw = dict(q0=(0.0, 0.0, 0.0), duration=0.2, record_every=1)
    delayed = run_on_twin(_Step(10), 1, twin=Twin(elements={"delay"},
                                                  firmware=FirmwareSpec(delay=1.0)), **kw)
    ideal_late = run_on_twin(_Step(11), 1, twin=Twin.ideal(), **kw)
    ideal = run_on_twin(_Step(10), 1, twin=Twin.ideal(), **kw)
    assert np.array_equal(delayed.states, ideal_late.states)
    assert not np.array_equal(delayed.states, ideal.states)
    ua = delayed.series()["u_applied"]
    assert np.array_equal(ua[1:], ideal.series()["u_applied"][:-1])
    # a fraction d holds d u_{k-1} + (1 - d) u_k
    half = run_on_twin(_Step(10), 1, twin=Twin(elements={"delay"},
                                               firmware=FirmwareSpec(delay=0.5)), **kw)
    assert half.series()["u_applied"][10, 0] == pytest.approx(0.025)
    assert half.series()["u_applied"][11, 0] == pytest.approx(0.05)


def test_accelerometer_reads_gravity_plus_body_acceleration_in_its_frame() -> None:
    h, g = 0.1, 9.81
    t = np.linspace(0.0, 1.0, 20001)
    dt = t[1] - t[0]
    th = 0.3 * np.sin(2.0 * t)
    x = 0.4 * t**2 + 0.1 * np.sin(5.0 * t)
    # sensor point and its acceleration by finite differences (independent of the formula)
    px, pz = x + h * np.sin(th), h * np.cos(th)
    ax_w, az_w = np.gradient(np.gradient(px, dt), dt), np.gradient(np.gradient(pz, dt), dt)
    fx, fz = ax_w, az_w + g  # specific force = acceleration - gravity, gravity (0, -g)
    # body axes: y along the body (axle -> sensor), x across it, oriented so that a static
    # body reads (g sin theta, g cos theta) as (2.37)-(2.39) assume
    ex = (-np.cos(th), np.sin(th))
    ey = (np.sin(th), np.cos(th))
    want_x = fx * ex[0] + fz * ex[1]
    want_y = fx * ey[0] + fz * ey[1]
    tdot = np.gradient(th, dt)
    ax, ay, om = _imu_read(Twin(imu=ImuNoise.ideal(height=h)), th, tdot, np.gradient(tdot, dt),
                           np.gradient(np.gradient(x, dt), dt))  # fmt: skip
    inner = slice(10, -10)
    assert np.allclose(ax[inner], want_x[inner], atol=1e-4)
    assert np.allclose(ay[inner], want_y[inner], atol=1e-4)
    assert np.max(np.abs(want_x - g * np.sin(th))[inner]) > 0.5  # the motion is visible
    assert np.array_equal(om, tdot)
    # switched off, the accelerometer reads gravity only
    still = Twin(imu=ImuNoise.ideal(height=h), elements=set(ELEMENTS) - {"accel_motion"})
    ax0, ay0, _ = _imu_read(still, th, tdot, tdot, tdot)
    assert np.allclose(ax0, g * np.sin(th)) and np.allclose(ay0, g * np.cos(th))


def _imu_read(tw: Twin, th: np.ndarray, tdot: np.ndarray, tddot: np.ndarray,
              xddot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The compiled IMU kernel's ``(a_x, a_y, omega*)`` for the true motion: one sample each,
    its previous sample's velocities set so that the kernel's mean acceleration over the
    sample is ``theta''`` and ``x'' = r psi''``."""
    ctx = PackContext(twin=tw, plant=REAL, values=tw.values(), masks=tw.masks(), n=1)
    P, X = imu.ELEMENT.vectors(ctx)
    Ts = tw.Ts
    out = np.empty((3, th.size))
    bus, z, lg = np.zeros(BUS.size), np.zeros(imu.ELEMENT.noise), np.zeros(6)
    for i in range(th.size):
        yi = np.zeros(8)
        yi[1], yi[4] = th[i], tdot[i]
        s = X[0].copy()
        s[imu.S.prev + 3] = yi[3] - Ts * xddot[i] / REAL.r
        s[imu.S.prev + 4] = yi[4] - Ts * tddot[i]
        imu.step(1, P[0], s, bus, yi, z, lg)
        out[:, i] = lg[3], lg[4], lg[1]
    return out[0], out[1], out[2]


def test_reflected_rotor_inertia_matches_the_rotor_kinetic_energy() -> None:
    n, j = 23.0, RE25.rotor_inertia
    p = derive_plant(REAL, inertia=True, gear_ratio=n, rotor_inertia=j)
    rng = np.random.default_rng(3)
    for _ in range(5):
        qd = rng.normal(size=3)
        psi_d, th_d, al_d = qd
        br = REAL.b / REAL.r
        rotor = sum(0.5 * j * (n * (psi_d + s * br * al_d) - (n - 1) * th_d) ** 2
                    for s in (1.0, -1.0))  # fmt: skip
        q = np.array([0.0, 0.0, 0.0])  # upright: the constant coupling is exact here
        t_new = 0.5 * qd @ mass_matrix(p, q) @ qd
        t_old = 0.5 * qd @ mass_matrix(REAL, q) @ qd
        assert t_new - t_old == pytest.approx(rotor, rel=1e-10)
    assert p.Iwa - REAL.Iwa == pytest.approx(n * n * j)
    assert p.Gb == REAL.Gb and p.m12 < REAL.m12
    # the pitch input gain drops by the reflected inertia (the nominal design does not know)
    assert input_gains(p)[1] / input_gains(REAL)[1] == pytest.approx(0.329, abs=0.002)


def test_voltage_drive_puts_back_emf_into_db_and_torque_mode_does_not() -> None:
    tw = Twin()
    c = tw.drive.emf_damping(tw.motor)
    assert c == pytest.approx(0.75 * 23**2 * RE25.k_t * RE25.k_e / RE25.resistance)
    assert tw.plant(REAL).Db == pytest.approx(REAL.Db + c)
    tq = replace(tw, drive=replace(tw.drive, mode="torque"))
    assert tq.plant(REAL).Db == REAL.Db
    assert Twin.ideal().plant(REAL) is REAL


def test_coulomb_friction_slides_and_sticks(rng: np.random.Generator) -> None:
    p = derive_plant(REAL, inertia=True)
    m = relative_mobility(p)
    # the mobility is the relative wheel acceleration per unit torque on that wheel (2.32)
    qdd = accelerations(p, np.zeros(3), np.zeros(3), np.array([1.0, 0.0]))
    assert m == pytest.approx(qdd[0] - qdd[1] + (REAL.b / REAL.r) * qdd[2], rel=1e-10)
    fc = 0.034
    w = rng.normal(scale=0.3, size=(200, 2))
    drive = rng.normal(scale=0.1, size=(200, 2))
    # the compiled friction element, alone in the drive chain, on wheels at these speeds
    act = TwinActuator(p, Twin(gearbox=GearboxSpec(coulomb=fc), elements={"friction"}))
    act.reset(200)
    bor = REAL.b / REAL.r
    state = np.zeros((200, 8))
    state[:, 3] = (w[:, 0] + w[:, 1]) / 2.0
    state[:, 5] = (w[:, 0] - w[:, 1]) / (2.0 * bor)
    w = np.column_stack([state[:, 3] + bor * state[:, 5], state[:, 3] - bor * state[:, 5]])
    act(0.0, drive, state)
    f = act.last["drive_friction"]
    assert np.all(np.abs(f) <= fc + 1e-15)
    w_end = w + TS * m * (drive + f)  # the relative speed the sample would end with
    free = w + TS * m * drive
    stuck = np.isclose(w_end, 0.0, atol=1e-12)
    assert stuck.any() and (~stuck).any()
    # sliding: full friction against the motion, never reversing it
    assert np.allclose(np.abs(f[~stuck]), fc)
    assert np.all(np.sign(w_end[~stuck]) == np.sign(free[~stuck]))
    assert np.all(np.abs(w_end[~stuck]) < np.abs(free[~stuck]))
    g = GearboxSpec()
    i0 = (24.0 / RE25.resistance) * (1 - np.sqrt(RE25.max_efficiency)) ** 2
    assert g.coulomb == pytest.approx(23 * RE25.k_t * i0, rel=0.01)


def test_backlash_delays_a_torque_reversal_by_the_crossing_time() -> None:
    width, jm, tau = np.deg2rad(0.7), 23**2 * RE25.rotor_inertia, 0.1
    # the compiled backlash element alone in the drive chain (motor side N^2 J, N = 23)
    bl = TwinActuator(REAL, Twin(gearbox=GearboxSpec(backlash=width), elements={"backlash"}))
    bl.reset(1)
    y = np.zeros((1, 8))
    assert np.allclose(bl(0.0, np.full((1, 2), tau), y), tau)  # in contact: passes
    t_c = np.sqrt(2 * width * jm / tau)  # free motor side crosses the play from rest
    k = int(t_c // TS)
    out = [bl(0.0, np.full((1, 2), -tau), y)[0, 0] for _ in range(k + 3)]
    assert np.allclose(out[:k], 0.0)
    assert out[k] == pytest.approx(-tau * ((k + 1) * TS - t_c) / TS)
    assert np.allclose(out[k + 1 :], -tau)


def test_pitch_pole_and_payload_geometry() -> None:
    assert pitch_pole(REAL) == pytest.approx(20.1, abs=0.05)  # SPEC.md section 2
    rows = payload_sensitivity(masses=(0.5,), heights=(0.1,))
    hp = 2 * REAL.l + 0.1
    assert rows[0]["l"] == pytest.approx((REAL.mb * REAL.l + 0.5 * hp) / (REAL.mb + 0.5))
    poles = [r["pitch_pole"] for r in payload_sensitivity(heights=(0.1,))]
    assert all(a > b for a, b in zip(poles, poles[1:], strict=False))  # heavier: slower


def test_robot_file_round_trip_and_errors(tmp_path: object) -> None:
    # the twin is the robot file's hardware part (the twin file format is gone)
    tw = Twin(firmware=FirmwareSpec(delay=1.0), drive=DriveSpec(mode="torque"),
              elements={"motor", "delay"})  # fmt: skip
    robot = Robot(twin=tw)
    assert robot_from_dict(tomllib.loads(robot_to_toml(robot))) == robot
    assert robot_from_dict(tomllib.loads(robot_to_toml(default_robot()))) == default_robot()
    with pytest.raises(RobotFileError, match=r"unknown key drive\.gear;"):
        robot_from_dict({"drive": {"gear": 3}})
    with pytest.raises(RobotFileError, match="firmware.delay"):
        robot_from_dict({"firmware": {"delay": 2.0}})
    with pytest.raises(RobotFileError, match="unknown element 'wind'"):
        robot_from_dict({"robot": {"elements": ["wind"]}})
    m = robot_from_dict({"motor": {"torque_constant": 0.0234,
                                   "terminal_resistance": 2.32}}).twin.motor  # fmt: skip
    assert (m.k_t, m.k_e, m.resistance) == (0.0234, 0.0234, 2.32)  # catalogue values
    with pytest.raises(RobotFileError, match="terminal_resistance"):
        robot_from_dict({"motor": {"terminal_resistance": -1.0}})
    # the encoder is on the motor shaft: its wheel resolution follows the file's gear ratio;
    # a legacy [twin] table loads the same
    for i, text in enumerate(("[drive]\ngear_ratio = 11.0\n",
                              "[twin.drive]\ngear_ratio = 11.0\n")):  # fmt: skip
        f = tmp_path / f"t{i}.toml"  # type: ignore[operator]
        f.write_text(text)
        t11 = load_robot(f).twin
        assert t11.drive.gear_ratio == 11.0 and t11.values()["drive.gear_ratio"] == 11.0
        assert t11.encoder.resolution(11.0) == pytest.approx(2 * np.pi / (400 * 11.0))


def test_cli_robot_show_and_bad_file(tmp_path: object, capsys: pytest.CaptureFixture) -> None:
    from mwip.cli import main

    assert main(["robot", "show"]) == 0
    text = capsys.readouterr().out
    assert robot_from_dict(tomllib.loads(text)) == default_robot()
    assert "Table 2.1" in text
    f = tmp_path / "bad.toml"  # type: ignore[operator]
    f.write_text("[imu]\naccel_sigma = -1.0\n")
    assert main(["robot", "show", str(f)]) == 2
    err = capsys.readouterr().err
    assert "accel_sigma" in err and len(err.strip().splitlines()) == 1
    # `mwip twin show` is gone: one line pointing at `mwip robot show`
    assert main(["twin", "show"]) == 2
    err = capsys.readouterr().err
    assert "mwip robot show" in err and len(err.strip().splitlines()) == 1


def _smc() -> object:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return make_smc("do1smc", (3, 0.01, 0.1, 3), K=(17.3, 14.0), Ts=TS,
                        observer_gains=[50.0])  # fmt: skip


def test_ablation_keys_batched_equals_one_by_one_and_ideal_is_plain() -> None:
    order = ("inertia", "delay", "encoder", "imu_noise", "fusion")
    steps = ablation_steps(order)
    assert [s for s, _ in steps] == ["ideal", *order]
    assert steps[-1][1] == frozenset(order)
    kw = {"q0": (0.0, 0.1, 0.0), "duration": 0.6, "record_every": 2, "seed": 4}
    fn = rms_metrics((0.2, 0.6))
    claim = ("rms_theta below 0.1", lambda m: m["do1smc.case1.rms_theta"] < 0.1)
    a = run_ablation([("do1smc", _smc)], order=order, metrics=fn, run_kwargs=kw, claims=[claim])
    b = run_ablation([("do1smc", _smc)], order=order, metrics=fn, run_kwargs=kw,
                     batched=False)  # fmt: skip
    assert a.metrics.keys() == b.metrics.keys()
    assert "ablation.imu_noise.do1smc.case1.rms_theta_meas" in a.metrics
    for k, v in a.metrics.items():
        assert v == pytest.approx(b.metrics[k], rel=1e-9, abs=1e-12), k
    plain = simulate(_smc(), REAL, q0=kw["q0"], duration=0.6, Ts=TS, dt=0.0005, record_every=2)
    from mwip.metrics import rms

    assert a.metrics["ablation.ideal.do1smc.case1.rms_theta"] == pytest.approx(
        float(rms(plain.t, plain.theta, (0.2, 0.6))), rel=1e-12
    )
    # the elements change the numbers (a test that cannot fail would not)
    assert a.metrics["ablation.inertia.do1smc.case1.rms_theta"] != pytest.approx(
        a.metrics["ablation.ideal.do1smc.case1.rms_theta"], rel=1e-6
    )
    table = a.table("rms_theta")
    assert table.count("\n| ") == len(steps) + 1 and "+ imu_noise" in table
    assert "C1: rms_theta below 0.1" in table
    assert a.claims["ideal"] == [True]
    assert "<table>" in a.table("rms_theta", html=True)
    with pytest.raises(ValueError, match="unknown element"):
        ablation_steps(("inertia", "wind"))
    alone = dict(ablation_steps(cumulative=False))
    assert alone["pwm"] == {"motor", "pwm"} and alone["imu_bias"] == {"fusion", "imu_bias"}
    assert alone["delay"] == {"delay"} and len(alone) == len(ELEMENTS) + 1


def test_all_elements_registered_in_order() -> None:
    assert ELEMENTS[0] == "inertia" and ELEMENTS[-1] == "imu_bias" and len(set(ELEMENTS)) == 12
    assert Twin().active == frozenset(ELEMENTS)
    assert Twin.ideal().active == frozenset()


def test_closed_loop_sensitivities_equal_single_runs() -> None:
    from mwip.hardware.sensitivity import payload_closed_loop, stick_closed_loop
    from mwip.hardware.twin import stick_for

    tw = Twin(elements={"inertia", "encoder", "fusion", "imu_noise"})
    kw = {"q0": (0.0, 0.05, 0.0), "duration": 0.8, "seed": 2}
    rows = payload_closed_loop(_smc, (0.1, 0.5), twin=tw, window=(0.2, 0.8), **kw)
    for row in rows:
        one = run_on_twin(_smc(), 2, twin=tw, plant=REAL.with_payload(mass=row["mass"]), **kw)
        from mwip.metrics import rms

        assert row["rms_theta"] == pytest.approx(float(rms(one.t, one.theta, (0.2, 0.8))))
    assert rows[0]["rms_theta"] != pytest.approx(rows[1]["rms_theta"], rel=1e-3)
    kw2 = {"q0": (0.0, 0.0, 0.0), "duration": 0.8, "seed": 2}
    srows = stick_closed_loop(_smc, (0.005, 0.02), twin=tw, start=0.3, window=(0.2, 0.8), **kw2)
    p2 = REAL.with_payload()
    for row in srows:
        stick = replace(stick_for(p2, -7.0, 0.3), height=row["height"])
        one = run_on_twin(_smc(), 2, twin=tw, plant=p2, disturbance=stick, **kw2)
        assert row["rms_speed_err"] == pytest.approx(
            float(rms(one.t, one.q_dot[:, 0] + 7.0, (0.2, 0.8)))
        )
    assert srows[0]["rms_theta"] < srows[1]["rms_theta"]  # a higher stick disturbs more


def test_pwm_deadband_and_supply_sag() -> None:
    # the dead-band of the compiled driver: duty d -> sign(d) max(|d| - 0.01, 0)
    bare = DriveSpec(pwm_levels=0, deadband=0.01, supply_resistance=0.0, current_limit=10.0)
    act = _drive(bare, 4, ("motor", "pwm"))
    gain = bare.gear_ratio * bare.gear_efficiency * RE25.k_t
    duty = np.array([0.005, -0.005, 0.5, -0.5])
    cmd = np.column_stack([duty, duty]) * gain * bare.supply_voltage / RE25.resistance
    act(0.0, cmd, np.zeros((4, 8)))
    assert np.allclose(act.last["drive_duty"][:, 0], [0.0, 0.0, 0.49, -0.49])
    drive = DriveSpec(pwm_levels=0, deadband=0.0, supply_resistance=0.2, current_limit=3.0)
    act = _drive(drive, 2, ("motor", "pwm", "sag"))
    state = np.zeros((2, 8))
    cmd = np.array([[0.5, 0.5], [-0.2, 0.3]])
    act(0.0, cmd, state)
    i_bat = np.sum(act.last["drive_duty"] * act.last["drive_current"], axis=1)
    supply = act.last["drive_supply"][:, 0]
    assert np.allclose(supply, 24.0)  # no current drawn before the first sample
    act(TS, cmd, state)
    supply = act.last["drive_supply"][:, 0]
    assert np.allclose(supply, 24.0 - 0.2 * i_bat)
    assert np.all(supply < 24.0)
    # switched off per row, the supply stays stiff
    tw = Twin(drive=drive, elements={"motor", "pwm", "sag"})
    act2 = _drive(drive, 2, ("motor", "pwm", "sag"),
                  masks=tw.masks([["motor", "pwm", "sag"], ["motor", "pwm"]]))
    act2(0.0, cmd, state)
    act2(TS, cmd, state)
    supply = act2.last["drive_supply"][:, 0]
    assert supply[1] == 24.0 and supply[0] < 24.0
