"""docs/extending.md runs: its Python blocks, in order, define, register and use a controller
(the walk-through's own assertions check that it balances and that bad settings exit 2)."""

from __future__ import annotations

import re
from pathlib import Path

from mwip.laws.registry import CONTROLLERS

DOC = Path(__file__).resolve().parents[1] / "docs" / "extending.md"


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(), flags=re.DOTALL)


def test_walkthrough_runs(tmp_path, capsys, monkeypatch):
    blocks = _blocks("python")
    assert len(blocks) >= 5
    ns: dict[str, object] = {"__name__": "extending_example"}
    try:
        for code in blocks:
            exec(compile(code, str(DOC), "exec"), ns)  # noqa: S102 - our own documentation
        # the scenario file of the page runs too
        from mwip.cli import main

        (tmp_path / "s.toml").write_text(_blocks("toml")[0])
        assert main(["simulate", "--scenario", str(tmp_path / "s.toml")]) == 0
        assert "status: ok" in capsys.readouterr().out
    finally:
        CONTROLLERS.pop("place", None)
    assert "place" not in CONTROLLERS
