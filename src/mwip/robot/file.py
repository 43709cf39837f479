"""The robot file: one TOML file, read by one loader, written back byte for byte.

:func:`load_robot` reads a robot file (tables and fields: :mod:`mwip.robot.schema`); missing
tables and fields come from a base robot (the book's, :func:`mwip.robot.default_robot`),
except in ``[body]``, which is given whole or starts from a book table (``base = "real"`` /
``"nominal"``). ``[design]`` gives the model the controllers are designed on: Table 6.2
(``base = "nominal"``, the default), Table 6.1 (``"real"``) or the file's own body
(``"body"``), plus any field. Every error is one line naming the file and the field
(``robot file 'x.toml': body.r = 40 m is outside ...``).

:func:`robot_to_toml` writes every value with its unit, status and source in a comment, and
the robot's notes, prior and provenance as data, so that a file written and read back is the
same robot and writes the same text (``mwip robot show FILE``).

Two older formats load as robots, said in the docs: a twin file (``[twin]`` tables: its Ts,
delay, fusion and back-EMF compensation move to ``[firmware]``) and a parameter file
(``[params]``, or the symbols at the top level: the body, in the book's symbols).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from mwip.io import read_toml, write_text_atomic
from mwip.params import PARAM_FIELDS, Params, book_params
from mwip.robot.schema import BODY_TO_PARAMS, TABLES, FieldInfo
from mwip.robot.spec import Robot

__all__ = ["load_robot", "load_named_robot", "robot_from_dict", "robot_to_toml", "save_robot",
           "RobotFileError"]  # fmt: skip


class RobotFileError(ValueError):
    """A robot file (or mapping) that cannot be a robot: one line naming the field."""


#: The hardware tables: table -> (the Twin attribute path, the dataclass fields' owner).
_HW = ("motor", "drive", "gearbox", "firmware", "firmware.fusion", "imu", "encoder", "payload",
       "stick")  # fmt: skip
_ORDER = ("robot", "body", "design", *_HW)
_BODY_REQUIRED = tuple(k for k in BODY_TO_PARAMS if k != "g")


def _fail(where: str, msg: str) -> RobotFileError:
    return RobotFileError(f"{where}: {msg}" if where else msg)


def _shown(v: Any) -> str:
    s = repr(v)
    return s if len(s) <= 40 else s[:37] + "..."


def _number(where: str, path: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        info = _info(path)
        unit = f" in {info.unit}" if info and info.unit else ""
        raise _fail(where, f"{path} must be a number{unit} (the file is SI; no units in the "
                    f"value), got {_shown(v)}")  # fmt: skip
    return float(v)


def _info(path: str) -> FieldInfo | None:
    from mwip.robot.schema import info

    return info(path)


# ------------------------------------------------------------------------------ reading
def _params_table(where: str, table: str, data: Mapping[str, Any], base: Params,
                  own_body: Params | None, damping: str) -> Params:  # fmt: skip
    """``[body]`` or ``[design]``: Params from the physical names (and ``base``)."""
    allowed = {*BODY_TO_PARAMS, "base"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise _fail(where, f"unknown key {table}.{unknown[0]}; allowed: "
                    f"{', '.join(sorted(allowed))}")  # fmt: skip
    start: Params | None = None
    if "base" in data:
        choices = ("real", "nominal") + (("body",) if table == "design" else ())
        b = data["base"]
        if not isinstance(b, str) or b not in choices:
            raise _fail(where, f"{table}.base must be one of {', '.join(choices)}, got "
                        f"{_shown(b)}")  # fmt: skip
        start = own_body if b == "body" else book_params(b, damping)
    elif table == "body" and data:
        missing = [k for k in _BODY_REQUIRED if k not in data]
        if missing:
            raise _fail(where, f"body.{missing[0]} is missing: give every body field "
                        f"({', '.join(_BODY_REQUIRED)}) or base = \"real\"")  # fmt: skip
    values: dict[str, float] = {}
    for key, raw in data.items():
        if key == "base":
            continue
        path = f"{table}.{key}"
        v = _number(where, path, raw)
        info = TABLES[table][key]
        lo, hi = info.plausible or (-float("inf"), float("inf"))
        if not (lo <= v <= hi):
            raise _fail(where, f"{path} = {v:g} {info.unit} is outside the plausible "
                        f"[{lo:g}, {hi:g}] {info.unit} for a robot of this class (a unit "
                        "mistake? the file is SI)")  # fmt: skip
        values[BODY_TO_PARAMS[key]] = v
    origin = start if start is not None else base
    try:
        return replace(origin, **values) if values else origin
    except (TypeError, ValueError) as exc:
        raise _fail(where, f"{table}: {exc}") from None


def _dataclass_table(where: str, table: str, obj: Any, data: Mapping[str, Any],
                     skip: tuple[str, ...] = ()) -> Any:  # fmt: skip
    """A hardware dataclass with the fields of ``data`` replaced, each of its default's type."""
    names = [f.name for f in fields(obj) if f.name not in skip]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise _fail(where, f"unknown key {table}.{unknown[0]}; allowed: {', '.join(names)}")
    for key, value in data.items():
        old = getattr(obj, key)
        kinds = ((bool, "true or false") if isinstance(old, bool) else
                 ((int, float), "a number") if isinstance(old, int | float) else
                 (str, "text") if isinstance(old, str) else (None, ""))  # fmt: skip
        if kinds[0] is not None and (not isinstance(value, kinds[0])
                                     or (kinds[0] is not bool and isinstance(value, bool))):
            info = _info(f"{table}.{key}")
            unit = f" in {info.unit}" if kinds[1] == "a number" and info and info.unit else ""
            raise _fail(where, f"{table}.{key} must be {kinds[1]}{unit}, got {_shown(value)}")
    try:
        return replace(obj, **dict(data))
    except (TypeError, ValueError) as exc:
        msg = str(exc)
        if msg.startswith("'"):  # "'gear_ratio' must be ..." -> "drive.gear_ratio must be ..."
            key = msg.split("'")[1]
            msg = f"{table}.{key}{msg[len(key) + 2:]}"
        raise _fail(where, msg) from None


