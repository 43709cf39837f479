"""File I/O: TOML input with one-line errors, and atomic output.

A reader never sees a half-written file: every writer goes through a temporary file in the
destination folder followed by ``os.replace``, so an interrupted or failed write leaves any
previous file untouched.
"""

from __future__ import annotations

import json
import os
import stat
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
    not the private mode of a temporary file. Only a regular file is ever replaced: a
    ``path`` that names a folder, a device, a pipe or a symbolic link is a ``ValueError``
    (as root, renaming onto ``/dev/full`` would turn the device node into a text file).
    """
    dest = Path(path)
    if not str(path).strip():
        raise ValueError("output file name is empty")
    try:
        mode = os.lstat(dest).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        raise ValueError(f"cannot write {str(dest)!r}: {exc.strerror or exc}") from None
    if mode is not None and not stat.S_ISREG(mode):
        kind = (
            "a folder"
            if stat.S_ISDIR(mode)
            else (
                "a symbolic link" if stat.S_ISLNK(mode) else "not a regular file (a device or pipe)"
            )
        )
        raise ValueError(f"{str(dest)!r} exists and is {kind}; mwip replaces only regular files")
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


def write_parquet_atomic(path: str | os.PathLike[str], frame: Any) -> Path:
    """Write the pandas DataFrame ``frame`` to ``path`` as Parquet (no index), atomically."""
    return write_atomic(path, lambda fh: frame.to_parquet(fh, index=False))


def read_toml(path: str | os.PathLike[str], what: str) -> dict[str, Any]:
    """Parse a TOML file; a missing, unreadable or malformed file is a one-line ``ValueError``.

    ``what`` names the file's role in the message (e.g. ``"scenario file"``). A folder, an
    empty name, a device and a file nested too deeply to parse are refused the same way.
    """
    text = str(path)
    if not text.strip():
        raise ValueError(f"{what} name is empty; give the path of a TOML file")
    p = Path(path)
    if p.exists() and not p.is_file():
        raise ValueError(f"{what} {text!r} is not a regular file (a folder or a device)")
    try:
        with p.open("rb") as fh:
            data = fh.read(_MAX_TOML_BYTES + 1)
    except FileNotFoundError:
        raise ValueError(f"{what} {text!r} does not exist") from None
    except OSError as exc:
        raise ValueError(f"{what} {text!r} cannot be read: {exc.strerror or exc}") from None
    if len(data) > _MAX_TOML_BYTES:
        raise ValueError(f"{what} {text!r} is larger than {_MAX_TOML_BYTES // 2**20} MiB")
    try:
        return tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise ValueError(f"{what} {text!r} is not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{what} {text!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise ValueError(f"{what} {text!r} is nested too deeply") from None


#: Input files are small; a larger one is a mistake (and would be slow to parse).
_MAX_TOML_BYTES = 4 * 2**20
