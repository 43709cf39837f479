"""Hardening (issue 26, items 5-7): values inside the documented ranges work or the range is
narrowed (no internal error); input that used to be ignored silently is an error (or a
notice); bad input exits 2 with one line that quotes at most an excerpt of the bad value."""

from __future__ import annotations

import json

import pytest

from mwip.cli import main
from mwip.laws.registry import CONTROLLERS, MAGNITUDE
from mwip.studies import registry
from mwip.studies.study import Study, save_study


def _lines(capsys) -> list[str]:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and all("Traceback" not in x for x in err), err
    return err


def _err_line(capsys) -> str:
    err = _lines(capsys)
    assert len(err) == 1, err
    return err[0]


# ---- 5. values inside the documented ranges -----------------------------------------------------
@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--Ts", "1e-320"], "integration steps"),  # was OverflowError
        (["--controller", "tsmc", "--set", "Tf=1e308"], "'Tf' must be"),  # was OverflowError
        (["--controller", "tsmc", "--set", "Tf=1e-300"], "'Tf' must be"),  # was a format error
        (["--controller", "it2", "--set", "epsilon=1e308"], "'epsilon' must be"),
        (["--controller", "it2", "--set", "rho=1e12"], "'rho' must be"),  # was 20 s, then internal
    ],
)
def test_out_of_the_narrowed_range_is_a_usage_error(argv, needle, capsys, tmp_path):
    assert main(["simulate", *argv, "--duration", "0.1", "--out", str(tmp_path / "o")]) == 2
    assert needle in _err_line(capsys)
    assert not (tmp_path / "o").exists()


def test_no_open_ended_setting_beyond_the_magnitude():
    """Every numeric setting's range is finite (what it allows is what was tried)."""
    for spec in CONTROLLERS.values():
        for s in spec.settings:
            if not s.choices:
                assert "inf" not in s.allowed(), (spec.name, s.name, s.allowed())
                assert s.hi <= MAGNITUDE or "1e+06" in s.allowed()
                with pytest.raises(ValueError):
                    s.parse(",".join(["1e7"] * max(s.size, 1)), spec.name)


def test_the_ends_of_tsmc_tf_run(tmp_path, capsys):
    for tf in ("1e-3", "1e6"):
        code = main(["simulate", "--controller", "tsmc", "--set", f"Tf={tf}", "--duration", "0.2",
                     "--out", str(tmp_path / tf)])  # fmt: skip
        assert code in (0, 1)  # 1: the robot fell (a verdict), never an internal error
        out = capsys.readouterr()
        assert "internal error" not in out.err and "status:" in out.out


def test_an_infeasible_lmi_design_is_bad_input(capsys, tmp_path):
    from mwip.fuzzy.pdc import PDCInfeasibleError

    assert issubclass(PDCInfeasibleError, ValueError)
    assert main(["simulate", "--controller", "it2", "--set", "rho=1e-3", "--duration", "0.1",
                 "--out", str(tmp_path / "o")]) == 2  # fmt: skip
    assert "infeasible" in _err_line(capsys)


SMALL = """
[campaign]
samples = 2
seed = 7
duration = 0.2
block = 2
sensors = "ideal"
[[controllers]]
name = "lqr"
"""


@pytest.fixture(scope="module")
def robustness_run(tmp_path_factory):
    from mwip.campaign.execute import run_campaign
    from mwip.campaign.spec import load_campaign

    folder = tmp_path_factory.mktemp("rob")
    (folder / "c.toml").write_text(SMALL)
    run_campaign(load_campaign(str(folder / "c.toml")), folder / "out", jobs=1, progress=None)
    return folder / "out"


@pytest.mark.parametrize("content", ['{"x": ', "[1, 2]", '{"campaign": 3}',
                                     '{"campaign": {"campaign": []}}'])  # fmt: skip
def test_campaign_report_names_a_malformed_record(content, robustness_run, capsys):
    rec = robustness_run / "campaign.json"
    good = rec.read_text()
    try:
        rec.write_text(content)
        assert main(["campaign", "report", str(robustness_run)]) == 2
        assert "campaign.json" in _err_line(capsys)
    finally:
        rec.write_text(good)