def _legacy(data: Mapping[str, Any]) -> dict[str, Any]:
    """A twin file's ``[twin]`` tables or a parameter file as robot-file tables."""
    if "twin" in data:
        extra = sorted(set(data) - {"twin"})
        if extra:
            raise RobotFileError(f"unknown table or key {extra[0]!r}; a twin file holds only "
                                 "[twin] and its sub-tables")  # fmt: skip
        tw = data["twin"]
        if not isinstance(tw, Mapping):
            raise RobotFileError(f"twin must be a table, got {_shown(tw)}")
        out: dict[str, Any] = {}
        robot: dict[str, Any] = {}
        firmware: dict[str, Any] = {}
        for key, value in tw.items():
            if key in ("Ts", "delay"):
                firmware[key] = value
            elif key in ("elements", "dt"):
                robot[key] = value
            elif key == "fusion":
                firmware["fusion"] = value
            elif key == "drive" and isinstance(value, Mapping):
                drv = dict(value)
                if "emf_feedforward" in drv:
                    ff = drv.pop("emf_feedforward")
                    if not isinstance(ff, bool):
                        raise RobotFileError(f"twin.drive.emf_feedforward must be true or "
                                             f"false, got {_shown(ff)}")  # fmt: skip
                    firmware.setdefault("emf_compensation", 1.0 if ff else 0.0)
                if "emf_compensation" in drv:
                    firmware["emf_compensation"] = drv.pop("emf_compensation")
                out["drive"] = drv
            elif key == "encoder" and isinstance(value, Mapping):
                enc = dict(value)
                gr = enc.pop("gear_ratio", None)
                drive_gr = tw.get("drive", {}).get("gear_ratio") if isinstance(
                    tw.get("drive"), Mapping) else None  # fmt: skip
                if gr is not None and drive_gr is not None and gr != drive_gr:
                    raise RobotFileError(f"twin.encoder.gear_ratio ({gr!r}) must equal "
                                         f"twin.drive.gear_ratio ({drive_gr!r}): one gearbox")
                out["encoder"] = enc
            else:
                out[key] = value
        if firmware:
            out["firmware"] = firmware
        if robot:
            out["robot"] = robot
        return out
    # a parameter file: [params] (and base) or the symbols at the top level
    body = data.get("params", {k: v for k, v in data.items() if k != "base"})
    if not isinstance(body, Mapping):
        raise RobotFileError(f"params must be a table, got {_shown(body)}")
    extra = sorted(set(data) - {"params", "base"}) if "params" in data else []
    if extra:
        raise RobotFileError(f"unknown key {extra[0]!r}; allowed: params, base")
    unknown = sorted(set(body) - set(PARAM_FIELDS))
    if unknown:
        raise RobotFileError(f"unknown parameter {unknown[0]!r}; allowed: "
                             f"{', '.join(PARAM_FIELDS)}")  # fmt: skip
    if not body and "base" not in data:
        raise RobotFileError("holds no parameters (an empty file would silently mean the "
                             "default robot); give at least one field, or base = 'real'")
    to_phys = {v: k for k, v in BODY_TO_PARAMS.items()}
    table: dict[str, Any] = {to_phys[k]: v for k, v in body.items()}
    table["base"] = data.get("base", "real")
    return {"body": table}


