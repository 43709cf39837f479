"""The result of a simulation: named time series, per-plant status, export.

Series are stored batch-first, ``(N, K, ...)`` for N plants and K records. For a run that was
given a single robot (not a batch) the accessors drop the batch axis, so ``res.theta`` is
``(K,)``. Rows after a plant stopped ("fell"/"diverged") are NaN; ``t_end`` says when it
stopped and ``final_state`` holds its state at that moment.
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.io import write_atomic, write_text_atomic

__all__ = ["SimResult", "STATE_COLUMNS"]

STATE_COLUMNS: tuple[str, ...] = (
    "psi", "theta", "alpha", "psi_dot", "theta_dot", "alpha_dot", "x", "y",
)  # fmt: skip


@dataclass
class SimResult:
    """Time series of a (batch of) simulation(s).

    Attributes
    ----------
    t : (K,) record times (s)
    states : (N, K, 8) ``[psi, theta, alpha, psi', theta', alpha', x, y]``
    inputs : (N, K, 2) controller output ``[u_r, u_l]`` computed at each record time

    The properties ``state``, ``u``, ``q``, ``q_dot``, ``theta``, ``v``, ``x``, ... give the
    same data without the batch axis for a single run.
    logs : name -> (N, K, ...) whatever the controller logged
    status : (N,) ``"ok"``, ``"fell"`` or ``"diverged"``
    t_end : (N,) time the plant stopped (the duration when ``ok``)
    final_state : (N, 8) state at ``t_end``
    r : (N,) wheel radius of each plant (for ``v = r psi'``)
    batched : whether the run was given a batch
    settings : the run's settings (dt, Ts, mode, ...)
    """

    t: NDArray[np.float64]
    states: NDArray[np.float64]
    inputs: NDArray[np.float64]
    status: NDArray[np.str_]
    t_end: NDArray[np.float64]
    final_state: NDArray[np.float64]
    r: NDArray[np.float64]
    batched: bool
    logs: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)

    # ---- accessors ------------------------------------------------------------------------
    def _out(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        return a if self.batched else a[0]

    def series(self) -> dict[str, NDArray[np.float64]]:
        """All named series, batch axis dropped for a single run."""
        out: dict[str, NDArray[np.float64]] = {
            name: self._out(self.states[..., i]) for i, name in enumerate(STATE_COLUMNS)
        }
        out["v"] = self.v
        out["u_r"] = self._out(self.inputs[..., 0])
        out["u_l"] = self._out(self.inputs[..., 1])
        for name, arr in self.logs.items():
            out[name] = self._out(arr)
        return out

    @property
    def state(self) -> NDArray[np.float64]:
        """State records, (N, K, 8) or (K, 8)."""
        return self._out(self.states)

    @property
    def u(self) -> NDArray[np.float64]:
        """Controller outputs ``[u_r, u_l]``, (N, K, 2) or (K, 2)."""
        return self._out(self.inputs)

    @property
    def n_plants(self) -> int:
        return int(self.states.shape[0])

    @property
    def q(self) -> NDArray[np.float64]:
        """``[psi, theta, alpha]``, (N, K, 3) or (K, 3)."""
        return self._out(self.states[..., 0:3])

    @property
    def q_dot(self) -> NDArray[np.float64]:
        """``[psi', theta', alpha']``."""
        return self._out(self.states[..., 3:6])

    qdot = q_dot

    @property
    def theta(self) -> NDArray[np.float64]:
        return self._out(self.states[..., 1])

    @property
    def alpha(self) -> NDArray[np.float64]:
        return self._out(self.states[..., 2])

    @property
    def v(self) -> NDArray[np.float64]:
        """Forward speed ``v = r psi'`` (m/s)."""
        return self._out(self.r[:, None] * self.states[..., 3])

    @property
    def x(self) -> NDArray[np.float64]:
        return self._out(self.states[..., 6])

    @property
    def y(self) -> NDArray[np.float64]:
        return self._out(self.states[..., 7])

    @property
    def ok(self) -> bool:
        """True when every plant finished with status ``"ok"``."""
        return bool(np.all(self.status == "ok"))

    def valid(self) -> NDArray[np.bool_]:
        """(N, K) mask of rows recorded before the plant stopped."""
        return self.t[None, :] <= self.t_end[:, None] + 1e-12

    def plant(self, i: int) -> SimResult:
        """The result of plant ``i`` alone, as a single run truncated at its stop time."""
        keep = self.valid()[i]
        return SimResult(
            t=self.t[keep],
            states=self.states[i : i + 1, keep],
            inputs=self.inputs[i : i + 1, keep],
            status=self.status[i : i + 1],
            t_end=self.t_end[i : i + 1],
            final_state=self.final_state[i : i + 1],
            r=self.r[i : i + 1],
            batched=False,
            logs={k: v[i : i + 1, keep] for k, v in self.logs.items()},
            settings=dict(self.settings),
        )

    # ---- export ---------------------------------------------------------------------------
    def columns(self) -> dict[str, NDArray[np.float64]]:
        """Flat columns in long format (one row per plant and record)."""
        n, k = self.states.shape[:2]
        cols: dict[str, NDArray[np.float64]] = {}
        if self.batched:
            cols["plant"] = np.repeat(np.arange(n), k).astype(float)
        cols["t"] = np.tile(self.t, n)
        for i, name in enumerate(STATE_COLUMNS):
            cols[name] = self.states[..., i].reshape(-1)
        cols["v"] = (self.r[:, None] * self.states[..., 3]).reshape(-1)
        cols["u_r"] = self.inputs[..., 0].reshape(-1)
        cols["u_l"] = self.inputs[..., 1].reshape(-1)
        for name, arr in self.logs.items():
            flat = arr.reshape(n * k, -1)
            if flat.shape[1] == 1:
                cols[name] = flat[:, 0]
            else:
                for j in range(flat.shape[1]):
                    cols[f"{name}_{j}"] = flat[:, j]
        return cols

    def to_dataframe(self) -> Any:
        """A pandas DataFrame of :meth:`columns` (needs the optional ``pandas`` extra)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_dataframe needs pandas: pip install 'mwip[pandas]'") from exc
        df = pd.DataFrame(self.columns())
        if "plant" in df:
            df["plant"] = df["plant"].astype(int)
        return df

    def to_csv(self, path: str | Path) -> Path:
        """Write :meth:`columns` as CSV (atomically)."""
        cols = self.columns()
        buf = io.StringIO()
        buf.write(",".join(cols) + "\n")
        np.savetxt(buf, np.column_stack(list(cols.values())), delimiter=",", fmt="%.10g")
        return write_text_atomic(path, buf.getvalue())

    def to_npz(self, path: str | Path) -> Path:
        """Write all arrays to a compressed ``.npz`` (atomically); see :meth:`from_npz`."""
        arrays: dict[str, Any] = {
            "t": self.t, "states": self.states, "inputs": self.inputs,
            "status": self.status.astype(str), "t_end": self.t_end,
            "final_state": self.final_state, "r": self.r, "batched": np.array(self.batched),
        }  # fmt: skip
        for name, arr in self.logs.items():
            arrays[f"log__{name}"] = arr
        return write_atomic(path, lambda fh: np.savez_compressed(fh, **arrays))

    @classmethod
    def from_npz(cls, path: str | Path) -> SimResult:
        """Read a result written by :meth:`to_npz`."""
        with np.load(path) as z:
            logs = {k[5:]: z[k] for k in z.files if k.startswith("log__")}
            return cls(
                t=z["t"], states=z["states"], inputs=z["inputs"], status=z["status"],
                t_end=z["t_end"], final_state=z["final_state"], r=z["r"],
                batched=bool(z["batched"]), logs=logs,
            )  # fmt: skip

    def summary(self) -> Mapping[str, Any]:
        """Status, settling time of theta (``nan`` for a plant that fell or diverged), max |u|
        (per plant for a batch)."""
        from mwip.metrics import settling_time

        th = self.states[..., 1]
        st = np.array([settling_time(self.t, th[i], status=str(self.status[i]))
                       for i in range(self.n_plants)])  # fmt: skip
        umax = np.nanmax(np.abs(self.inputs), axis=(1, 2))
        out = {"status": self.status, "t_end": self.t_end, "settling_time": st, "max_abs_u": umax}
        if not self.batched:
            return {k: (str(v[0]) if k == "status" else float(v[0])) for k, v in out.items()}
        return out
