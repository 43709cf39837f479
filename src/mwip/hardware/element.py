"""What a twin element is: its parameters, state and logs as named layouts, and one kernel.

Every physical effect of the digital twin between the controller and the plant (the board's
firmware, the drive, the sensors) is an *element*: one module of :mod:`mwip.hardware` that
declares an :class:`Element` and holds its compiled kernel ``step``. The kernel is the only
implementation of the element: the compiled twin loop (:mod:`mwip.hardware.loop`) calls it for
single runs, batches, campaigns, the bench, the tuner, the fit and the calibration, and the
Python loop's :class:`~mwip.hardware.twin.TwinSensor` / :class:`~mwip.hardware.twin.TwinActuator`
call it through the same dispatcher (NumPy forms of the elements live in the tests, as oracles).

A kernel has one signature for every element::

    step(k, p, s, bus, yi, z, lg)

``k`` the sample index (``k = 0``: the first sample, where an element starts its state), ``p``
its parameter vector (layout :attr:`Element.params`), ``s`` its state (layout
:attr:`Element.state`), ``bus`` the robot's signal bus (:mod:`mwip.hardware.bus`: the torque
on its way to the wheels, the measurement being built, ...), ``yi`` the plant's true state
(8,), ``z`` the normal variates it draws this sample (:attr:`Element.noise` of them) and
``lg`` its log entries (:attr:`Element.logs`). A kernel reads and writes its fields by the
constant offsets of its layouts (:meth:`mwip.layout.Layout.index`), never by hand-numbered
slots.

Python packs an element for a batch of robots with :attr:`Element.pack` and
:attr:`Element.init` (per-row values from the twin's configuration, its unknowns and the plant,
:class:`PackContext`): each returns ``{field: value}``, a value being a number, an (N,) array
(one per robot) or an array of the field's shape with a leading N.

Adding an element: its module (an :class:`Element` and its ``step``), one entry in a chain of
:mod:`mwip.hardware.registry` and one import and branch in :mod:`mwip.hardware.dispatch`
(docs/extending.md, "Adding a twin element").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from mwip.layout import Layout

if TYPE_CHECKING:
    from mwip.hardware.twin import Twin
    from mwip.params import Params

__all__ = ["Element", "PackContext"]


@dataclass(frozen=True)
class PackContext:
    """What an element packs from, for ``n`` robots: the twin's configuration ``twin``, the
    plant the twin integrates ``plant`` (its wheel geometry, one row per robot or one for all),
    ``values`` the twin's unknowns (dotted names; floats, or (n,) arrays per robot) and
    ``masks`` (n or 1, E) the element switches of each robot
    (:data:`mwip.hardware.elements.ELEMENTS`)."""

    twin: Twin
    plant: Params
    values: Mapping[str, Any]
    masks: NDArray[np.bool_]
    n: int
    extra: Mapping[str, Any] = field(default_factory=dict)

    def value(self, name: str) -> Any:
        """The unknown ``name``: a float, or an (n,) array; a name the twin's prior leaves
        out (a structure whose prior fixes it, e.g. the torque gain of the book calibration's
        S0) is the twin's own value (its dotted path)."""
        if name in self.values:
            v = self.values[name]
        else:
            v = self.twin
            for part in name.split("."):
                v = getattr(v, part)
        return float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float)

    def on(self, switch: str) -> NDArray[np.float64]:
        """1.0 / 0.0 per robot (n,): the element switch ``switch`` is on."""
        from mwip.hardware.elements import ELEMENTS

        col = self.masks[:, ELEMENTS.index(switch)].astype(float)
        return np.broadcast_to(col, (self.n,)).copy() if col.size == 1 else col

    def any(self, *switches: str) -> bool:
        """Some robot has one of ``switches`` on."""
        return any(bool(self.on(s).any()) for s in switches)

    def rows(self, x: Any) -> NDArray[np.float64]:
        """A number or per-robot value as (n,) floats."""
        return np.broadcast_to(np.asarray(x, dtype=float).reshape(-1), (self.n,)).astype(float)


