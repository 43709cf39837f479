"""The run figure (``simulate --plot``) and ``mwip animate``: what is drawn, to scale, for a
simulate run, a study's folder and a fallen run; bad input is one line and exit code 2."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mwip.animate import HOLD_S, animate_run, poster_frame
from mwip.cli import main
from mwip.laws import LQR, design_lqr
from mwip.params import NOMINAL, REAL
from mwip.plot.robot_view import Frames, RobotView, frame_times
from mwip.plot.run_figure import run_figure
from mwip.plot.runs import load_run, records
from mwip.sim import simulate


class _Zero:
    """No torque: the robot falls (a controller that sees nothing and does nothing)."""

    def reset(self, meas):  # noqa: ANN001 - Controller protocol
        pass

    def __call__(self, t, meas):  # noqa: ANN001
        return np.zeros((meas.y.shape[0], 2))


class _WithLogs(LQR):
    """The LQR with the logs of an observer-based law on the twin: ``tau_hat``, ``u_applied``."""

    def log(self):
        n = 1
        return {"tau_hat": np.full((n, 3), 0.25), "u_applied": np.full((n, 2), 0.01)}


def _balanced(duration: float = 1.0):
    return simulate(LQR(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0.0, 0.1, 0.0),
                    qdot0=(5.0, 0.0, 0.3), duration=duration, Ts=0.005)  # fmt: skip


def _fallen():
    res = simulate(_Zero(), REAL, q0=(0.0, 0.3, 0.0), duration=3.0, Ts=0.005)
    assert res.status[0] == "fell" and res.t_end[0] < 3.0
    return res


@pytest.fixture(scope="module")
def study_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A study's folder as `mwip run` writes it: OUT/run.json, OUT/<study>/metrics.json and one
    .npz per run (one of them Case 2, with the payload, and one that fell)."""
    out = tmp_path_factory.mktemp("study") / "out"
    folder = out / "exp-hodosmc-balance"
    folder.mkdir(parents=True)
    _balanced().to_npz(folder / "smc.case1.npz")
    _fallen().to_npz(folder / "do4smc.case2.npz")
    np.savez(folder / "tsmc_sliding.npz", t=np.arange(3.0))  # not a run: skipped
    runs = {"smc.case1": {"status": "ok"}, "do4smc.case2": {"status": "fell"}}
    (folder / "metrics.json").write_text(json.dumps(
        {"study": "exp-hodosmc-balance", "runs": runs, "settings": {"speed": -7.0},
         "claims": []}))  # fmt: skip
    plant = REAL.to_dict() | {"r": 0.05}
    (out / "run.json").write_text(json.dumps({"params": {"plant": plant}, "studies": {}}))
    return folder


