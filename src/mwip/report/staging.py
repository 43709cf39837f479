"""Safe output folders: results are written to a staging folder beside the output folder and
moved into it only when complete.

An existing output folder is therefore never half-overwritten: if a run is interrupted
(Ctrl-C) or crashes, the staging folder is removed and the previous results stay as they
were. Each staged entry (a study's folder, ``index.html``, ``run.json``) replaces its old
version by renames on the same file system; entries of the output folder that the run did
not produce are left alone.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from types import TracebackType

__all__ = ["Staging"]


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

    def __enter__(self) -> Staging:
        parent = self.out.resolve().parent
        if self.out.exists() and not self.out.is_dir():
            raise ValueError(f"--out: {self.out} exists and is not a folder")
        parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.partial-", dir=parent))
        return self

    def commit(self, names: list[str] | None = None) -> list[Path]:
        """Move the staged entries ``names`` (default: all) into the output folder."""
        assert self.path is not None, "use Staging as a context manager"
        self.out.mkdir(parents=True, exist_ok=True)
        names = sorted(p.name for p in self.path.iterdir()) if names is None else names
        trash = Path(tempfile.mkdtemp(prefix=".replaced-", dir=self.out))
        moved = []
        try:
            for name in names:
                src, dst = self.path / name, self.out / name
                if not src.exists():
                    continue
                if dst.exists() or dst.is_symlink():
                    os.replace(dst, trash / name)
                os.replace(src, dst)
                moved.append(dst)
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
