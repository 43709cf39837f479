"""Studies as data: packaged study files, overrides, validation, the `scenario` command."""

from __future__ import annotations

import json
import tomllib

import pytest

from mwip.cli import main
from mwip.studies import registry, settings, study_names
from mwip.studies.study_file import load_study_file


@pytest.mark.parametrize("name", study_names())
def test_every_study_ships_a_study_file_that_loads(name, tmp_path):
    text = settings.packaged_text(name)
    data = tomllib.loads(text)
    assert data["study"]["name"] == name
    # the book's robot: no robot file named (its [robot] params/nominal keys are gone: a
    # robot file, [robot] file, holds the body and the design model)
    assert data["robot"] == {}
    assert data["settings"], "a study file lists the study's settings"
    path = tmp_path / "copy.toml"
    path.write_text(text)
    sf = load_study_file(path)
    assert sf.name == name and sf.settings == data["settings"] and sf.quick is False
    assert {"title", "setup", "book", "gaps", "docs"} <= set(data["report"])  # the report's texts
    assert registry.get(name).title == data["report"]["title"]
    ctx = registry.context(name, tmp_path)
    assert dict(ctx.settings) == settings.defaults(name) == data["settings"]
    assert ctx.out == tmp_path / name and ctx.seed == data["settings"].get("seed", 0)


def test_one_module_and_one_study_file_per_study():
    """Every study file belongs to a registered study and every study has one; the registry
    orders them by their place in the book."""
    from importlib import resources

    files = {p.name.removesuffix(".toml")
             for p in resources.files("mwip.studies").joinpath("scenarios").iterdir()
             if p.name.endswith(".toml")}  # fmt: skip
    assert files == set(study_names())
    places = [registry.get(n).place for n in study_names()]
    assert places == sorted(places) and places[0][0] == 3 and places[-1][0] == 6


def test_validation_names_the_field():
    with pytest.raises(ValueError, match=r"^\[settings\] theta1: unknown for study 'lqr-gain'"):
        settings.validate("lqr-gain", {"theta1": 0.2})
    with pytest.raises(ValueError, match=r"^\[settings\] theta0 must be a number"):
        settings.validate("lqr-gain", {"theta0": "0.2"})
    with pytest.raises(ValueError, match=r"^\[settings\] theta0 must be a number"):
        settings.validate("lqr-gain", {"theta0": True})
    with pytest.raises(ValueError, match=r"^\[settings\] R_diag must be a list of 2 values"):
        settings.validate("lqr-gain", {"R_diag": [0.01]})
    with pytest.raises(ValueError, match=r"^\[settings\] Q_diag\[1\] must be finite"):
        settings.validate("lqr-gain", {"Q_diag": [1.0, float("nan"), 1.0, 1.0, 1.0]})
    assert settings.validate("lqr-gain", {"theta0": -1}) == {"theta0": -1}  # int for a float


def test_context_overrides_without_state(tmp_path):
    before = settings.defaults("lqr-gain")
    ctx = registry.context("lqr-gain", tmp_path, overrides={"theta0": 0.3})
    assert ctx.settings["theta0"] == 0.3 and ctx.settings["Ts"] == before["Ts"]
    with pytest.raises(TypeError):  # read-only
        ctx.settings["theta0"] = 0.4  # type: ignore[index]
    assert registry.context("lqr-gain", tmp_path).settings["theta0"] == before["theta0"]
    with pytest.raises(ValueError, match=r"^\[settings\] theta1: unknown"):
        registry.context("lqr-gain", tmp_path, overrides={"theta1": 0.3})


def test_scenario_command_and_a_study_file_with_settings(tmp_path, capsys):
    assert main(["scenario", "lqr-gain"]) == 0
    assert capsys.readouterr().out == settings.packaged_text("lqr-gain")
    path = tmp_path / "mine.toml"
    assert main(["scenario", "lqr-gain", "--out", str(path)]) == 0
    text = (
        path.read_text()
        .replace("theta0 = 0.1745", "theta0 = -0.05")
        .replace("quick = false", "quick = true")
    )
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["run", "--scenario", str(path), "--out", str(out)]) == 0
    doc = json.loads((out / "lqr-gain" / "metrics.json").read_text())
    assert doc["settings"]["theta0"] == -0.05 and doc["settings"]["duration"] == 3.0
    record = json.loads((out / "run.json").read_text())
    assert record["studies"]["lqr-gain"]["settings"]["theta0"] == -0.05
    capsys.readouterr()
    path.write_text(text.replace("theta0 = -0.05", "theta0 = [1.0]"))
    assert main(["run", "--scenario", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"mwip: error: study file {str(path)!r}: [settings] theta0 must be a number, got [1.0]"
    ]
    assert main(["scenario", "no-such-study"]) == 2
