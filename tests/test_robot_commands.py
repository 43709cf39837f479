"""Every command that runs a robot takes it (issue 35): a robot file that differs from the
default changes each command's result in the direction physics predicts, so no command can
silently fall back to the default robot.

The robots differ in one value each from a fixed base: for the torque gain, the book
calibration's earlier twin of record (``tests/data/record_robot.toml``: structure S0, the
firmware's torque gain 1), on which the physics below was checked, so that it does not move
with the default robot's calibration (every run passes ``--robot``: a command falling back
to the default would give both runs the same result); for the others the default
(:func:`mwip.robot.default_robot`):

- ``gain2``: ``firmware.torque_gain = 2`` (the drive delivers twice what the firmware
  commands), against ``base``'s 1. Physics: the torque reaching the wheels is about twice as
  large for the same command, so a run's peak *delivered* torque rises (the first commands,
  from the same initial pitch and the same measurement, are equal; the loop's later
  corrections are smaller, so the factor is below 2 but well above 1).
- ``wheel5``: the body's wheel radius 0.05 m (the default's 0.04 m), the design model
  unchanged. Physics: a speed controller regulates the wheels' rate through its design
  model's radius, so the robot's true forward speed ``r psi'`` grows with the body's radius
  (about 0.05 / 0.04 = 1.25 times).
- ``gear12``: ``drive.gear_ratio = 12`` (the default's 4.2). Physics: the largest wheel
  torque ``N eta k_t i_max`` grows in proportion to the gear ratio.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.robot import default_robot, load_robot, save_robot


@pytest.fixture(scope="module")
def robots(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("robots")
    r = default_robot()
    base = load_robot(Path(__file__).parent / "data" / "record_robot.toml")
    out = {
        "base": base,
        "gain2": base.with_values({"firmware.torque_gain": 2.0}),
        "wheel5": replace(r, body=replace(r.body, r=0.05)),
        "gear12": r.with_values({"drive.gear_ratio": 12.0}),
    }
    paths = {}
    for name, robot in out.items():
        paths[name] = save_robot(robot, d / f"{name}.toml")
        back = load_robot(paths[name])  # the file is the robot (its values; the provenance
        for part in ("body", "design", "twin"):  # says which were given in the file)
            assert getattr(back, part) == getattr(robot, part), (name, part)
    return paths


def _peak_delivered(npz: Path) -> float:
    return float(np.abs(np.load(npz)["log__u_applied"]).max())


def test_simulate(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip simulate --twin --robot`: the delivered torque is the firmware's command times
    its torque gain (the first sample after the delay, before any correction: ~2)."""
    peaks, ratios = [], []
    for name, extra in (("default", ["--robot", str(robots["base"])]),
                        ("gain2", ["--robot", str(robots["gain2"])])):  # fmt: skip
        out = tmp_path / name
        assert main(["simulate", "--twin", "--duration", "1", "--theta0", "0.05", "--out",
                     str(out), *extra]) == 0  # fmt: skip
        z = np.load(out / "timeseries.npz")
        u, applied = z["inputs"][0, :, 0], z["log__u_applied"][0, :, 0]
        big = np.abs(u) > 0.01  # commands well above the drive's dead-band and friction
        ratios.append(float(np.median(applied[big] / u[big])))
        peaks.append(_peak_delivered(out / "timeseries.npz"))
    assert 0.7 < ratios[0] < 1.3 and 1.5 < ratios[1] < 2.5, ratios
    assert peaks[1] > 1.3 * peaks[0], peaks


