"""The one registry of studies: every module of :mod:`mwip.studies` that declares ``STUDY``
(a :class:`~mwip.studies.study.Study`) or ``STUDIES`` (several) is a study; nothing else
registers one. Studies are ordered by their place in the book (``Study.place``, then name).

:func:`run_study` builds the :class:`~mwip.studies.study.StudyContext` (robot, design model,
validated settings, folder, seed) and runs one study; ``mwip run``, ``mwip reproduce``, the
runner and the tests go through it.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from mwip.studies import settings as study_settings

if TYPE_CHECKING:  # loaded with the first study that runs: `mwip list` reads no study module
    from mwip.hardware.twin import Twin
    from mwip.params import Params
    from mwip.studies.study import Study, StudyContext

__all__ = ["Declared", "all_studies", "context", "declared", "get", "names", "robot",
           "run_study"]  # fmt: skip

#: Modules of the package that are infrastructure, not studies (not imported by discovery).
_NOT_STUDIES = frozenset(
    {"common", "progress", "registry", "runner", "settings", "study", "study_file"}
)


class Declared(NamedTuple):
    """A study's declaration as written in its module (name, book source, place, cost), read
    without importing the module (and NumPy, Matplotlib, the engine with it)."""

    name: str
    source: str
    place: tuple[int, ...]
    cost: float


def _study_modules() -> list[str]:
    import mwip.studies as package

    infos = pkgutil.iter_modules(package.__path__)
    return [i.name for i in infos
            if not (i.ispkg or i.name.startswith("_") or i.name in _NOT_STUDIES)]  # fmt: skip


_FIELDS = ("name", "source", "run", "place", "cost")


def _read_declarations(path: Path) -> list[Declared] | None:
    """The ``Study(...)`` calls assigned to ``STUDY``/``STUDIES`` at the top level of the
    module at ``path``, their arguments literals or names of module-level literals; ``None``
    when the module declares them any other way (it is then imported)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    consts: dict[str, Any] = {}
    calls: list[ast.Call] = []
    for node in tree.body:
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1
                and isinstance(node.targets[0], ast.Name)):  # fmt: skip
            continue
        target = node.targets[0].id
        if target in ("STUDY", "STUDIES"):
            many = isinstance(node.value, ast.Tuple | ast.List)
            items = node.value.elts if many else [node.value]  # type: ignore[attr-defined]
            for item in items:
                if not (isinstance(item, ast.Call) and isinstance(item.func, ast.Name)
                        and item.func.id == "Study"):  # fmt: skip
                    return None
                calls.append(item)
            continue
        try:
            consts[target] = ast.literal_eval(node.value)
        except ValueError:
            continue

    def value(expr: ast.expr) -> Any:
        if isinstance(expr, ast.Name):
            if expr.id not in consts:
                raise ValueError(expr.id)
            return consts[expr.id]
        return ast.literal_eval(expr)

    out = []
    for call in calls:
        args: dict[str, ast.expr] = dict(zip(_FIELDS, call.args, strict=False))
        args.update({k.arg: k.value for k in call.keywords if k.arg is not None})
        try:
            name, source, place = value(args["name"]), value(args["source"]), value(args["place"])
            cost = value(args["cost"]) if "cost" in args else 5.0
        except (KeyError, ValueError):
            return None
        out.append(Declared(str(name), str(source), tuple(place), float(cost)))
    return out


@cache
def _index() -> dict[str, Declared]:
    """Every study's :class:`Declared`, in book order, read from the modules' source (a
    module whose declaration is not written as literals is imported instead)."""
    import mwip.studies as package

    found: list[Declared] = []
    for mod in _study_modules():
        read = _read_declarations(Path(package.__path__[0]) / f"{mod}.py")
        if read is None:
            module = importlib.import_module(f"mwip.studies.{mod}")
            one = getattr(module, "STUDY", None)
            studies = (*(getattr(module, "STUDIES", None) or ()), *([one] if one else []))
            read = [Declared(s.name, s.source, s.place, s.cost) for s in studies]
        found.extend(read)
    found.sort(key=lambda s: (s.place, s.name))
    out: dict[str, Declared] = {}
    for s in found:
        if s.name in out:
            raise ValueError(f"study name {s.name!r} is declared twice")
        out[s.name] = s
    return out


def declared() -> list[Declared]:
    """Every study's declaration, in book order, without importing any study module (``mwip
    list``, a study name's validation); :func:`all_studies` has the same studies."""
    return list(_index().values())


