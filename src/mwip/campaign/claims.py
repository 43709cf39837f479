"""Claim robustness: how each book claim's verdict depends on the settings the book leaves open.

Each study's file declares its open settings with plausible ranges (``[open]``,
:func:`mwip.studies.settings.open_settings`). A claims campaign draws, for each study with open
settings and each sample, every open setting uniformly from its range (each element of a
list; integers, e.g. seeds, uniformly among the integers of the range), made consistent where
settings depend on each other (:func:`draw_settings`: ``dt`` a whole divisor of ``Ts`` or
``Ts_record``, a ``[start, end]`` window or ``[low, high]`` range in order), reruns the study
with
those settings (the ``overrides`` of :func:`mwip.studies.run_study`) and records every claim's
verdict from the metrics document: its ``id`` (the claim's text when it has no id), ``book`` and
``holds``. A sample whose study run fails is one row with its ``error`` and ``holds`` missing
(``<NA>``): an error, never a verdict. Sample ``s`` of the ``k``-th such study is global
index ``s S + k`` (S studies), drawn from the campaign seed and that index alone
(:mod:`mwip.campaign.sampling`).

Summary: the fraction of plausible settings under which a claim holds, with a Wilson 95 %
interval (:func:`mwip.campaign.stats.wilson`): :func:`claim_robustness` and, for the main
report, :func:`robustness_text` ("holds in 75 % of plausible settings (95 % interval 62-85 %,
n = 40)").
"""

from __future__ import annotations

import json
import math
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from mwip.campaign.sampling import sample_rng
from mwip.campaign.spec import Campaign
from mwip.schema.robustness import (
    ClaimRobustness,
    claim_robustness,
    load_claim_robustness,
    robustness_text,
)

__all__ = [
    "claim_studies",
    "draw_settings",
    "run_block",
    "ClaimRobustness",
    "claim_robustness",
    "load_claim_robustness",
    "robustness_text",
]


def claim_studies(campaign: Campaign) -> list[str]:
    """The campaign's studies that declare open settings (the others are skipped)."""
    from mwip.studies.settings import open_settings

    return [s for s in campaign.studies if open_settings(s)]


def draw_settings(study: str, rng: np.random.Generator) -> dict[str, Any]:
    """One draw of study ``study``'s open settings from their ranges (keys in sorted order),
    made consistent (:func:`_consistent`)."""
    from mwip.studies.settings import defaults, open_settings

    base = defaults(study)
    opened = open_settings(study)
    out: dict[str, Any] = {}
    for key, entry in sorted(opened.items()):
        lo, hi = entry["range"]
        default = base[key]
        items = default if isinstance(default, list) else [default]
        vals: list[Any] = []
        for d in items:
            if isinstance(d, bool):
                vals.append(d)
            elif isinstance(d, int):
                vals.append(int(rng.integers(math.ceil(lo), math.floor(hi) + 1)))
            else:
                vals.append(float(lo + rng.random() * (hi - lo)))
        out[key] = vals if isinstance(default, list) else vals[0]
    return _consistent(out, base, opened)


#: The periods the integration step ``dt`` must divide into whole steps
#: (:func:`mwip.studies.settings.validate`).
_PERIODS = ("Ts", "Ts_record")


def _consistent(
    drawn: dict[str, Any], base: dict[str, Any], opened: dict[str, dict[str, Any]]
) -> dict[str, Any]:
    """The draw with its dependent settings made consistent, as the study's rules require:

    - ``dt`` divides each period of :data:`_PERIODS` the study has: with ``dt`` open,
      ``dt = P / n`` for the first period ``P`` (drawn or default), the whole ``n`` nearest to
      ``P / dt_drawn`` among those keeping ``dt`` in its open range (the nearest overall if
      none does); any other open period is then rounded to a whole multiple of ``dt``;
    - a two-element ``*_window`` or ``*_range`` ([start, end], [low, high]) is put in order.
    """
    out = dict(drawn)
    periods = [p for p in _PERIODS if p in base]
    if "dt" in base and periods and ({"dt", *periods} & set(out)):
        first = periods[0]
        P = float(out.get(first, base[first]))
        if "dt" in out:
            lo, hi = (float(x) for x in opened["dt"]["range"])
            n_lo, n_hi = max(1, math.ceil(P / hi - 1e-9)), math.floor(P / lo + 1e-9)
            n = max(1, round(P / float(out["dt"])))
            if n_lo <= n_hi:
                n = min(max(n, n_lo), n_hi)
            out["dt"] = P / n
        dt = float(out.get("dt", base["dt"]))
        for other in periods:
            if other in out and (other != first or "dt" not in out):
                out[other] = dt * max(1, round(float(out[other]) / dt))
    for key, value in out.items():
        if (key.endswith(("_window", "_range")) and isinstance(value, list)
                and len(value) == 2):  # fmt: skip
            out[key] = sorted(value)
    return out


def _rows(
    study: str, sample: int, drawn: dict[str, Any], doc: dict[str, Any] | None, error: str | None
) -> list[dict[str, Any]]:
    settings = json.dumps(drawn, sort_keys=True)
    if doc is None:
        return [
            {
                "study": study,
                "sample": sample,
                "claim_index": -1,
                "claim": "",
                "book": "",
                "text": "",
                "holds": None,  # an error, not a verdict
                "error": error or "run failed",
                "settings": settings,
            }
        ]
    rows = []
    for j, c in enumerate(doc.get("claims", [])):
        text = str(c.get("text", ""))
        rows.append(
            {
                "study": study,
                "sample": sample,
                "claim_index": j,
                "claim": str(c.get("id") or text),
                "book": str(c.get("book", "")),
                "text": text,
                "holds": None if c.get("holds") is None else bool(c["holds"]),
                "error": "",
                "settings": settings,
            }
        )
    return rows


def run_block(campaign: Campaign, block: int) -> Any:
    """The claim verdicts of the samples of ``block`` (a pandas DataFrame, possibly empty)."""
    import pandas as pd

    from mwip.studies import run_study

    studies = claim_studies(campaign)
    rows: list[dict[str, Any]] = []
    units = campaign.samples * len(studies)  # each unit one study run: only what was asked
    for i in range(block * campaign.block, min((block + 1) * campaign.block, units)):
        study, sample = studies[i % len(studies)], i // len(studies)
        drawn = draw_settings(study, sample_rng(campaign.seed, i))
        doc, error = None, None
        with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                doc = run_study(study, Path(tmp), quick=campaign.quick, overrides=drawn)
            except Exception as exc:  # noqa: BLE001 - recorded as the sample's error
                error = f"{type(exc).__name__}: {exc}"
        rows.extend(_rows(study, sample, drawn, doc, error))
    cols = ["study", "sample", "claim_index", "claim", "book", "text", "holds", "error", "settings"]
    df = pd.DataFrame(rows, columns=cols)
    return df.astype({"sample": "int64", "claim_index": "int64", "holds": "boolean"})
