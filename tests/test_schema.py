"""mwip.schema: the results schema on the ground floor (issue 24, item 2)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import pytest

from mwip.schema import CAUSES, Claim, finish_claims, metrics_document, validate_claim


def test_claim_is_frozen_and_checks_itself():
    c = Claim(id="a", text="holds", holds=True, book=True)
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.holds = False  # type: ignore[misc]
    with pytest.raises(ValueError, match="'cause'"):
        Claim(id="a", text="t", holds=False, book=True)
    with pytest.raises(ValueError, match="'evidence'"):
        Claim(id="a", text="t", holds=False, book=True, cause="implementation")
    with pytest.raises(ValueError, match="'book'"):
        Claim.from_dict({"id": "a", "text": "t", "holds": True})
    with pytest.raises(ValueError, match="'holds' is missing"):
        Claim.from_dict({"id": "a", "text": "t", "book": True})
    Claim(id="a", text="t", holds=False, book=False)  # an extra needs no cause
    assert set(CAUSES) >= {"implementation", "twin-model"}


def test_from_dict_and_to_dict_round_trip_and_validate_keeps_the_order():
    d = {"text": "t", "id": "x", "holds": 0, "book": False, "keys": ["m"], "robot": "real"}
    c = Claim.from_dict(d)
    assert c.holds is False and c.keys == ("m",) and c.extra == {"robot": "real"}
    assert Claim.from_dict(c.to_dict()) == c
    out = validate_claim(d)
    assert list(out) == list(d) and out["holds"] is False


def test_finish_claims_is_the_one_post_processing():
    metrics = {"m": 1.5}
    claims = [
        {"id": "a", "text": "a", "holds": True, "book": True, "cause": "twin-model",
         "evidence": "e"},
        {"id": "b", "text": "b", "holds": False, "book": True, "keys": ["m"]},
        {"id": "c", "text": "c", "holds": False, "book": False, "evidence": "why"},
    ]  # fmt: skip
    a, b, c = finish_claims(claims, metrics, "real robot")
    assert "cause" not in a and "evidence" not in a
    assert b["cause"] == "implementation" and "m = 1.5" in b["evidence"]
    assert "real robot" in b["evidence"]
    assert c["evidence"] == "why" and "cause" not in c
    doc = metrics_document("s", "src", metrics, {}, [a, b, c], {}, {})
    assert doc["claims"][1]["values"] == {"m": 1.5}


def test_the_drifted_studies_use_finish_claims():
    """The four studies whose own claim loop had drifted call the shared one."""
    from pathlib import Path

    src = Path(__file__).resolve().parents[1] / "src" / "mwip" / "studies"
    for name in ("it2_balance", "tsmc_circle", "tsmc_equilibrium", "tsmc_velocity"):
        text = (src / f"{name}.py").read_text()
        assert "finish_claims(claims, metrics" in text and 'c.pop("cause"' not in text, name


def test_the_schema_loads_without_studies_or_matplotlib():
    code = ("import sys, mwip.schema, mwip.report.claims, mwip.report.results; "
            "print(sorted(m for m in sys.modules if m.startswith(('mwip.studies', "
            "'mwip.campaign', 'matplotlib'))))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()  # fmt: skip
    assert out == "[]"
