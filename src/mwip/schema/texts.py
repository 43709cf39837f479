"""The study texts the report shows (title, set-up, the book's figure, gaps, docs) and each
study's ``main_run``: the ``[report]`` table of each study file
``mwip/studies/scenarios/<study>.toml``, read as data (no study module is imported)."""

from __future__ import annotations

import tomllib
from importlib import resources

__all__ = ["load_catalog", "study_texts"]


def load_catalog() -> dict[str, dict[str, str]]:
    """The per-study texts shipped with mwip: ``{study: its [report] table}``."""
    folder = resources.files("mwip").joinpath("studies", "scenarios")
    out: dict[str, dict[str, str]] = {}
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".toml"):
            texts = tomllib.loads(entry.read_text("utf-8")).get("report")
            if texts:
                out[entry.name.removesuffix(".toml")] = dict(texts)
    return out


def study_texts(name: str) -> dict[str, str]:
    """The texts the report shows for study ``name`` (title, setup, book, gaps, docs) and the
    name of its ``main_run`` (the run its animation shows); ``{}`` if there are none.

    Every reader of these texts goes through this function (:func:`load_catalog`).
    """
    entry = load_catalog().get(name, {})
    return {str(k): str(v) for k, v in entry.items()} if isinstance(entry, dict) else {}
