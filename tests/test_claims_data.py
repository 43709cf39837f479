"""Claims as data (issue 12): over every metrics.json of a quick reproduce, every claim has
an id and a book flag, and every book claim that does not hold names a cause from the list
and evidence with numbers."""

from __future__ import annotations

import json
import re

from mwip.schema.claims import CAUSES


def test_every_failing_book_claim_has_cause_and_evidence(quick_reproduction):
    out, _code, _stdout = quick_reproduction
    docs = sorted(out.glob("*/metrics.json"))
    assert len(docs) >= 14
    seen_book = seen_failing = 0
    for path in docs:
        doc = json.loads(path.read_text())
        ids = [c["id"] for c in doc["claims"]]
        assert len(ids) == len(set(ids)), f"{path}: claim ids repeat"
        for c in doc["claims"]:
            assert isinstance(c["book"], bool), f"{path}: {c['id']} has no book flag"
            if not c["book"]:
                continue
            seen_book += 1
            if c["holds"]:
                continue
            seen_failing += 1
            assert c.get("cause") in CAUSES, f"{path}: {c['id']} cause {c.get('cause')!r}"
            ev = c.get("evidence", "")
            assert isinstance(ev, str) and ev.strip(), f"{path}: {c['id']} has no evidence"
            assert re.search(r"\d", ev), f"{path}: {c['id']} evidence without a number: {ev!r}"
    assert seen_book >= 40 and seen_failing >= 1
