"""Evaluating candidate settings on a set of robots: the one place a tuning run simulates.

A :class:`RobotSet` is a robustness campaign (:mod:`mwip.campaign.spec`: the robot
distribution, initial states, disturbances, sensors and drive, duration) cut into blocks of
``chunk`` robots: robot ``i`` is the campaign's sample ``i`` (drawn from the campaign seed and
``i`` alone, :mod:`mwip.campaign.sampling`), and block ``b``'s sensor noise is seeded from
(seed, b). So every candidate meets the same robots with the same noise (common random
numbers), whether its blocks are run together or one at a time (pruning).

:func:`evaluate` runs each candidate through :func:`mwip.campaign.blocks.run_block`, the
campaign's own block runner, on the twin or on the plain plant as the campaign says: one
engine batch per (candidate, block). When the laws take one packed parameter vector per robot,
a whole population (a CMA-ES generation) becomes one batch here, and nothing else changes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.campaign.spec import Campaign, ControllerEntry

__all__ = ["RobotSet", "robot_set", "evaluate", "METRIC_KEYS"]

#: The per-robot metrics :func:`evaluate` returns (:mod:`mwip.campaign.metrics`).
METRIC_KEYS: tuple[str, ...] = ("success", "status", "rms_theta", "rms_speed_error",
                                "peak_torque", "control_tv", "energy", "fall_time")  # fmt: skip


@dataclass(frozen=True)
class RobotSet:
    """``samples`` robots of ``campaign`` in blocks of ``campaign.block`` (= ``chunk``)."""

    campaign: Campaign
    samples: int

    @property
    def chunk(self) -> int:
        return int(self.campaign.block)

    @property
    def n_blocks(self) -> int:
        return self.samples // self.chunk

    @property
    def plant_seconds(self) -> float:
        """Simulated robot-seconds of one candidate on the whole set."""
        return self.samples * float(self.campaign.duration)


def robot_set(
    campaign: str | Campaign,
    samples: int,
    chunk: int,
    seed: int,
    plant: str = "campaign",
    duration: float | None = None,
    success_theta: float | None = None,
    robot: Any = None,
) -> RobotSet:
    """The robots of ``campaign`` (built-in name, file or :class:`Campaign`) with ``seed``;
    ``plant``: ``twin`` (the twin's sensors and drive), ``plain`` (ideal both) or
    ``campaign`` (as the campaign says); ``robot`` (a :class:`mwip.robot.Robot` or a robot
    file) replaces the campaign's robot (for a campaign given by name or file)."""
    import math

    from mwip.campaign.spec import load_campaign

    if not isinstance(campaign, str | Campaign):
        raise TypeError(f"'campaign' must be a campaign name, file or Campaign, got "
                        f"{type(campaign).__name__}")  # fmt: skip
    for name, v in (("samples", samples), ("chunk", chunk), ("seed", seed)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer):
            raise TypeError(f"{name!r} must be an integer, got {v!r}")
    if not 1 <= samples <= 10**7:
        raise ValueError(f"'samples' must be in [1, 10000000], got {samples!r}")
    if not 1 <= chunk <= samples:
        raise ValueError(f"'chunk' must be in [1, samples = {samples}], got {chunk!r}")
    if not 0 <= seed < 2**63:
        raise ValueError(f"'seed' must be in [0, 2^63), got {seed!r}")
    for name, x, hi in (("duration", duration, 3600.0), ("success_theta", success_theta, 1.5)):
        if x is None:
            continue
        if isinstance(x, bool) or not isinstance(x, int | float | np.floating):
            raise TypeError(f"{name!r} must be a number, got {x!r}")
        if not (math.isfinite(x) and 0 < x <= hi):
            raise ValueError(f"{name!r} must be in (0, {hi:g}], got {x!r}")
    if robot is not None and not isinstance(campaign, str):
        raise ValueError("robot: give the robot in the Campaign itself (load_campaign(..., "
                         "robot=...)) when passing a Campaign")  # fmt: skip
    camp = load_campaign(campaign, robot=robot) if isinstance(campaign, str) else campaign
    if camp.kind != "robustness":
        raise ValueError(f"objective robots.campaign must be a robustness campaign, got kind "
                         f"{camp.kind!r}")  # fmt: skip
    if samples % chunk:
        raise ValueError(f"robots: chunk {chunk} must divide samples {samples}")
    changes: dict[str, Any] = {"seed": seed, "block": chunk, "samples": samples}
    if plant == "twin":
        changes.update(sensors="twin", drive="twin")
    elif plant == "plain":
        changes.update(sensors="ideal", drive="ideal")
    elif plant != "campaign":
        raise ValueError(f"plant must be one of twin, plain, campaign; got {plant!r}")
    if duration is not None:
        changes["duration"] = float(duration)
    if success_theta is not None:
        changes["success_theta"] = float(success_theta)
    from mwip.budget import DEFAULT, estimate

    dur = float(changes.get("duration", camp.duration))
    DEFAULT.check(estimate(dur, 0.005, 0.005, n=chunk), "one chunk of robots",
                  "lower robots.chunk or robots.duration")  # fmt: skip
    return RobotSet(replace(camp, **changes), samples)


def _blocks(robots: RobotSet, blocks: Sequence[int] | None) -> list[int]:
    todo = list(range(robots.n_blocks)) if blocks is None else [int(b) for b in blocks]
    for b in todo:
        if not 0 <= b < robots.n_blocks:
            raise ValueError(f"block {b} is outside the robot set's {robots.n_blocks} blocks")
    return todo


def evaluate(
    name: str,
    candidates: Sequence[Mapping[str, Any]],
    robots: RobotSet,
    *,
    blocks: Sequence[int] | None = None,
) -> list[dict[str, NDArray]]:
    """The per-robot metrics of every candidate (settings of controller ``name``) on
    ``robots`` (its ``blocks``, default all, in order): one dict per candidate, each metric
    of :data:`METRIC_KEYS` an array over the robots.

    Each candidate is designed on the campaign's design model (the nominal parameters: the
    controller never sees the robot it runs on). A candidate whose design fails (a
    ``ValueError`` or ``LinAlgError`` of its construction) fails on every robot.

    Several candidates of a law with a packed form (:mod:`mwip.laws.packing`) run as one
    batch per block: one parameter vector per robot (:class:`mwip.laws.batch.PackedController`,
    candidate ``j`` on robots ``j B .. j B + B - 1``), the robots of the block repeated once per
    candidate (:func:`mwip.campaign.blocks.run_block` with ``repeat``). On the plain plant this
    gives each candidate exactly its own run's numbers; on the twin each copy of a robot draws
    its own sensor noise.
    """
    from mwip.campaign.blocks import run_block
    from mwip.laws.registry import get

    spec = get(name)
    todo = _blocks(robots, blocks)
    built: list[Any] = []
    for settings in candidates:
        given = spec.resolve(settings)  # outside the allowed range: ValueError, not a failure
        try:
            built.append(spec.build(robots.campaign.design, given))
        except (ValueError, np.linalg.LinAlgError, ArithmeticError):
            built.append(None)

    def entry(settings: Mapping[str, Any]) -> ControllerEntry:
        return ControllerEntry(name, name, tuple(sorted(
            (k, list(v) if isinstance(v, tuple) else v) for k, v in settings.items())))  # fmt: skip

    live = [j for j, c in enumerate(built) if c is not None]
    batched: dict[int, dict[str, NDArray]] = {}
    if len(live) > 1 and _same_reference(spec, [candidates[j] for j in live]):
        from mwip.laws.batch import PackedController

        camp = replace(robots.campaign, controllers=(entry(candidates[live[0]]),))
        try:
            parts = []
            for b in todo:
                pc = PackedController([built[j] for j in live], repeat=robots.chunk)
                parts.append(run_block(camp, b, {name: pc}, repeat=len(live))[0])
        except ValueError:  # no packed form (e.g. an observer the kernels do not run)
            parts = []
        for pos, j in enumerate(live if parts else []):
            sl = slice(pos * robots.chunk, (pos + 1) * robots.chunk)
            batched[j] = {k: np.concatenate([np.asarray(p[k])[sl] for p in parts])
                          for k in METRIC_KEYS}  # fmt: skip
    out: list[dict[str, NDArray]] = []
    for j, settings in enumerate(candidates):
        if built[j] is None:
            out.append(_failed(robots.chunk * len(todo)))
        elif j in batched:
            out.append(batched[j])
        else:
            camp = replace(robots.campaign, controllers=(entry(settings),))
            parts = [run_block(camp, b, {name: built[j]})[0] for b in todo]
            out.append({k: np.concatenate([np.asarray(p[k]) for p in parts])
                        for k in METRIC_KEYS})  # fmt: skip
    return out


def _same_reference(spec: Any, candidates: Sequence[Mapping[str, Any]]) -> bool:
    """The candidates share the speed reference the metrics are measured against (a batch
    measures every robot's speed error against one)."""
    keys = ("v_d", "psi_dot_d")
    refs = {tuple(spec.resolve(c).get(k) for k in keys) for c in candidates}
    return len(refs) == 1


def _failed(n: int) -> dict[str, NDArray]:
    nan = np.full(n, np.nan)
    return {"success": np.zeros(n, dtype=bool), "status": np.full(n, "design-failed", dtype=object),
            "rms_theta": nan, "rms_speed_error": nan.copy(), "peak_torque": nan.copy(),
            "control_tv": nan.copy(), "energy": nan.copy(), "fall_time": np.zeros(n)}  # fmt: skip
