"""docs/extending.md, "Adding a study": the files it shows are the shipped example study, and
that study runs through the registry and `mwip run` like every other."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from mwip.cli import main
from mwip.metrics import settling_time
from mwip.studies import registry

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "extending.md").read_text()
STUDIES = ROOT / "src" / "mwip" / "studies"


def _block(after: str, lang: str) -> str:
    tail = DOC[DOC.index(after) :]
    return re.search(rf"```{lang}\n(.*?)```", tail, flags=re.DOTALL).group(1)


def test_the_page_shows_the_shipped_files():
    assert (
        _block("`src/mwip/studies/lqr_settling.py`:", "python")
        == (STUDIES / "lqr_settling.py").read_text()
    )
    assert (
        _block("`src/mwip/studies/scenarios/lqr-settling.toml`", "toml")
        == (STUDIES / "scenarios" / "lqr-settling.toml").read_text()
    )


def test_example_study_runs_through_the_registry_and_the_cli(tmp_path, capsys):
    study = registry.get("lqr-settling")
    assert study.run.__module__ == "mwip.studies.lqr_settling"
    assert main(["run", "lqr-settling", "--quick", "--out", str(tmp_path)]) == 0
    assert "lqr-settling (Sec. 4.4.2)" in capsys.readouterr().out
    folder = tmp_path / "lqr-settling"
    doc = json.loads((folder / "metrics.json").read_text())
    record = json.loads((tmp_path / "run.json").read_text())
    assert list(record["studies"]) == ["lqr-settling"]
    # the metrics are the saved runs' own: recompute the settling times from the npz
    runs = np.load(folder / "runs.npz")
    t, theta = runs["t"], runs["states"][..., 1]  # [psi, theta, alpha, ...]
    starts = np.linspace(0.05, 0.35, 5)
    for i, theta0 in enumerate(starts):
        assert theta[i, 0] == theta0 == doc["metrics"][f"start{i}.theta0"]
        assert doc["metrics"][f"start{i}.settling_time"] == settling_time(t, theta[i])
    assert doc["claims"][0]["values"] == {"max_settling_time": doc["metrics"]["max_settling_time"]}
