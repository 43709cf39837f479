"""A robot's evidence as facts on the user's own runs (``mwip twin calibrate FACTS --robot
FILE``; docs/twin_fit.md, "Calibrating your robot on what it did").

The file states what the robot did, run by run; each run is a scenario file
(:mod:`mwip.scenario`, ``twin = true``) that says how it was driven (controller, gains,
start, payload case, duration). A fact is either qualitative, "it stood the whole run" or "it
fell", or a number the board recorded, "this metric (:data:`mwip.calibration.measured.METRICS`)
was this value, within a factor or an absolute margin"::

    [evidence]
    title = "my-robot in the lab, November"

    [sample]                  # optional; the defaults shown
    draws = 1000              # stage A: draws from the robot file's [prior]
    search_draws = 500        # stage B: a search around the twins meeting the most facts
    seed = 0
    block = 250               # twins per stored block (a rerun resumes)

    [[fact]]
    scenario = "lqr-stood.toml"     # relative to this file; run on the calibrated robot's twin
    stands = true                   # stood the whole run (false: it fell before the end)
    source = "lab log 2026-11-03: stood 20 s with these gains"

    [[fact]]
    scenario = "lqr-stood.toml"
    metric = "rms_theta"            # rad
    value = 0.02
    tolerance = 1.5                 # a factor: 0.02 / 1.5 .. 0.02 x 1.5
    # within = 0.005                # or an absolute margin (signed metrics need it)
    window = [5.0, 20.0]            # s; default the whole run
    source = "the board's log of that run"

Every fact runs on the robot the command calibrates (``--robot``; a scenario's own
``[scenario] robot`` and ``[plant]``/``[design]`` are replaced by it, as ``mwip simulate
--robot`` does), so that the facts speak of one robot. Errors are one line naming the fact
and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mwip.calibration.measured import METRICS

__all__ = ["Fact", "FactsFile", "is_facts_file", "load_facts", "DEFAULT_SAMPLE"]

#: ``[sample]``'s defaults: stage A's draws, stage B's, seed, block; stage B's box
#: half-width factor (x the seeds' standard deviation, as the book calibration's).
DEFAULT_SAMPLE = {"draws": 1000, "search_draws": 500, "seed": 0, "block": 250}
FACTOR = 1.0

_FACT_KEYS = ("scenario", "stands", "metric", "value", "tolerance", "within", "window",
              "reference", "source")  # fmt: skip


@dataclass(frozen=True)
class Fact:
    """One fact: on ``scenario`` (its file), either ``stands`` (True/False) or ``metric``
    ``value`` within the factor ``tolerance`` or the absolute ``within``."""

    index: int
    scenario: Path
    source: str
    stands: bool | None = None
    metric: str | None = None
    value: float = math.nan
    tolerance: float | None = None
    within: float | None = None
    window: tuple[float, float] | None = None
    reference: float = 0.0

    @property
    def name(self) -> str:
        """A short name: ``up:<scenario>``, ``down:<scenario>`` or
        ``num:<scenario>.<metric>`` (two facts sharing one are numbered ``#1``, ``#2`` in the
        calibration's fact table, :func:`mwip.calibration.robot_evidence.fact_table`)."""
        run = self.scenario.stem
        if self.metric is None:
            return f"{'up' if self.stands else 'down'}:{run}"
        return f"num:{run}.{self.metric}"

    @property
    def column(self) -> str:
        """The per-twin column this fact reads."""
        return f"fact{self.index}"

    def describe(self) -> str:
        """The fact in words."""
        if self.metric is None:
            return f"{self.scenario.name}: {'stands the whole run' if self.stands else 'falls'}"
        unit = METRICS[self.metric].unit
        margin = (f"x/÷ {self.tolerance:g}" if self.tolerance is not None
                  else f"± {self.within:g} {unit}")  # fmt: skip
        win = "" if self.window is None else f" over {self.window[0]:g}-{self.window[1]:g} s"
        return f"{self.scenario.name}: {self.metric} = {self.value:g} {unit} {margin}{win}"


@dataclass(frozen=True)
class FactsFile:
    """The file: ``title``, ``facts``, the sample (``draws``, ``search_draws``, ``seed``,
    ``block``), and ``path``."""

    path: Path
    title: str
    facts: tuple[Fact, ...]
    draws: int
    search_draws: int
    seed: int
    block: int

    @property
    def scenarios(self) -> tuple[Path, ...]:
        """The distinct scenario files, in the order the facts first name them."""
        return tuple(dict.fromkeys(f.scenario for f in self.facts))


def is_facts_file(path: Path) -> bool:
    """Whether ``path`` is a facts file (it has ``[[fact]]`` entries), not the book's form."""
    from mwip.io import read_toml

    return "fact" in read_toml(path, "evidence file")


def _num(where: str, v: Any, lo: float, hi: float, *, open_lo: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValueError(f"{where} must be a number, got {v!r}")
    if (v <= lo if open_lo else v < lo) or v > hi:
        raise ValueError(f"{where} must be in {'(' if open_lo else '['}{lo:g}, {hi:g}], got {v!r}")
    return float(v)


def _int(where: str, v: Any, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise ValueError(f"{where} must be an integer in [{lo}, {hi}], got {v!r}")
    return int(v)


def _fact(i: int, e: Any, folder: Path) -> Fact:
    w = f"fact {i + 1}"
    if not isinstance(e, dict):
        raise ValueError(f"{w} must be a table ([[fact]]), got {e!r}")
    bad = sorted(set(e) - set(_FACT_KEYS))
    if bad:
        raise ValueError(f"{w}: unknown key {bad[0]!r}; allowed: {', '.join(_FACT_KEYS)}")
    sc = e.get("scenario")
    if not isinstance(sc, str) or not sc:
        raise ValueError(f"{w}.scenario must name a scenario file (relative to the evidence "
                         "file)")  # fmt: skip
    path = (folder / sc).resolve()
    if not path.is_file():
        raise ValueError(f"{w}.scenario: no such file {sc!r} (relative to the evidence file)")
    source = e.get("source", "")
    if not isinstance(source, str):
        raise ValueError(f"{w}.source must be text, got {source!r}")
    if ("stands" in e) == ("metric" in e):
        raise ValueError(f"{w}: give either stands = true/false or metric = ... with value")
    if "stands" in e:
        if not isinstance(e["stands"], bool):
            raise ValueError(f"{w}.stands must be true or false, got {e['stands']!r}")
        extra = sorted(set(e) & {"value", "tolerance", "within", "window", "reference"})
        if extra:
            raise ValueError(f"{w}.{extra[0]}: only for a metric fact (metric = ...)")
        return Fact(i, path, source, stands=bool(e["stands"]))
    metric = e["metric"]
    if metric not in METRICS:
        raise ValueError(f"{w}.metric {metric!r} unknown; allowed: {', '.join(METRICS)}")
    if "value" not in e:
        raise ValueError(f"{w}.value is missing (the metric's value, in "
                         f"{METRICS[metric].unit})")  # fmt: skip
    value = _num(f"{w}.value", e["value"], -1e6, 1e6)
    if ("tolerance" in e) == ("within" in e):
        raise ValueError(f"{w}: give either tolerance (a factor > 1) or within (an absolute "
                         "margin > 0)")  # fmt: skip
    tol = within = None
    if "tolerance" in e:
        tol = _num(f"{w}.tolerance", e["tolerance"], 1.0, 100.0, open_lo=True)
        if not value > 0:
            raise ValueError(f"{w}.value must be > 0 with a factor tolerance, got {value!r} "
                             "(give within, an absolute margin, for a signed value)")  # fmt: skip
    else:
        within = _num(f"{w}.within", e["within"], 0.0, 1e6, open_lo=True)
    window = None
    if "window" in e:
        win = e["window"]
        if (not isinstance(win, list) or len(win) != 2
                or any(isinstance(x, bool) or not isinstance(x, int | float) for x in win)
                or not 0 <= win[0] < win[1] <= 3600):  # fmt: skip
            raise ValueError(f"{w}.window must be [t0, t1] s with 0 <= t0 < t1 <= 3600, got "
                             f"{win!r}")  # fmt: skip
        window = (float(win[0]), float(win[1]))
    ref = 0.0
    if "reference" in e:
        if metric != "rms_speed":
            raise ValueError(f"{w}.reference: only for metric = 'rms_speed'")
        ref = _num(f"{w}.reference", e["reference"], -1e3, 1e3)
    return Fact(i, path, source, metric=str(metric), value=value, tolerance=tol,
                within=within, window=window, reference=ref)  # fmt: skip


def load_facts(path: Path) -> FactsFile:
    """Read a facts file (module docstring); ``ValueError`` naming the fact and the field."""
    from mwip.io import read_toml

    p = Path(path)
    data = read_toml(p, "evidence file")
    try:
        bad = sorted(set(data) - {"evidence", "sample", "fact"})
        if bad:
            raise ValueError(f"unknown table [{bad[0]}]; allowed: [evidence], [sample], "
                             "[[fact]]")  # fmt: skip
        head = data.get("evidence", {})
        if not isinstance(head, dict) or set(head) - {"title"}:
            raise ValueError("[evidence] holds only title = \"...\"")
        title = head.get("title", p.stem)
        if not isinstance(title, str):
            raise ValueError(f"evidence.title must be text, got {title!r}")
        sample = data.get("sample", {})
        if not isinstance(sample, dict):
            raise ValueError("[sample] must be a table")
        extra = sorted(set(sample) - set(DEFAULT_SAMPLE))
        if extra:
            raise ValueError(f"sample.{extra[0]}: unknown; allowed: {', '.join(DEFAULT_SAMPLE)}")
        s = {**DEFAULT_SAMPLE, **sample}
        draws = _int("sample.draws", s["draws"], 1, 1_000_000)
        search = _int("sample.search_draws", s["search_draws"], 0, 1_000_000)
        seed = _int("sample.seed", s["seed"], 0, 2**32 - 1)
        block = _int("sample.block", s["block"], 1, 100_000)
        raw = data.get("fact")
        if not isinstance(raw, list) or not raw:
            raise ValueError("[[fact]]: give at least one fact")
        facts = tuple(_fact(i, e, p.parent) for i, e in enumerate(raw))
    except ValueError as exc:
        raise ValueError(f"evidence file {str(p)!r}: {exc}") from None
    return FactsFile(p, title, facts, draws, search, seed, block)
