"""Shared fixtures: seeded random states; a private cache for the ahead-of-time loop."""

from __future__ import annotations

import os
import shutil
import tempfile

import numpy as np
import pytest

_AOT_CACHE: list[str] = []


def pytest_configure(config: pytest.Config) -> None:
    """The suite builds and loads the ahead-of-time loop (mwip.sim.aot) in a cache of its own
    (built once per session, ~10 s), unless MWIP_CACHE_DIR is already set; subprocesses of the
    tests inherit it. First-use notices (mwip.notice) are off unless a test turns them on."""
    os.environ.setdefault("MWIP_NOTICES", "off")  # first-use notices depend on the caches' state
    if not os.environ.get("MWIP_CACHE_DIR"):
        path = tempfile.mkdtemp(prefix="mwip-test-cache-")
        _AOT_CACHE.append(path)
        os.environ["MWIP_CACHE_DIR"] = path


def pytest_unconfigure(config: pytest.Config) -> None:
    for path in _AOT_CACHE:
        shutil.rmtree(path, ignore_errors=True)
        os.environ.pop("MWIP_CACHE_DIR", None)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


def random_states(rng: np.random.Generator, n: int = 64) -> tuple[np.ndarray, ...]:
    """Random q (n,3), qdot (n,3), u (n,2), tau_ext (n,3) in physically sensible ranges."""
    q = rng.uniform(-1.2, 1.2, (n, 3))
    qd = rng.uniform(-3.0, 3.0, (n, 3))
    u = rng.uniform(-2.0, 2.0, (n, 2))
    e = rng.uniform(-0.5, 0.5, (n, 3))
    return q, qd, u, e


@pytest.fixture(scope="session")
def quick_reproduction(tmp_path_factory: pytest.TempPathFactory):
    """``mwip reproduce --quick --no-compare`` once per test session (every study, shortened
    runs, one damping reading): returns ``(out folder, exit code, captured stdout)``."""
    import contextlib
    import io

    from mwip.cli import main

    out = tmp_path_factory.mktemp("reproduce") / "out"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["reproduce", "--quick", "--no-compare", "--out", str(out), "--jobs", "2"])
    return out, code, buf.getvalue()
