"""The design cache (mwip.cache): a cached IT2 PDC design is the solved one, bit for bit; a
corrupt or failing entry is solved again; names follow every input; ``MWIP_CACHE=off``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mwip import cache
from mwip.fuzzy import pdc
from mwip.params import NOMINAL


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MWIP_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("MWIP_CACHE", raising=False)
    return tmp_path


def _same(a, b):
    for k in ("G", "P", "Q", "N", "Y", "W"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert (a.status, a.n_models, a.epsilon, a.rho) == (b.status, b.n_models, b.epsilon, b.rho)


def test_cached_design_is_the_solved_one_and_skips_the_solver(private_cache, monkeypatch):
    solved = pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL)
    assert len(list((private_cache / "pdc").glob("*.npz"))) == 1

    def no_solver(*a, **k):
        raise AssertionError("the LMIs were solved again")

    monkeypatch.setattr("cvxpy.Problem.solve", no_solver)
    _same(pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL), solved)
    monkeypatch.setenv("MWIP_CACHE", "off")
    with pytest.raises(AssertionError, match="solved again"):
        pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL)


def test_a_corrupt_or_failing_entry_is_solved_again(private_cache):
    solved = pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL)
    (entry,) = (private_cache / "pdc").glob("*.npz")
    z = dict(np.load(entry))
    z["G"] = -z["G"]  # destabilises the vertex loops: verify_design must refuse it
    np.savez(entry, **z)
    _same(pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL), solved)
    entry.write_bytes(b"not an npz")
    _same(pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL), solved)


def test_other_settings_are_other_entries(private_cache):
    a = pdc.design_pdc(epsilon=0.2, rho=20.0, params=NOMINAL)
    b = pdc.design_pdc(epsilon=0.25, rho=20.0, params=NOMINAL)
    assert len(list((private_cache / "pdc").glob("*.npz"))) == 2
    assert not np.array_equal(a.G, b.G)


def test_digest_reads_files_arrays_and_values(tmp_path):
    f = tmp_path / "src.py"
    f.write_text("x = 1\n")
    d0 = cache.digest([f, np.zeros(3), 0.2, None])
    assert d0 == cache.digest([f, np.zeros(3), 0.2, None])
    assert d0 != cache.digest([f, np.zeros(4), 0.2, None])
    assert d0 != cache.digest([f, np.zeros(3, dtype=np.float32), 0.2, None])
    assert d0 != cache.digest([f, np.zeros(3), 0.2000000001, None])
    f.write_text("x = 2\n")
    assert d0 != cache.digest([f, np.zeros(3), 0.2, None])
    assert cache.digest([b"ab", b"c"]) != cache.digest([b"a", b"bc"])  # parts are delimited


def test_an_unwritable_cache_is_skipped(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("MWIP_CACHE_DIR", str(blocker / "sub"))
    cache.save_arrays("pdc", "name", {"a": np.zeros(2)})  # no error
    assert cache.load_arrays("pdc", "name") is None


def test_the_cache_folder(monkeypatch):
    monkeypatch.delenv("MWIP_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", "/x/y")
    assert cache.cache_dir() == Path("/x/y/mwip")
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache.cache_dir() == Path.home() / ".cache" / "mwip"
