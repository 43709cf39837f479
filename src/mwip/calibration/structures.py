"""The declared twin structures of the book calibration's revision 6 (``book-structures.toml``,
beside this module; SPEC.md "Twin structure").

A structure is a twin (the board's program: torque gain, gyro zeroing, fusion filter) and the
prior of its unknowns. ``S0`` is revisions 1-5's (:data:`mwip.calibration.structure.BOOK_PRIOR`
on the default twin); each other structure extends one: its ``firmware`` switches, unknowns
added (from the twin's declared prior :data:`mwip.hardware.prior.PRIOR`, or declared in the
file with their source), unknowns dropped. Every structure's Case 2/3 payload prior is the
file's ``[payload]`` (both of the book's sentences). The file is read, never computed: it was
committed before any draw of its structures.

Draws are made in the prior's *unit coordinates* ``u`` in ``[0, 1]^D``, where every prior
(uniform or log-uniform per unknown) is uniform with density 1: ``x_j = F_j^-1(u_j)``
(:meth:`mwip.hardware.unknown.Unknown.from_unit`), so that a box drawn in them (stage B's,
:mod:`mwip.calibration.comparison`) treats every unknown alike.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.prior import PRIOR, Prior, Unknown

__all__ = ["Structure", "SamplePlan", "STRUCTURES_FILE", "load_structures", "load_plan",
           "load_directed", "load_importance"]  # fmt: skip

STRUCTURES_FILE = Path(__file__).with_name("book-structures.toml")

_ENTRY = ("low", "high", "unit", "source", "scale")


@dataclass(frozen=True)
class Structure:
    """One declared structure: ``name``, ``title``, the base ``twin`` (its firmware
    switches) whose ``prior`` is this structure's."""

    name: str
    title: str
    twin: Any

    @property
    def prior(self) -> Prior:
        pr: Prior = self.twin.prior
        return pr

    def to_unit(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Values (N, D) to unit coordinates (the inverse of :meth:`from_unit`)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return np.column_stack([unk.to_unit(x[:, j])
                                for j, unk in enumerate(self.prior.unknowns)])  # fmt: skip

    def from_unit(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Unit coordinates (N, D) to values (each unknown's ``from_unit``)."""
        u = np.atleast_2d(np.asarray(u, dtype=float))
        return np.column_stack([unk.from_unit(u[:, j])
                                for j, unk in enumerate(self.prior.unknowns)])  # fmt: skip

    def values(self, x: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """Rows (N, D) of values as ``{name: (N,)}`` for :func:`runs.run_batch`."""
        return self.prior.as_values(x)


@dataclass(frozen=True)
class SamplePlan:
    """The declared sample of every structure (the file's ``[sample]``)."""

    prior_draws: int
    kernel_draws: int
    factor: float
    seed: int
    block: int


def _read(path: Path | None) -> dict[str, Any]:
    p = STRUCTURES_FILE if path is None else Path(path)
    with p.open("rb") as fh:
        return tomllib.load(fh)


def load_plan(path: Path | None = None) -> SamplePlan:
    """The declared ``[sample]`` (a ``ValueError`` naming a bad field)."""
    s = _read(path)["sample"]
    for key, lo in (("prior_draws", 1), ("kernel_draws", 0), ("seed", 0), ("block", 1)):
        v = s.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"sample.{key} must be an integer >= {lo}, got {v!r}")
    f = s.get("factor")
    if isinstance(f, bool) or not isinstance(f, int | float) or not 0 < f <= 10:
        raise ValueError(f"sample.factor must be a number in (0, 10], got {f!r}")
    return SamplePlan(int(s["prior_draws"]), int(s["kernel_draws"]), float(f), int(s["seed"]),
                      int(s["block"]))  # fmt: skip


def load_directed(path: Path | None = None) -> Any:
    """Revision 8's declared stage C (:class:`mwip.calibration.directed.DirectedPlan`), or
    ``None`` where the file declares none (a ``ValueError`` naming a bad field)."""
    from mwip.calibration.directed import DirectedPlan

    r = _read(path).get("revision_8")
    if r is None:
        return None
    for key, lo in (("generations", 0), ("per_generation", 1), ("parents", 1), ("seed", 0)):
        v = r.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise ValueError(f"revision_8.{key} must be an integer >= {lo}, got {v!r}")
    m = r.get("min_step")
    if isinstance(m, bool) or not isinstance(m, int | float) or not 0 < m <= 1:
        raise ValueError(f"revision_8.min_step must be a number in (0, 1], got {m!r}")
    return DirectedPlan(int(r["generations"]), int(r["per_generation"]), int(r["parents"]),
                        float(m), int(r["seed"]))  # fmt: skip


def load_importance(path: Path | None = None) -> Any:
    """Revision 9's declared stage D (:class:`mwip.calibration.importance.ImportancePlan`), or
    ``None`` where the file declares none (a ``ValueError`` naming a bad field)."""
    from mwip.calibration.importance import ImportancePlan

    r = _read(path).get("revision_9")
    if r is None:
        return None
    f = r.get("factors")
    if not isinstance(f, list) or not all(isinstance(x, int | float) and not isinstance(x, bool)
                                          for x in f):  # fmt: skip
        raise ValueError(f"revision_9.factors must be a list of numbers, got {f!r}")
    a = r.get("defensive")
    if isinstance(a, bool) or not isinstance(a, int | float):
        raise ValueError(f"revision_9.defensive must be a number in (0, 1), got {a!r}")
    return ImportancePlan(r.get("draws"), float(a), tuple(float(x) for x in f), r.get("seed"))


def _unknown(name: str, e: dict[str, Any]) -> Unknown:
    bad = sorted(set(e) - set(_ENTRY))
    if bad:
        raise ValueError(f"structures: {name}: unknown key {bad[0]!r}; allowed: "
                         f"{', '.join(_ENTRY)}")  # fmt: skip
    prefix = name.rsplit(".", 1)[0]  # the element of the twin's unknowns of the same table
    element = next((u.element for u in PRIOR.unknowns if u.name.rsplit(".", 1)[0] == prefix),
                   name.split(".")[0])  # fmt: skip
    mid = float(np.sqrt(e["low"] * e["high"])) if e.get("scale") == "log" else (
        0.5 * (e["low"] + e["high"]))
    return Unknown(name, e["low"], e["high"], e.get("unit", ""), e.get("source", ""), element,
                   mid, scale=e.get("scale", "linear"))  # fmt: skip


def _firmware(twin: Any, sw: dict[str, Any]) -> Any:
    from mwip.hardware.fusion import FusionSpec

    fw = twin.firmware
    for key, v in sw.items():
        if key == "gyro_zeroing":
            fw = replace(fw, gyro_zeroing=bool(v))
        elif key == "fusion":
            fw = replace(fw, fusion=FusionSpec(kind=v))
        else:
            raise ValueError(f"structures: firmware.{key}: allowed: gyro_zeroing, fusion")
    return replace(twin, firmware=fw)


def load_structures(path: Path | None = None, *, base: Any = None) -> dict[str, Structure]:
    """The declared structures in file order (module docstring); ``base`` the twin whose
    hardware they share (default: the twin the book calibration runs, ``Twin()``)."""
    from mwip.calibration.structure import BOOK_PRIOR
    from mwip.hardware.twin import Twin

    doc = _read(path)
    payload = {n: _unknown(n, e) for n, e in doc.get("payload", {}).items()}
    tw0 = Twin() if base is None else base
    out: dict[str, Structure] = {}
    for name, s in doc["structures"].items():
        if "base" in s:
            if s["base"] != "book":
                raise ValueError(f"structures.{name}.base: allowed: 'book'")
            unknowns = list(BOOK_PRIOR.unknowns)
            twin = replace(tw0, firmware=replace(tw0.firmware, torque_gain=1.0,
                                                 gyro_zeroing=False))  # fmt: skip
        else:
            parent = out.get(s.get("extends", ""))
            if parent is None:
                raise ValueError(f"structures.{name}.extends: name a structure declared "
                                 f"before it ({', '.join(out)})")  # fmt: skip
            unknowns = list(parent.prior.unknowns)
            twin = parent.twin
        twin = _firmware(twin, s.get("firmware", {}))
        drop = set(s.get("drop", []))
        unknowns = [u for u in unknowns if u.name not in drop]
        for n in s.get("add", []):
            unknowns.append(PRIOR[n])
        for n, e in s.get("unknowns", {}).items():
            unknowns.append(_unknown(n, e))
        unknowns = [payload.get(u.name, u) for u in unknowns]
        out[name] = Structure(name, str(s["title"]), replace(twin, prior=Prior(tuple(unknowns))))
    return out