@pytest.fixture
def fake_studies(monkeypatch):
    def run(ctx):
        claim = {"id": "x", "text": "x", "holds": True, "book": False, "keys": ["a.x"]}
        return save_study(ctx, metrics={"a.x": 1.0}, claims=[claim],
                          runs={"a": {"status": "ok"}}, settings={})  # fmt: skip

    declared = {"good": Study("good", "x", run, place=(1,))}
    monkeypatch.setattr(registry, "_discover", lambda: declared)


def test_report_claims_of_a_robustness_campaign_is_refused(robustness_run, tmp_path, capsys,
                                                             fake_studies):  # fmt: skip
    out = tmp_path / "site"
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 0
    capsys.readouterr()
    assert main(["report", "--out", str(out), "--claims", str(robustness_run)]) == 2
    assert "no claims campaign" in _err_line(capsys)


def test_plot_and_animate_a_one_record_run(tmp_path, capsys):
    import numpy as np

    assert main(["simulate", "--duration", "0.005", "--out", str(tmp_path / "r")]) == 0
    z = dict(np.load(tmp_path / "r" / "timeseries.npz", allow_pickle=False))
    n = z["t"].shape[0]
    one = {k: (v[..., :1, :] if v.ndim >= 2 and v.shape[-2] == n else
               v[:1] if v.ndim == 1 and v.shape[0] == n else v) for k, v in z.items()}  # fmt: skip
    np.savez(tmp_path / "one.npz", **one)
    assert main(["plot", str(tmp_path / "one.npz"), "--out", str(tmp_path / "p.png")]) == 0
    assert main(["animate", str(tmp_path / "one.npz"), "--out", str(tmp_path / "a.gif")]) == 0
    assert "internal error" not in capsys.readouterr().err


# ---- 6. input that used to be ignored silently --------------------------------------------------
def test_case_without_the_twin_is_refused(capsys, tmp_path):
    assert main(["simulate", "--case", "2", "--duration", "0.1", "--out", str(tmp_path)]) == 2
    assert "--twin" in _err_line(capsys)


def test_an_empty_parameter_file_is_refused(tmp_path, capsys):
    # the robot file (--robot; a parameter file loads as one) replaces --params
    (tmp_path / "p.toml").write_text("")
    assert main(["simulate", "--robot", str(tmp_path / "p.toml"), "--duration", "0.1"]) == 2
    assert "is empty (an empty file would silently mean the default robot)" in _err_line(capsys)
    (tmp_path / "q.toml").write_text('base = "real"\n')  # the default robot, said so: fine
    assert main(["simulate", "--robot", str(tmp_path / "q.toml"), "--duration", "0.1",
                 "--out", str(tmp_path / "o")]) == 0  # fmt: skip


@pytest.mark.parametrize(
    "text, needle",
    [
        # a legacy twin file (still read as a robot file)
        ("[twin]\n[twinx]\nTs = 0.005\n", "'twinx'"),
        ('[twin.drive]\nemf_compensation = "no"\n', "emf_compensation must be a number"),
        ("[twin.drive]\npwm_levels = true\n", "pwm_levels must be a number"),
        ('[twin.drive]\nmode = 3\n', "mode must be text"),
        # the robot file
        ("[twinx]\nTs = 0.005\n", "'twinx'"),
        ('[firmware]\nemf_compensation = "no"\n', "firmware.emf_compensation must be a number"),
        ("[drive]\npwm_levels = true\n", "drive.pwm_levels must be a number"),
        ('[drive]\nmode = 3\n', "drive.mode must be text"),
    ],
)
def test_twin_file_tables_and_types(text, needle, tmp_path, capsys):
    (tmp_path / "t.toml").write_text(text)
    assert main(["simulate", "--twin", "--robot", str(tmp_path / "t.toml"),
                 "--duration", "0.1"]) == 2  # fmt: skip
    assert needle in _err_line(capsys)


def test_pwm_levels_zero_is_documented():
    from mwip.robot import default_robot, robot_to_toml

    text = robot_to_toml(default_robot())
    assert "pwm_levels = 1000" in text and "0: not quantised" in text