def test_simulate_plot_writes_the_run_figure(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", "--duration", "0.5", "--out", str(out), "--plot"]) == 0
    with Image.open(out / "run.png") as im:
        assert im.size == (1000, 960)  # drawn for display at its natural size
    assert (out / "plant.toml").is_file()
    run = load_run(out)
    assert run.name == "timeseries" and run.params == REAL and run.status == "ok"
    capsys.readouterr()
    assert main(["simulate", "--duration", "0.5", "--plot"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--plot" in err[0] and "--out" in err[0]


def test_run_figure_panels_have_units_and_show_what_the_run_logged():
    from mwip.plot.runs import Run

    plain = Run("a", _balanced().plant(0), REAL, False, 0.0, Path("a.npz"))
    fig = run_figure(plain)
    axes = fig.axes
    assert len(axes) == 6
    for ax in axes:  # units on every axis that has ticks
        assert "(" in ax.get_xlabel() and "(" in ax.get_ylabel(), (ax.get_xlabel(), ax.get_ylabel())
    torque = next(ax for ax in axes if "torque" in ax.get_ylabel())
    assert len(torque.lines) == 2  # commanded only
    rates = next(ax for ax in axes if ax.get_ylabel() == "rates (rad/s)")  # no empty panel
    assert len(rates.lines) == 2 and "no disturbance observer" in rates.get_title()
    res = simulate(_WithLogs(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0, 0.1, 0), duration=0.2)
    logged = Run("b", res.plant(0), REAL, False, 1.5, Path("b.npz"))
    axes = run_figure(logged).axes
    torque = next(ax for ax in axes if "torque" in ax.get_ylabel())
    assert [ln.get_label() for ln in torque.lines] == [
        "u_r commanded", "u_l commanded", "u_r applied", "u_l applied"]  # fmt: skip
    dist = next(ax for ax in axes if "disturbance" in ax.get_ylabel())
    assert len(dist.lines) == 3 and np.allclose(dist.lines[1].get_ydata()[1:], 0.25)
    speed = next(ax for ax in axes if "wheel speed" in ax.get_ylabel())
    assert speed.lines[-1].get_ydata()[0] == 1.5  # the reference
    zero = res.plant(0)
    zero.logs["tau_hat"] = np.zeros_like(zero.logs["tau_hat"])  # a law without observer
    labels = [ax.get_ylabel() for ax in run_figure(Run("z", zero, REAL, False, None,
                                                       Path("z"))).axes]  # fmt: skip
    assert "rates (rad/s)" in labels and not any("disturbance" in y for y in labels)
    fell = Run("c", _fallen().plant(0), REAL, False, None, Path("c.npz"))
    fig = run_figure(fell)
    assert "FELL at t = " in fig.get_suptitle()


def test_side_view_is_to_scale_and_follows_the_state():
    """Body top at (2 l sin theta, r + 2 l cos theta) from the contact point's vertical, spokes
    turned by psi, ground marks shifted by the distance rolled r psi."""
    from mwip.plot.runs import Run

    res = _balanced(0.6).plant(0)
    run = Run("a", res, REAL, True, None, Path("a.npz"))
    times = frame_times(run.t_end, 20.0, 1.0)
    frames = Frames.of(run, times)
    view = RobotView(run, frames)
    r, h = REAL.r, 2 * REAL.l
    for i in (0, 5, len(times) - 1):
        view.show(i)
        th, psi = frames.theta[i], frames.psi[i]
        body = view.body.get_xy()[:4]
        top_mid = (body[2] + body[3]) / 2
        assert np.allclose(top_mid, [h * math.sin(th), r + h * math.cos(th)], atol=1e-12)
        sx, sy = view.spokes.get_data()
        assert np.allclose([sx[0], sy[0]], [r * math.cos(-psi), r + r * math.sin(-psi)])
        pan = np.column_stack(view.payload.get_data())
        pan_mid = pan.mean(axis=0)
        hp = h + 0.1  # the payload of Params.with_payload: 0.1 m above the body's top
        assert np.allclose(pan_mid, [hp * math.sin(th), r + hp * math.cos(th)], atol=1e-12)
        marks = np.array([seg[0][0] for seg in view.marks.get_segments()])
        step = view.mark_step
        k = (marks + r * psi) / step  # ground marks sit at whole steps of the ground
        assert np.allclose(k, np.round(k), atol=1e-9) and len(marks) >= 5
    # frames interpolate the records; the last is the stop time
    t, x = records(run)
    assert frames.t[-1] == pytest.approx(run.t_end)
    assert frames.theta[-1] == pytest.approx(x[-1, 1])
    assert np.allclose(frames.x, np.interp(times, t, x[:, 6]))


def test_animate_a_simulate_run_gif_and_html(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", "--duration", "0.5", "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["animate", str(out), "--fps", "10", "--speed", "0.5"]) == 0
    gif = out / "timeseries.gif"
    assert f"wrote {gif}" in capsys.readouterr().out
    with Image.open(gif) as im:
        assert im.n_frames == frame_times(0.5, 10, 0.5).size == 11  # 0.05 s of run per frame
        assert im.info.get("loop") == 0  # a run that ended ok loops
        assert im.size == (768, 512)
    page = tmp_path / "a.html"
    assert main(["animate", str(out), "--out", str(page), "--speed", "5"]) == 0
    text = page.read_text()
    assert text.count("data:image/gif;base64,") == 1 and "<script" not in text


def test_animate_a_study_folder_main_run_and_payload(study_folder, tmp_path):
    run = load_run(study_folder)  # the catalog's main run of exp-hodosmc-balance
    assert run.name == "do4smc.case2" and run.study == "exp-hodosmc-balance"
    assert run.payload and run.params.r == 0.05  # Case 2; the plant of OUT/run.json
    assert run.reference == -7.0  # the study's wheel-speed setting
    first = load_run(study_folder, "smc.case1")
    assert not first.payload and first.status == "ok"
    assert main(["animate", str(study_folder), "--run", "smc.case1", "--out",
                 str(tmp_path / "s.gif"), "--speed", "4"]) == 0  # fmt: skip
    assert (tmp_path / "s.gif").stat().st_size > 1000


def test_animate_a_fallen_run_shows_the_fall_then_stops(study_folder, tmp_path):
    run = load_run(study_folder, "do4smc.case2")
    assert run.status == "fell"
    t, x = records(run)
    assert t[-1] == pytest.approx(run.t_end) and abs(x[-1, 1]) >= math.pi / 2  # the fall
    path = animate_run(run, tmp_path / "f.gif", fps=20.0, speed=1.0)
    n = frame_times(run.t_end, 20.0, 1.0).size
    with Image.open(path) as im:
        assert "loop" not in im.info  # plays once, ends on the fall
        durations = []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
    assert sum(durations) == pytest.approx((n + HOLD_S * 20) * 50, abs=60)
    assert durations[-1] >= HOLD_S * 1000  # the fall is held
    poster = poster_frame(run, tmp_path / "p.png")
    with Image.open(poster) as im:
        assert im.size == (640, 424)


def test_plot_command_draws_any_run_of_a_study(study_folder, tmp_path, capsys):
    """`mwip plot` on a study folder: the figure of its run, apart from the study's figures."""
    assert main(["plot", str(study_folder), "--run", "smc.case1"]) == 0
    path = study_folder / "plot" / "smc.case1.png"
    assert f"wrote {path}" in capsys.readouterr().out
    with Image.open(path) as im:
        assert im.size == (1000, 960)
    assert main(["plot", str(study_folder), "--out", str(tmp_path / "x.jpg")]) == 2
    assert main(["plot", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "must end in .png" in err[0] and "no run found" in err[1]


@pytest.mark.parametrize(
    ("setup", "args", "expect"),
    [
        ("empty", [], "no run found"),
        ("results", [], "give one study's folder"),
        ("short", [], "an animation needs at least 2 records"),
        ("sim", ["--out", "x.avi"], "must end in .gif, .mp4, .html"),
        ("sim", ["--fps", "0"], "--fps"),
        ("sim", ["--run", "nope"], "no run 'nope'"),
        ("missing", [], "does not exist"),
    ],
)
def test_animate_bad_input_is_one_line_and_exit_2(tmp_path, capsys, setup, args, expect):
    folder = tmp_path / "f"
    if setup != "missing":
        folder.mkdir()
    if setup == "results":
        (folder / "run.json").write_text("{}")
    if setup in ("short", "sim"):
        res = simulate(LQR(design_lqr(NOMINAL, Ts=0.005)), REAL, q0=(0, 0.1, 0),
                       duration=0.005 if setup == "short" else 0.1)  # fmt: skip
        res.to_npz(folder / "timeseries.npz")
        if setup == "short":  # one record
            z = dict(np.load(folder / "timeseries.npz"))
            z["t"], z["states"], z["inputs"] = z["t"][:1], z["states"][:, :1], z["inputs"][:, :1]
            z["t_end"] = np.array([0.0])
            np.savez(folder / "timeseries.npz", **z)
    assert main(["animate", str(folder), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mwip: error: ") and expect in err[0], err


def test_animate_mp4_without_ffmpeg_says_so(study_folder, capsys, monkeypatch):
    import mwip.animate

    monkeypatch.setattr(mwip.animate.shutil, "which", lambda _name: None)  # no ffmpeg
    assert main(["animate", str(study_folder), "--out", "x.mp4"]) == 2
    assert "needs ffmpeg" in capsys.readouterr().err


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg not installed")
def test_animate_mp4_with_ffmpeg(study_folder, tmp_path):
    path = animate_run(load_run(study_folder, "smc.case1"), tmp_path / "a.mp4", speed=4.0)
    assert path.read_bytes()[4:8] == b"ftyp"
