"""The house (issue 24, item 2): no import runs down-to-up a floor, no circle between rooms.

The import graph of ``mwip`` is read from the source with :mod:`ast`: every ``import`` and
``from ... import`` of an ``mwip`` module, at module level *and* inside functions (a lazy
import is still a dependency; it only moves the cost). ``TYPE_CHECKING`` imports count too.
A *room* is a top-level module or a subpackage (``mwip.report``, ``mwip.cache``); the command
line (the package ``mwip.cli``, one module per command, and the entry points ``mwip.__main__``,
``mwip.console``) is the room ``cli`` on the top floor, and no other room holds CLI code (none
imports click). The floors are declared below, as data.

Checks: a module imports only rooms on its own floor or below, and the rooms form no cycle.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

#: Floors, bottom first: a room may import rooms of its own floor and the floors below.
FLOORS: tuple[tuple[str, ...], ...] = (
    # ground: core types, parameters, the results schema, files, caches, small utilities
    ("mwip.lazy", "mwip.core", "mwip.params", "mwip.damping", "mwip.validate",
     "mwip.io", "mwip.cache", "mwip.budget", "mwip.outdir", "mwip.outfile", "mwip.metrics",
     "mwip.schema",
     "mwip.jit_cache", "mwip.numerics", "mwip.notice", "mwip.layout"),
    # the plant
    ("mwip.models",),
    # estimation and control laws, their interop
    ("mwip.observers", "mwip.fuzzy", "mwip.laws", "mwip.pycontrol"),
    # the engine
    ("mwip.sim",),
    # the digital twin
    ("mwip.hardware",),
    # a robot: its body, design model and twin, as one file
    ("mwip.robot",),
    # what runs on a robot and its twin: scenarios, identification, export, gym
    ("mwip.identify", "mwip.scenario", "mwip.export", "mwip.gym"),
    # views of results: report, figures, animations (read the schema, never the studies)
    ("mwip.report", "mwip.plot", "mwip.animate"),
    # what produces results: studies and campaigns of runs
    ("mwip.studies", "mwip.campaign", "mwip.bench"),
    # the book calibration of the twin (runs campaigns of studies)
    ("mwip.calibration",),
    # robust gain tuning (runs campaign blocks of candidate settings, Optuna studies)
    ("mwip.tune",),
    # command lines, and the package's own namespace (``mwip.linearize``, ``mwip.NOMINAL``)
    ("cli", "mwip"),
)  # fmt: skip

#: Imports that break the rules and are known, each with why it stays for now; the test
#: fails if one disappears (remove it here) or a new one appears.
KNOWN: dict[tuple[str, str], str] = {
    ("mwip.hardware.identified", "mwip.robot"): "the default twin is the default robot's "
    "(mwip/robot/book.toml): default_twin() reads it (a lazy import; issue 35)",
    ("mwip.hardware.sensitivity", "mwip.robot"): "the sensitivities take a robot file "
    "(robot_or_default; a lazy import; issue 35)",
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_cli(module: str) -> bool:
    return module in ("mwip.cli", "mwip.__main__", "mwip.console") or module.startswith("mwip.cli.")


def room(module: str) -> str:
    """The room of a module: ``cli`` for command-line modules, else the top-level module or
    subpackage it belongs to."""
    if _is_cli(module):
        return "cli"
    parts = module.split(".")
    return ".".join(parts[:2])


def imports() -> dict[str, set[str]]:
    """``module -> the mwip modules it imports`` (every import statement, at any depth)."""
    modules = {_module_name(p): p for p in (SRC / "mwip").rglob("*.py")}
    out: dict[str, set[str]] = defaultdict(set)
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                # ``from pkg import sub`` imports the module pkg.sub; a name, pkg itself
                targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in modules else mod
                           for a in node.names]  # fmt: skip
            for t in targets:
                if t in modules and t != name:
                    out[name].add(t)
    return out


def _floor(r: str) -> int:
    for i, rooms in enumerate(FLOORS):
        if r in rooms:
            return i
    raise AssertionError(f"room {r!r} is on no floor: add it to FLOORS")


def violations() -> dict[tuple[str, str], str]:
    """``(importer, imported) -> why`` for every import that runs up a floor."""
    bad = {}
    for mod, targets in imports().items():
        for t in targets:
            a, b = room(mod), room(t)
            if a != b and _floor(b) > _floor(a):
                bad[(mod, t)] = f"{a} (floor {_floor(a)}) imports {b} (floor {_floor(b)})"
    return bad


def room_cycles() -> list[list[str]]:
    """Strongly connected components of more than one room (Tarjan)."""
    graph: dict[str, set[str]] = defaultdict(set)
    for mod, targets in imports().items():
        for t in targets:
            if (mod, t) not in KNOWN and room(mod) != room(t):
                graph[room(mod)].add(room(t))
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_is_read():
    graph = imports()
    assert "mwip.models.linear" in graph["mwip.laws.lqr.controller"]
    assert "mwip.laws.lqr.kernel" in graph["mwip.laws.lqr.controller"]  # a lazy import counts


def test_every_room_is_on_a_floor():
    rooms = {room(m) for m in imports()} | {room(t) for ts in imports().values() for t in ts}
    for r in rooms:
        _floor(r)


def test_no_import_runs_up_a_floor():
    bad = violations()
    new = {k: v for k, v in bad.items() if k not in KNOWN}
    assert not new, "\n".join(f"{a} -> {b}: {why}" for (a, b), why in sorted(new.items()))
    gone = set(KNOWN) - set(bad)
    assert not gone, f"no longer an upward import, remove from KNOWN: {sorted(gone)}"


def test_the_issue_24_arrows_are_gone():
    """The upward imports and circles the review of issue 24 found, by module."""
    graph = imports()
    gone = [("mwip.report.claims", "mwip.studies.common"), ("mwip.report.html", "mwip.campaign"),
            ("mwip.plot.runs", "mwip.report"), ("mwip.models.linear", "mwip.pycontrol"),
            ("mwip.jit_cache", "mwip.sim")]
    for a, b in gone:
        assert not [t for t in graph.get(a, ()) if t == b or t.startswith(b + ".")], (a, b)
    plot = [m for m in graph if room(m) == "mwip.plot"]  # plot <-> animate (plot/command.py)
    assert plot and not [m for m in plot if "mwip.animate" in graph[m]]
    for view in ("mwip.report", "mwip.plot", "mwip.animate"):
        for mod, targets in graph.items():
            if room(mod) == view:
                assert not [t for t in targets if room(t) in ("mwip.studies", "mwip.campaign",
                                                               "mwip.calibration")], mod


def test_no_circle_between_rooms():
    assert room_cycles() == []


def test_only_the_cli_room_imports_click():
    """Issue 24, item 3: a command lives in a file of ``mwip.cli``; no library module holds
    command-line code (imports click)."""
    for path in (SRC / "mwip").rglob("*.py"):
        name = _module_name(path)
        if _is_cli(name):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            mods: list[str] = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mods = [node.module or ""]
            assert not [m for m in mods if m.split(".")[0] == "click"], name
