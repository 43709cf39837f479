"""``mwip params show | save``: the book's parameter sets (Tables 3.1, 3.2) or a file's, with
the derived coefficients of (2.32)."""

from __future__ import annotations

from pathlib import Path

import click

from mwip.cli._common import (
    DAMPING,
    FILE_FORCE,
    NonEmptyPath,
    file_ok,
    params_value,
    record_file,
)

__all__ = ["params"]


@click.group()
def params() -> None:
    """Show or write robot parameters."""


@params.command("show")
@click.argument("which", default="real")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@DAMPING
def params_show(which: str, as_json: bool, damping: str) -> None:
    """Show parameters (real, nominal or a TOML file) and the derived coefficients of (2.32).

    Db, Dw are shown as the equations use them: rotational damping in N m s/rad.
    """
    from mwip.params import UNITS, steady_speed_cap

    p = params_value(which, "WHICH", damping=damping)
    derived = {k: float(getattr(p, k)) for k in ("m11", "m12", "m22", "m33", "Ibl", "Gb")}
    derived["steady_speed_cap"] = float(steady_speed_cap(p))
    book = which.lower() in ("real", "nominal")
    if as_json:
        doc = {"params": p.to_dict(), "units": UNITS, "derived": derived,
               "damping": damping if book else "file (rotational coefficients)"}  # fmt: skip
        from mwip.io import json_text

        click.echo(json_text(doc, indent=2))
        return
    units = {**UNITS, "m11": "kg m^2", "m12": "kg m^2", "m22": "kg m^2", "m33": "kg m^2",
             "Ibl": "kg m^2", "Gb": "N m", "steady_speed_cap": "rad/s (Gb / (2 Dw))"}  # fmt: skip
    for k, v in {**p.to_dict(), **derived}.items():
        click.echo(f"{k:>16} = {v:<12.6g} {units.get(k, '')}")
    click.echo(
        "body inertias about its centre of mass: Iby pitch, Ibz roll (the book's Ibz), Iyaw "
        "yaw; the book's (2.32) is the case Iyaw = 0"
    )
    if book:
        click.echo(
            f"damping reading: {damping} (the table's Db, Dw in N s/m "
            + ("times r^2" if damping == "units" else "taken as N m s/rad")
            + ")"
        )
    else:
        click.echo("Db, Dw as in the file: rotational coefficients of (2.32), N m s/rad")


@params.command("save")
@click.argument("which")
@click.argument("path", type=NonEmptyPath(dir_okay=False, path_type=Path))
@DAMPING
@FILE_FORCE
def params_save(which: str, path: Path, damping: str, force: bool) -> None:
    """Write parameters (real or nominal) to a TOML file to edit for your own robot.

    The file holds Db, Dw as rotational coefficients (N m s/rad), as the equations use them.
    An existing PATH that mwip did not write is refused unless --force.
    """
    from mwip.params import save_params

    params = params_value(which, "WHICH", damping=damping)
    file_ok(path, force, "PATH")
    save_params(params, path)
    record_file(path)
    click.echo(f"wrote {path}")
