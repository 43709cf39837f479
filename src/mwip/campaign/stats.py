"""Small statistics for campaign summaries: the Wilson score interval of a success rate,
:func:`mwip.schema.robustness.wilson` (on the ground floor, where the report reads a claims
campaign's verdicts)."""

from __future__ import annotations

from mwip.schema.robustness import Z95, wilson

__all__ = ["wilson", "Z95"]
