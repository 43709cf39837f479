"""Hardening (issue 26, items 10 and 11): a claims campaign draws dependent settings consistently
(``dt`` a whole divisor of ``Ts`` / ``Ts_record``, windows in order), so that every draw is a
valid setting of its study; a sample whose study fails is stored and reported as an error,
never as ``holds = false``; Dask tasks carry the campaign instead of depending on scattered
data (the "lost dependencies" of a run on a scheduler that has just released the same key)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mwip.campaign import claims
from mwip.campaign.sampling import sample_rng
from mwip.campaign.spec import parse_campaign
from mwip.studies import settings


def _studies_with_open_settings() -> list[str]:
    from mwip.studies import registry

    return [s for s in registry.names() if settings.open_settings(s)]


@pytest.mark.parametrize("study", _studies_with_open_settings())
def test_every_draw_is_a_valid_setting_of_its_study(study):
    """Before: Ts and dt were drawn independently and ~all draws of do-comparison,
    hodosmc-vs-smc, asta-*, the TSMC studies failed with "dt must divide Ts"; windows were
    drawn out of order half the time."""
    opened = settings.open_settings(study)
    for i in range(200):
        drawn = claims.draw_settings(study, sample_rng(2026, i))
        assert set(drawn) == set(opened)
        settings.validate(study, drawn)  # raises on any inconsistency
        if "dt" in drawn:
            lo, hi = opened["dt"]["range"]
            assert lo - 1e-12 <= drawn["dt"] <= hi + 1e-12, drawn


def test_dt_still_varies_and_is_reproducible():
    a = [claims.draw_settings("do-comparison", sample_rng(1, i)) for i in range(50)]
    b = [claims.draw_settings("do-comparison", sample_rng(1, i)) for i in range(50)]
    assert a == b
    dts = np.array([d["dt"] for d in a])
    assert len(set(np.round(dts, 12))) > 10  # not one fixed step


def _claims_campaign(study: str, samples: int) -> object:
    spec = {"kind": "claims", "studies": [study], "samples": samples, "seed": 3, "block": samples}
    return parse_campaign({"campaign": spec})


def test_an_errored_sample_is_an_error_not_a_verdict(monkeypatch):
    import mwip.studies as studies

    calls = []

    def run_study(name, out, quick=False, overrides=None):
        calls.append(name)
        if len(calls) == 1:
            raise RuntimeError("solver failed")
        return {"claims": [{"id": "c", "book": "Sec. 1", "text": "c", "holds": True}]}

    monkeypatch.setattr(studies, "run_study", run_study)
    c = _claims_campaign("lqr-gain", 3)
    df = claims.run_block(c, 0)
    err = df[df["error"] != ""]
    assert len(err) == 1 and err["holds"].isna().all()
    assert "RuntimeError: solver failed" in err["error"].iloc[0]
    assert str(df["holds"].dtype) == "boolean"
    table = claims.claim_robustness(df)
    assert {k: (r.k, r.n) for k, r in table.items()} == {("lqr-gain", "c"): (2, 2)}


def test_the_report_counts_errors_apart(monkeypatch):
    from mwip.campaign.report import _claims_html

    df = pd.DataFrame({"study": ["s", "s", "s"], "sample": [0, 1, 2], "claim_index": [0, 0, -1],
                       "claim": ["c", "c", ""], "book": ["b", "b", ""], "text": ["c", "c", ""],
                       "holds": pd.array([True, False, None], dtype="boolean"),
                       "error": ["", "", "ValueError: x"], "settings": ["{}"] * 3})  # fmt: skip
    page = _claims_html(df)
    assert "1 study runs failed (excluded)" in page and "50 %" in page


def test_dask_tasks_do_not_depend_on_scattered_data():
    """Item 11: the cause of "lost dependencies" under load: every task depended on one
    scattered copy of the campaign whose content-hashed key the previous run's client was
    releasing. Tasks now carry the campaign themselves."""
    from mwip.campaign import execute

    class Client:
        submitted: list = []

        def scatter(self, *a, **k):
            raise AssertionError("scattered data is a dependency that can be lost")

        def submit(self, fn, *args, **kw):
            self.submitted.append(args)
            raise KeyboardInterrupt  # stop after the first submission

        def close(self):
            pass

    c = _claims_campaign("lqr-gain", 2)
    with pytest.raises(KeyboardInterrupt):
        execute._run_dask(c, [[0]], Client(), None, lambda b, df: None)
    assert Client.submitted and Client.submitted[0][0] is c
