"""The law families (the folders of :mod:`mwip.laws`), found by their ``packing.py``: which
folder a law code belongs to, without importing any compiled code."""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache
from pathlib import Path

__all__ = ["codes", "family_of"]


@cache
def codes() -> dict[int, str]:
    """Law code -> family folder name, for every folder with a ``packing.py`` (unique codes)."""
    here = Path(__file__).resolve().parent
    out: dict[int, str] = {}
    for info in pkgutil.iter_modules([str(here)]):
        if info.ispkg and (here / info.name / "packing.py").is_file():
            code = int(importlib.import_module(f"mwip.laws.{info.name}.packing").CODE)
            if code in out:
                raise RuntimeError(f"law code {code} is used by {out[code]} and {info.name}")
            out[code] = info.name
    return out


def family_of(code: int) -> str:
    """The family folder of law ``code``."""
    try:
        return codes()[int(code)]
    except KeyError:
        raise ValueError(f"unknown law code {code!r}; known: {sorted(codes())}") from None
