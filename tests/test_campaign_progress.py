"""A campaign runs and counts what was asked (issue 25 item 6: `--samples 20` printed
"100/100 samples")."""

from __future__ import annotations

import pandas as pd

from mwip.campaign.execute import run_campaign
from mwip.campaign.spec import parse_campaign


def test_progress_counts_the_samples_asked(tmp_path) -> None:
    camp = parse_campaign({
        "campaign": {"title": "t", "samples": 7, "seed": 1, "block": 5, "duration": 0.2},
        "controllers": [{"name": "lqr"}], "robot": {"centre": "real", "design": "nominal"},
    })  # fmt: skip
    seen: list[tuple[int, int]] = []
    run_campaign(camp, tmp_path / "c", jobs=1, progress=lambda a, b, t: seen.append((a, b)))
    assert seen == [(5, 7), (7, 7)]
    table = pd.read_parquet(tmp_path / "c" / "results.parquet")
    assert sorted(table["sample"]) == list(range(7))
