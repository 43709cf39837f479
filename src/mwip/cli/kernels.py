"""``mwip kernels status | build``: the ahead-of-time compiled simulation loop
(:mod:`mwip.sim.aot`).

A single sampled run loads the loop from a CPython extension module built once per version of
the kernels' sources (~10 s); ``build`` does it now (e.g. after installing, so that the first
``mwip simulate`` is fast), ``status`` says where it is and whether it is current.
"""

from __future__ import annotations

import time

import click

__all__ = ["kernels"]


@click.group()
def kernels() -> None:
    """The ahead-of-time compiled simulation loop (built once per version; ~10 s)."""


@kernels.command("status")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def status_cmd(as_json: bool) -> None:
    """Where the compiled loop lives and whether it is built for the current sources (and
    matches the size and SHA-256 its build recorded)."""
    from mwip.sim import aot

    info = aot.status()
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(info, indent=2))
        return
    if info["built"]:
        state = "built (verified against its manifest)"
    elif info["state"] == "missing":
        state = "not built (the next single run builds it)"
    elif info["state"].startswith("unusable"):
        state = f"not built: {info['state']} (MWIP_CACHE_DIR; simulations use Numba's JIT)"
    else:
        state = f"{info['state']} (the next single run rebuilds it; or 'mwip kernels build')"
    click.echo(f"compiled loop: {state}\nmodule: {info['module']}\nkey: {info['key']}\n"
               f"MWIP_AOT: {info['mode']}")  # fmt: skip


@kernels.command("build")
@click.option("--force", is_flag=True, help="Rebuild even if a sound module exists.")
def build_cmd(force: bool) -> None:
    """Compile the simulation loop ahead of time into the cache (MWIP_CACHE_DIR, else
    ~/.cache/mwip), replacing a corrupt module; exits 1 if the toolchain fails (simulations
    then use Numba's JIT)."""
    from mwip.sim import aot

    problem = aot.folder_problem()
    if problem is not None:
        raise click.UsageError(f"the cache folder cannot be used: {problem} (set MWIP_CACHE_DIR "
                               "to a writable folder)")  # fmt: skip
    t0 = time.perf_counter()
    try:
        path = aot.build(force=force)
    except (RuntimeError, OSError) as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"compiled loop: {path} ({time.perf_counter() - t0:.1f} s)")
