"""File I/O: TOML input with one-line errors, and atomic output.

A reader never sees a half-written file: every writer goes through a temporary file in the
destination folder followed by ``os.replace``, so an interrupted or failed write leaves any
previous file untouched.
"""

from __future__ import annotations

import json
import os
import tempfile
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = ["write_atomic", "write_text_atomic", "write_json_atomic", "read_toml"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_MODE = 0o666 & ~_umask()  # what open() would give a new file


def write_atomic(path: str | os.PathLike[str], writer: Callable[[IO[bytes]], object]) -> Path:
    """Call ``writer(fh)`` on a temporary binary file, then rename it onto ``path``.

    The file gets the permissions a plainly created file would (``0666`` less the umask),
    not the private mode of a temporary file.
    """
    dest = Path(path)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", suffix=".tmp", dir=dest.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            writer(fh)
        os.chmod(tmp, _MODE)
        os.replace(tmp, dest)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return dest


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 text atomically."""
    return write_atomic(path, lambda fh: fh.write(text.encode("utf-8")))


def write_json_atomic(path: str | os.PathLike[str], data: Any) -> Path:
    """Write JSON (indented, keys in insertion order) atomically."""
    return write_text_atomic(path, json.dumps(data, indent=2, allow_nan=True) + "\n")


def read_toml(path: str | os.PathLike[str], what: str) -> dict[str, Any]:
    """Parse a TOML file; a missing or malformed file is a one-line ``ValueError``.

    ``what`` names the file's role in the message (e.g. ``"scenario file"``).
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ValueError(f"{what} {str(p)!r} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{what} {str(p)!r} is not valid TOML: {exc}") from None
