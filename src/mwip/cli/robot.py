"""``mwip robot``: robot files (:mod:`mwip.robot`, docs/robot.md).

- ``mwip robot show [FILE] [--book | --datasheet]``: the default robot (the book's), the
  book's robot with the data-sheet guesses, or FILE as loaded (validated, every value with
  its unit, status and source); the text loads back to the same robot and prints the same.
"""

from __future__ import annotations

from pathlib import Path

import click

from mwip.cli._common import NonEmptyPath, robot_option

__all__ = ["robot"]


@click.group()
def robot() -> None:
    """Robot files: one file per robot, taken by every command that runs one (--robot)."""


@robot.command("show")
@click.argument("file", required=False, type=NonEmptyPath(dir_okay=False, path_type=Path))
@click.option("--book", is_flag=True, help="The book's robot (the default): Tables 6.1/6.2 "
              "and the twin identified from the book's evidence.")  # fmt: skip
@click.option("--datasheet", is_flag=True, help="The book's robot with every unknown at its "
              "data-sheet guess (the prior's centre).")  # fmt: skip
def robot_show(file: Path | None, book: bool, datasheet: bool) -> None:
    """Print a robot file: FILE as loaded, or the default robot; every value with its unit,
    status (known, assumed, unknown with its prior) and source."""
    from mwip.robot import datasheet_robot, robot_to_toml

    if sum((file is not None, book, datasheet)) > 1:
        raise click.UsageError("give one of FILE, --book, --datasheet")
    if datasheet:
        r = datasheet_robot()
    else:
        if file is not None and not file.exists():
            raise click.BadParameter(f"no such file {str(file)!r}", param_hint="FILE")
        r = robot_option(file, hint="FILE")
    click.echo(robot_to_toml(r), nl=False)
