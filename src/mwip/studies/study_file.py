"""Study files: a TOML that names a study and the robot to run it on.

``mwip run --scenario FILE.toml``; example (``examples/study_heavy_robot.toml``)::

    [study]
    name = "asta-balance"        # a study of `mwip list`
    quick = false                # optional: shorter runs

    [robot]                      # optional; default: the book's robot
    file = "heavy_robot.toml"    # a robot file (`mwip robot show`): its body, design model
                                 # and twin
    damping = "units"            # optional, without a file: how the book's tables' Db, Dw
                                 # read ("units": D r^2, or "literal"; SPEC.md section 2)

    [settings]                   # optional: the study's own numbers (:mod:`.settings`)
    theta0 = -0.2                # e.g. the initial pitch (rad)

The robot file's twin is the one the Chapter 6 studies run on; ``mwip run --robot FILE``
replaces the file's robot. (The older ``[robot] params``, ``nominal`` and ``twin`` keys and
``[twin]`` tables are gone: one robot file holds them all.)

Every study ships its file with all its settings (``mwip scenario STUDY`` prints it). Paths are
relative to the study file. Unknown tables or keys are errors; every error is a one-line
``ValueError`` naming the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mwip.io import read_toml
from mwip.params import DAMPING_READINGS, Params, book_params
from mwip.studies.settings import validate

__all__ = ["StudyFile", "load_study_file"]

_TABLES = {
    "study": ("name", "quick"),
    "robot": ("file", "damping"),
    "settings": (),
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
    robot: Any = None  # mwip.robot.Robot of [robot] file, or None: the book's


_GONE = {"params": "the body", "nominal": "the design model", "twin": "the twin"}


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
    tables_free = ("settings", "open", "ranges", "report")  # keys not checked here

    if "twin" in data:
        raise ValueError("[twin] tables are gone: the robot file ([robot] file) holds the twin")
    for key, what in _GONE.items():
        if key in data.get("robot", {}):
            raise ValueError(f"[robot] {key} is gone: a robot file holds {what} "
                             "([robot] file = \"my_robot.toml\")")  # fmt: skip
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
    rb = None
    if "file" in robot:
        from mwip.robot import load_named_robot

        if "damping" in robot:
            raise ValueError("[robot] damping reads the book's tables; the robot file gives "
                             "its own Db, Dw: give one of file and damping")  # fmt: skip
        rb = load_named_robot(robot["file"], "[robot] file", folder)
        plant, nominal = rb.body, rb.design
    else:
        plant, nominal = book_params("real", reading), book_params("nominal", reading)
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
                     settings=overrides, twin=None if rb is None else rb.twin,
                     robot=rb)  # fmt: skip
