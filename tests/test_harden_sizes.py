"""Hardening (issue 26, item 4): runs too large are refused before they start, for campaigns
(samples, block, grid points, blocks in all, jobs) and for continuous-mode simulations, with
exit 2 and one line naming the field and the allowed range; nothing is written."""

from __future__ import annotations

import tomllib

import pytest

from mwip.budget import BudgetError
from mwip.campaign.execute import max_jobs, n_blocks
from mwip.campaign.spec import MAX_SAMPLES, parse_campaign
from mwip.cli import main

SMALL = """
[campaign]
samples = 10
seed = 7
duration = 0.6
block = 4
sensors = "ideal"
[[controllers]]
name = "lqr"
[initial]
theta = { uniform = [-0.3, 0.3] }
"""


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


def _run(tmp_path, text: str, *extra: str) -> int:
    path = tmp_path / "c.toml"
    path.write_text(text)
    return main(["campaign", "run", str(path), "--out", str(tmp_path / "out"), *extra])


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--samples", "100000000000000"], f"--samples: must be an integer in [1, {MAX_SAMPLES}]"),
        (["--jobs", "1000"], "--jobs"),
        (["--jobs", "0"], "--jobs"),
    ],
)
def test_cli_sizes_are_refused_before_starting(extra, needle, tmp_path, capsys):
    if extra[0] == "--jobs" and extra[1] == "1000" and max_jobs() >= 1000:
        pytest.skip("a machine with 250 CPUs")
    assert _run(tmp_path, SMALL, *extra) == 2
    line = _err_line(capsys)
    assert needle.split(":")[0] in line and ("[1, " in line)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "edit, needle",
    [
        (("samples = 10", "samples = 1000000000000"), "campaign.samples must be an integer in"),
        (("block = 4", "block = 100000"), "campaign.block must be an integer in"),
        (("theta = { uniform = [-0.3, 0.3] }",
          "theta = { grid = [-0.3, 0.3, 10000] }\ntheta_dot = { grid = [-1, 1, 10000] }"),
         "the grid has 1e+08 points"),
        (("theta = { uniform = [-0.3, 0.3] }", "theta = { grid = [-0.3, 0.3, 100000000] }"),
         "initial.theta.grid[2] must be an integer in"),
        (("duration = 0.6\nblock = 4", "duration = 3600\nblock = 10000"), "one block"),
        (("seed = 7", "seed = 100000000000000000000"), "campaign.seed"),
    ],
)  # fmt: skip
def test_campaign_file_sizes_are_refused(edit, needle, tmp_path, capsys):
    text = SMALL.replace(*edit)
    assert text != SMALL
    code = _run(tmp_path, text)
    assert code == 2
    assert needle in _err_line(capsys)
    assert not (tmp_path / "out").exists()


def test_claims_blocks_in_all_are_bounded(tmp_path, capsys):
    text = ('[campaign]\nkind = "claims"\nstudies = ["all"]\nsamples = 10000000\n'
            "block = 1\n")  # fmt: skip
    camp = parse_campaign(tomllib.loads(text))
    with pytest.raises(ValueError, match="at most 1000000"):
        n_blocks(camp)
    assert _run(tmp_path, text) == 2
    assert "campaign.samples" in _err_line(capsys)
    assert not (tmp_path / "out").exists()


def test_continuous_mode_steps_are_weighed(capsys):
    """``--mode continuous --dt 1e-9`` ran silently for minutes (1e9 NumPy steps under the
    sampled-mode budget of 2e9 compiled steps)."""
    argv = ["simulate", "--mode", "continuous", "--dt", "1e-9", "--duration", "1"]
    assert main(argv) == 2
    line = _err_line(capsys)
    assert "integration steps" in line and "continuous mode" in line
    from mwip.laws import registry
    from mwip.params import NOMINAL, REAL
    from mwip.sim import simulate

    ctrl = registry.build("lqr", NOMINAL, Ts=0.005)
    with pytest.raises(BudgetError, match="continuous mode"):
        simulate(ctrl, REAL, mode="continuous", dt=1e-7, duration=1.0)
