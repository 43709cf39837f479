"""Study files: a TOML that names a study and the robot to run it on.

``mwip run --scenario FILE.toml``; example (``examples/study_heavy_robot.toml``)::

    [study]
    name = "asta-balance"        # a study of `mwip list`
    quick = false                # optional: shorter runs

    [robot]                      # optional; default: the book's robot and design model
    params = "heavy_robot.toml"  # the simulated robot: "real", "nominal" or a parameter TOML
    nominal = "nominal"          # the design model: same choices
    damping = "units"            # optional: how "real"/"nominal" read the tables' Db, Dw
                                 # ("units": D r^2, or "literal"; SPEC.md section 2)

    [settings]                   # optional: the study's own numbers (:mod:`.settings`)
    theta0 = -0.2                # e.g. the initial pitch (rad)

A Chapter 6 study file may name the digital twin it runs on: ``[robot] twin = "my_twin.toml"``
(a twin file, ``mwip twin show``) and/or ``[twin]`` tables of its own that override it key by
key (:mod:`mwip.hardware.twin_config`); ``mwip run --twin FILE`` replaces both.

Every study ships its file with all its settings (``mwip scenario STUDY`` prints it). Paths are
relative to the study file. Unknown tables or keys are errors; every error is a one-line
``ValueError`` naming the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mwip.io import read_toml
from mwip.params import DAMPING_READINGS, Params, book_params, load_params
from mwip.studies.settings import validate

__all__ = ["StudyFile", "load_study_file"]

_TABLES = {
    "study": ("name", "quick"),
    "robot": ("params", "nominal", "damping", "twin"),
    "settings": (),
    "twin": (),  # the twin's [twin] tables (mwip.hardware.twin_config)
    "open": (),  # documentation of the settings the book leaves open (settings.open_settings)
    "ranges": (),  # the study's allowed values (settings.ranges), accepted unchanged
    "report": (),  # the texts of the HTML report (settings.report_texts); ignored in a run
}


@dataclass(frozen=True)
class StudyFile:
    """A parsed study file."""

    path: Path
    name: str
    quick: bool
    plant: Params
    nominal: Params
    settings: dict[str, Any] = field(default_factory=dict)
    twin: Any = None  # mwip.hardware.twin.Twin, or None: the run's twin


def _robot(value: object, key: str, base: Params, folder: Path, damping: str) -> Params:
    if not isinstance(value, str) or not value:
        raise ValueError(f"[robot] {key} must be 'real', 'nominal' or a TOML path, got {value!r}")
    if value.lower() in ("real", "nominal"):
        return book_params(value.lower(), damping)
    path = (folder / value).resolve()
    if not path.is_file():
        raise ValueError(f"[robot] {key}: no such parameter file {str(path)!r}")
    return load_params(path, base=base)


def load_study_file(path: str | Path, damping: str | None = None) -> StudyFile:
    """Read and validate a study file (see the module docstring).

    ``damping`` (the CLI's ``--damping``), when given, replaces the file's ``[robot] damping``.
    Every error is a one-line ``ValueError`` starting with the file's name.
    """
    path = Path(path)
    data = read_toml(path, "study file")
    try:
        return _parse(path, data, damping)
    except ValueError as exc:
        raise ValueError(f"study file {str(path)!r}: {exc}") from None


def _parse(path: Path, data: dict[str, Any], damping: str | None) -> StudyFile:
    from mwip.studies import study_names
    from mwip.studies.settings import packaged_ranges_text

    known = study_names()
    tables_free = ("settings", "open", "ranges", "report", "twin")  # keys not checked here

    for table, body in data.items():
        if table not in _TABLES:
            raise ValueError(f"unknown table [{table}]; allowed: {', '.join(_TABLES)}")
        if not isinstance(body, dict):
            raise ValueError(f"{path.name}: [{table}] must be a table")
        for key in body:
            if table not in tables_free and key not in _TABLES[table]:
                allowed = ", ".join(_TABLES[table])
                raise ValueError(f"[{table}] {key}: unknown key; allowed: {allowed}")
    study = data.get("study", {})
    name = study.get("name")
    if not isinstance(name, str) or name not in known:
        raise ValueError(f"[study] name must be one of {', '.join(known)}; got {name!r}")
    quick = study.get("quick", False)
    if not isinstance(quick, bool):
        raise ValueError(f"[study] quick must be true or false, got {quick!r}")
    robot = data.get("robot", {})
    folder = path.resolve().parent
    reading = damping if damping is not None else robot.get("damping", "units")
    if reading not in DAMPING_READINGS:
        raise ValueError(
            f"[robot] damping must be one of {', '.join(DAMPING_READINGS)}, got {reading!r}"
        )
    plant = _robot(robot.get("params", "real"), "params", book_params("real", reading),
                   folder, reading)  # fmt: skip
    nominal = _robot(robot.get("nominal", "nominal"), "nominal",
                     book_params("nominal", reading), folder, reading)  # fmt: skip
    if "ranges" in data and data["ranges"] != packaged_ranges_text(name):
        raise ValueError(
            f"[ranges] is the study's own table of allowed values and cannot be changed; "
            f"remove it or copy it unchanged from `mwip scenario {name}`"
        )
    if "open" in data:
        import tomllib

        from mwip.studies.settings import packaged_text

        packaged = tomllib.loads(packaged_text(name)).get("open", {})
        for key in data["open"]:
            if key not in packaged:
                raise ValueError(f"[open] {key}: not an open setting of {name!r} "
                                 f"(open: {', '.join(sorted(packaged)) or 'none'})")  # fmt: skip
        if data["open"] != packaged:
            raise ValueError(
                "[open] documents the study's open settings (the claims campaign draws them "
                f"from the packaged file) and cannot be changed; remove it or copy it "
                f"unchanged from `mwip scenario {name}`"
            )
    overrides = validate(name, data.get("settings", {}))
    return StudyFile(path=path, name=name, quick=quick, plant=plant, nominal=nominal,
                     settings=overrides, twin=_twin(robot.get("twin"), data.get("twin"),
                                                    folder))  # fmt: skip


def _twin(path: object, tables: Any, folder: Path) -> Any:
    """The twin of ``[robot] twin`` (a twin file) overridden by the file's ``[twin]`` tables;
    ``None`` when the study file names neither."""
    if path is None and tables is None:
        return None
    from mwip.hardware.twin_config import load_twin, twin_from_dict

    base = None
    if path is not None:
        if not isinstance(path, str) or not path:
            raise ValueError(f"[robot] twin must be a twin file path, got {path!r}")
        full = (folder / path).resolve()
        if not full.is_file():
            raise ValueError(f"[robot] twin: no such twin file {str(full)!r}")
        base = load_twin(full)
    return base if tables is None else twin_from_dict(tables, base)
