"""The twin's elements in the order they act, read from the one dispatcher.

Each sample the compiled twin loop runs the sensor chain on the true state (the IMU reads,
the firmware fuses the pitch, the encoders count), the law on the measurement, then the drive
chain on the command (the firmware's delay and torque-to-duty map, the driver and motors, the
gearbox's Coulomb friction and backlash). An element runs when some robot of the batch has
one of its switches on (:attr:`~mwip.hardware.element.Element.switches`), or, for an
``optional`` one, when the run asks for it.

The registered elements are the element modules :mod:`mwip.hardware.dispatch` imports (each
with its branch there); each declares its stage and its place in that stage's chain
(:attr:`~mwip.hardware.element.Element.place`). So a new element is its file plus three
lines in ``dispatch.py``: the import and the two-line branch (docs/extending.md). An element
imported without a branch, or two elements sharing a code or a place, is an ``ImportError``
here: the compiled loop would skip such an element without a word.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from types import ModuleType

from mwip.hardware import dispatch
from mwip.hardware.element import Element

__all__ = ["SENSOR_CHAIN", "DRIVE_CHAIN", "ELEMENTS_BY_NAME", "registered"]


def registered(namespace: Mapping[str, object], source: str) -> tuple[Element, ...]:
    """The elements of the modules in a dispatcher's ``namespace`` (its globals), checked
    against its ``source`` (module docstring); sensor chain first, each chain in place order."""
    found: dict[str, Element] = {}
    for alias, mod in namespace.items():
        element = getattr(mod, "ELEMENT", None) if isinstance(mod, ModuleType) else None
        if not isinstance(element, Element):
            continue
        if f"code == {alias}.CODE" not in source or f"{alias}.step(" not in source:
            raise ImportError(f"twin element {element.name!r} ({alias}) is imported by "
                              "mwip.hardware.dispatch without its branch "
                              f"'elif code == {alias}.CODE: {alias}.step(...)'")  # fmt: skip
        found[element.name] = element
    elements = tuple(sorted(found.values(), key=lambda e: (e.stage != "sensor", e.place)))
    for attr in ("code", "place"):
        seen: dict[tuple[str, int], str] = {}
        for e in elements:
            where = (e.stage if attr == "place" else "", getattr(e, attr))
            if where in seen:
                raise ImportError(f"twin elements {seen[where]!r} and {e.name!r} share the "
                                  f"{attr} {where[1]}")  # fmt: skip
            seen[where] = e.name
    return elements


_ELEMENTS = registered(vars(dispatch), inspect.getsource(dispatch))

SENSOR_CHAIN: tuple[Element, ...] = tuple(e for e in _ELEMENTS if e.stage == "sensor")
DRIVE_CHAIN: tuple[Element, ...] = tuple(e for e in _ELEMENTS if e.stage == "drive")
ELEMENTS_BY_NAME: dict[str, Element] = {e.name: e for e in _ELEMENTS}