def _speed(npz: Path) -> float:
    """The robot's true forward speed ``r psi'`` over the run's second half (m/s)."""
    z = np.load(npz)
    s, r = z["states"][0], float(z["r"][0])
    return abs(r * float(s[s.shape[0] // 2:, 3].mean()))


def test_run(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip run --robot`: exp-hodosmc-speed's robot (its body's wheels, its design model's
    controller) runs faster with larger wheels."""
    speeds = []
    for name, extra in (("default", []), ("wheel5", ["--robot", str(robots["wheel5"])])):
        out = tmp_path / name
        assert main(["run", "exp-hodosmc-speed", "--quick", "--out", str(out), *extra]) == 0
        speeds.append(_speed(out / "exp-hodosmc-speed" / "do4smc.case1.npz"))
    assert 1.1 < speeds[1] / speeds[0] < 1.45, speeds


def test_reproduce(tmp_path: Path, robots: dict[str, Path],
                   monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    """`mwip reproduce --robot` (its studies cut to one, as the test's budget asks)."""
    import mwip.studies

    monkeypatch.setattr(mwip.studies, "study_names", lambda: ["exp-hodosmc-speed"])
    speeds = []
    for name, extra in (("default", ["--no-compare"]),
                        ("wheel5", ["--robot", str(robots["wheel5"])])):  # fmt: skip
        out = tmp_path / name
        assert main(["reproduce", "--quick", "-j", "1", "--out", str(out), *extra]) == 0
        speeds.append(_speed(out / "exp-hodosmc-speed" / "do4smc.case1.npz"))
    assert 1.1 < speeds[1] / speeds[0] < 1.45, speeds


def test_python_api(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip.studies.run_study(..., robot=FILE)`, and without one the default robot's twin
    (as `mwip run`), not the data-sheet twin."""
    from mwip.studies import registry, run_study

    assert registry.context("exp-asta", tmp_path).twin == default_robot().twin
    run_study("exp-hodosmc-speed", tmp_path / "a", quick=True)
    run_study("exp-hodosmc-speed", tmp_path / "b", quick=True, robot=robots["wheel5"])
    v = [_speed(tmp_path / x / "exp-hodosmc-speed" / "do4smc.case1.npz") for x in "ab"]
    assert 1.1 < v[1] / v[0] < 1.45, v
    with pytest.raises(ValueError, match="robot"):
        registry.context("exp-asta", tmp_path, robot=robots["wheel5"], twin=default_robot().twin)


_CAMPAIGN = """
[campaign]
samples = 8
block = 8
duration = 2.0
[[controllers]]
name = "lqr"
[robot]
{robot}
centre = "real"
design = "nominal"
[initial]
theta = {{ uniform = [-0.1, 0.1] }}
"""


def _peak_torque(folder: Path) -> float:
    pd = pytest.importorskip("pandas")
    return float(pd.read_parquet(folder / "results.parquet")["peak_torque"].mean())


def test_campaign_run(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip campaign run --robot` and a campaign file's `[robot] file` (relative to the
    campaign file): the twin delivers the torque gain's torque."""
    pytest.importorskip("pyarrow")
    plain = tmp_path / "c.toml"
    plain.write_text(_CAMPAIGN.format(robot=""))
    own = tmp_path / "sub" / "c.toml"
    own.parent.mkdir()
    (own.parent / "gain2.toml").write_text(robots["gain2"].read_text())
    own.write_text(_CAMPAIGN.format(robot='file = "gain2.toml"'))
    base = tmp_path / "b.toml"
    base.write_text(_CAMPAIGN.format(robot=f'file = "{robots["base"].as_posix()}"'))
    runs = {"default": [str(base)], "option": [str(plain), "--robot", str(robots["gain2"])],
            "file": [str(own)]}  # fmt: skip
    peak = {}
    for name, args in runs.items():
        assert main(["campaign", "run", *args, "--out", str(tmp_path / name), "--jobs", "1"]) == 0
        peak[name] = _peak_torque(tmp_path / name)
    assert peak["option"] == peak["file"] > 1.3 * peak["default"], peak
    # resuming with another robot is refused (the robot is part of the campaign's identity)
    assert main(["campaign", "run", str(plain), "--out", str(tmp_path / "default"), "--jobs",
                 "1", "--robot", str(robots["gear12"])]) == 2  # fmt: skip


def test_bench(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip bench --robot`: the nominal level's peak delivered torque."""
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    peak = []
    for name, extra in (("default", ["--robot", str(robots["base"])]),
                        ("gain2", ["--robot", str(robots["gain2"])])):  # fmt: skip
        out = tmp_path / name
        assert main(["bench", "lqr", "--quick", "--jobs", "1", "--out", str(out), *extra]) == 0
        res = pd.read_parquet(out / "results.parquet")
        peak.append(float(res[res["axis"] == "nominal"]["peak_torque"].mean()))
    assert peak[1] > 1.5 * peak[0], peak
    page = (tmp_path / "gain2" / "index.html").read_text()
    assert "the twin of robot &#x27;record&#x27;" in page  # which robot, not "the default twin"


_OBJECTIVE = """
[objective]
torque_limit = "drive"
[[objective.terms]]
metric = "rms_theta"
scale = 0.02
[robots]
{robot}
campaign = "{campaign}"
samples = 8
chunk = 8
duration = 2.0
[validation]
samples = 8
seed = 5
"""


def test_tune(tmp_path: Path, robots: dict[str, Path]) -> None:
    """`mwip tune --robot` and an objective's `[robots] robot`: the objective's "drive" torque
    limit is the robot's (in proportion to its gear ratio), and the trials' costs change."""
    pytest.importorskip("optuna")
    pytest.importorskip("pyarrow")
    from mwip.tune.objective import load_objective

    camp = tmp_path / "c.toml"
    camp.write_text(_CAMPAIGN.format(robot=""))
    obj = tmp_path / "o.toml"
    obj.write_text(_OBJECTIVE.format(robot="", campaign=camp.as_posix()))
    own = tmp_path / "own.toml"
    (tmp_path / "gear12.toml").write_text(robots["gear12"].read_text())
    own.write_text(_OBJECTIVE.format(robot='robot = "gear12.toml"', campaign=camp.as_posix()))
    limit = [load_objective(str(obj)).torque_limit,
             load_objective(str(obj), robot=robots["gear12"]).torque_limit,
             load_objective(str(own)).torque_limit]  # fmt: skip
    n0 = default_robot().twin.drive.gear_ratio
    assert limit[1] == limit[2] == pytest.approx(limit[0] * 12.0 / n0), limit  # type: ignore[operator]
    costs = []
    for name, extra in (("default", []), ("gain2", ["--robot", str(robots["gain2"])])):
        out = tmp_path / name
        assert main(["tune", "lqr", "--objective", str(obj), "--trials", "2", "--out", str(out),
                     *extra]) == 0  # fmt: skip
        costs.append((out / "trials.csv").read_text())
    assert costs[0] != costs[1]
    assert "--robot (record)" in (tmp_path / "gain2" / "best.toml").read_text().splitlines()[0]


def test_export_verify(tmp_path: Path, robots: dict[str, Path],
                       capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    """`mwip export c --verify --twin --robot`: the loop runs on the robot's twin (its peak
    delivered torque rises with the torque gain); the C code is designed on the robot's
    design model."""
    from mwip.export.sil import find_compiler

    if find_compiler() is None:
        pytest.skip("no C compiler ($CC, cc, gcc or clang) on this machine")
    peaks = []
    for name, extra in (("default", ["--robot", str(robots["base"])]),
                        ("gain2", ["--robot", str(robots["gain2"])])):  # fmt: skip
        capsys.readouterr()
        assert main(["export", "c", "--controller", "lqr", "--out", str(tmp_path / name),
                     "--verify", "--twin", "--duration", "2", *extra]) == 0  # fmt: skip
        line = capsys.readouterr().out.strip().splitlines()[-1]
        peaks.append(float(line.rsplit("peak delivered torque ", 1)[1].split()[0]))
    assert peaks[1] > 1.4 * peaks[0], peaks


def test_twin_fit(tmp_path: Path) -> None:
    """`mwip twin fit --robot`: the body is the robot's and held fixed. Stand logs of a robot
    whose wheels are 3x as heavy (Iwa) as the book's: the fit on that robot's body recovers the
    gear ratio better than the fit on the book's body, which must explain the slower wheels
    with another drive; the written robot file carries the given body."""
    from mwip.identify import excite, synth

    r = default_robot()
    heavy = replace(r, body=replace(r.body, Iwa=3.0 * r.body.Iwa))
    robot_file = save_robot(heavy, tmp_path / "heavy.toml")
    _, duty, mode = excite.schedule(static=0.3, step=0.06, chirp=0.5)
    truth = synth.draw_truth(7)
    log = synth.write_csv(tmp_path / "log.csv",
                          synth.stand_log(truth, duty, mode, seed=7, body=heavy.body))  # fmt: skip
    err = {}
    for name, extra in (("book", []), ("heavy", ["--robot", str(robot_file)])):
        out = tmp_path / name
        assert main(["twin", "fit", str(log), "--out", str(out), "--fix", "firmware.delay=0.5",
                     *extra]) == 0  # fmt: skip
        fitted = load_robot(out / "robot.toml")
        assert fitted.body == (heavy.body if name == "heavy" else r.body)
        err[name] = abs(fitted.twin.drive.gear_ratio - truth["drive.gear_ratio"])
    assert err["heavy"] < 0.6 * err["book"], err


def test_gym_keyword(robots: dict[str, Path]) -> None:
    """`MwipEnv(robot=...)`, `MwipVectorEnv(robot=...)`: the robot's body, sample period and
    its drive's largest wheel torque (the action bound, in proportion to the gear ratio)."""
    pytest.importorskip("gymnasium")
    from mwip.gym.env import MwipEnv
    from mwip.gym.vector import MwipVectorEnv

    base = MwipEnv(robot=default_robot())
    geared = MwipEnv(robot=robots["gear12"])
    n0 = default_robot().twin.drive.gear_ratio
    assert geared.action_space.high[0] == pytest.approx(base.action_space.high[0] * 12 / n0,
                                                        rel=1e-6)  # fmt: skip
    wheel = MwipVectorEnv(2, robot=robots["wheel5"])
    assert wheel.cfg.plant.r == 0.05 and np.all(wheel.r == 0.05)
    with pytest.raises(ValueError, match="robot"):
        MwipEnv(robot=robots["wheel5"], plant=default_robot().body)


def test_robot_file_round_trip(tmp_path: Path, robots: dict[str, Path],
                               capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    """show -> file -> load -> show is byte-identical, for the default and a changed robot."""
    for extra in ([], [str(robots["gain2"])]):
        capsys.readouterr()
        assert main(["robot", "show", *extra]) == 0
        first = capsys.readouterr().out
        f = tmp_path / "shown.toml"
        f.write_text(first)
        assert main(["robot", "show", str(f)]) == 0
        assert capsys.readouterr().out == first


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (("[body]\n", "[body]\nwheel_radius_typo = 1.0\n"), "body.wheel_radius_typo"),
        (("\ntorque_gain = ", "\ntorque_gain = \"two\" # "), "firmware.torque_gain"),
        (("\ntorque_gain = ", "\ntorque_gain = 9.0 # "), "firmware.torque_gain"),
        (("\nr = 0.04", "\nr = -0.04"), "body.r"),
        (("\nr = 0.04 ", "\n# r = 0.04 "), "body.r is missing"),
        (("\nr = 0.04 ", "\nr = 40 "), "body.r"),
    ],
)
def test_bad_robot_file_exit_2_one_line_nothing_written(
    tmp_path: Path, edit: tuple[str, str], field: str, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    assert main(["robot", "show"]) == 0
    text = capsys.readouterr().out
    assert edit[0] in text, edit
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(edit[0], edit[1], 1))
    for cmd in (["simulate", "--robot", str(bad), "--out", str(tmp_path / "o")],
                ["robot", "show", str(bad)],
                ["export", "c", "--controller", "lqr", "--robot", str(bad), "--out",
                 str(tmp_path / "e")]):  # fmt: skip
        assert main(cmd) == 2, cmd
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "bad.toml" in err and field in err, (cmd, err)
    assert not (tmp_path / "o").exists() and not (tmp_path / "e").exists()


def test_campaign_summary_identity_differs(robots: dict[str, Path]) -> None:
    """The robot is part of a campaign's identity (a resumed run with another robot is
    refused, as test_campaign_run shows on the command line)."""
    from mwip.campaign.spec import load_campaign

    ids = {load_campaign("robustness").identity(),
           load_campaign("robustness", robot=robots["gain2"]).identity(),
           load_campaign("robustness", robot=robots["gear12"]).identity()}  # fmt: skip
    assert len(ids) == 3
    assert json.dumps(load_campaign("robustness").source)  # the file, as parsed
