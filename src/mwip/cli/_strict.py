"""Option rules every command shares, applied to the whole command tree at start-up.

- An option that takes one value (not ``multiple``, not a flag or a count) given twice is
  refused (``--settings a.toml --settings b.toml``: click would keep the last one silently).
- A number option (``float``, :class:`click.FloatRange`) refuses ``nan``, ``inf`` and
  ``-inf`` (click's ranges let NaN through: every comparison with it is false).

Both are exit 2 with one line naming the option. Only click at import time.
"""

from __future__ import annotations

import math
from typing import Any

import click

__all__ = ["strict_options"]

_DONE = "_mwip_strict"


def strict_options(group: click.Command) -> None:
    """Apply the rules (module docstring) to ``group`` and every command under it (once)."""
    for cmd in _walk(group):
        if getattr(cmd, _DONE, False):
            continue
        setattr(cmd, _DONE, True)
        cmd.parse_args = _checked(cmd, cmd.parse_args)  # type: ignore[method-assign]


def _walk(cmd: click.Command) -> list[click.Command]:
    out = [cmd]
    if isinstance(cmd, click.Group):
        for sub in cmd.commands.values():
            out += _walk(sub)
    return out


def _single_valued(p: click.Parameter) -> bool:
    return (isinstance(p, click.Option) and not p.multiple and not p.count
            and not p.is_flag and p.nargs == 1)  # fmt: skip


def _non_finite(raw: Any) -> float | None:
    """The non-finite number ``raw`` (text as typed) reads as, else ``None``."""
    for item in raw if isinstance(raw, list | tuple) else (raw,):
        try:
            x = float(item)
        except (TypeError, ValueError):
            continue  # not a number at all: the option's own type says so
        if not math.isfinite(x):
            return x
    return None


def _checked(cmd: click.Command, parse: Any) -> Any:
    def parse_args(ctx: click.Context, args: list[str]) -> list[str]:
        if not isinstance(cmd, click.Group) and not ctx.resilient_parsing:
            try:
                opts, _, order = cmd.make_parser(ctx).parse_args(args=list(args))
            except click.UsageError:
                opts, order = {}, []  # the real parse below says what is wrong
            seen: set[str] = set()
            for p in order:
                if _single_valued(p) and p.name is not None:
                    if p.name in seen:
                        name = max(p.opts, key=len) if p.opts else p.name
                        raise click.UsageError(f"{name} is given twice; give it once "
                                               "(it takes one value)", ctx=ctx)  # fmt: skip
                    seen.add(p.name)
                if (isinstance(p.type, click.types.FloatParamType) and p.name in opts
                        and (bad := _non_finite(opts[p.name])) is not None):  # fmt: skip
                    raise click.BadParameter(f"must be a finite number, got {bad!r}",
                                             ctx=ctx, param=p)  # fmt: skip
        return parse(ctx, args)

    return parse_args
