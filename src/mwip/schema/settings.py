"""A controller's settings as a file: what ``mwip tune`` writes (``best.toml``) and what
``mwip bench --settings``, ``mwip simulate --settings`` and ``mwip export c --settings`` read.

The format (TOML)::

    # any comment lines: provenance (the tuning run, its objective, its score)
    [controller]
    name = "hodosmc"          # a registered controller (`mwip controllers`)
    label = "hodosmc-tuned"   # optional: the name shown in tables (default: NAME (FILE stem))

    [settings]                # the settings to change; the others keep the book's defaults
    K = [7.1, 3.2]
    lambdas = [2.0, 5.0, 0.8]

Only the shape is checked here (the ground floor knows no controllers): ``[controller]`` with
a text ``name`` (and optional ``label``), ``[settings]`` a table of numbers, lists of numbers,
words or booleans; no other table or key. The values are validated against the registry's
ranges by the reader (``mwip.laws.registry.get(name).resolve(settings)``), which names the
file on error. Every error is a one-line ``ValueError`` naming the file and the field.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mwip.io import read_toml, toml_comment, toml_key, toml_str, write_text_atomic

__all__ = ["SettingsFile", "parse_settings", "read_settings_file", "settings_text",
           "write_settings_file"]


@dataclass(frozen=True)
class SettingsFile:
    """The parsed file: controller ``name``, optional ``label``, ``settings`` (sorted items)."""

    name: str
    settings: tuple[tuple[str, Any], ...]
    label: str | None = None

    def settings_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in self.settings}


def _value(v: Any, where: str) -> Any:
    if isinstance(v, bool | str):
        return v
    if isinstance(v, int | float):
        if not math.isfinite(v):
            raise ValueError(f"{where} must be finite, got {v!r}")
        return v
    if isinstance(v, list) and v and all(isinstance(x, int | float) and not isinstance(x, bool)
                                         for x in v):  # fmt: skip
        if not all(math.isfinite(x) for x in v):
            raise ValueError(f"{where} must hold finite numbers, got {v!r}")
        return tuple(v)
    raise ValueError(f"{where} must be a number, a list of numbers, a word or true/false, "
                     f"got {v!r}")  # fmt: skip


def parse_settings(data: dict[str, Any], where: str = "settings file") -> SettingsFile:
    """Check the shape of a parsed settings file (module docstring)."""
    extra = sorted(set(data) - {"controller", "settings"})
    if extra:
        raise ValueError(f"{where}: unknown table {extra[0]!r}; allowed: controller, settings")
    ctrl = data.get("controller")
    if not isinstance(ctrl, dict):
        raise ValueError(f"{where}: missing [controller] table with name = \"...\"")
    bad = sorted(set(ctrl) - {"name", "label"})
    if bad:
        raise ValueError(f"{where}: controller.{bad[0]}: unknown key; allowed: label, name")
    name = ctrl.get("name")
    if not (isinstance(name, str) and name.strip()):
        raise ValueError(f"{where}: controller.name must be a registered controller's name, "
                         f"got {name!r}")  # fmt: skip
    label = ctrl.get("label")
    if label is not None and not (isinstance(label, str) and label.strip()):
        raise ValueError(f"{where}: controller.label must be non-empty text, got {label!r}")
    table = data.get("settings", {})
    if not isinstance(table, dict):
        raise ValueError(f"{where}: [settings] must be a table of setting = value")
    items = tuple(sorted((k, _value(v, f"{where}: settings.{k}")) for k, v in table.items()))
    return SettingsFile(name.strip(), items, label)


def read_settings_file(path: str | os.PathLike[str]) -> SettingsFile:
    """Read and shape-check a settings file (one-line ``ValueError`` naming it)."""
    where = f"settings file {str(path)!r}"
    return parse_settings(read_toml(path, "settings file"), where)


def _toml(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return toml_str(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(int(v))


def settings_text(name: str, settings: dict[str, Any], comment: str = "",
                  label: str | None = None) -> str:  # fmt: skip
    """The file's text for controller ``name`` and ``settings`` (``comment``: lines put first,
    each prefixed with ``# ``, control characters escaped). Floats are written with ``repr``
    (read back exactly); names and words are escaped (:mod:`mwip.io`); the text is checked to
    read back as the same file."""
    lines = toml_comment(comment.removesuffix("\n")).split("\n") if comment else []
    lines += ["[controller]", f"name = {_toml(name)}"]
    if label is not None:
        lines.append(f"label = {_toml(label)}")
    lines += ["", "[settings]"]
    lines += [f"{toml_key(k)} = {_toml(v)}" for k, v in sorted(settings.items()) if v is not None]
    text = "\n".join(lines) + "\n"
    back = parse_settings(tomllib.loads(text), "settings_text")  # round trip
    if back.name != name.strip() or back.label != label:
        raise ValueError(f"settings_text: controller name {name!r} does not read back")
    return text


def write_settings_file(path: str | os.PathLike[str], name: str, settings: dict[str, Any],
                        comment: str = "", label: str | None = None) -> Path:  # fmt: skip
    """Write :func:`settings_text` to ``path`` atomically."""
    return write_text_atomic(path, settings_text(name, settings, comment, label))
