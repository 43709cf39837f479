"""The robot of a run drawn to scale and moving (``mwip animate RUN_DIR``,
:mod:`mwip.cli.plot`).

A side view (wheel turning, body leaning, payload when present) beside a top view of the path,
with a time cursor on the theta and torque traces (:class:`mwip.plot.robot_view.RobotView`).
Written as GIF (matplotlib and Pillow; the default), MP4 (needs ``ffmpeg`` on the PATH) or
HTML (a page showing the GIF, no script). A run that fell or diverged
is shown up to the moment it stopped, then held for ``HOLD_S`` with the stop marked, and the
animation ends. :func:`poster_frame` draws one frame (the last) as a PNG.
"""

from __future__ import annotations

import base64
import io
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mwip.io import html_text, write_atomic, write_text_atomic
from mwip.plot.runs import Run, RunFolderError, records

if TYPE_CHECKING:  # matplotlib: imported where a frame is drawn
    from mwip.plot.robot_view import RobotView

__all__ = ["FORMATS", "MAX_FRAMES", "AnimationError", "animate_run", "poster_frame"]

FORMATS = (".gif", ".mp4", ".html")
MAX_FRAMES = 5000
HOLD_S = 1.0


class AnimationError(RuntimeError):
    """The video encoder (ffmpeg) failed; the message says how (the CLI prints it, exit 1)."""


def _check(run: Run) -> None:
    t, _ = records(run)
    if t.size < 2 or not t[-1] > t[0]:
        span = float(t[-1] - t[0]) if t.size else 0.0
        raise RunFolderError(
            f"{run.source}: run {run.name!r} has {t.size} record(s) over {span:g} s; an "
            "animation needs at least 2 records spanning some time"
        )


def _view(run: Run, fps: float, speed: float) -> tuple[RobotView, int]:
    from mwip.plot.robot_view import Frames, RobotView, frame_times

    _check(run)
    times = frame_times(run.t_end, fps, speed)
    if times.size > MAX_FRAMES:
        raise RunFolderError(
            f"--speed: {run.t_end:g} s at {fps:g} frames/s and speed-up {speed:g} makes "
            f"{times.size} frames, at most {MAX_FRAMES}: raise --speed or lower --fps"
        )
    hold = int(round(HOLD_S * fps)) if run.status != "ok" else 0
    return RobotView(run, Frames.of(run, times)), hold


def animate_run(run: Run, path: Path, *, fps: float = 20.0, speed: float = 1.0) -> Path:
    """Write the animation of ``run`` to ``path`` (``.gif``, ``.mp4`` or ``.html``): ``fps``
    frames per second of video, each ``speed / fps`` seconds of the run (``speed`` > 1 plays
    faster than real time). A GIF of a run that stopped plays once and ends on the stop; one
    of a run that ended ``ok`` loops. Returns ``path``."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise RunFolderError(f"--out: must end in {', '.join(FORMATS)}, got {path.name!r}")
    ffmpeg = shutil.which("ffmpeg")
    if ext == ".mp4" and ffmpeg is None:
        raise RunFolderError("--out: .mp4 needs ffmpeg on the PATH (not found); use .gif or .html")
    view, hold = _view(run, fps, speed)
    frames = view.frames(hold)
    if ext == ".mp4":
        assert ffmpeg is not None
        return _write_mp4(frames, path, fps, ffmpeg)
    gif = _gif_bytes(frames, fps, loop=run.status == "ok")
    if ext == ".gif":
        return write_atomic(path, lambda fh: fh.write(gif))
    title = html_text(f"{run.study + ': ' if run.study else ''}{run.name}")
    page = (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f"<title>{title}</title></head><body style='font-family:sans-serif'>"
        f"<h1 style='font-size:1.2rem'>{title} ({html_text(run.status)}, "
        f"{run.t_end:.3g} s, {speed:g}x)</h1>"
        f'<img alt="{title}" style="max-width:100%" src="data:image/gif;base64,'
        f'{base64.b64encode(gif).decode("ascii")}"></body></html>\n'
    )
    return write_text_atomic(path, page)


def _gif_bytes(frames: Iterator[np.ndarray], fps: float, *, loop: bool) -> bytes:
    from PIL import Image

    images = [Image.fromarray(f[..., :3]).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
              for f in frames]  # fmt: skip
    buf = io.BytesIO()
    extra = {"loop": 0} if loop else {}
    images[0].save(buf, format="GIF", save_all=True, append_images=images[1:],
                   duration=max(int(round(1000.0 / fps)), 20), optimize=False, **extra)  # fmt: skip
    return buf.getvalue()


def _write_mp4(frames: Iterator[np.ndarray], path: Path, fps: float, ffmpeg: str) -> Path:
    first = next(frames)
    h, w = first.shape[:2]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.partial-{os.getpid()}.mp4")
    cmd = [ffmpeg, "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba",
           "-s", f"{w}x{h}", "-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
           "-pix_fmt", "yuv420p", "-vcodec", "libx264", str(tmp)]  # fmt: skip
    try:
        with subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
            assert proc.stdin is not None
            try:
                proc.stdin.write(first.tobytes())
                for f in frames:
                    proc.stdin.write(f.tobytes())
            finally:
                proc.stdin.close()
            err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
        if proc.returncode != 0:
            raise AnimationError(f"ffmpeg failed: {err.strip().splitlines()[-1:]}")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def poster_frame(run: Run, path: Path, *, size: tuple[float, float] = (8.0, 5.3),
                 dpi: int = 80) -> Path:  # fmt: skip
    """One frame of the animation, at the run's last moment (the fall, for a run that fell),
    as a PNG of ``size`` inches at ``dpi`` (default 640 x 424 px)."""
    from mwip.plot.robot_view import Frames, RobotView, frame_times

    _check(run)
    times = frame_times(run.t_end, 20.0, max(run.t_end / 200.0, 0.05))
    view = RobotView(run, Frames.of(run, times), size=size, dpi=dpi)
    view.show(times.size - 1, final=True)
    return write_atomic(path, lambda fh: view.fig.savefig(fh, format="png", dpi=dpi))
