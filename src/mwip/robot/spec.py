"""A robot: its body, the model its controllers are designed on, and its hardware.

:class:`Robot` is what a robot file (:mod:`mwip.robot.file`) holds and what every command
that runs a robot takes (``--robot FILE``): the body (the plant, :class:`mwip.params.Params`,
Table 6.1 for the book's robot), the design model (Table 6.2), and the twin's hardware
(:class:`mwip.hardware.twin.Twin`: motors, drive, firmware, sensors, payload, and the prior of
the values the book does not print), with where each value comes from.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from mwip.params import NOMINAL, REAL, Params

if TYPE_CHECKING:
    from mwip.hardware.prior import Prior
    from mwip.hardware.twin import Twin

__all__ = ["Robot"]


def _datasheet_twin() -> Twin:
    from mwip.hardware.twin import Twin

    return Twin()


@dataclass(frozen=True)
class Robot:
    """One robot (module docstring).

    ``body`` the real robot's parameters (the plant the twin integrates, before its drive
    train and payload); ``design`` the nominal parameters controllers and observers use;
    ``twin`` the hardware; ``name`` and ``notes`` (where the robot comes from);
    ``provenance`` ``((path, source), ...)``: sources that replace the built-in ones for
    these values (a fitted or measured value says so)."""

    body: Params = REAL
    design: Params = NOMINAL
    twin: Twin = field(default_factory=_datasheet_twin)
    name: str = "robot"
    notes: str = ""
    provenance: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        for name in ("body", "design"):
            p = getattr(self, name)
            if not isinstance(p, Params) or p.batch_shape != ():
                raise ValueError(f"robot: {name!r} must be the parameters of one robot")
        object.__setattr__(self, "provenance", tuple(sorted(dict(self.provenance).items())))

    @property
    def prior(self) -> Prior:
        """The declared prior of the robot's unknown values."""
        return self.twin.prior

    @property
    def wheel_torque_limit(self) -> float:
        """The largest wheel torque its drive gives (N m per wheel,
        :meth:`mwip.hardware.motor_data.DriveSpec.wheel_torque_limit`)."""
        return float(self.twin.drive.wheel_torque_limit(self.twin.motor))

    @property
    def Ts(self) -> float:
        """The firmware's sample period (s)."""
        return self.twin.Ts

    def values(self) -> dict[str, float]:
        """The robot's value of every unknown of its prior."""
        return self.twin.values()

    def with_values(self, mapping: Mapping[str, float]) -> Robot:
        """This robot with unknowns replaced (:meth:`mwip.hardware.twin.Twin.with_values`)."""
        return replace(self, twin=self.twin.with_values(mapping))

    def sources(self) -> dict[str, str]:
        """The provenance overrides as a mapping."""
        return dict(self.provenance)

    def with_sources(self, sources: Mapping[str, str]) -> Robot:
        """This robot with the provenance of ``sources``'s values replaced."""
        merged = dict(self.provenance)
        merged.update(sources)
        return replace(self, provenance=tuple(merged.items()))

    def case_plant(self, case: int = 1) -> Params:
        """The body for a Chapter 6 case: 1 the robot, 2 and 3 with its payload
        (:func:`mwip.hardware.twin.case_plant`)."""
        from mwip.hardware.twin import case_plant

        return case_plant(case, self.body, self.twin)

    def digest(self) -> str:
        """A short hash of the robot's file text (the same robot, the same digest)."""
        import hashlib

        from mwip.robot.file import robot_to_toml

        return hashlib.sha256(robot_to_toml(self).encode()).hexdigest()[:12]

    def describe(self) -> str:
        """One line: the robot's name and its key values."""
        b, tw = self.body, self.twin
        return (f"robot {self.name!r}: mb {b.mb:g} kg, r {b.r:g} m, l {b.l:g} m; gear "
                f"{tw.drive.gear_ratio:g}:1, firmware torque gain "
                f"{tw.firmware.torque_gain:g}, delay {tw.firmware.delay:g} Ts")

    def replace_params(self, **kw: Any) -> Robot:
        """This robot with ``body``/``design``/``twin``/... replaced (``dataclasses.replace``)."""
        return replace(self, **kw)