@pytest.mark.parametrize(
    "table, needle",
    [
        ('kind = "book"\namplitude = 1.0\n', "takes no other keys"),
        ('kind = "sinusoid"\namplitude = [0.1]\n', "must be a number or 3 numbers"),
        ('kind = "sinusoid"\namplitude = "0.1, 0.1, 0.1"\n', "must be a number or 3 numbers"),
        ('kind = "sinusoid"\namplitudes = 0.1\n', "amplitudes"),
    ],
)
def test_scenario_disturbance_tables(table, needle, tmp_path, capsys):
    (tmp_path / "s.toml").write_text("[scenario]\nduration = 0.1\n[disturbance]\n" + table)
    assert main(["simulate", "--scenario", str(tmp_path / "s.toml")]) == 2
    assert needle in _err_line(capsys)


def test_study_file_open_table_is_checked(tmp_path, capsys):
    from mwip.studies.settings import packaged_text

    text = packaged_text("lqr-gain")
    bad = text.replace("[open]", "[open]\nnot_a_setting = 1", 1)
    (tmp_path / "s.toml").write_text(bad)
    assert main(["run", "--scenario", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o")]) == 2
    assert "[open] not_a_setting" in _err_line(capsys)
    edited = text.replace('range = [0.05, 0.35]', 'range = [0.05, 0.3]', 1)
    assert edited != text
    (tmp_path / "e.toml").write_text(edited)
    assert main(["run", "--scenario", str(tmp_path / "e.toml"), "--out", str(tmp_path / "o")]) == 2
    assert "cannot be changed" in _err_line(capsys)


def test_an_empty_metrics_document_is_named(tmp_path, capsys, fake_studies):
    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "-j", "1"]) == 0
    capsys.readouterr()
    (out / "good" / "metrics.json").write_text("{}")
    assert main(["report", "--out", str(out)]) == 1
    assert "empty metrics document" in capsys.readouterr().err


def test_a_truncated_comparison_is_said(tmp_path, capsys, fake_studies):
    out, other = tmp_path / "out", tmp_path / "other"
    for folder in (out, other):
        assert main(["reproduce", "--out", str(folder), "-j", "1"]) == 0
    path = other / "good" / "metrics.json"
    path.write_text(path.read_text()[:20])
    capsys.readouterr()
    assert main(["report", "--out", str(out), "--compare", str(other)]) == 0
    err = capsys.readouterr().err
    assert "--compare" in err and str(path) in err and "left out" in err


# ---- 7. exit codes and excerpts -----------------------------------------------------------------
def test_a_huge_bad_value_is_quoted_in_part(capsys):
    values = ",".join(["1"] * 10000)
    assert main(["simulate", "--controller", "smc", "--set", f"K={values}"]) == 2
    line = _err_line(capsys)
    assert len(line) < 500 and "characters" in line
    assert main(["simulate", "--Ts", "x" * 10000]) == 2
    assert len(_err_line(capsys)) < 500


@pytest.mark.parametrize("opt", ["--robot", "--out", "--scenario"])  # --twin is a flag now
def test_a_file_name_too_long_is_bad_input(opt, capsys):
    argv = ["simulate", opt, "a" * 5000, "--duration", "0.1"]
    assert main(argv) == 2
    line = _err_line(capsys)
    assert len(line) < 400


def test_a_dangling_symlink_out_is_bad_input(tmp_path, capsys):
    (tmp_path / "dl").symlink_to(tmp_path / "nowhere" / "x")
    assert main(["simulate", "--duration", "0.1", "--out", str(tmp_path / "dl")]) == 2
    assert "--out" in _err_line(capsys)


def test_an_unusable_cache_folder_is_bad_input_for_kernels_build(tmp_path, monkeypatch, capsys):
    (tmp_path / "file").write_text("x")
    monkeypatch.setenv("MWIP_CACHE_DIR", str(tmp_path / "file" / "cache"))
    assert main(["kernels", "build"]) == 2
    assert "cache folder" in _err_line(capsys)
    assert main(["kernels", "status", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert not info["built"] and info["state"].startswith("unusable cache folder")
