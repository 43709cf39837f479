"""The entrants of a benchmark: registered controllers, settings files and scenario files.

- a registry name (``mwip controllers``): the book's settings, designed on the nominal model
  (Table 3.2); label: the name;
- a settings file (:mod:`mwip.schema.settings`, e.g. ``mwip tune``'s ``best.toml``): its
  controller with its settings (validated against the registry's ranges); label: the file's
  ``label``, else ``NAME (FILE stem)``;
- a scenario file (:mod:`mwip.scenario`): its ``controller``, ``[controller]`` settings and
  ``[design]`` model (the rest of the scenario, its plant, initial state and twin, is the
  benchmark's to set); label: the file's stem.

Every error is a one-line ``ValueError`` naming the argument; two entrants with the same label
are refused.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mwip.bench.run import Entrant
from mwip.params import NOMINAL, Params

__all__ = ["resolve_entrants"]


def _frozen(settings: dict[str, Any]) -> tuple[tuple[str, Any], ...]:
    return tuple(sorted((k, tuple(v) if isinstance(v, list) else v)
                        for k, v in settings.items()))  # fmt: skip


def resolve_entrants(names: Sequence[str], settings_files: Sequence[str | Path] = (),
                     scenario_files: Sequence[str | Path] = (),
                     design: Params | None = None) -> tuple[Entrant, ...]:  # fmt: skip
    """The entrants, in the order: ``names`` (all registered ones when ``names`` is empty),
    then the settings files, then the scenarios. The registry's and the settings files'
    controllers are designed on ``design`` (the robot's design model; default Table 3.2); a
    scenario's on its own ``[design]``."""
    from mwip.laws.registry import get
    from mwip.laws.registry import names as registered
    from mwip.schema.settings import read_settings_file

    design = NOMINAL if design is None else design

    out: list[Entrant] = []
    for n in names or registered():
        try:
            get(n)
        except ValueError as exc:
            raise ValueError(f"CONTROLLER: {exc}") from None
        out.append(Entrant(n, n, design=design))
    for f in settings_files:
        sf = read_settings_file(f)
        where = f"--settings {str(f)!r}"
        try:
            spec = get(sf.name)
        except ValueError as exc:
            raise ValueError(f"{where}: controller.name: {exc}") from None
        from mwip.laws.settings_file import check_file_types

        check_file_types(sf.name, sf.settings_dict(), where)
        try:
            spec.resolve(sf.settings_dict())
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        label = sf.label or f"{sf.name} ({Path(f).stem})"
        out.append(Entrant(label, sf.name, _frozen(sf.settings_dict()), design,
                           f"settings file {Path(f).name}"))  # fmt: skip
    for f in scenario_files:
        from mwip.scenario import load_scenario

        try:
            sc = load_scenario(f)
        except ValueError as exc:
            raise ValueError(f"--scenario: {exc}") from None
        out.append(Entrant(Path(f).stem, sc.controller, _frozen(dict(sc.settings)), sc.design,
                           f"scenario {Path(f).name}"))  # fmt: skip
    labels = [e.label for e in out]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise ValueError(f"entrants: {dup[0]!r} is entered twice (a controller named twice, "
                         "or two files of the same name)")
    return tuple(out)