Packer = Callable[[PackContext], Mapping[str, Any]]


@dataclass(frozen=True)
class Element:
    """A twin element (module docstring): ``name``, its unique ``code`` (the dispatcher's
    branch), the ``stage`` it runs in (``"sensor"``: from the true state to the measurement;
    ``"drive"``: from the commanded to the applied torque), its ``place`` in that stage's
    chain (the elements of a stage run in increasing place; unique within the stage), its
    layouts, its ``logs`` (``(name, width)``, recorded as ``res.logs[name]``), the normal
    variates it draws per sample (``noise``), the element switches it honours (``switches``;
    the element runs when a robot of the batch has one of them on; an ``optional`` element
    runs only when the run asks for it, ``PackContext.extra[name]``) and its packers. ``pack``
    gives the parameter vector's fields, ``init`` the state's at the start of a run (fields it
    omits start at 0)."""

    name: str
    code: int
    stage: Literal["sensor", "drive"]
    params: Layout
    state: Layout
    pack: Packer
    init: Packer | None = None
    logs: tuple[tuple[str, int], ...] = ()
    noise: int = 0
    switches: tuple[str, ...] = ()
    optional: bool = False
    doc: str = ""
    place: int = 0

    def __post_init__(self) -> None:
        if self.stage not in ("sensor", "drive"):
            raise ValueError(f"element {self.name!r}: stage must be 'sensor' or 'drive'")
        if not (isinstance(self.code, int) and self.code > 0):
            raise ValueError(f"element {self.name!r}: code must be a positive integer")
        if not (isinstance(self.place, int) and self.place > 0):
            raise ValueError(f"element {self.name!r}: place must be a positive integer (its "
                             "place in its stage's chain)")  # fmt: skip

    @property
    def log_width(self) -> int:
        return sum(w for _, w in self.logs)

    def active(self, ctx: PackContext) -> bool:
        """The element runs for ``ctx``: an ``optional`` one when ``ctx.extra`` has its
        name, another when some robot has one of its switches on (or it has none)."""
        if self.optional:
            return ctx.extra.get(self.name) is not None
        return not self.switches or ctx.any(*self.switches)

    def vectors(self, ctx: PackContext) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(P, X)``: the parameter vectors (1 or n, size) and the initial states (n, size)
        of ``ctx``'s robots, packed by the layouts."""
        return (_rows_of(self.params, self.pack(ctx), ctx.n, self.name, "params"),
                _rows_of(self.state, self.init(ctx) if self.init else {}, ctx.n, self.name,
                         "state", full=True))  # fmt: skip


def _rows_of(layout: Layout, values: Mapping[str, Any], n: int, name: str, what: str,
             full: bool = False) -> NDArray[np.float64]:  # fmt: skip
    """Vectors of ``layout`` for ``n`` robots from per-field values (numbers, per-robot (n,)
    arrays, or arrays of the field's shape with or without a leading n); one row when every
    value is common to all robots (unless ``full``)."""
    extra = sorted(set(values) - set(layout.names))
    if extra:
        raise ValueError(f"element {name!r}: {what} has no field {extra[0]!r}")
    per_row = full
    cols: list[tuple[int, int, NDArray[np.float64]]] = []
    start = 0
    for f in layout.fields:
        size = f.size
        v = np.asarray(values.get(f.name, 0.0), dtype=float)
        if v.ndim == 0:
            arr = np.full((1, size), float(v))
        elif v.shape == (n, *f.shape):
            arr = v.reshape(n, size)
            per_row = per_row or n > 1
        elif v.shape in (f.shape, (1, *f.shape)):
            arr = v.reshape(1, size)
        else:
            raise ValueError(f"element {name!r}: {what}.{f.name} has shape {v.shape}, expected "
                             f"{f.shape} or ({n}, ...)")  # fmt: skip
        cols.append((start, start + size, arr))
        start += size
    rows = n if per_row else 1
    out = np.zeros((rows, max(layout.size, 1)))
    for a, b, arr in cols:
        out[:, a:b] = np.broadcast_to(arr, (rows, b - a))
    return out
