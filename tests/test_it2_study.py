"""Study it2-balance (Fig. 5.4), quick mode."""

from __future__ import annotations

import json

import numpy as np

from mwip.studies import it2_balance


def test_it2_balance_quick(tmp_path):
    doc = it2_balance.run(tmp_path, quick=True)
    folder = tmp_path / "it2-balance"
    on_disk = json.loads((folder / "metrics.json").read_text())
    assert on_disk["study"] == "it2-balance" and on_disk["source"] == it2_balance.SOURCE
    for key in ("it2.settling_time", "it2.final_abs_theta"):
        assert key in doc["metrics"] and np.isfinite(doc["metrics"][key])
    assert (folder / "it2-balance.png").stat().st_size > 1000
    assert (folder / "it2.npz").exists()
    # the book's claim: theta converges quickly and stays at 0
    assert doc["runs"]["it2"]["status"] == "ok"
    assert doc["metrics"]["it2.settling_time"] < 3.0
    assert doc["metrics"]["it2.final_abs_theta"] < 2e-3
    assert doc["claims"][0]["holds"] is True
    # the nominal-only design on the real plant is recorded as it is (it falls)
    assert doc["runs"]["book"]["status"] == "fell"
    assert doc["claims"][1]["holds"] is False
    assert set(doc["published"]) <= set(doc["metrics"])
