"""Study it2-balance (Fig. 5.4), quick mode."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mwip.fuzzy.pdc import BOOK_G1, BOOK_G2
from mwip.fuzzy.ts_model import vertex_matrices
from mwip.params import NOMINAL
from mwip.studies import it2_balance, run_study


def _claim(doc: dict, cid: str) -> dict:
    hits = [c for c in doc["claims"] if c["id"] == cid]
    assert len(hits) == 1, cid
    return hits[0]


def test_it2_balance_quick(tmp_path):
    doc = run_study("it2-balance", tmp_path, quick=True)
    folder = tmp_path / "it2-balance"
    on_disk = json.loads((folder / "metrics.json").read_text())
    assert on_disk == doc
    assert on_disk["study"] == "it2-balance" and on_disk["source"] == it2_balance.SOURCE
    for key in ("it2.settling_time", "it2.final_abs_theta"):
        assert key in doc["metrics"] and np.isfinite(doc["metrics"][key])
    assert (folder / "it2-balance.png").stat().st_size > 1000
    assert (folder / "it2.npz").exists()
    m = doc["metrics"]
    # the book's claim, with the book's design (Lemma 5.1/5.2 on the nominal model alone):
    # under the units damping reading it balances the real plant
    assert all(r["status"] == "ok" for r in doc["runs"].values())
    assert m["it2.settling_time"] < 3.0 and m["it2.final_abs_theta"] < 2e-3
    assert _claim(doc, "it2.converges")["holds"] and _claim(doc, "it2.converges")["book"]
    assert _claim(doc, "robust.converges")["holds"] and not _claim(doc, "robust.converges")["book"]
    # the verified design: every LMI at the solved point and the vertex loops stable
    assert m["it2.lmi.lmi_ii"] < 0 and m["it2.lmi.input"] <= 1e-7 and m["it2.max_re_pole"] < 0
    # the printed gains: a book inconsistency, with their poles computed independently here
    c = _claim(doc, "it2.gains")
    assert not c["holds"] and c["cause"] == "book-inconsistency"
    ts = vertex_matrices(NOMINAL)
    poles = [np.linalg.eigvals(ts.A[i] + np.outer(ts.B[i], g)) for i, g in
             enumerate((BOOK_G1, BOOK_G2))]  # fmt: skip
    assert m["printed.max_re_pole"] == pytest.approx(max(p.real.max() for p in poles), rel=1e-9)
    assert m["printed.max_re_pole"] > 1e5  # u = G x with (5.4)'s B: violently unstable
    assert m["printed_flipped.min_re_pole"] < -1e5 < 0 < m["printed_flipped.max_re_pole"]
    assert set(doc["published"]) <= set(doc["metrics"])
    assert doc["published"]["it2.G1.theta"] == BOOK_G1[0]
