"""Single output files mwip may replace (the file counterpart of :mod:`mwip.outdir`).

A command that writes one file the user names (``mwip twin excite --out FILE``, ``mwip params
save WHICH FILE``, ``mwip scenario STUDY --out FILE``, ``mwip animate --out FILE``, ``mwip plot
--out FILE``) never replaces a file that mwip did not write there without ``--force``: a
mistyped name (``--out README.md``) is refused with one line, and the file stays as it was.

A file counts as mwip's when

- it does not exist yet;
- it lies in an mwip output folder (one carrying :data:`mwip.outdir.MARKER`, the file's own
  folder or one of the two above it: ``OUT/<study>/plot/<run>.png``): mwip replaces the
  entries it writes there; or
- mwip wrote it and it is unchanged since: every file written through :func:`record` is
  noted with its size and SHA-256 in the record :data:`RECORD` in mwip's cache folder
  (:func:`mwip.cache.cache_dir`). Deleting the cache only means that the next write over such
  a file asks for ``--force``; a file edited since mwip wrote it is the user's again.

:func:`check` decides without writing anything (call it before the work that makes the
file); :func:`record` notes a file after it was written.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path

__all__ = ["RECORD", "check", "record", "is_mwip_file"]

#: The record of files mwip wrote (in the cache folder): ``{path: [size, sha256]}``.
RECORD = "written-files.json"
#: How many files the record remembers (the oldest are forgotten first).
MAX_ENTRIES = 2000


def _record_path() -> Path:
    from mwip.cache import cache_dir

    return cache_dir() / RECORD


def _key(path: Path) -> str:
    return str(Path(os.path.realpath(path)))


def _fingerprint(path: Path) -> list[object] | None:
    """``[size, sha256]`` of the regular file ``path``; ``None`` if it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        return [path.stat().st_size, h.hexdigest()]
    except OSError:
        return None


def _load() -> dict[str, list[object]]:
    try:
        doc = json.loads(_record_path().read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def is_mwip_file(path: Path | str) -> bool:
    """Whether mwip wrote the existing file ``path`` and it is unchanged since (by the record),
    or it lies in an mwip output folder."""
    from mwip.outdir import is_owned

    path = Path(path)
    if any(is_owned(folder) for folder in path.absolute().parents[:3]):
        return True
    seen = _load().get(_key(path))
    return seen is not None and seen == _fingerprint(path)


def check(path: Path | str, force: bool = False, option: str = "--out") -> Path:
    """``path`` if mwip may write the file there; otherwise ``ValueError`` naming ``option``.

    Refused: an empty name, a folder, and an existing file that is not mwip's (see the
    module) unless ``force``.
    """
    text = str(path)
    if not text.strip():
        raise ValueError(f"{option}: the file name is empty; give a file name")
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{option}: {text!r} is a folder; give a file name")
    if force or not (path.exists() or path.is_symlink()) or is_mwip_file(path):
        return path
    changed = _key(path) in _load()
    why = "was changed since mwip wrote it" if changed else "exists and mwip did not write it"
    raise ValueError(f"{option}: {text!r} {why}; give another name, or add --force to "
                     "replace it")  # fmt: skip


def record(path: Path | str) -> None:
    """Note that mwip has just written ``path`` (its size and SHA-256), so that a later run may
    replace it without ``--force``. Never fails: a record that cannot be written only means a
    later ``--force``."""
    path = Path(path)
    stamp = _fingerprint(path)
    if stamp is None:
        return
    with contextlib.suppress(OSError, ValueError):
        import fcntl

        from mwip.io import write_json_atomic

        where = _record_path()
        where.parent.mkdir(parents=True, exist_ok=True)
        with open(where.with_suffix(".lock"), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            doc = _load()
            doc.pop(_key(path), None)
            doc[_key(path)] = stamp  # (insertion order: the newest last)
            while len(doc) > MAX_ENTRIES:
                doc.pop(next(iter(doc)))
            write_json_atomic(where, doc)
