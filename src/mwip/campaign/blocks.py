"""One block of a robustness campaign: its samples as one batch of the engine per controller.

Block ``b`` holds samples ``b B .. (b + 1) B - 1`` (``B`` = ``campaign.block``). Each
controller, designed once on the design model (``campaign.design``), runs the whole block in
one call of :func:`mwip.sim.simulate`: batched :class:`Params` with (B,) fields (the samples'
robots), ``q0``/``qdot0`` (B, 3), a disturbance returning (K, B, 3) and, with twin sensors,
the digital twin's sensors and/or drive for the batch (:mod:`mwip.hardware.twin`, Chapter 6),
seeded from (campaign seed, b). The block is the numerical unit: the same block is computed
with the same batch size and noise stream wherever and with whatever chunk it runs, so every
row is bit-identical across chunk sizes, job counts and schedulers.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.campaign.metrics import sample_metrics
from mwip.campaign.sampling import block_seed, draw
from mwip.campaign.spec import Campaign, ControllerEntry
from mwip.core import Controller
from mwip.params import Params
from mwip.sim.disturbance import Disturbance, disturbance_from_dict

__all__ = ["build_controllers", "run_block", "block_samples"]


def block_samples(campaign: Campaign, block: int) -> NDArray[np.int64]:
    """The sample indices of ``block`` (whole blocks; rows >= N are dropped later)."""
    return np.arange(block * campaign.block, (block + 1) * campaign.block, dtype=np.int64)


def build_controllers(campaign: Campaign) -> dict[str, Controller]:
    """Every controller of the campaign designed on the design model, by label."""
    from mwip.laws.registry import build

    return {
        c.label: build(c.name, campaign.design, c.settings_dict()) for c in campaign.controllers
    }


class _PerSample:
    """A disturbance per sample: sample j gets ``parts[choice[j]]`` (or none)."""

    def __init__(self, parts: list[Disturbance | None], choice: NDArray[np.int64]) -> None:
        self.n = choice.size
        self.used = [(p, choice == k) for k, p in enumerate(parts) if p is not None]
        self.used = [(p, m) for p, m in self.used if m.any()]

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((np.size(t), self.n, 3))
        for part, mask in self.used:
            out[:, mask, :] = np.asarray(part(t), dtype=float)[:, None, :]
        return out

    @property
    def column_of(self) -> NDArray[np.int64]:
        """Sample j's column of :meth:`columns` (0: none)."""
        col = np.zeros(self.n, dtype=np.int64)
        for k, (_, mask) in enumerate(self.used):
            col[mask] = k + 1
        return col

    def columns(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """The distinct disturbances, (K, 1 + parts, 3): zero, then each part used; sample j's
        is column ``column_of[j]`` (the same numbers as its column of the call, without the
        (K, N, 3) table: the twin's compiled loop, :func:`mwip.sim.engine.simulate`)."""
        out = np.zeros((np.size(t), 1 + len(self.used), 3))
        for k, (part, _) in enumerate(self.used):
            out[:, k + 1, :] = np.asarray(part(t), dtype=float)
        return out


def _disturbance(campaign: Campaign, labels: NDArray) -> Disturbance | None:
    names = [label for label, _ in campaign.disturbances]
    parts: list[Disturbance | None] = [
        None if d.get("kind") == "none" else disturbance_from_dict(d)
        for _, d in campaign.disturbances
    ]
    choice = np.array([names.index(x) for x in labels], dtype=np.int64)
    if all(parts[c] is None for c in set(choice.tolist())):
        return None
    return _PerSample(parts, choice)


def _v_ref(entry: ControllerEntry, design: Params) -> float:
    from mwip.laws.registry import get

    s = get(entry.name).resolve(entry.settings_dict())
    if "v_d" in s:
        return float(s["v_d"])
    if "psi_dot_d" in s:
        return float(design.r) * float(s["psi_dot_d"])
    return 0.0


def run_block(
    campaign: Campaign, block: int, controllers: Mapping[str, Controller], repeat: int = 1
) -> list[dict[str, NDArray]]:
    """The rows of ``block``, one table (column -> (B,) array) per controller: columns
    ``controller``, ``sample``, the sample's inputs, ``noise_seed`` and the metrics
    (:mod:`mwip.campaign.metrics`).

    ``repeat = k > 1``: the block's B robots are run ``k`` times in one batch (robot
    ``j B + i`` is sample ``i``, for a controller whose robot ``j B + i`` runs candidate ``j``,
    e.g. :func:`mwip.laws.batch.batch` with ``repeat = B``); the tables have ``k B`` rows in
    that order. The twin's sensor noise is drawn for the ``k B`` robots of the batch, so the
    copies of a sample see different noise (the plant, the start and the disturbance are the
    sample's)."""
    from mwip.sim.engine import simulate

    idx = block_samples(campaign, block)
    inputs = draw(campaign, idx)
    k = int(repeat)
    if k < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat!r}")
    if k > 1:
        inputs = {key: np.tile(np.asarray(v), k) for key, v in inputs.items()}
    n = idx.size * k
    fields = {k_: inputs[k_] for k_, _ in campaign.uncertainty}
    plant = replace(campaign.centre, **fields) if fields else campaign.centre
    pb = {f: np.broadcast_to(np.asarray(getattr(plant, f), dtype=float), (n,)) for f in "rb"}
    q0 = np.column_stack([inputs["psi0"], inputs["theta0"], inputs["alpha0"]])
    qdot0 = np.column_stack([inputs["psi_dot0"], inputs["theta_dot0"], inputs["alpha_dot0"]])
    seed = block_seed(campaign.seed, block)
    dist = _disturbance(campaign, inputs["disturbance"])
    rows: list[dict[str, NDArray]] = []
    for entry in campaign.controllers:
        ctrl = copy.deepcopy(controllers[entry.label])
        kw: dict[str, Any] = {}
        if "twin" in (campaign.sensors, campaign.drive):
            from mwip.robot import robot_or_default

            # the robot's twin (default: the book's robot's identified twin), its sensors or
            # drive ideal on request
            twin = replace(robot_or_default(campaign.robot).twin,
                           ideal_sensors=campaign.sensors == "ideal",
                           ideal_actuator=campaign.drive == "ideal")  # fmt: skip
            # the plant the twin integrates: reflected rotor inertia and the back-EMF and
            # viscous damping on Db (as run_on_twin; the drive returns the rest of the torque)
            sim_plant = twin.plant(plant)
            # each sample's own wheel geometry and drive-train mobility: the chains take them
            # per robot from the plant the twin integrates
            sensor = twin.sensor(sim_plant)
            actuator = twin.actuator(sim_plant)
            kw = {"sensor": sensor, "actuator": actuator, "Ts": twin.Ts, "dt": twin.dt}
        else:
            sim_plant = plant
        res = simulate(
            ctrl,
            sim_plant,
            q0=q0,
            qdot0=qdot0,
            duration=campaign.duration,
            disturbance=dist,
            seed=seed,
            **kw,
        )
        met = sample_metrics(res, pb["b"], _v_ref(entry, campaign.design), campaign.success_theta)
        cols: dict[str, Any] = {"controller": np.full(n, entry.label, dtype=object)}
        cols.update(inputs)
        cols["noise_seed"] = np.full(n, seed, dtype=np.int64)
        cols.update(met)
        rows.append(cols)
    return rows
