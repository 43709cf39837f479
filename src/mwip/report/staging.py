"""Safe output folders: results are written to a staging folder beside the output folder and
moved into it only when complete.

An existing output folder is therefore never half-overwritten: if a run is interrupted
(Ctrl-C) or crashes, the staging folder is removed and the previous results stay as they
were. Each staged entry (a study's folder, ``index.html``, ``run.json``) replaces its old
version by renames on the same file system; entries of the output folder that the run did
not produce are left alone.

A run killed outright (SIGKILL, power loss) cannot clean up: its staging folder
(``.<out>.partial-<pid>-*`` beside the output folder) and the trash of an interrupted commit
(``<out>/.replaced-<pid>-*``) are removed by the next run on the same folder, once the
process that made them is gone; old entries in such trash whose replacement never arrived
are put back first. The commit itself runs with SIGINT and SIGTERM held back, so
Ctrl-C arrives after it, not half-way through it.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType

__all__ = ["Staging", "remove_stale", "signals_held"]

_PID = re.compile(r"-(\d+)-")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale(out: Path) -> list[Path]:
    """Remove staging and trash folders of ``out`` left by runs that no longer exist."""
    out = Path(out)
    removed = []
    candidates: list[tuple[Path, str]] = []
    parent = out.absolute().parent
    if parent.is_dir():
        candidates += [(parent, f".{out.name}.partial-")]
    if out.is_dir() and not out.is_symlink():
        candidates += [(out, ".replaced-")]
    for folder, prefix in candidates:
        try:
            names = [n for n in os.listdir(folder) if n.startswith(prefix)]
        except OSError:
            continue
        for name in names:
            path = folder / name
            m = _PID.match(name[len(prefix) - 1 :])
            if m is None or path.is_symlink() or not path.is_dir() or _alive(int(m.group(1))):
                continue
            if prefix == ".replaced-":  # a killed commit: its old entries not yet replaced
                _restore(path, out)
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


@contextmanager
def _locked(folder: Path) -> Iterator[None]:
    """An exclusive advisory lock on ``folder`` itself (no lock file; POSIX only)."""
    try:
        import fcntl

        fd = os.open(folder, os.O_RDONLY)
    except (ImportError, OSError):
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


_RETIRED = ".retired-"


def _restore(trash: Path, out: Path) -> None:
    """Put the entries of an interrupted commit's ``trash`` back where ``out`` lacks them."""
    try:
        names = os.listdir(trash)
    except OSError:
        return
    for name in names:
        if name.startswith(_RETIRED):
            continue
        if not (out / name).exists() and not (out / name).is_symlink():
            with contextlib.suppress(OSError):
                os.replace(trash / name, out / name)


@contextmanager
def signals_held() -> Iterator[None]:
    """Hold back SIGINT and SIGTERM inside the block (delivered when it ends)."""
    held = {signal.SIGINT, signal.SIGTERM}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    except (AttributeError, OSError, ValueError):  # not on this platform
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class Staging:
    """Context manager: ``with Staging(out) as stage: ...write under stage.path...;
    stage.commit()``.

    Leaving the block without :meth:`commit` (an exception, Ctrl-C) discards the staging
    folder. :meth:`commit` may also be given the names to move (default: everything staged).
    """

    def __init__(self, out: Path) -> None:
        self.out = Path(out)
        self.path: Path | None = None
        self.committed = False
        self._held = False

    def __enter__(self) -> Staging:
        parent = self.out.resolve().parent
        if self.out.exists() and not self.out.is_dir():
            raise ValueError(f"--out: {self.out} exists and is not a folder")
        parent.mkdir(parents=True, exist_ok=True)
        remove_stale(self.out)
        self.path = Path(
            tempfile.mkdtemp(prefix=f".{self.out.name}.partial-{os.getpid()}-", dir=parent)
        )
        return self

    def commit(self, names: list[str] | None = None, retire: tuple[str, ...] = ()) -> list[Path]:
        """Move the staged entries ``names`` (default: all) into the output folder, in order.

        Entries ``retire`` of the output folder (a report that the new entries make stale)
        are moved away first, so that a commit cut short leaves no stale copy of them. If a
        move fails, the old entries whose replacements did not arrive are put back.
        """
        assert self.path is not None, "use Staging as a context manager"
        self.out.mkdir(parents=True, exist_ok=True)
        with self.lock():  # two runs into one OUT commit one after the other
            return self._commit(names, retire)

    @contextmanager
    def lock(self) -> Iterator[None]:
        """Hold OUT's lock in the block (reentrant): what is read from OUT to build the
        staged run record and report stays true until the commit."""
        if self._held:
            yield
            return
        with _locked(self.out.absolute().parent):  # OUT itself may not exist yet
            self._held = True
            try:
                yield
            finally:
                self._held = False

    def _commit(self, names: list[str] | None, retire: tuple[str, ...]) -> list[Path]:
        assert self.path is not None
        names = sorted(p.name for p in self.path.iterdir()) if names is None else names
        trash = Path(tempfile.mkdtemp(prefix=f".replaced-{os.getpid()}-", dir=self.out))
        moved = []
        try:
            for name in retire:
                old = self.out / name
                if (self.path / name).exists() and (old.exists() or old.is_symlink()):
                    os.replace(old, trash / f"{_RETIRED}{name}")  # never put back
            for name in names:
                src, dst = self.path / name, self.out / name
                if not src.exists():
                    continue
                if dst.exists() or dst.is_symlink():
                    os.replace(dst, trash / name)
                os.replace(src, dst)
                moved.append(dst)
        except BaseException:
            _restore(trash, self.out)
            raise
        finally:
            shutil.rmtree(trash, ignore_errors=True)
        self.committed = True
        return moved

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
