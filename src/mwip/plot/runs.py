"""Finding a run in a folder that ``mwip simulate --out`` or a study wrote.

A *run* is one :class:`~mwip.sim.result.SimResult` saved as ``.npz`` (single robot), with what
a drawing of it needs beyond the time series:

- the robot's geometry (wheel radius ``r``, half track ``b``, centre-of-mass height ``l``):
  from ``plant.toml`` beside a ``simulate`` run, from the results folder's ``run.json``
  (``params.plant``) for a study, else the book's real robot (Table 3.1);
- whether the payload of Chapter 6 is on (Cases 2 and 3, :data:`mwip.hardware.twin.CASES`):
  a run named ``...case2...``/``...case3...``, or a study whose settings hold a ``stick``
  (Case 3 crosses a stick with the payload on);
- the wheel-speed reference ``psi'_d`` (rad/s) where the run has one: ``reference`` in a
  ``simulate`` run's ``summary.json``; in a study's settings the first of
  :data:`SPEED_SETTINGS` (rad/s) or ``v_d`` (m/s, divided by the plant's ``r``).

Folders that hold no run are a one-line :class:`RunFolderError` (a ``ValueError``) saying what
is expected.
"""

from __future__ import annotations

import json
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mwip.params import REAL, Params, load_params
from mwip.sim.result import SimResult

__all__ = [
    "Run",
    "RunFolderError",
    "SPEED_SETTINGS",
    "find_runs",
    "load_run",
    "main_run_name",
]

#: Study settings that hold the wheel-speed reference psi'_d in rad/s (the scenarios' names).
SPEED_SETTINGS = ("psi_dot_d", "q1d_dot", "speed")

EXPECTED = (
    "expected a folder written by `mwip simulate --out` (timeseries.npz) or a study's folder "
    "(OUT/<study>/ with metrics.json and <run>.npz), or a run's .npz file"
)


class RunFolderError(ValueError):
    """Input that cannot be drawn: no run at the path, a run too short, an output format that
    is not supported (a ``ValueError``; the message is one line saying what is expected)."""


@dataclass(frozen=True)
class Run:
    """One run to draw: its time series truncated at its stop time, and its context."""

    name: str
    result: SimResult
    params: Params
    payload: bool
    reference: float | None
    source: Path
    study: str | None = None
    #: the drive's wheel-torque limit (N m) of the robot the run stands for; ``None``: the
    #: default twin's (:func:`mwip.plot.run_figure.torque_limit`)
    torque_limit: float | None = None

    @property
    def status(self) -> str:
        return str(self.result.status[0])

    @property
    def t_end(self) -> float:
        return float(self.result.t_end[0])


def _is_simresult(path: Path) -> bool:
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
    except (OSError, zipfile.BadZipFile):
        return False
    return {"t.npy", "states.npy", "inputs.npy", "status.npy"} <= names


def find_runs(folder: Path) -> dict[str, Path]:
    """The runs saved in ``folder``: run name -> ``.npz`` path (other ``.npz`` files, such as
    sliding-variable replays, are skipped), in the order of ``metrics.json``'s ``runs`` where
    it has one, then by name."""
    folder = Path(folder)
    found = {p.stem: p for p in sorted(folder.glob("*.npz")) if _is_simresult(p)}
    order: list[str] = []
    doc = _metrics(folder)
    for name in (doc or {}).get("runs", {}):
        for key in (name, name.replace(".", "_")):
            if key in found and key not in order:
                order.append(key)
    order += [k for k in found if k not in order]
    return {k: found[k] for k in order}


def main_run_name(folder: Path, runs: dict[str, Path] | None = None) -> str:
    """The run a study is shown by: the catalog's ``main_run`` for the study where it names a
    run that is there, else the first run (:func:`find_runs`)."""
    from mwip.schema.texts import study_texts

    folder = Path(folder)
    runs = find_runs(folder) if runs is None else runs
    if not runs:
        raise RunFolderError(f"{folder}: no run found; {EXPECTED}")
    doc = _metrics(folder) or {}
    wanted = study_texts(str(doc.get("study", folder.name))).get("main_run")
    if wanted:
        for key in (wanted, wanted.replace(".", "_")):
            if key in runs:
                return key
    return next(iter(runs))