def _is_legacy(data: Mapping[str, Any]) -> bool:
    # a parameter file may hold its base alone (``base = "real"``: the book's robot, said so);
    # a robot file has no top-level ``base`` (its [body] and [design] have theirs)
    return ("twin" in data or "params" in data or "base" in data
            or bool(set(data) & set(PARAM_FIELDS)))  # fmt: skip


def robot_from_dict(data: Mapping[str, Any], base: Robot | None = None, *, where: str = "",
                    damping: str = "units") -> Robot:  # fmt: skip
    """A :class:`Robot` from a robot file's tables (module docstring); ``base`` gives what
    is missing (default: the default robot); ``where`` prefixes every error (the file)."""
    from mwip.hardware.elements import check_elements
    from mwip.hardware.prior import Prior

    if base is None:
        from mwip.robot import default_robot

        base = default_robot()
    if _is_legacy(data):
        try:
            data = _legacy(data)
        except RobotFileError as exc:
            raise _fail(where, str(exc)) from None
    allowed = set(_ORDER) - {"firmware.fusion"} | {"prior", "provenance"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise _fail(where, f"unknown table or key {unknown[0]!r}; allowed: "
                    f"{', '.join(sorted(allowed))}")  # fmt: skip
    for key, value in data.items():
        if not isinstance(value, Mapping):
            raise _fail(where, f"[{key}] must be a table, got {_shown(value)}")
    body = _params_table(where, "body", data.get("body", {}), base.body, None, damping)
    design = _params_table(where, "design", data.get("design", {}), base.design, body, damping)
    tw = base.twin
    kw: dict[str, Any] = {}
    for table in ("motor", "drive", "gearbox", "imu", "encoder", "payload", "stick"):
        sub = data.get(table, {})
        kw[table] = _dataclass_table(where, table, getattr(tw, table), sub)
    fw = dict(data.get("firmware", {}))
    fus = fw.pop("fusion", {})
    if not isinstance(fus, Mapping):
        raise _fail(where, f"[firmware.fusion] must be a table, got {_shown(fus)}")
    fusion = _dataclass_table(where, "firmware.fusion", tw.firmware.fusion, fus)
    firmware = _dataclass_table(where, "firmware", tw.firmware, fw, skip=("fusion",))
    kw["firmware"] = replace(firmware, fusion=fusion)
    rb = dict(data.get("robot", {}))
    allowed_r = tuple(TABLES["robot"])
    bad = sorted(set(rb) - set(allowed_r))
    if bad:
        raise _fail(where, f"unknown key robot.{bad[0]}; allowed: {', '.join(allowed_r)}")
    name = rb.get("name", base.name)
    notes = rb.get("notes", "")
    for key, v in (("name", name), ("notes", notes)):
        if not isinstance(v, str):
            raise _fail(where, f"robot.{key} must be text, got {_shown(v)}")
    if "elements" in rb:
        el = rb["elements"]
        if not isinstance(el, list | tuple) or not all(isinstance(x, str) for x in el):
            raise _fail(where, f"robot.elements must be a list of names, got {_shown(el)}")
        try:
            kw["elements"] = check_elements(el, "robot.elements")
        except ValueError as exc:
            raise _fail(where, str(exc).replace("'robot.elements'", "robot.elements")) from None
    if "dt" in rb:
        kw["dt"] = _number(where, "robot.dt", rb["dt"])
    try:
        twin = replace(tw, **kw)
    except (TypeError, ValueError) as exc:
        raise _fail(where, str(exc).replace("'dt'", "robot.dt")) from None
    try:
        prior = Prior.from_dict(data.get("prior", {}), base=tw.prior)
    except ValueError as exc:
        raise _fail(where, str(exc).replace("twin.prior", "prior")) from None
    twin = replace(twin, prior=prior)
    try:
        prior.check(twin.values())
    except ValueError as exc:
        name_ = str(exc).split(":")[0].replace("twin.prior.", "")
        u = prior[name_]
        raise _fail(where, f"{name_} = {twin.values()[name_]:g} is outside its prior "
                    f"[{u.low:g}, {u.high:g}] {u.unit} (prior.{name_}: widen the range or "
                    "change the value)") from None  # fmt: skip
    given = {f"{t}.{k}" for t in ("body", "design", "robot", *_HW) if t in data
             for k in data[t] if k != "base"}  # fmt: skip
    given |= {f"firmware.fusion.{k}" for k in data.get("firmware", {}).get("fusion", {})}
    # the base's sources hold for the values the file leaves as they are
    provenance = {k: v for k, v in base.provenance if k not in given}
    if "body" in data:
        provenance = {k: v for k, v in provenance.items() if not k.startswith("body.")}
    # a value the file changes from its base and whose source it does not give: "given"
    if where:
        given_src = f"given in the {where}"
        new = Robot(body=body, design=design, twin=twin)
        for path in sorted(given):
            if path in provenance or _info(path) is None:
                continue
            if _path_value(new, path) != _path_value(base, path):
                provenance[path] = given_src
        if design is body or data.get("design", {}).get("base") == "body":
            for key in BODY_TO_PARAMS:
                provenance.setdefault(f"design.{key}", "the robot's body ([design] base = "
                                      "\"body\")")  # fmt: skip
    for key, v in data.get("provenance", {}).items():
        if _info(key) is None:
            raise _fail(where, f"provenance: {key!r} names no field of the robot file")
        if not isinstance(v, str):
            raise _fail(where, f"provenance.{key} must be text, got {_shown(v)}")
        provenance[key] = v
    return Robot(body=body, design=design, twin=twin, name=name, notes=notes,
                 provenance=tuple(provenance.items()))  # fmt: skip


def _path_value(robot: Robot, path: str) -> Any:
    """The value at a robot-file path (``body.r``, ``firmware.fusion.tau``)."""
    table, _, key = path.rpartition(".")
    if table in ("body", "design"):
        return float(getattr(getattr(robot, table), BODY_TO_PARAMS[key]))
    if table == "robot":
        return {"elements": robot.twin.active, "dt": robot.twin.dt}.get(key)
    obj: Any = robot.twin
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def load_robot(path: str | os.PathLike[str], base: Robot | None = None, *,
               damping: str = "units") -> Robot:  # fmt: skip
    """Read a robot file (module docstring); one-line errors naming the file and the field."""
    where = f"robot file {str(path)!r}"
    try:
        data = read_toml(path, "robot file")
    except ValueError as exc:
        raise RobotFileError(str(exc)) from None
    if not data:
        raise _fail(where, "is empty (an empty file would silently mean the default robot); "
                    "start from `mwip robot show`")  # fmt: skip
    rb = data.get("robot")
    if not (isinstance(rb, Mapping) and "name" in rb) and not _is_legacy(data):
        data = {**data, "robot": {**(rb if isinstance(rb, Mapping) else {}),
                                  "name": Path(path).stem}}  # fmt: skip
    return robot_from_dict(data, base, where=where, damping=damping)


def load_named_robot(value: Any, where: str, folder: str | os.PathLike[str] | None) -> Robot:
    """The robot of a robot file another file names in its field ``where`` (a campaign's
    ``robot.file``, an objective's ``robots.robot``, ...): ``value`` a path, relative to that
    file's ``folder`` (default the current folder); one-line errors naming ``where``."""
    if not isinstance(value, str) or not value.strip():
        raise RobotFileError(f"{where} must be a robot file path, got {value!r}")
    path = Path(value)
    if not path.is_absolute():
        path = Path(folder if folder is not None else Path.cwd()) / path
    if not path.is_file():
        raise RobotFileError(f"{where}: no such robot file {str(path)!r}")
    return load_robot(path)


# ------------------------------------------------------------------------------ writing
def _toml_string(s: str) -> str:
    """A TOML basic string (:func:`mwip.io.toml_str`)."""
    from mwip.io import toml_str

    return toml_str(s)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v != v or v in (float("inf"), float("-inf")):
            raise ValueError(f"cannot write the non-finite number {v!r} in a robot file")
        return repr(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r}")


def _notes(text: str) -> str:
    """A multi-line TOML basic string of ``text`` (quotes, backslashes and control
    characters escaped; newlines kept)."""
    lines = [_toml_string(line)[1:-1] for line in text.split("\n")]
    return 'notes = """\n' + "\n".join(lines) + '"""'


def _comment(robot: Robot, path: str, unknowns: set[str], sources: Mapping[str, str]) -> str:
    info = _info(path)
    if info is None:
        return ""
    unit = info.unit or "-"
    if path in sources:
        return f"{unit}; {sources[path]}"
    status = "unknown (prior)" if path in unknowns else info.status
    return f"{unit}; {status}: {info.source}"


def robot_to_toml(robot: Robot) -> str:
    """The robot file of ``robot`` (module docstring)."""
    from mwip.hardware.elements import ELEMENTS

    tw = robot.twin
    unknowns = set(tw.prior.names)
    sources = robot.sources()
    out = ["# mwip robot file (docs/robot.md). SI units; each value: unit; status: source.",
           "", "[robot]", f"name = {_toml_value(robot.name)}"]  # fmt: skip
    if robot.notes:
        out.append(_notes(robot.notes))

    def put(table: str, key: str, value: Any) -> None:
        text = f"{key} = {_toml_value(value)}"
        note = _comment(robot, f"{table}.{key}", unknowns, sources)
        if note:  # a control character in a source cannot end the comment early
            from mwip.io import toml_comment

            note = toml_comment(note.replace("\n", " "))[2:]
        out.append(f"{text:<34} # {note}" if note else text)

    put("robot", "elements", [e for e in ELEMENTS if e in tw.active])
    put("robot", "dt", tw.dt)
    for table, params in (("body", robot.body), ("design", robot.design)):
        out += ["", f"[{table}]"]
        for key, sym in BODY_TO_PARAMS.items():
            put(table, key, float(getattr(params, sym)))
    for table in _HW:
        obj: Any = tw
        for part in table.split("."):
            obj = getattr(obj, part)
        out += ["", f"[{table}]"]
        for f in fields(obj):
            value = getattr(obj, f.name)
            if f.name == "fusion" and table == "firmware":
                continue
            put(table, f.name, value)
    out += ["", "# the unknowns: their declared ranges (low = high fixes one; scale = \"log\": "
            "log-uniform)", "[prior]"]  # fmt: skip
    for name, e in tw.prior.to_dict().items():
        body = ", ".join(f"{k} = {_toml_value(e[k])}" for k in e)
        out.append(f"{_toml_string(name)} = {{ {body} }}")
    if sources:
        out += ["", "# sources that replace the built-in ones", "[provenance]"]
        for key in sorted(sources):
            out.append(f"{_toml_string(key)} = {_toml_value(sources[key])}")
    return "\n".join(out) + "\n"


def save_robot(robot: Robot, path: str | os.PathLike[str]) -> Path:
    """Write :func:`robot_to_toml` atomically."""
    return write_text_atomic(path, robot_to_toml(robot))
