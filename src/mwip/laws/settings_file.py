"""A settings file read and validated against the registry: ``(controller, settings)``.

The format and its shape check are the ground floor's (:mod:`mwip.schema.settings`: what
``mwip tune`` writes as ``best.toml``); here each setting is also checked against the named
controller's allowed range (:meth:`mwip.laws.registry.ControllerSpec.resolve`). Every error is
a one-line ``ValueError`` naming the file and the field.
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["load_settings", "check_file_types"]


def check_file_types(controller: str, settings: dict[str, Any], where: str) -> None:
    """Refuse text where a file must hold numbers: ``K = "7,3"`` for a vector setting is a
    string (the ``--set K=7,3`` syntax of the command line), not the list ``[7, 3]``; a word
    is text only for a setting that takes a word (or ``"none"`` for an optional one).
    One-line ``ValueError`` naming ``where`` and the setting; unknown names are left to the
    registry's check."""
    from mwip.laws.registry import get

    try:
        spec = get(controller)
    except ValueError:
        return
    for key, value in settings.items():
        try:
            s = spec.setting(key)
        except ValueError:
            continue
        if not isinstance(value, str) or s.choices:
            continue
        if s.optional and value.strip().lower() == "none":
            continue
        example = ("[" + ", ".join(["1.0"] * s.size) + "]") if s.size else "1.0"
        raise ValueError(f"{where}: settings.{key} must be {s.allowed()} written as TOML "
                         f"numbers (e.g. {key} = {example}), got the text {value!r}")


def load_settings(path: str | os.PathLike[str]) -> tuple[str, dict[str, Any]]:
    """``(controller name, settings as given)`` of the settings file ``path``, validated."""
    from mwip.laws.registry import get
    from mwip.schema.settings import read_settings_file

    sf = read_settings_file(path)
    settings = sf.settings_dict()
    check_file_types(sf.name, settings, f"settings file {str(path)!r}")
    try:
        get(sf.name).resolve(settings)
    except ValueError as exc:
        raise ValueError(f"settings file {str(path)!r}: {exc}") from None
    return sf.name, settings
