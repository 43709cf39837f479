"""Settings as data for the Chapter 5-6 studies (it2-balance, exp-hodosmc-*, exp-asta,
exp-it2): an override of one setting reaches the run (a metric or the recorded settings),
and bad overrides are one-line ``ValueError`` naming the key. Quick mode throughout."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from mwip.studies import run_study, settings

STUDIES = (
    "it2-balance",
    "exp-hodosmc-balance",
    "exp-hodosmc-speed",
    "exp-hodosmc-obstacle",
    "exp-asta",
    "exp-it2",
)
#: study -> a number-valued setting of it (for the wrong-type check)
NUMBER_KEY = {
    "it2-balance": "rho",
    "exp-hodosmc-balance": "phi",
    "exp-hodosmc-speed": "speed",
    "exp-hodosmc-obstacle": "stick_start",
    "exp-asta": "eps",
    "exp-it2": "exp2_p_d",
}


def _run(name: str, out: Path, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """The metrics document of a quick run of ``name`` with ``overrides`` of its settings."""
    return run_study(name, out, quick=True, overrides=overrides)


def _same(x: Any, y: Any) -> bool:
    if x is None or y is None:
        return x is y
    return bool(x == y or (math.isnan(x) and math.isnan(y)))


@pytest.mark.parametrize("name", STUDIES)
def test_packaged_defaults_are_scalars_or_flat_lists(name: str) -> None:
    cfg = settings.defaults(name)
    assert cfg
    for key, value in cfg.items():
        items = value if isinstance(value, list) else [value]
        assert all(isinstance(v, bool | int | float | str) for v in items), key


@pytest.mark.parametrize(
    ("name", "overrides", "metric", "recorded"),
    [
        # the robust PDC design changes with the input bound
        ("it2-balance", {"rho": 15.0}, "it2.G1.theta", ("rho", 15.0)),
        # a larger DO4SMC switching gain changes its torque
        ("exp-hodosmc-balance", {"do4smc_K": [8.0, 4.0]}, "do4smc.case1.u_tv",
         ("K", {"smc": [25.0, 21.0], "do1smc": [17.3, 14.0], "do4smc": [8.0, 4.0]})),
        # a larger super-twisting gain changes the ASTA torque
        ("exp-asta", {"K": [12.0, 10.0]}, "asta.case1.u_tv", ("K", [12.0, 10.0])),
    ],
)  # fmt: skip
def test_override_changes_a_metric(
    name: str, overrides: dict[str, Any], metric: str, recorded: tuple[str, Any], tmp_path: Path
) -> None:
    base = _run(name, tmp_path / "base")
    new = _run(name, tmp_path / "new", overrides)
    assert not _same(base["metrics"][metric], new["metrics"][metric])
    key, value = recorded
    assert new["settings"][key] == value and base["settings"][key] != value
    assert _run(name, tmp_path / "again")["settings"][key] != value  # no state is left behind


def test_override_recorded_hodosmc_speed_obstacle(tmp_path: Path) -> None:
    doc = _run("exp-hodosmc-speed", tmp_path, {"duration": 2.5, "speed": -5.0, "seed": 3})
    assert doc["settings"]["q1d_dot"] == -5.0 and doc["settings"]["seed"] == 3
    assert doc["settings"]["duration"] == 2.5 and doc["settings"]["window"] == [2.0, 2.5]
    assert all(r["t_end"] <= 2.5 + 1e-9 for r in doc["runs"].values())
    over = {"stick_start": 5.0, "stick_speed": -6.0, "lambdas": [3.0, 0.02, 0.1, 3.0]}
    s = _run("exp-hodosmc-obstacle", tmp_path, over)["settings"]
    assert s["stick"]["start"] == 5.0 and s["stick_speed"] == -6.0
    assert s["window"] == [2.0, 5.0] and s["lambdas"] == [3.0, 0.02, 0.1, 3.0]


def test_override_recorded_exp_it2(tmp_path: Path) -> None:
    over = {"duration": 1.0, "exp2_p_d": 0.5, "theta0": 0.3, "epsilon": 0.3}
    s = _run("exp-it2", tmp_path, over)["settings"]
    assert s["duration"] == 1.0 and s["x0"] == [0.3, 0.0, 0.0, 0.0] and s["epsilon"] == 0.3
    assert s["experiments"]["exp2"] == {"p_d": 0.5, "alpha_d": None}


@pytest.mark.parametrize("name", STUDIES)
def test_unknown_key_is_named(name: str) -> None:
    with pytest.raises(ValueError, match=r"\[settings\] no_such_key: unknown"):
        settings.validate(name, {"no_such_key": 1.0})


@pytest.mark.parametrize("name", STUDIES)
def test_wrong_type_is_named(name: str) -> None:
    key = NUMBER_KEY[name]
    with pytest.raises(ValueError, match=rf"\[settings\] {key} must be a number"):
        settings.validate(name, {key: "fast"})
    if "record_every" in settings.defaults(name):  # the twin studies
        with pytest.raises(ValueError, match=r"\[settings\] record_every must be an integer"):
            settings.validate(name, {"record_every": 2.5})


TWIN_STUDIES = STUDIES[1:]


#: the twin's numbers: they live in the robot file (mwip.robot), not here
TWIN_NUMBERS = {
    "Ts", "dt", "delay", "fusion_tau", "accel_sigma", "accel_bias", "gyro_sigma", "gyro_bias",
    "gyro_bias_walk", "imu_height", "encoder_cpr", "gear_ratio", "current_limit", "pwm_levels",
}  # fmt: skip


@pytest.mark.parametrize("name", TWIN_STUDIES)
def test_open_settings_load_and_leave_the_twin_to_the_twin_file(name: str) -> None:
    """Every ``[open]`` key of a Chapter 6 study loads (a key of ``[settings]``, a finite range
    holding the default, a reason), and no twin number is a study setting: one source, the
    robot file."""
    table = settings.open_settings(name)
    cfg = settings.defaults(name)
    assert not TWIN_NUMBERS & set(cfg)
    for key, entry in table.items():
        lo, hi = entry["range"]
        values = cfg[key] if isinstance(cfg[key], list) else [cfg[key]]
        assert all(lo <= v <= hi for v in values) and len(entry["why"]) > 20, key
    study_specific = {
        "exp-hodosmc-balance": {"do1_gain", "phi"},
        "exp-hodosmc-speed": {"do1_gain", "phi"},
        "exp-hodosmc-obstacle": {"do1_gain", "phi", "stick_height"},
        "exp-asta": {"Gamma0", "eps"},
        "exp-it2": {"epsilon", "rho", "uncertainty", "rms_start"},
    }[name]
    assert study_specific <= set(table)


def test_a_robot_file_value_reaches_the_run(tmp_path: Path) -> None:
    """A study file's ``[robot] file`` (a robot file: the twin file and the study file's
    ``[twin]`` tables are gone) reaches the twin the study runs on: the fusion constant
    changes the run and is recorded."""
    from mwip.hardware.identified import default_twin
    from mwip.studies.study_file import load_study_file

    (tmp_path / "my_robot.toml").write_text("[firmware]\ndelay = 0.4\n"
                                            "[firmware.fusion]\ntau = 0.2\n")  # fmt: skip
    study = tmp_path / "study.toml"
    study.write_text('[study]\nname = "exp-asta"\n[robot]\nfile = "my_robot.toml"\n')
    tw = load_study_file(study).twin
    assert tw.firmware.fusion.tau == 0.2 and tw.firmware.delay == 0.4
    assert tw.imu == default_twin().imu  # the rest: the default robot's
    base = _run("exp-asta", tmp_path / "base")
    new = run_study("exp-asta", tmp_path / "new", quick=True, twin=tw)
    # the base run: run_study's default, the default robot's twin (as `mwip run`)
    tau = default_twin().firmware.fusion.tau
    assert tau != 0.2
    assert "tau 0.2 s" in new["settings"]["twin"] and f"tau {tau:g} s" in base["settings"]["twin"]
    assert not _same(base["metrics"]["asmc.case1.u_tv"], new["metrics"]["asmc.case1.u_tv"])


def test_bad_robot_file_is_one_line_exit_2(tmp_path: Path) -> None:
    """``mwip run --robot FILE`` and a study file's ``[robot] file`` name the bad key; a
    study file's ``[twin]`` table (gone) is refused."""
    from click.testing import CliRunner

    from mwip.cli import cli
    from mwip.studies.study_file import load_study_file

    bad = tmp_path / "bad.toml"
    bad.write_text("[drive]\ngear = 3\n")
    res = CliRunner().invoke(cli, ["run", "exp-asta", "--quick", "--robot", str(bad),
                                   "--out", str(tmp_path / "o")])  # fmt: skip
    assert res.exit_code == 2 and "unknown key drive.gear" in res.output
    assert "Traceback" not in res.output
    (tmp_path / "late.toml").write_text("[firmware]\ndelay = 2.0\n")
    study = tmp_path / "study.toml"
    study.write_text('[study]\nname = "exp-asta"\n[robot]\nfile = "late.toml"\n')
    with pytest.raises(ValueError, match=r"firmware\.delay must be finite and in \[0, 1\]"):
        load_study_file(study)
    study.write_text('[study]\nname = "exp-asta"\n[twin]\ndelay = 2.0\n')
    with pytest.raises(ValueError, match=r"\[twin\] tables are gone"):
        load_study_file(study)
