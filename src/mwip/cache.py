"""mwip's on-disk cache: the ahead-of-time compiled loop (:mod:`mwip.sim.aot`) and solved
designs whose solver is slow to load (the IT2 PDC LMIs, :func:`mwip.fuzzy.pdc.design_pdc`).

Everything here is derived data: an entry is named by a hash of all its inputs (the source
files of the code that computes it, the library versions, the arguments), so an edit gives a
new name and a stale entry is never read; deleting the folder only costs a recomputation.
Besides, :data:`mwip.outfile.RECORD` notes the single files mwip wrote (deleting it only means
that replacing one of them asks for ``--force``).
A design read back is checked again by its own verification before use.

Folder: ``$MWIP_CACHE_DIR``, else ``$XDG_CACHE_HOME/mwip``, else ``~/.cache/mwip``.
``MWIP_CACHE=off`` turns the design cache off (no reads, no writes).
"""

from __future__ import annotations

import hashlib
import io
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

__all__ = ["cache_dir", "digest", "versions", "load_arrays", "save_arrays", "enabled"]


def cache_dir() -> Path:
    """``$MWIP_CACHE_DIR``, ``$XDG_CACHE_HOME/mwip`` or ``~/.cache/mwip``."""
    if os.environ.get("MWIP_CACHE_DIR"):
        return Path(os.environ["MWIP_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mwip"


def enabled() -> bool:
    """Whether designs are read from and written to the cache (``MWIP_CACHE`` not ``off``)."""
    return os.environ.get("MWIP_CACHE", "on").strip().lower() != "off"


def versions(packages: Iterable[str]) -> list[str | None]:
    """The installed versions of ``packages`` (``None`` where one is absent), read from their
    metadata without importing them: part of a cache name."""
    from importlib.metadata import PackageNotFoundError, version

    out: list[str | None] = []
    for pkg in packages:
        try:
            out.append(version(pkg))
        except PackageNotFoundError:
            out.append(None)
    return out


def digest(parts: Iterable[Any]) -> str:
    """A hex name for ``parts``: bytes as they are, files (:class:`~pathlib.Path`) by their
    contents, NumPy arrays by dtype, shape and bytes, anything else by ``repr``."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, Path):
            data = b"file:" + p.read_bytes()
        elif isinstance(p, bytes | bytearray):
            data = bytes(p)
        elif hasattr(p, "tobytes") and hasattr(p, "dtype"):
            data = f"{p.dtype}{p.shape}".encode() + p.tobytes()
        else:
            data = repr(p).encode()
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()[:24]


def load_arrays(kind: str, name: str) -> dict[str, Any] | None:
    """The arrays saved as ``kind/name`` (``None``: absent, unreadable or cache off)."""
    if not enabled():
        return None
    import numpy as np

    path = cache_dir() / kind / f"{name}.npz"
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError):
        return None


def save_arrays(kind: str, name: str, arrays: dict[str, Any]) -> None:
    """Save ``arrays`` as ``kind/name`` atomically; a cache that cannot be written is skipped
    (it is only a cache)."""
    if not enabled():
        return
    import numpy as np

    from mwip.io import write_atomic

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    try:
        path = cache_dir() / kind / f"{name}.npz"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, lambda fh: fh.write(buf.getvalue()))
    except OSError:
        pass
