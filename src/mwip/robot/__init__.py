"""Robots as files: the body, the design model and the hardware of a robot in one TOML file.

- :class:`Robot` (:mod:`mwip.robot.spec`): what a robot is;
- :func:`load_robot`, :func:`robot_to_toml`, :func:`save_robot` (:mod:`mwip.robot.file`):
  the one loader and writer, one-line errors naming the file and the field;
- :mod:`mwip.robot.schema`: every table and field with its unit, status and source;
- :func:`default_robot`: the book's robot (Tables 6.1 and 6.2, and the twin identified from
  the book's evidence, ``book.toml`` beside this module); :func:`datasheet_robot`: the same
  with every unknown at its data-sheet guess.

Every command that runs a robot takes ``--robot FILE`` (docs/robot.md).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from mwip.robot.file import (
    RobotFileError,
    load_named_robot,
    load_robot,
    robot_from_dict,
    robot_to_toml,
    save_robot,
)  # fmt: skip
from mwip.robot.spec import Robot

__all__ = [
    "Robot", "load_robot", "load_named_robot", "robot_from_dict", "robot_to_toml", "save_robot",
    "RobotFileError",
    "default_robot", "datasheet_robot", "BOOK_FILE", "robot_or_default",
]  # fmt: skip

#: The book's robot: Tables 6.1 and 6.2, and the most probable twin of the book calibration.
BOOK_FILE = Path(__file__).with_name("book.toml")


@lru_cache(maxsize=1)
def default_robot() -> Robot:
    """The default robot: the book's (``book.toml``; what it leaves out from the data-sheet
    robot)."""
    return load_robot(BOOK_FILE, base=Robot(name="book"))


def datasheet_robot() -> Robot:
    """The book's robot with every unknown at its data-sheet guess (the twin the prior is
    centred on)."""
    from mwip.hardware.twin import Twin

    return Robot(name="book-datasheet", notes="The book's robot (Tables 6.1, 6.2) with the "
                 "data-sheet guesses for every value the book does not print.", twin=Twin())


def robot_or_default(robot: Robot | str | Path | None) -> Robot:
    """``robot`` itself, the robot of a file path, or the default robot for ``None``."""
    if robot is None:
        return default_robot()
    if isinstance(robot, Robot):
        return robot
    if isinstance(robot, str | Path):
        return load_robot(robot)
    raise TypeError(f"robot must be a mwip.robot.Robot, a file path or None, got "
                    f"{type(robot).__name__}")
