"""The declared split of the book's evidence (``book-evidence.toml``, beside this module).

The file was written before any fit and is read, never computed: the calibration facts
(every Chapter 6 run stands; Table 6.4's Case 1 SMC numbers), the acceptance tolerance, the
verdict thresholds across the posterior and the prior sample (size, seed, block); then its
dated revisions: stage 2's box proposal, stage 3's Markov chains, stage 4's mixture
draws and stage 5's envelope draws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["Evidence", "Number", "load_evidence", "EVIDENCE_FILE"]

EVIDENCE_FILE = Path(__file__).with_name("book-evidence.toml")


@dataclass(frozen=True)
class Number:
    """A calibration number: the metric ``key`` (``<run>.<metric>``), the book's value."""

    key: str
    book: float
    unit: str
    source: str


@dataclass(frozen=True)
class Evidence:
    """The declaration (see ``book-evidence.toml`` for the meaning of each field)."""

    title: str
    standing_source: str
    numbers: tuple[Number, ...]
    tolerance: float
    decided: float
    interval: float
    identified: float
    samples: int
    seed: int
    block: int
    source: dict[str, Any]
    proposal: Any = None  # mwip.calibration.proposal.BoxProposal, or None
    chains: Any = None  # mwip.calibration.chains.ChainPlan, or None
    mixture: Any = None  # mwip.calibration.mixture.MixturePlan, or None
    envelope: Any = None  # mwip.calibration.mixture.EnvelopePlan, or None

    @property
    def log_tolerance(self) -> float:
        """``ln(tolerance)``: the largest accepted ``|ln(x / book)|``."""
        return math.log(self.tolerance)

    @property
    def kernel_scale(self) -> float:
        """``s = ln(tolerance) / 2`` of the ABC kernel."""
        return math.log(self.tolerance) / 2.0


def _proposal(entry: Any) -> Any:
    from mwip.calibration.proposal import BoxProposal

    if entry is None:
        return None
    from mwip.hardware.prior import current_name

    # the declaration names the unknowns as the twin file of its time did
    box = {current_name(str(k)): (float(v[0]), float(v[1]))
           for k, v in entry.get("box", {}).items()}  # fmt: skip
    return BoxProposal(draws=int(entry["draws"]), seed=int(entry["seed"]), box=box)


def _chains(entry: Any) -> Any:
    from mwip.calibration.chains import ChainPlan

    if entry is None:
        return None
    return ChainPlan(chains=int(entry["chains"]), steps=int(entry["steps"]),
                     burn=int(entry["burn"]), seed=int(entry["seed"]),
                     scale=float(entry["scale"]), accept=float(entry["accept"]),
                     adapt_every=int(entry["adapt_every"]),
                     converged=float(entry["converged"]))  # fmt: skip


def _mixture(entry: Any) -> Any:
    from mwip.calibration.mixture import MixturePlan

    if entry is None:
        return None
    return MixturePlan(draws=int(entry["draws"]), seed=int(entry["seed"]),
                       factors=tuple(float(f) for f in entry["factors"]),
                       effective=float(entry["effective"]))  # fmt: skip


def _envelope(entry: Any, extension: Any, mixture: Any) -> Any:
    from mwip.calibration.mixture import EnvelopePlan

    if entry is None:
        return None
    if extension is None:
        return EnvelopePlan(draws=int(entry["draws"]), seed=int(entry["seed"]))
    return EnvelopePlan(draws=int(entry["draws"]), seed=int(entry["seed"]),
                        max_draws=int(extension["max_draws"]),
                        effective=None if mixture is None else float(mixture.effective))


def load_evidence(path: Path = EVIDENCE_FILE) -> Evidence:
    """Read the declaration (``ValueError`` naming the key if it is malformed)."""
    from mwip.io import read_toml

    data = read_toml(path, "evidence file")
    try:
        nums = tuple(
            Number(k, float(v["book"]), str(v.get("unit", "")), str(v["source"]))
            for k, v in data["calibration"]["numbers"].items()
        )
        s = data["prior_sample"]
        ev = Evidence(
            title=str(data["evidence"]["title"]),
            standing_source=str(data["calibration"]["standing"]["source"]),
            numbers=nums,
            tolerance=float(data["acceptance"]["tolerance"]),
            decided=float(data["verdict"]["decided"]),
            interval=float(data["verdict"]["interval"]),
            identified=float(data["verdict"]["identified"]),
            samples=int(s["samples"]),
            seed=int(s["seed"]),
            block=int(s["block"]),
            source=data,
            proposal=_proposal(data.get("proposal")),
            chains=_chains(data.get("chains")),
            mixture=_mixture(data.get("mixture")),
            envelope=_envelope(data.get("envelope"), data.get("envelope_extension"),
                               _mixture(data.get("mixture"))),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"evidence file {str(path)!r}: missing or bad entry {exc}") from None
    if not ev.tolerance > 1.0:
        raise ValueError("evidence file: acceptance.tolerance must be > 1")
    return ev
