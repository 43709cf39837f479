"""The results schema, on the ground floor: what studies and campaigns write and what the
summary, the report, the figures and the animations read (never the studies themselves).

- :mod:`mwip.schema.claims` - a claim (:class:`~mwip.schema.claims.Claim`), the causes of a
  failing book claim (:data:`~mwip.schema.claims.CAUSES`), their validation and the one
  post-processing every study applies (:func:`~mwip.schema.claims.finish_claims`);
- :mod:`mwip.schema.metrics` - the metrics document ``metrics.json`` (SPEC.md section 6);
- :mod:`mwip.schema.texts` - the study texts the report shows (the study files' ``[report]``);
- :mod:`mwip.schema.robustness` - a claims campaign's verdicts per claim (Wilson intervals).
"""

from mwip.schema.claims import CAUSES, Claim, finish_claims, validate_claim
from mwip.schema.metrics import metrics_document, to_jsonable, write_metrics
from mwip.schema.texts import load_catalog, study_texts

__all__ = [
    "CAUSES",
    "Claim",
    "finish_claims",
    "load_catalog",
    "metrics_document",
    "study_texts",
    "to_jsonable",
    "validate_claim",
    "write_metrics",
]
