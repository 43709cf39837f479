"""The twin's prior (mwip.hardware.prior) and batches of different twins (run_on_twin values=)."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.hardware.elements import ELEMENTS
from mwip.hardware.firmware import FirmwareSpec
from mwip.hardware.identified import default_twin
from mwip.hardware.motor import RE25, DriveSpec
from mwip.hardware.prior import PRIOR, Prior, Unknown
from mwip.hardware.twin import Twin, TwinActuator, run_on_twin
from mwip.params import REAL
from mwip.robot import Robot, default_robot, load_robot, robot_from_dict, robot_to_toml
from mwip.studies import exp_hodosmc
from mwip.studies.twin_settings import study_settings

DATA = Path(__file__).parent / "data"

NAMES = (
    "drive.gear_ratio", "firmware.emf_compensation", "drive.deadband", "drive.current_limit",
    "gearbox.coulomb", "gearbox.viscous", "gearbox.backlash", "firmware.delay",
    "imu.gyro_bias", "imu.accel_bias", "imu.accel_sigma", "imu.gyro_sigma", "imu.height",
    "firmware.fusion.tau", "payload.height", "payload.radius", "stick.height",
    "firmware.torque_gain",
)  # fmt: skip


def _cfg() -> dict:
    return dict(study_settings("exp-hodosmc-speed")[0])


def _smc(cfg: dict):  # type: ignore[no-untyped-def]
    return exp_hodosmc.make_controller("smc", cfg, cfg["speed"])


# --- the prior -------------------------------------------------------------------------------


def test_declared_prior_names_ranges_and_defaults() -> None:
    assert PRIOR.names == NAMES
    tw = Twin()
    vals = tw.values()
    for u in PRIOR:
        assert u.low <= u.default <= u.high, u.name
        assert vals[u.name] == u.default, u.name  # the default twin's value
        assert u.source
    assert PRIOR.bounds.shape == (len(NAMES), 2)
    assert PRIOR["drive.gear_ratio"].low == 3.7 and PRIOR["drive.gear_ratio"].high == 51.0
    # the firmware's torque gain: log-uniform over [0.25, 4], 1 (agreeing with the drive)
    tg = PRIOR["firmware.torque_gain"]
    assert (tg.low, tg.high, tg.scale, tg.default) == (0.25, 4.0, "log", 1.0)
    assert tw.prior == PRIOR


def test_prior_sample_centre_index_subset_dict() -> None:
    x = PRIOR.sample(np.random.default_rng(1), 100)
    b = PRIOR.bounds
    assert x.shape == (100, len(PRIOR)) and np.all(x >= b[:, 0]) and np.all(x <= b[:, 1])
    assert np.allclose(PRIOR.centre(), b.mean(axis=1))
    assert PRIOR.index("firmware.delay") == NAMES.index("firmware.delay")
    sub = PRIOR.subset(["firmware.delay", "drive.gear_ratio"])
    assert sub.names == ("firmware.delay", "drive.gear_ratio")
    assert Prior.from_dict(PRIOR.to_dict()) == PRIOR
    with pytest.raises(ValueError, match=r"twin.prior: unknown name 'nope'"):
        PRIOR.index("nope")
    fixed = Prior.from_dict({"firmware.delay": {"low": 0.3, "high": 0.3}})
    column = fixed.sample(np.random.default_rng(0), 5)[:, fixed.index("firmware.delay")]
    assert np.all(column == 0.3)
    # a name before the robot file (a [twin] file's) reads as its name now
    assert Prior.from_dict({"delay": {"low": 0.3, "high": 0.3}}) == fixed


def test_robot_file_round_trips_with_the_prior(tmp_path: Path) -> None:
    tw = Twin().with_values({"firmware.delay": 0.4, "drive.gear_ratio": 14.0,
                             "stick.height": 0.015})  # fmt: skip
    narrowed = Prior.from_dict({"drive.gear_ratio": {"low": 10.0, "high": 20.0}})
    tw = replace(tw, prior=narrowed)
    text = robot_to_toml(Robot(twin=tw))
    assert "[prior]" in text and '"drive.gear_ratio" = { low = 10.0, high = 20.0' in text
    path = tmp_path / "t.toml"
    path.write_text(text)
    back = load_robot(path).twin
    assert back == tw and back.prior == narrowed and back.drive.gear_ratio == 14.0
    # the default robot (its twin the identified one) and the data-sheet twin round-trip
    assert load_robot_text(robot_to_toml(default_robot())) == default_robot()
    assert load_robot_text(robot_to_toml(default_robot())).twin == default_twin()
    assert load_robot_text(robot_to_toml(Robot(twin=Twin()))).twin == Twin()


def load_robot_text(text: str) -> Robot:
    return robot_from_dict(tomllib.loads(text))


@pytest.mark.parametrize(
    ("prior", "match"),
    [
        # the robot file's [prior] table (a legacy name, 'delay', reads as firmware.delay)
        ({"delay": {"low": 0.5, "high": 0.1}},
         r"^prior.firmware.delay: low \(0.5\) must be <= high"),
        ({"drive.nope": {"low": 0, "high": 1}}, r"^prior.drive.nope: unknown name"),
        ({"firmware.delay": {"low": 0.5, "high": 0.9}},
         r"^firmware.delay = 0.2 is outside its prior \[0.5, 0.9\]"),
        ({"delay": {"low": 0.0, "high": 1.0, "wide": 2}},
         r"^prior.firmware.delay: unknown key 'wide'"),
        ({"delay": {"low": "a", "high": 1.0}}, r"^prior.firmware.delay: 'low' must be a number"),
    ],
)  # fmt: skip
def test_bad_prior_entries_are_one_line_errors(prior: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match) as exc:  # the data-sheet twin: delay 0.2
        robot_from_dict({"prior": prior}, base=Robot(twin=Twin()))
    assert "\n" not in str(exc.value)


def test_emf_feedforward_alias_and_half_compensation() -> None:
    # a legacy twin file's drive.emf_feedforward: the firmware's full back-EMF compensation
    r = robot_from_dict({"twin": {"drive": {"emf_feedforward": True}}}, base=Robot(twin=Twin()))
    tw = r.twin
    assert tw.firmware.emf_compensation == 1.0 and tw.drive == DriveSpec()
    assert tw.firmware == FirmwareSpec(emf_compensation=1.0)
    assert "emf_feedforward" not in robot_to_toml(r)
    assert "emf_compensation = 1.0" in robot_to_toml(r)
    # the compiled drive's voltage: c = 0.5 adds half the back-EMF of c = 1, and a
    # current-mode driver compensates fully
    state = np.zeros((1, 8))
    state[0, 3] = 5.0  # psi' (relative wheel speed 5 rad/s)
    u = np.array([[0.05, 0.05]])
    volts = {}
    for c in (0.0, 0.5, 1.0, "torque"):
        drive = DriveSpec(pwm_levels=0, deadband=0.0, current_limit=100.0,
                          mode="torque" if c == "torque" else "voltage")  # fmt: skip
        fw = FirmwareSpec(emf_compensation=0.0 if c == "torque" else c)
        act = TwinActuator(REAL, Twin(drive=drive, firmware=fw, elements={"motor"}))
        act.reset(1)
        act(0.0, u, state)
        volts[c] = act.last["drive_voltage"][0, 0]
    assert volts[0.5] - volts[0.0] == pytest.approx(0.5 * (volts[1.0] - volts[0.0]), rel=1e-12)
    assert volts[1.0] - volts[0.0] == pytest.approx(
        DriveSpec().gear_ratio * 5.0 * RE25.k_e, rel=1e-12
    )
    assert volts["torque"] == volts[1.0]


def test_with_values_errors() -> None:
    tw = Twin()
    with pytest.raises(ValueError, match=r"^with_values: unknown name 'drive.nope'") as e1:
        tw.with_values({"drive.nope": 1.0})
    # a legacy name ('delay') is read as its name now
    with pytest.raises(ValueError, match=r"^with_values: 'firmware.delay' = 1.5 is outside") as e2:
        tw.with_values({"delay": 1.5})
    assert "\n" not in str(e1.value) + str(e2.value)
    t2 = tw.with_values({"drive.gear_ratio": 33.0, "imu.height": 0.05})
    assert t2.drive.gear_ratio == 33.0 and t2.imu.height == 0.05
    assert t2.values()["firmware.delay"] == 0.2
    with pytest.raises(ValueError, match=r"values\['delay'\]\[1\] = 2.0 is outside"):
        run_on_twin(_smc(_cfg()), 1, twin=tw, values={"delay": [0.1, 2.0]}, duration=0.05)
    with pytest.raises(ValueError, match=r"values: unknown name 'x'"):
        run_on_twin(_smc(_cfg()), 1, twin=tw, values={"x": [0.1]}, duration=0.05)


# --- the default twin is unchanged -------------------------------------------------------------


def test_default_twin_runs_unchanged() -> None:
    """Against runs stored on the tree before the prior (tests/data/twin_default_ref.npz:
    SMC, the default twin, a feed-forward twin and a torque-mode twin with each element,
    Cases 1-3); bit-identical on the machine that stored them."""
    ref = np.load(DATA / "twin_default_ref.npz")
    cfg = _cfg()
    q0 = (0.0, cfg["theta0"], 0.0)

    def check(key: str, res: object) -> None:
        got = res.states[:, ::5]  # type: ignore[attr-defined]
        np.testing.assert_allclose(got, ref[key], rtol=0, atol=1e-9, err_msg=key)

    for case in (1, 2, 3):
        res = run_on_twin(_smc(cfg), case, twin=Twin(), duration=1.5, stick_start=0.5, seed=3)
        check(f"c{case}_x", res)
    res = run_on_twin(_smc(cfg), 1, twin=Twin(), duration=1.0, seed=1,
                      rows=[["motor", "delay"], ["fusion", "imu_noise", "encoder"],
                            list(Twin().active)])  # fmt: skip
    check("rows_x", res)
    rows = [[e] for e in ELEMENTS] + [[e for e in ELEMENTS if e != "motor"]]
    from mwip.hardware.drivetrain import GearboxSpec

    twins = {"ff": Twin(firmware=FirmwareSpec(emf_compensation=1.0),
                        drive=DriveSpec(deadband=0.0), gearbox=GearboxSpec(coulomb=0.0)),
             "tq": Twin(drive=DriveSpec(mode="torque"))}  # fmt: skip
    for name, tw in twins.items():
        for case in (1, 2, 3):
            res = run_on_twin(_smc(cfg), case, twin=tw, duration=1.5, stick_start=0.5, seed=3,
                              rows=rows, q0=q0)  # fmt: skip
            check(f"{name}{case}", res)
            np.testing.assert_array_equal(res.t_end, ref[f"{name}{case}_t"])


# --- a batch of different twins ----------------------------------------------------------------


def _draws(n: int, seed: int = 7) -> dict[str, np.ndarray]:
    """``n`` prior draws; the first two made torque-ish (with :data:`NO_FUSION` they stand)."""
    vals = PRIOR.as_values(PRIOR.sample(np.random.default_rng(seed), n))
    for k, v in (
        ("firmware.emf_compensation", 1.0),
        ("drive.deadband", 0.0),
        ("drive.gear_ratio", 5.0),
        ("gearbox.viscous", 0.0),
        ("gearbox.coulomb", 0.0),
        ("firmware.delay", 0.2),
        ("drive.current_limit", 10.0),
        ("firmware.torque_gain", 1.0),
    ):
        vals[k][:2] = v  # fmt: skip
    return vals


def _assert_rows_equal(batch: object, singles: list, tol: float) -> None:
    for i, one in enumerate(singles):
        row = batch.plant(i)  # type: ignore[attr-defined]
        assert row.status[0] == one.status[0] and row.t_end[0] == one.t_end[0], i
        np.testing.assert_allclose(row.states, one.states, rtol=0, atol=tol, err_msg=str(i))
        np.testing.assert_allclose(row.inputs, one.inputs, rtol=0, atol=tol, err_msg=str(i))


#: Every element but the fusion (true theta, theta'): SMC stands on torque-ish twins.
NO_FUSION = [e for e in ELEMENTS if e not in ("fusion", "accel_motion", "imu_noise", "imu_bias")]

#: Rows of a batch equal the single runs to this (absolute; states in rad, rad/s, m): they are
#: bit-identical where measured (0.0); the margin is for SIMD paths of other machines.
TOL = 1e-10


@pytest.mark.parametrize("case", [1, 2, 3])
def test_batch_of_twins_equals_single_runs(case: int) -> None:
    cfg = _cfg()
    q0 = (0.0, cfg["theta0"], 0.0)
    vals = _draws(5)
    tw = Twin()
    kw = dict(duration=1.5, seed=4, q0=q0, stick_start=0.3)  # the stick: 0.3-0.5 s
    batch = run_on_twin(_smc(cfg), case, twin=tw, values=vals, **kw)  # type: ignore[arg-type]
    singles = [run_on_twin(_smc(cfg), case, twin=tw.with_values({k: v[i] for k, v in vals.items()}),
                           **kw)  # type: ignore[arg-type]
               for i in range(5)]  # fmt: skip
    _assert_rows_equal(batch, singles, TOL)
    # rows that stand longer: the torque-ish twins without the fusion (Case 1: they stand;
    # Cases 2 and 3: SMC falls with the pan even on the ideal robot, after the stick)
    rows = [NO_FUSION, NO_FUSION, ELEMENTS, ELEMENTS, NO_FUSION]
    batch = run_on_twin(_smc(cfg), case, twin=tw, values=vals, rows=rows, **kw)  # type: ignore[arg-type]
    if case == 1:
        assert batch.status[0] == "ok" and batch.status[1] == "ok"
    else:
        assert np.all(batch.t_end[:2] > 0.52)
    singles = [run_on_twin(_smc(cfg), case, **kw,  # type: ignore[arg-type]
                           twin=replace(tw.with_values({k: v[i] for k, v in vals.items()}),
                                        elements=frozenset(rows[i])))
               for i in range(5)]  # fmt: skip
    _assert_rows_equal(batch, singles, TOL)


def test_batch_of_twins_with_rows_and_asta() -> None:
    """``values`` with ``rows`` (row i both), and ASTA (exp_asta) as the controller."""
    from mwip.studies import exp_asta

    cfg = _cfg()
    q0 = (0.0, cfg["theta0"], 0.0)
    vals = {k: v[:3] for k, v in _draws(3, seed=11).items()}
    rows = [[e for e in ELEMENTS if e != "motor"], ["fusion", "imu_noise", "delay"], list(ELEMENTS)]
    tw = Twin()
    kw = dict(duration=1.0, seed=2, q0=q0)
    batch = run_on_twin(_smc(cfg), 2, twin=tw, values=vals, rows=rows, **kw)  # type: ignore[arg-type]
    singles = [run_on_twin(_smc(cfg), 2, **kw,  # type: ignore[arg-type]
                           twin=replace(tw.with_values({k: v[i] for k, v in vals.items()}),
                                        elements=frozenset(rows[i])))
               for i in range(3)]  # fmt: skip
    _assert_rows_equal(batch, singles, TOL)
    acfg = dict(study_settings("exp-asta")[0])
    batch = run_on_twin(exp_asta.make_controller("asta", acfg), 1, twin=tw, values=vals, **kw)  # type: ignore[arg-type]
    singles = [run_on_twin(exp_asta.make_controller("asta", acfg), 1, **kw,  # type: ignore[arg-type]
                           twin=tw.with_values({k: v[i] for k, v in vals.items()}))
               for i in range(3)]  # fmt: skip
    _assert_rows_equal(batch, singles, TOL)


def test_batch_stick_and_payload_conflicts() -> None:
    cfg = _cfg()
    from mwip.params import REAL

    with pytest.raises(ValueError, match=r"stick_height both given"):
        run_on_twin(_smc(cfg), 3, values={"stick.height": [0.01]}, stick_height=0.01,
                    duration=0.05)  # fmt: skip
    with pytest.raises(ValueError, match=r"pass base="):
        run_on_twin(_smc(cfg), 2, values={"payload.height": [0.09]}, plant=REAL, duration=0.05)
    with pytest.raises(ValueError, match=r"rows has 2 entries, values 1"):
        run_on_twin(_smc(cfg), 1, values={"delay": [0.1]}, rows=[[], []], duration=0.05)


def test_unknown_declaration_errors() -> None:
    with pytest.raises(ValueError, match=r"^twin.prior.x: low \(2\) must be <= high \(1\)"):
        Unknown("x", 2.0, 1.0, "", "s", "delay", 1.0)
