"""Prior draws of the twin as a campaign (``kind = "calibration"``): one block, one batch.

Draw ``s`` (global index) takes every unknown of the twin's prior uniformly from its range
with the generator of ``(campaign seed, s)`` alone (:func:`mwip.campaign.sampling.sample_rng`),
so a draw's twin never depends on blocks, chunks or workers. A block of ``campaign.block``
draws is one batch of twins per Chapter 6 run (:func:`mwip.calibration.runs.run_batch`, the
studies' noise seed for every row: each row sees the noise of the study's single run).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.campaign.sampling import sample_rng

__all__ = ["draw", "run_block", "calibration_campaign", "evaluate", "map_chunks"]


def draw(
    seed: int, indices: range | list[int], prior: Any = None
) -> dict[str, NDArray[np.float64]]:
    """The unknowns of draws ``indices`` (name -> array), uniform on the prior's ranges."""
    from mwip.calibration.structure import BOOK_PRIOR as PRIOR

    pr = PRIOR if prior is None else prior
    b = np.asarray(pr.bounds, dtype=float)
    u = np.array([sample_rng(seed, int(i)).random(len(pr.names)) for i in indices])
    x = b[:, 0] + u.reshape(len(indices), len(pr.names)) * (b[:, 1] - b[:, 0])
    return {name: x[:, j].copy() for j, name in enumerate(pr.names)}


def run_block(campaign: Any, block: int) -> Any:
    """The rows of block ``block``: ``evidence``, ``sample``, the unknowns and every run's
    metrics (a pandas DataFrame)."""
    import pandas as pd

    from mwip.calibration.runs import run_batch

    # only what was asked: each twin's runs are independent of its batch (common noise)
    idx = list(range(block * campaign.block, min((block + 1) * campaign.block, campaign.samples)))
    values = draw(campaign.seed, idx)
    cap = campaign.duration if campaign.duration > 0 else None
    cols = run_batch(values, duration=cap)
    data: dict[str, Any] = {"evidence": ["book"] * len(idx), "sample": idx}
    data.update({f"param.{k}": v for k, v in values.items()})
    data.update(cols)
    return pd.DataFrame(data)


def calibration_campaign(samples: int, seed: int, block: int, duration: float = 0.0) -> Any:
    """The campaign of the book calibration (``duration`` > 0 caps every run: a smoke test)."""
    from mwip.campaign.spec import parse_campaign

    camp: dict[str, Any] = {"kind": "calibration", "samples": samples, "seed": seed,
                            "block": block,
                            "title": "The book's robot: prior draws of the twin"}  # fmt: skip
    if duration > 0:
        camp["duration"] = duration
    return CalibrationWork(parse_campaign({"campaign": camp}))


@dataclass(frozen=True)
class CalibrationWork:
    """The calibration's campaign as work for :func:`mwip.campaign.execute.run_campaign`: the
    campaign's ``kind``, ``samples``, ``seed``, ``block``, ``duration``, ``source`` and
    ``identity()``, with its own block runner (:func:`run_block`) and row order, so that the
    campaign engine never imports the calibration (a floor above it)."""

    campaign: Any

    @property
    def kind(self) -> str:
        return str(self.campaign.kind)

    @property
    def title(self) -> str:
        return str(self.campaign.title)

    @property
    def samples(self) -> int:
        return int(self.campaign.samples)

    @property
    def seed(self) -> int:
        return int(self.campaign.seed)

    @property
    def block(self) -> int:
        return int(self.campaign.block)

    @property
    def duration(self) -> float:
        return float(self.campaign.duration)

    @property
    def source(self) -> Any:
        return self.campaign.source

    def identity(self) -> str:
        return str(self.campaign.identity())

    def order_key(self) -> tuple[str, list[str]]:
        return "evidence", ["book"]

    def compute_chunk(self, blocks: list[int]) -> Any:
        """The rows of ``blocks`` (a pandas DataFrame; runs on a worker)."""
        import pandas as pd

        return pd.concat([run_block(self.campaign, b) for b in blocks], ignore_index=True)


def _init_worker(parent: int) -> None:
    """A worker ignores Ctrl-C (the parent decides) and exits when its parent is gone (killed
    outright), instead of computing twins for nobody."""
    import signal
    import threading
    import time

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=watch, daemon=True).start()


def _evaluate_chunk(args: tuple[dict[str, NDArray[np.float64]], float | None, Any]
                    ) -> dict[str, Any]:  # fmt: skip
    from mwip.calibration.runs import run_batch

    values, cap, twin = args
    return run_batch(values, duration=cap, twin=twin)


def evaluate(
    values: dict[str, NDArray[np.float64]],
    *,
    jobs: int = 1,
    block: int = 250,
    duration: float = 0.0,
    progress: Any = None,
    twin: Any = None,
) -> dict[str, NDArray[np.float64]]:
    """Every Chapter 6 run on the batch of twins ``values`` (name -> (N,)), in chunks of at
    most ``block`` twins over ``jobs`` worker processes (each twin's runs are independent of
    its chunk, so the columns do not depend on ``jobs`` or ``block``); ``duration`` > 0 caps
    every run (a smoke test); ``twin`` the twin the values vary (default the default twin;
    a declared structure's, :mod:`mwip.calibration.structures`)."""
    n = len(next(iter(values.values())))
    cap = duration if duration > 0 else None
    parts = max(jobs, -(-n // block))
    edges = np.linspace(0, n, parts + 1).round().astype(int)
    chunks = [({k: v[a:b] for k, v in values.items()}, cap, twin)
              for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]  # fmt: skip
    results = map_chunks(_evaluate_chunk, chunks, jobs, progress)
    return {k: np.concatenate([r[k] for r in results]) for k in results[0]}


def map_chunks(fn: Callable[[Any], Any], chunks: Sequence[Any], jobs: int,
               progress: Any = None) -> list[Any]:  # fmt: skip
    """``[fn(c) for c in chunks]``, over ``jobs`` spawned worker processes when ``jobs > 1``
    (``fn`` a module-level function): the workers never see the terminal's Ctrl-C and die with
    this process; a Ctrl-C here kills them at once. ``progress(done, total)`` after each."""
    results: list[Any] = []
    if jobs <= 1 or len(chunks) <= 1:
        for c in chunks:
            results.append(fn(c))
            if progress is not None:
                progress(len(results), len(chunks))
        return results
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from mwip.campaign.execute import deaf_spawns, kill_children

    with deaf_spawns():  # the workers never see the terminal's Ctrl-C; this process does
        ex = ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("spawn"),
                                 initializer=_init_worker, initargs=(os.getpid(),))
        try:
            for r in ex.map(fn, chunks):
                results.append(r)
                if progress is not None:
                    progress(len(results), len(chunks))
        except KeyboardInterrupt:  # stop now: kill the workers, do not wait for them
            kill_children()
            ex.shutdown(wait=False, cancel_futures=True)
            raise
        ex.shutdown(wait=True)
    return results