@cache
def _discover() -> dict[str, Study]:
    from mwip.studies.study import Study

    found: list[Study] = []
    for mod in _study_modules():
        module = importlib.import_module(f"mwip.studies.{mod}")
        declared = getattr(module, "STUDIES", None) or ()
        one = getattr(module, "STUDY", None)
        for s in (*declared, *([one] if one is not None else [])):
            if not isinstance(s, Study):
                raise TypeError(f"mwip.studies.{mod}: STUDY/STUDIES must be Study objects")
            found.append(s)
    found.sort(key=lambda s: (s.place, s.name))
    out: dict[str, Study] = {}
    for s in found:
        if s.name in out:
            raise ValueError(f"study name {s.name!r} is declared twice")
        out[s.name] = s
    return out


def all_studies() -> list[Study]:
    """Every study, in book order."""
    return list(_discover().values())


def _known() -> Mapping[str, Any]:
    """The studies by name in book order: the imported ones once they are imported (or
    replaced, as tests do), else the declarations read from the source (:func:`declared`)."""
    info = getattr(_discover, "cache_info", None)
    return _discover() if info is None or info().currsize else _index()


def names() -> list[str]:
    """Every study's name, in book order (``mwip list``, ``mwip reproduce``), without
    importing the study modules."""
    return list(_known())


def get(name: str) -> Study:
    """The study called ``name``; ``ValueError`` listing the names if there is none (known
    without importing any study module)."""
    known = _known()
    if name not in known:
        raise ValueError(f"unknown study {name!r}; choose from: {', '.join(known)}")
    return _discover()[name]


def robot(plant: Params | None = None, nominal: Params | None = None) -> tuple[Params, Params]:
    """The simulated robot and the design model a study runs on: the given ones, else the
    book's (Table 3.1 and Table 3.2, units damping reading; SPEC.md section 2)."""
    from mwip.params import NOMINAL, REAL

    return (REAL if plant is None else plant), (NOMINAL if nominal is None else nominal)


#: (:func:`robot` under a name the ``robot`` argument of :func:`context` does not hide)
_book_robot = robot


def context(
    name: str,
    out: Path,
    *,
    quick: bool = False,
    plant: Params | None = None,
    nominal: Params | None = None,
    overrides: Mapping[str, Any] | None = None,
    twin: Twin | None = None,
    robot: Any = None,
) -> StudyContext:
    """The context study ``name`` runs in: its folder ``out/<name>``, the robot ``plant``
    (default Table 3.1) and design model ``nominal`` (default Table 3.2), its settings (the
    study file's defaults with ``overrides``, validated), its seed (setting ``seed``, else
    0) and, for the Chapter 6 studies, the twin configuration ``twin`` (default: the default
    robot's, :func:`mwip.hardware.identified.default_twin`, as ``mwip run``). ``robot`` (a
    :class:`mwip.robot.Robot` or a robot file) gives all three at once (then none of
    ``plant``, ``nominal``, ``twin``)."""
    if robot is not None:
        from mwip.robot import robot_or_default

        if plant is not None or nominal is not None or twin is not None:
            raise ValueError("robot: give the robot or plant/nominal/twin, not both (the "
                             "robot file holds its body, design model and twin)")  # fmt: skip
        robot = robot_or_default(robot)
        plant, nominal, twin = robot.body, robot.design, robot.twin
    if twin is None:
        from mwip.hardware.identified import default_twin

        twin = default_twin()
    study = get(name)
    try:
        base = study_settings.defaults(name)
    except ValueError:  # a study without a study file has no settings (e.g. in a test)
        base = {}
    cfg = {**base, **study_settings.validate(name, overrides or {})}
    plant, nominal = _book_robot(plant, nominal)
    from mwip.studies.study import StudyContext

    return StudyContext(
        name=name,
        source=study.source,
        plant=plant,
        nominal=nominal,
        settings=cfg,
        out=Path(out) / name,
        quick=quick,
        seed=int(cfg.get("seed", 0)),
        twin=twin,
    )


def run_study(
    name: str,
    out: Path,
    *,
    quick: bool = False,
    plant: Params | None = None,
    nominal: Params | None = None,
    overrides: Mapping[str, Any] | None = None,
    twin: Twin | None = None,
    robot: Any = None,
) -> dict[str, Any]:
    """Run study ``name`` into ``out/<name>`` (see :func:`context`; ``robot``: a robot file or
    :class:`mwip.robot.Robot`); returns its metrics document."""
    ctx = context(name, out, quick=quick, plant=plant, nominal=nominal, overrides=overrides,
                  twin=twin, robot=robot)  # fmt: skip
    return get(name).run(ctx)
