"""A settings file read and validated against the registry: ``(controller, settings)``.

The format and its shape check are the ground floor's (:mod:`mwip.schema.settings`: what
``mwip tune`` writes as ``best.toml``); here each setting is also checked against the named
controller's allowed range (:meth:`mwip.laws.registry.ControllerSpec.resolve`). Every error is
a one-line ``ValueError`` naming the file and the field.
"""

from __future__ import annotations

import os
from typing import Any

__all__ = ["load_settings"]


def load_settings(path: str | os.PathLike[str]) -> tuple[str, dict[str, Any]]:
    """``(controller name, settings as given)`` of the settings file ``path``, validated."""
    from mwip.laws.registry import get
    from mwip.schema.settings import read_settings_file

    sf = read_settings_file(path)
    settings = sf.settings_dict()
    try:
        get(sf.name).resolve(settings)
    except ValueError as exc:
        raise ValueError(f"settings file {str(path)!r}: {exc}") from None
    return sf.name, settings
