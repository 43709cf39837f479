"""``mwip controllers [NAME]``: the registered controllers, their book sources and settings."""

from __future__ import annotations

import math
from typing import Any

import click

__all__ = ["controllers"]


def _show(value: Any) -> Any:
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" for v in value)
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    return "none" if value is None else value


@click.command("controllers")
@click.argument("name", required=False)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def controllers(name: str | None, as_json: bool) -> None:
    """List the controllers (or one controller's settings, with the book's defaults).

    Run one with `mwip simulate --controller NAME [--set key=value ...]`.
    """
    from mwip.laws.registry import CONTROLLERS, get

    if name is not None:
        try:
            specs = [get(name)]
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="NAME") from None
    else:
        specs = list(CONTROLLERS.values())
    if as_json:
        doc = {
            s.name: {
                "title": s.title, "source": s.source, "Ts": s.Ts, "robot": s.robot,
                "settings": {
                    x.name: {"default": list(x.default) if isinstance(x.default, tuple)
                             else x.default, "allowed": x.allowed(), "help": x.help}
                    for x in s.settings
                },
            }
            for s in specs
        }  # fmt: skip
        from mwip.io import json_text

        click.echo(json_text(doc, indent=2))
        return
    for s in specs:
        twin = " [twin]" if s.robot else ""
        click.echo(f"{s.name:8s} {s.title}{twin}\n{'':8s} source: {s.source}")
        if name is not None:
            click.echo(f"{'':8s} sample period by default: {s.Ts:g} s")
            for x in s.settings:
                click.echo(f"  {x.name:13s} = {str(_show(x.default)):28s} {x.allowed()}")
                click.echo(f"  {'':13s}   {x.help}")
    if name is None:
        click.echo("\n[twin]: run on the robot in Chapter 6 (`mwip simulate --twin`). "
                   "Settings: `mwip controllers NAME`.")  # fmt: skip
