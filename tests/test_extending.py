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


def test_a_command_is_one_file(tmp_path, capsys, monkeypatch):
    """docs/extending.md, "Adding a command": its file, dropped next to the command modules,
    is registered and runs (on a fresh root group: the real one is left as it was)."""
    import sys

    import click

    import mwip.cli
    from mwip.cli._errors import run_guarded

    (code,) = re.findall(r"```py\n(.*?)```", DOC.read_text(), flags=re.DOTALL)
    (tmp_path / "hello.py").write_text(code)
    monkeypatch.setattr(mwip.cli, "__path__", [*mwip.cli.__path__, str(tmp_path)])
    group = click.Group("mwip")
    try:
        mwip.cli._register(group)
        assert "hello" in group.commands and "simulate" in group.commands
        assert run_guarded(group, ["hello"]) == 0
        assert capsys.readouterr().out == "r = 0.04 m\n"  # Table 3.1
        assert run_guarded(group, ["hello", "--params", "no-such.toml"]) == 2
        assert "--params" in capsys.readouterr().err
    finally:
        sys.modules.pop("mwip.cli.hello", None)
    assert "hello" not in mwip.cli.cli.commands
