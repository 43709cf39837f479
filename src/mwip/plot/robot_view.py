"""The robot drawn to scale: a side view (wheel turning, body leaning, payload) beside a top
view of the path, with theta and torque traces and a time cursor; one frame of it at any time.

Geometry (SPEC.md section 2 conventions): the wheel is a circle of radius ``r`` on the ground;
it has rolled the distance ``s = r psi`` (the mean wheel angle), which is the side view's
horizontal position, and its spokes turn by ``psi``. The body is drawn as a block from the
axle to ``2 l`` (its centre of mass at ``l``, the geometry :meth:`mwip.params.Params.with_payload`
assumes), ``1.5 r`` wide, leaning by ``theta`` (positive forward, toward increasing ``s``).
The payload of Chapter 6 (Cases 2 and 3) is a pan of radius 0.08 m on rods 0.1 m above the
body's top (again as ``with_payload`` assumes). The top view shows the path ``(x, y)`` with
the axle (length ``2 b``) across the heading ``alpha``. The block's width and the pan's
radius are drawing choices; every length that the model uses is to scale.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon

from mwip.plot.runs import Run, records

__all__ = ["Frames", "RobotView", "frame_times"]

#: Payload geometry of Chapter 6 (as mwip.params.Params.with_payload assumes), m.
PAYLOAD_HEIGHT = 0.1
PAYLOAD_RADIUS = 0.08
_FELL = "#c0392b"


def frame_times(t_end: float, fps: float, speed: float) -> np.ndarray:
    """Times (s) of the frames: every ``speed / fps`` seconds of the run, ending at ``t_end``."""
    step = speed / fps
    n = int(np.floor(t_end / step + 1e-9))
    ts = np.arange(n + 1) * step
    if t_end - ts[-1] > 1e-9:
        ts = np.append(ts, t_end)
    return ts


@dataclass(frozen=True)
class Frames:
    """The run's records interpolated at the frame times ``t``: ``s`` (m, distance rolled),
    ``psi``, ``theta``, ``alpha`` (rad), ``x``, ``y`` (m)."""

    t: np.ndarray
    s: np.ndarray
    psi: np.ndarray
    theta: np.ndarray
    alpha: np.ndarray
    x: np.ndarray
    y: np.ndarray

    @classmethod
    def of(cls, run: Run, times: np.ndarray) -> Frames:
        t, st = records(run)
        r = float(run.params.r)

        def at(i: int) -> np.ndarray:
            return np.interp(times, t, st[:, i])

        psi = at(0)
        return cls(t=times, s=r * psi, psi=psi, theta=at(1), alpha=at(2), x=at(6), y=at(7))


def _rot(points: np.ndarray, angle: float) -> np.ndarray:
    """Rotate (n, 2) points by ``angle`` clockwise (a lean forward tips +y toward +x)."""
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, -s], [s, c]])


class RobotView:
    """A figure with the four panels; :meth:`show` moves everything to frame ``i``.

    ``size`` is the figure size in inches and ``dpi`` its resolution; fonts are 10 pt or more
    (at 80 dpi, 11 px).
    """

    def __init__(self, run: Run, frames: Frames, size: tuple[float, float] = (9.6, 6.4),
                 dpi: int = 80) -> None:  # fmt: skip
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        self.run, self.f = run, frames
        p = run.params
        self.r, self.b, self.h = float(p.r), float(p.b), 2.0 * float(p.l)
        self.w = 1.5 * self.r
        self.fig = Figure(figsize=size, dpi=dpi, layout="constrained")
        FigureCanvasAgg(self.fig)
        gs = self.fig.add_gridspec(2, 2, height_ratios=(1.35, 1), width_ratios=(1.35, 1))
        self.ax_side = self.fig.add_subplot(gs[0, 0])
        self.ax_top = self.fig.add_subplot(gs[0, 1])
        self.ax_th = self.fig.add_subplot(gs[1, 0])
        self.ax_u = self.fig.add_subplot(gs[1, 1])
        self._side()
        self._top()
        self._traces()
        title = (f"{run.study}: {run.name}" if run.study
                 else f"{run.source.parent.name}/{run.source.name}")  # fmt: skip
        self.fig.suptitle(title, fontsize=12, x=0.01, ha="left")
        self.fig.canvas.draw()  # lay out once, then freeze: every frame moves artists only
        self.fig.set_layout_engine("none")

    def frames(self, hold: int = 0) -> Iterator[np.ndarray]:
        """The frames as RGBA arrays (H, W, 4): the still parts are drawn once, each frame
        redraws only the moving artists (blitting); ``hold`` repeats the last frame."""
        canvas: Any = self.fig.canvas  # the Agg canvas: blitting and RGBA buffer
        for a in self.moving:
            a.set_animated(True)
        canvas.draw()
        background = canvas.copy_from_bbox(self.fig.bbox)
        n = self.f.t.size
        try:
            for i in range(n):
                canvas.restore_region(background)
                self.show(i, final=i == n - 1)
                for a in self.moving:
                    (a.axes or self.fig).draw_artist(a)
                frame = np.asarray(canvas.buffer_rgba()).copy()
                yield frame
            for _ in range(hold):
                yield frame
        finally:
            for a in self.moving:
                a.set_animated(False)

    # ---- panels ---------------------------------------------------------------------------
    def _side(self) -> None:
        """The side view follows the robot: the axle stays at 0, the ground marks move."""
        ax, r, h = self.ax_side, self.r, self.h
        top = h + (PAYLOAD_HEIGHT + 0.02 if self.run.payload else 0.0)
        self.half = max(1.6 * top, 0.25)
        self.mark_step = 0.05 if self.half < 1.0 else 0.1
        self.marks = LineCollection([], colors="#777", linewidths=1.2)
        ax.add_collection(self.marks)
        ax.axhline(0.0, color="k", lw=1.5)
        self.wheel = Circle((0, r), r, fc="#d6dbe0", ec="k", lw=1.5, alpha=0.85, zorder=3)
        ax.add_patch(self.wheel)
        (self.spokes,) = ax.plot([], [], color="k", lw=1.5, zorder=4)
        self.body = Polygon(np.zeros((4, 2)), closed=True, fc="#5b8fc9", ec="k", lw=1.2,
                            alpha=0.9)  # fmt: skip
        ax.add_patch(self.body)
        (self.com,) = ax.plot([], [], "o", color="k", ms=4)
        (self.payload,) = ax.plot([], [], color="#8e5a2b", lw=3)
        (self.rods,) = ax.plot([], [], color="#8e5a2b", lw=1)
        self.clock = self.fig.text(0.99, 0.985, "", ha="right", va="top", fontsize=11)
        self.banner = ax.text(0.5, 0.55, "", transform=ax.transAxes, ha="center", fontsize=16,
                              color=_FELL, weight="bold")  # fmt: skip
        ax.set_ylim(-0.05, max(1.25 * top, 0.75 * self.half))
        ax.set_xlim(-self.half, self.half)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(f"side view to scale: m from the axle (marks every "
                      f"{100 * self.mark_step:.0f} cm)")  # fmt: skip
        ax.set_ylabel("height (m)")
        self.moving = [self.marks, self.wheel, self.spokes, self.body, self.com, self.payload,
                       self.rods, self.clock, self.banner]  # fmt: skip

    def _top(self) -> None:
        ax, f = self.ax_top, self.f
        ax.plot(f.x, f.y, color="#c5ccd3", lw=1)
        (self.trail,) = ax.plot([], [], color="C0", lw=1.5)
        (self.axle,) = ax.plot([], [], color="k", lw=2.5)
        (self.heading,) = ax.plot([], [], color=_FELL, lw=1.5)
        self.moving += [self.trail, self.axle, self.heading]
        span = max(float(np.ptp(f.x)), float(np.ptp(f.y)), 6 * self.b, 0.3)
        cx, cy = float(f.x.min() + f.x.max()) / 2, float(f.y.min() + f.y.max()) / 2
        ax.set_xlim(cx - 0.6 * span, cx + 0.6 * span)
        ax.set_ylim(cy - 0.6 * span, cy + 0.6 * span)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("top view of the path: x (m)")
        ax.set_ylabel("y (m)")

    def _traces(self) -> None:
        res = self.run.result
        t = np.asarray(res.t)
        th = np.asarray(res.state)[:, 1]
        u = np.asarray(res.u)
        self.ax_th.plot(t, th, color="C0")
        self.ax_th.set_ylabel("theta (rad)")
        self.ax_u.plot(t, u[:, 0], color="C1", label="u_r")
        self.ax_u.plot(t, u[:, 1], color="C2", label="u_l")
        self.ax_u.set_ylabel("torque (N m)")
        self.ax_u.legend(loc="best", fontsize=10, ncol=2)
        self.cursors = []
        for ax in (self.ax_th, self.ax_u):
            ax.grid(True, alpha=0.3)
            ax.set_xlabel("t (s)")
            ax.set_xlim(0.0, max(self.run.t_end, float(t[-1]) if t.size else 0.0, 1e-3))
            if self.run.status != "ok":
                ax.axvline(self.run.t_end, color=_FELL, ls="--", lw=1)
            self.cursors.append(ax.axvline(0.0, color="k", lw=1.2))
        self.moving += self.cursors

    # ---- one frame ------------------------------------------------------------------------
    def show(self, i: int, *, final: bool = False) -> None:
        """Move the robot, cursors and clock to frame ``i``; ``final`` adds the stop banner
        for a run that did not end ``ok``."""
        f, r, h, w = self.f, self.r, self.h, self.w
        s, psi, th = float(f.s[i]), float(f.psi[i]), float(f.theta[i])
        step, half = self.mark_step, self.half
        first = np.ceil((s - half) / step) * step
        rel = np.arange(first, s + half + step, step) - s
        self.marks.set_segments([[(m, 0.0), (m - 0.4 * step, -0.025)] for m in rel])
        axle = np.array([0.0, r])
        self.wheel.center = (0.0, r)
        ang = -psi + np.arange(3) * 2 * np.pi / 3
        sx = np.stack([r * np.cos(ang), np.zeros(3), np.full(3, np.nan)], 1).ravel()
        sy = np.stack([r + r * np.sin(ang), np.full(3, r), np.full(3, np.nan)], 1).ravel()
        self.spokes.set_data(sx, sy)
        block = np.array([[-w / 2, 0.0], [w / 2, 0.0], [w / 2, h], [-w / 2, h]])
        self.body.set_xy(axle + _rot(block, th))
        com = axle + _rot(np.array([[0.0, h / 2]]), th)
        self.com.set_data(com[:, 0], com[:, 1])
        if self.run.payload:
            pan = axle + _rot(np.array([[-PAYLOAD_RADIUS, h + PAYLOAD_HEIGHT],
                                        [PAYLOAD_RADIUS, h + PAYLOAD_HEIGHT]]), th)  # fmt: skip
            rod = axle + _rot(np.array([[-w / 3, h], [-w / 3, h + PAYLOAD_HEIGHT], [np.nan, np.nan],
                                        [w / 3, h], [w / 3, h + PAYLOAD_HEIGHT]]), th)  # fmt: skip
            self.payload.set_data(pan[:, 0], pan[:, 1])
            self.rods.set_data(rod[:, 0], rod[:, 1])
        self.clock.set_text(f"t = {f.t[i]:.2f} s   theta = {th:+.3f} rad")
        stopped = final and self.run.status != "ok"
        self.banner.set_text(f"{self.run.status.upper()} at t = {self.run.t_end:.2f} s"
                             if stopped else "")  # fmt: skip
        x, y, a = float(f.x[i]), float(f.y[i]), float(f.alpha[i])
        self.trail.set_data(f.x[: i + 1], f.y[: i + 1])
        nx, ny = -np.sin(a) * self.b, np.cos(a) * self.b
        self.axle.set_data([x - nx, x + nx], [y - ny, y + ny])
        L = 1.5 * self.b
        self.heading.set_data([x, x + L * np.cos(a)], [y, y + L * np.sin(a)])
        for c in self.cursors:
            c.set_xdata([f.t[i], f.t[i]])
