"""``mwip twin``: the digital twin's configuration and its model sensitivities.

- ``mwip twin show [--twin FILE]``: the twin file (default twin, or FILE's after validation),
  every value commented with its source;
- ``mwip twin sensitivity [--twin FILE] [--json]``: the Case 2 payload / Case 3 stick
  assumptions and the gear ratio, varied (:mod:`mwip.hardware.sensitivity`).

Registered on the main CLI by :mod:`mwip.cli`; hardware modules are imported per command.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

__all__ = ["twin"]

TWIN_OPTION = click.option(
    "--twin", "twin_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
    help="Twin file ([twin] TOML tables, see `mwip twin show`); default: the default twin.",
)  # fmt: skip


def load_twin_option(path: Path | None) -> object:
    """The twin of a ``--twin FILE`` option (``None``: the default twin); errors name
    ``--twin``."""
    from mwip.hardware.twin import Twin
    from mwip.hardware.twin_config import load_twin

    if path is None:
        return Twin()
    try:
        return load_twin(path)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--twin") from None


@click.group()
def twin() -> None:
    """The digital twin of the Chapter 6 robot (docs/twin_model.md)."""


@twin.command("show")
@TWIN_OPTION
def twin_show(twin_file: Path | None) -> None:
    """Print the twin file (defaults with their sources)."""
    from mwip.hardware.twin_config import twin_to_toml

    click.echo(twin_to_toml(load_twin_option(twin_file)), nl=False)  # type: ignore[arg-type]


@twin.command("sensitivity")
@TWIN_OPTION
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def twin_sensitivity(twin_file: Path | None, as_json: bool) -> None:
    """Case 2 payload, Case 3 stick and gear-ratio sensitivities of the plant model."""
    from mwip.hardware.sensitivity import sensitivity_tables, tables_markdown

    tables = sensitivity_tables(load_twin_option(twin_file))  # type: ignore[arg-type]
    if as_json:
        click.echo(json.dumps(tables, indent=1))
    else:
        click.echo(tables_markdown(tables))
