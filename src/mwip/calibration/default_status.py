"""The default twin's status document (``mwip/hardware/book-twin.json``) from revision 9's
comparison: what :func:`mwip.hardware.identified.status`, the report and the robustness
bench's ``posterior`` level read about the twin every command runs by default.

Revision 9 (``book-structures.toml``) makes the default robot the most probable member of the
most probable structure. This document says so in the record's form (the keys
``posterior``, ``map_values``, ``map_standing``, ``calibration_numbers``, ``claims``,
``claim_counts``, ``members``, ``prior``), computed from the comparison's per-twin table:

- the **posterior** pooled over the structures with a probability given the facts: each
  structure's stage-D twins meeting every fact, importance weights ``w`` normalised within the
  structure and scaled by its probability ``p(S | facts)``, so a claim's weighted fraction is
  ``sum_S p(S) share_S``, the comparison's verdict over structures
  (:func:`mwip.calibration.compare.claim_verdict`, every structure being judgeable);
- each **claim** by :func:`mwip.calibration.claims.judge` on that pool (its fraction, the
  Wilson interval at Kish's effective size, the verdict by the declared rule, the unknown
  that decides an undecided one, its value on the default twin);
- **members**: 256 twins drawn from the pool by systematic resampling (offset from the
  generator of the declared stage-D seed), the bench's ``posterior`` level.
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

__all__ = ["status_document", "MEMBERS"]

#: Twins resampled from the posterior for the bench's ``posterior`` level.
MEMBERS = 256


def _systematic(w: np.ndarray, n: int, seed: int) -> np.ndarray:
    """Indices of ``n`` systematic-resampling draws from the normalised weights ``w``."""
    c = np.cumsum(w / w.sum())
    c[-1] = 1.0
    u0 = np.random.default_rng(seed).random()
    return np.searchsorted(c, (u0 + np.arange(n)) / n, side="right")


def status_document(doc: dict[str, Any], table: Any, structures: dict[str, Any],
                    ev: Any, seed: int) -> dict[str, Any] | None:  # fmt: skip
    """The status document of revision 9's default twin (module docstring), from the
    comparison document ``doc`` and its per-twin ``table``; ``None`` where no structure has
    a probability (no member)."""
    import pandas as pd

    from mwip.calibration.claims import claim_rows, judge
    from mwip.calibration.comparison import _evidence_with_d, _facts
    from mwip.calibration.evidence import EVIDENCE_FILE
    from mwip.calibration.runs import run_names

    m = doc.get("member")
    if m is None:
        return None
    post = doc["posterior_probability"]
    parts, weights = [], []
    for n, p in post.items():
        if p <= 0:
            continue
        df = table[table["structure"] == n].reset_index(drop=True)
        se = _evidence_with_d(n, df, _facts(df, ev))
        w = np.where(se.conditioned, se.weights, 0.0)
        parts.append(df)
        weights.append(p * w / w.sum())
    pool = pd.concat(parts, ignore_index=True)
    w = np.concatenate(weights)
    accepted = w > 0
    best = structures[m["structure"]]
    names = list(best.prior.names)
    other = [n for n, p in post.items() if p > 0 and structures[n].prior.names != best.prior.names]
    if other:  # one table of unknowns for the pool (S1 and S2 share theirs)
        raise ValueError(f"structures {', '.join(other)} have a probability but not "
                         f"{m['structure']}'s unknowns: no pooled posterior of one twin table")
    u = pool[[f"u.{k}" for k in names]].to_numpy(dtype=float)
    x = best.from_unit(u)
    params = {k: x[:, j] for j, k in enumerate(names)}
    cols = {c: pool[c].to_numpy(dtype=float) for c in pool.columns
            if c not in ("structure", "stage", "weight")}  # fmt: skip
    hit = (pool["structure"] == m["structure"]).to_numpy() & (
        pool["sample"] == m["sample"]).to_numpy()
    i = int(np.nonzero(hit)[0][0])
    claims = judge(claim_rows(cols), accepted, params, i, ev.decided, weights=w)
    counts = {k: sum(c["verdict"] == k for c in claims)
              for k in ("holds", "fails", "undecided", "no posterior")}  # fmt: skip
    wa = w[accepted]
    ess = float(wa.sum() ** 2 / np.sum(wa * wa))
    pick = _systematic(w, MEMBERS, seed)
    members = [{k: float(params[k][j]) for k in names} for j in pick]
    f = _facts(pool, ev)
    s = doc["structures"][m["structure"]]
    return {
        "title": "The book's robot (Chapter 6): the most probable member of the most probable "
                 "twin structure given Table 6.4's Case 1 SMC numbers and every run standing "
                 "(book calibration, revision 9)",
        "evidence_file": EVIDENCE_FILE.name,
        "evidence_sha256": hashlib.sha256(EVIDENCE_FILE.read_bytes()).hexdigest(),
        "signals": "measured: the board's fused pitch estimate and the encoder wheel speeds "
                   "(y_meas), not the true state",
        "acceptance": {"tolerance": ev.tolerance, "rule": "every run stands and |ln(x/book)| "
                       f"<= ln({ev.tolerance:g}) for every calibration number",
                       "kernel_scale": ev.kernel_scale},
        "prior": {"names": names, "bounds": [[float(a), float(b)]
                                             for a, b in best.prior.bounds]},
        "calibration_numbers": [{"key": n.key, "book": n.book, "source": n.source,
                                 "map": m["numbers"][n.key]} for n in ev.numbers],
        "posterior": {"n_prior": int(sum(doc["structures"][k]["searched"] for k in post
                                         if post[k] > 0)),
                      "size": int(accepted.sum()), "effective_size": ess,
                      "used": list(f.names), "dropped": [], "conflicts": [],
                      "map_index": i,
                      "sampler": {"kind": "importance", "revision": 9,
                                  "structure": m["structure"],
                                  "probability": post[m["structure"]],
                                  "evidence": s["evidence"],
                                  "evidence_95": s["evidence_95"],
                                  "structures": {k: v for k, v in post.items() if v > 0}}},
        "map_values": m["values"],
        "map_standing": {r: bool(cols[f"{r}.stands"][i] == 1.0) for r in run_names()},
        "claims": claims,
        "claim_counts": counts,
        "members": members,
        "seed": seed,
    }  # fmt: skip
