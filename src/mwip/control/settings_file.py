"""A controller's settings as a file: which controller, and the settings that differ from the
book's (``mwip tune`` writes one as ``best.toml``; ``mwip simulate --settings FILE`` reads it)::

    # any comment (what produced the file)
    [controller]
    name = "hodosmc"

    [settings]
    K = [6.3, 4.0]
    phi = 0.05

Every setting is validated against the registry (:meth:`ControllerSpec.resolve`): an unknown
name, a value outside its allowed range, or a missing ``[controller] name`` is a one-line
``ValueError`` naming the file and the field.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["read_settings_file", "settings_text", "write_settings_file"]


def read_settings_file(path: str | os.PathLike[str]) -> tuple[str, dict[str, Any]]:
    """``(controller name, settings as given)`` of a settings file, validated."""
    from mwip.control.registry import get
    from mwip.io import read_toml

    what = "settings file"
    data = read_toml(path, what)
    extra = sorted(set(data) - {"controller", "settings"})
    if extra:
        raise ValueError(f"{what} {str(path)!r}: unknown table {extra[0]!r}; allowed: "
                         "controller, settings")  # fmt: skip
    ctrl = data.get("controller")
    if not isinstance(ctrl, dict) or not isinstance(ctrl.get("name"), str):
        raise ValueError(f'{what} {str(path)!r}: needs [controller] name = "..."')
    unknown = sorted(set(ctrl) - {"name"})
    if unknown:
        raise ValueError(f"{what} {str(path)!r}: controller.{unknown[0]}: unknown key; "
                         "allowed: name")  # fmt: skip
    settings = data.get("settings", {})
    if not isinstance(settings, dict):
        raise ValueError(f"{what} {str(path)!r}: [settings] must be a table")
    try:
        get(ctrl["name"]).resolve(settings)
    except ValueError as exc:
        raise ValueError(f"{what} {str(path)!r}: {exc}") from None
    return ctrl["name"], dict(settings)


def settings_text(name: str, settings: Mapping[str, Any], header: str = "") -> str:
    """The text of a settings file (``header``: comment lines, ``#`` added where missing)."""
    import json

    def value(v: Any) -> str:
        if isinstance(v, list | tuple):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int | float):
            return repr(float(v)) if isinstance(v, float) else str(v)
        return json.dumps(str(v))  # a TOML basic string

    lines = [ln if ln.startswith("#") else f"# {ln}" for ln in header.splitlines()]
    body = [f"[controller]\nname = {json.dumps(name)}\n", "[settings]"]
    body += [f"{k} = {value(v)}" for k, v in settings.items() if v is not None]
    return ("\n".join(lines) + "\n" if lines else "") + "\n".join(body) + "\n"


def write_settings_file(
    path: str | os.PathLike[str], name: str, settings: Mapping[str, Any], header: str = ""
) -> Path:
    """Write :func:`settings_text` to ``path`` atomically."""
    from mwip.io import write_text_atomic

    return write_text_atomic(path, settings_text(name, settings, header))
