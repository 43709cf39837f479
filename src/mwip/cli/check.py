"""``mwip check smc``: design checks of a sliding-mode surface ((3.52), (3.66))."""

from __future__ import annotations

import math
import sys

import click

from mwip.cli._common import params_value

__all__ = ["check"]


@click.group()
def check() -> None:
    """Design checks (sliding-mode surfaces, ...)."""


def _floats(text: str, hint: str) -> tuple[float, ...]:
    items = text.replace(" ", "").split(",")
    if any(not x for x in items):
        raise click.BadParameter(f"must be comma-separated numbers with none left empty, "
                                 f"got {text!r}", param_hint=hint)  # fmt: skip
    try:
        return tuple(float(x) for x in items)
    except ValueError:
        raise click.BadParameter(f"must be comma-separated numbers, got {text!r}",
                                 param_hint=hint) from None  # fmt: skip


@check.command("smc")
@click.option(
    "--lambdas", required=True, help="l1,l2,l3[,l4] of the surface (3.49), e.g. 3,0.2,0.3,3."
)
@click.option(
    "--theta-max",
    type=float,
    default=0.35,
    show_default=True,
    help="Operating range |theta| <= THETA_MAX (rad) over which to check.",
)
@click.option(
    "--wheel-damping/--no-wheel-damping",
    "damping",
    default=False,
    show_default=True,
    help="Include the wheel damping Dw that the book's (3.58) omits.",
)
@click.option(
    "--params",
    "params_name",
    default="nominal",
    show_default=True,
    help="real, nominal or a TOML file.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def check_smc_cmd(
    lambdas: str, theta_max: float, damping: bool, params_name: str, as_json: bool
) -> None:
    """Check (3.52), the Hurwitz conditions (3.66) and the sign of g2 + l3 g1."""
    from mwip.laws.smc.design import check_smc_design

    lam = _floats(lambdas, "--lambdas")
    if len(lam) not in (3, 4) or not all(math.isfinite(x) and x > 0 for x in lam):
        raise click.BadParameter(f"needs 3 or 4 numbers in (0, inf), got {lambdas!r}",
                                 param_hint="--lambdas")  # fmt: skip
    if not (math.isfinite(theta_max) and 0 <= theta_max < math.pi / 2):
        raise click.BadParameter(f"must be in [0, 1.5708), got {theta_max!r}",
                                 param_hint="--theta-max")  # fmt: skip
    rep = check_smc_design(lam, params_value(params_name, "--params"), theta_max, damping=damping)
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(rep.to_dict(), indent=2))
    else:
        click.echo(f"lambdas {lam}, |theta| <= {theta_max:g} rad, "
                   f"{'with' if damping else 'without'} wheel damping:")  # fmt: skip
        for c in rep.conditions:
            click.echo(f"  {'ok  ' if c.holds else 'FAIL'} {c.name:8s} {c.expression:48s} "
                       f"worst {c.value: .4g}")  # fmt: skip
        eig = ", ".join(f"{z.real:.4g}{f'{z.imag:+.4g}j' if z.imag else ''}"
                        for z in rep.eigenvalues)  # fmt: skip
        click.echo(f"  sliding dynamics at upright: eig(A) = {eig}")
    if not rep.ok:
        sys.exit(1)
