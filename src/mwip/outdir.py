"""Output folders mwip may write into.

mwip writes only into a folder that it created or marked as its own, or an empty one: its
results replace whole entries (a study's folder, ``index.html``, ``run.json``), and in a
user's folder those names may be the user's files. A folder becomes mwip's when mwip first
writes into it: it gets the marker file :data:`MARKER`, which names the command that owns it
(``command: mwip reproduce``). Any other folder (not empty, no marker) is refused unless the
user names it with ``--force``, and so is a folder another command owns (``mwip run`` never
writes over ``mwip reproduce``'s results unless told to; a marker of an older mwip names no
command and is any command's); the current folder by an empty name (``--out ""``) is always
refused.

:func:`check` decides without writing anything (so a refused run changes nothing);
:func:`claim` creates the folder and its marker when the results are about to be written.

A command that rewrites the whole folder (``mwip reproduce``, ``mwip campaign run``) holds it
for its run (:func:`hold`): an exclusive lock on the file :data:`LOCK` in the folder, which
holds the owner's process id. A second such command on the same folder is refused with the
first one's id; the lock goes with the process that holds it (also when it is killed), so a
lock file left by a process that no longer runs is stale and simply taken over.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from mwip.io import write_text_atomic

__all__ = ["MARKER", "LOCK", "check", "claim", "is_owned", "hold", "marker_text", "owner"]

#: The marker file: its presence says the folder is mwip's output folder.
MARKER = ".mwip-output"
MARKER_TEXT = (
    "This folder holds mwip results. mwip replaces the entries it writes here "
    "(<study>/, index.html, run.json, timeseries.*, summary.json).\n"
)


_OWNER = "command: mwip "


def marker_text(command: str | None = None) -> str:
    """The marker file's text, naming ``command`` (e.g. ``"reproduce"``) as the folder's owner."""
    return MARKER_TEXT + (f"{_OWNER}{command}\n" if command else "")


#: The lock file of a folder held by a running command (:func:`hold`).
LOCK = ".mwip-lock"


def is_owned(out: Path) -> bool:
    """Whether ``out`` carries mwip's marker file."""
    return (Path(out) / MARKER).is_file()


def owner(out: Path) -> str | None:
    """The command that owns ``out`` by its marker (``"reproduce"``, ``"run"``, ...); ``None``
    when there is no marker or it names no command."""
    try:
        text = (Path(out) / MARKER).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    for line in text.splitlines():
        if line.startswith(_OWNER) and line[len(_OWNER) :].strip():
            return line[len(_OWNER) :].strip()
    return None


def check(
    out: Path | str, force: bool = False, option: str = "--out", command: str | None = None
) -> Path:
    """``out`` as a path if mwip may write into it; otherwise ``ValueError`` naming ``option``.

    Allowed: a folder that does not exist yet (its parent may not exist either), an empty
    folder, a folder with :data:`MARKER` owned by ``command`` (or by no named command, or
    ``command`` is ``None``), and with ``force`` any folder. Never allowed: an empty name, a
    path that exists and is not a folder.
    """
    text = str(out)
    if not text.strip():
        raise ValueError(f"{option}: the folder name is empty; give a folder such as 'out'")
    path = Path(out)
    if path.is_symlink() and not path.is_dir():
        raise ValueError(f"{option}: {text!r} is a symbolic link that does not lead to a folder")
    if not path.exists():
        for parent in path.absolute().parents:
            if parent.exists():
                if not parent.is_dir():
                    raise ValueError(f"{option}: {str(parent)!r} is not a folder")
                if not os.access(parent, os.W_OK | os.X_OK):
                    raise ValueError(f"{option}: cannot create a folder in {str(parent)!r}")
                break
        return path
    if not path.is_dir():
        raise ValueError(f"{option}: {text!r} exists and is not a folder")
    if not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"{option}: {text!r} is not writable")
    if force:
        return path
    if is_owned(path):
        held = owner(path)
        if command is not None and held is not None and held != command:
            raise ValueError(
                f"{option}: {text!r} holds the results of `mwip {held}`; give another folder "
                f"for `mwip {command}` or add --force to write into it"
            )
        return path
    try:
        entries = [e for e in os.listdir(path) if e not in (MARKER, LOCK)]
    except OSError as exc:
        raise ValueError(f"{option}: cannot read {text!r}: {exc.strerror or exc}") from None
    if entries:
        shown = ", ".join(sorted(entries)[:3]) + (", ..." if len(entries) > 3 else "")
        raise ValueError(
            f"{option}: {text!r} is not empty ({shown}) and is not an mwip output folder "
            f"(no {MARKER}); give a new or empty folder, or add --force to write into it"
        )
    return path


def claim(out: Path, command: str | None = None) -> Path:
    """Create ``out`` (if needed) and its marker file naming ``command`` as its owner; call
    after :func:`check`. A folder already marked keeps its owner (a ``--force`` write into
    another command's folder does not take it over); a marker naming no command gets one."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        if not is_owned(out) or (command is not None and owner(out) is None):
            write_text_atomic(out / MARKER, marker_text(command))
    except OSError as exc:
        raise ValueError(f"--out: cannot write into {str(out)!r}: {exc.strerror or exc}") from None
    return out


@contextlib.contextmanager
def hold(out: Path, option: str = "--out") -> Iterator[Path]:
    """Hold ``out`` (created if needed) for the duration of the block: an exclusive
    ``flock`` of ``out/.mwip-lock``, which records this process's id and is removed on exit.

    Raises ``ValueError`` naming ``option`` and the holder's process id when another process
    holds it. A lock file that no live process holds (its writer was killed) is taken over. A
    folder created here is removed again if it is still empty at the end.
    """
    import errno
    import fcntl

    out = Path(out)
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a path that cannot be a folder is bad input; a full disk is not
        if exc.errno not in (errno.ENOTDIR, errno.ENOENT, errno.EACCES, errno.EPERM,
                             errno.EROFS, errno.ENAMETOOLONG, errno.EEXIST, errno.ELOOP):
            raise
        raise ValueError(f"{option}: cannot create the folder {str(out)!r}: "
                         f"{exc.strerror or exc}") from None  # fmt: skip
    path = out / LOCK
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            with contextlib.suppress(OSError, ValueError):
                os.lseek(fd, 0, os.SEEK_SET)
            holder = os.read(fd, 32).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise ValueError(
                f"{option}: {str(out)!r} is in use by another mwip run (process {holder}); "
                "wait for it to finish, or give another folder"
            ) from None
        try:  # the file may have been removed by its previous holder meanwhile: lock anew
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield out
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # while still holding it: a waiting process then locks anew
        os.close(fd)
        if created:  # a run refused before writing anything leaves no empty folder
            with contextlib.suppress(OSError):
                out.rmdir()
