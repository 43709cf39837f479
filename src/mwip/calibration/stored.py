"""What a folder of stored calibration blocks belongs to (``plan.json``), checked on resume."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["claim_folder"]


def claim_folder(store: Path, ident: dict[str, Any], what: str) -> None:
    """Write ``ident`` as ``store/plan.json``, or check it against the one there: a folder
    holding another identity is a ``ValueError`` naming ``what`` it holds (its stored blocks
    would otherwise be replayed as this plan's)."""
    from mwip.io import write_json_atomic

    path = store / "plan.json"
    if path.exists():
        if json.loads(path.read_text(encoding="utf-8")) != json.loads(json.dumps(ident)):
            raise ValueError(f"{store}: holds the {what}; remove the folder to start again")
        return
    store.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, ident)