def _metrics(folder: Path) -> dict[str, Any] | None:
    try:
        doc = json.loads((Path(folder) / "metrics.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def _json(path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _study_plant(folder: Path) -> Params:
    record = _json(folder.parent / "run.json")
    plant = (record.get("params") or {}).get("plant")
    if isinstance(plant, dict):
        try:
            return Params.from_dict(plant, base=REAL)
        except (TypeError, ValueError):
            pass
    return REAL


def _speed_reference(settings: dict[str, Any], r: float) -> float | None:
    for key in SPEED_SETTINGS:
        val = settings.get(key)
        if isinstance(val, int | float) and not isinstance(val, bool):
            return float(val)
    vd = settings.get("v_d")
    if isinstance(vd, int | float) and not isinstance(vd, bool):
        return float(vd) / r
    return None


def _read(path: Path) -> SimResult:
    try:
        res = SimResult.from_npz(path)
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        raise RunFolderError(f"{path}: not a readable run ({exc}); {EXPECTED}") from None
    if res.n_plants != 1:
        raise RunFolderError(f"{path}: holds a batch of {res.n_plants} robots; expected one run")
    return res.plant(0)


def load_run(path: Path, name: str | None = None) -> Run:
    """The run at ``path``: a ``simulate`` output folder, a study folder (run ``name``, default
    its main run, :func:`main_run_name`) or a run's ``.npz`` file."""
    path = Path(path)
    if not path.exists():
        raise RunFolderError(f"{path}: does not exist; {EXPECTED}")
    if path.is_file():
        if path.suffix != ".npz" or not _is_simresult(path):
            raise RunFolderError(f"{path}: not a run's .npz file; {EXPECTED}")
        folder, runs = path.parent, {path.stem: path}
        name = path.stem
    else:
        folder = path
        runs = find_runs(folder)
        if not runs:
            hint = ""
            if (folder / "run.json").is_file():
                hint = " (this is a results folder: give one study's folder, e.g. OUT/lqr-gain)"
            raise RunFolderError(f"{folder}: no run found{hint}; {EXPECTED}")
        if name is None:
            name = main_run_name(folder, runs)
        elif name not in runs and name.replace(".", "_") not in runs:
            raise RunFolderError(f"--run: no run {name!r} in {folder}; choose from: "
                                 f"{', '.join(runs)}")  # fmt: skip
        else:
            name = name if name in runs else name.replace(".", "_")
    res = _read(runs[name])
    doc = _metrics(folder)
    if doc is not None:  # a study's run
        params = _study_plant(folder)
        settings = doc.get("settings") or {}
        payload = bool(re.search(r"case[23]", name)) or "stick" in settings
        reference = _speed_reference(settings, float(params.r))
        return Run(name=name, result=res, params=params, payload=payload, reference=reference,
                   source=runs[name], study=str(doc.get("study", folder.name)))  # fmt: skip
    params = REAL
    if (folder / "plant.toml").is_file():
        params = load_params(folder / "plant.toml", base=REAL)
    summary = _json(folder / "summary.json")
    ref = summary.get("reference")
    reference = float(ref) if isinstance(ref, int | float) and not isinstance(ref, bool) else None
    return Run(name=name, result=res, params=params, payload=False, reference=reference,
               source=runs[name])  # fmt: skip


def records(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """``(t, state)`` of the run up to its stop, ending with the state at the stop time (for a
    fallen run, the moment it fell: the row after the last record)."""
    res = run.result
    t = np.asarray(res.t, dtype=float)
    x = np.asarray(res.state, dtype=float)
    keep = np.all(np.isfinite(x), axis=1)
    t, x = t[keep], x[keep]
    t_end = run.t_end
    fin = np.asarray(res.final_state[0], dtype=float)
    if np.all(np.isfinite(fin)) and (t.size == 0 or t_end > t[-1] + 1e-12):
        t = np.append(t, t_end)
        x = np.vstack([x, fin])
    return t, x
