"""File I/O: TOML input with one-line errors, and atomic output escaped for its format.

A reader never sees a half-written file: every writer goes through a temporary file in the
destination folder followed by ``os.replace``, so an interrupted or failed write leaves any
previous file untouched.

Escaping. JSON is written without ``NaN`` or ``Infinity`` (not JSON: a non-finite number is
written ``null``, :func:`json_text`); TOML strings, keys and comments written by hand go
through :func:`toml_str`, :func:`toml_key` and :func:`toml_comment`, and text put into HTML
through :func:`html_text`, so a name or value with newlines, quotes, brackets or control
characters can neither break the file nor inject TOML or markup into it. CSV goes through
Python's ``csv`` writer (quoting).
"""

from __future__ import annotations

import json
import math
import os
import stat
import tempfile
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = ["write_atomic", "write_text_atomic", "write_json_atomic", "read_toml", "json_text",
           "finite_json", "toml_str", "toml_key", "toml_comment", "html_text"]


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


def finite_json(x: Any) -> Any:
    """``x`` with every non-finite float (also in NumPy scalars and arrays, inside dicts,
    lists and tuples) replaced by ``None``, NumPy values as plain Python ones; dict keys as
    text."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k if isinstance(k, str) else str(k): finite_json(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [finite_json(v) for v in x]
    tolist = getattr(x, "tolist", None)  # NumPy arrays and scalars
    if tolist is not None and type(x).__module__ == "numpy":
        return finite_json(tolist())
    return x


def json_text(data: Any, indent: int | None = 2) -> str:
    """``data`` as JSON text: non-finite numbers as ``null`` (:func:`finite_json`), never
    ``NaN`` or ``Infinity``; every string escaped by the ``json`` module."""
    return json.dumps(finite_json(data), indent=indent, allow_nan=False)


def write_json_atomic(path: str | os.PathLike[str], data: Any) -> Path:
    """Write JSON (indented, keys in insertion order; :func:`json_text`) atomically."""
    return write_text_atomic(path, json_text(data) + "\n")


_TOML_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f",
                 "\r": "\\r"}  # fmt: skip


def html_text(x: Any) -> str:
    """``str(x)`` for HTML text or an attribute value: ``& < > " '`` as character
    references, and a control character (which HTML does not allow, bar tab, newline and
    carriage return) as its visible escape ``\\xNN``."""
    import html

    text = html.escape(str(x), quote=True)
    return "".join(c if c in "\t\n\r" or not (ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0)
                   else f"\\x{ord(c):02x}" for c in text)  # fmt: skip


def toml_str(text: str) -> str:
    """``text`` as a TOML basic string (quotes, backslashes and every control character
    escaped; the rest, any Unicode, as it is)."""
    out = []
    for ch in str(text):
        if ch in _TOML_ESCAPES:
            out.append(_TOML_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(key: str) -> str:
    """``key`` bare where TOML allows it (letters, digits, ``_``, ``-``), else quoted."""
    k = str(key)
    if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k):
        return k
    return toml_str(k)


def toml_comment(text: str) -> str:
    """``text`` as TOML comment lines (``# ...``, one per line of ``text``): a control
    character that a comment may not hold (all but tab) is written as its escape, so the
    comment cannot end early and the text after it cannot become TOML."""
    lines = []
    for line in str(text).split("\n"):
        safe = "".join(c if c == "\t" or not (ord(c) < 0x20 or ord(c) == 0x7F)
                       else f"\\x{ord(c):02x}" for c in line)  # fmt: skip
        lines.append(f"# {safe}" if safe else "#")
    return "\n".join(lines)


def write_parquet_atomic(path: str | os.PathLike[str], frame: Any, **options: Any) -> Path:
    """Write the pandas DataFrame ``frame`` to ``path`` as Parquet (no index; ``options``
    pyarrow's writer options, e.g. ``compression``), atomically."""
    return write_atomic(path, lambda fh: frame.to_parquet(fh, index=False, **options))


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
    if data.startswith(b"\xef\xbb\xbf"):
        raise ValueError(f"{what} {text!r} starts with a UTF-8 byte-order mark (BOM), which TOML "
                         "does not allow; save it as UTF-8 without BOM")  # fmt: skip
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
