"""A whole benchmark run: the runs on the campaign engine, then ``scores.parquet`` and the page.

:func:`run_bench` runs (or continues) the benchmark into ``out`` with
:func:`mwip.campaign.execute.run_campaign` (``campaign.json``, ``chunks/``, ``results.parquet``:
resumable after Ctrl-C or ``kill -9``, the same rows for any ``jobs``), then writes
``scores.parquet`` (:mod:`mwip.bench.scores`) and the leaderboard page (:mod:`mwip.bench.page`),
each atomically. An interrupted run writes neither.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

from mwip.bench.run import BenchRun, posterior_members
from mwip.io import write_parquet_atomic

__all__ = ["BenchSummary", "run_bench", "notes"]


@dataclass(frozen=True)
class BenchSummary:
    """``status`` as :class:`mwip.campaign.execute.RunSummary`'s; ``runs``: rows of the table."""

    status: str
    blocks_run: int
    blocks_total: int
    runs: int
    out: Path
    wall_s: float


def notes(work: BenchRun) -> list[str]:
    """Lines the page shows about what the benchmark stands on."""
    origins = sorted({f"{e.label}: {e.origin}" for e in work.entrants if e.origin != "registry"})
    if work.robot is not None:
        robot = work.the_robot
        out = [f"Every entrant runs on the twin of robot {robot.name!r} (a robot file: its body "
               "is every run's real robot, its twin the hardware), designed on its design "
               "model unless a scenario says otherwise. The twin axis's 'posterior' level "
               "repeats the robot's own values (its file carries no posterior); the plausible "
               "ranges come from its declared prior."]
    else:
        m = len(posterior_members())
        post = ("the identified twin's posterior (book-twin.json) has a single member, the "
                "default twin itself: the twin axis's 'posterior' level therefore repeats the "
                "nominal runs, and the plausible ranges come from the declared prior "
                "(mwip.hardware.prior)"
                if m == 1 else f"the identified twin's 'posterior' level draws {m} members of "
                "the book calibration's posterior (book-twin.json: resampled from its weighted "
                "members, or a thinned set of its Markov chain states where the chains are its "
                "sampler)")  # fmt: skip
        out = ["Every entrant runs on the default robot's identified twin (mwip robot show), "
               "designed on its design model (the book's nominal, Table 3.2, unless a scenario "
               "says otherwise); the robot is Table 6.1's.", post.capitalize() + "."]
    if origins:
        out.append("Entrants from files: " + "; ".join(origins) + ".")
    return out


def run_bench(work: BenchRun, out: Path, *, jobs: int | None = None,
              scheduler: str | None = None, progress: Any = "default",
              max_hours: float | None = None) -> BenchSummary:  # fmt: skip
    """Run or continue ``work`` into ``out``; then the scores and the page (module docstring)."""
    import pandas as pd

    from mwip.bench.page import write_page
    from mwip.bench.scores import score_table
    from mwip.campaign.execute import run_campaign

    kw: dict[str, Any] = {} if progress == "default" else {"progress": progress}
    kw["max_hours"] = max_hours
    res = run_campaign(cast(Any, work), Path(out), jobs=jobs, scheduler=scheduler, **kw)
    if res.status == "interrupted":
        return BenchSummary(res.status, res.blocks_run, res.blocks_total, 0, Path(out),
                            res.wall_s)  # fmt: skip
    results = pd.read_parquet(Path(out) / "results.parquet")
    labels = [e.label for e in work.entrants]
    scores = score_table(results, work.bench, labels)
    write_parquet_atomic(Path(out) / "scores.parquet", scores)
    write_page(Path(out), scores, work.bench, labels, notes(work))
    return BenchSummary(res.status, res.blocks_run, res.blocks_total, len(results), Path(out),
                        res.wall_s)  # fmt: skip
