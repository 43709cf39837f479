"""The default twin: the book's robot identified from the book's evidence (issues 23, 38).

The default robot's twin (``mwip/robot/book.toml``, :func:`mwip.robot.default_robot`) is the
most probable member of the most probable twin structure of ``mwip twin calibrate book``
(revision 9, :mod:`mwip.calibration.comparison`; the declarations
``mwip/calibration/book-evidence.toml`` and ``book-structures.toml``), with its provenance in
the robot's notes; ``book-twin.json`` beside this module is that calibration's status
document of it (:mod:`mwip.calibration.default_status`). :func:`default_twin` is the twin
of every command and study not given ``--robot FILE`` (``mwip robot show`` prints it). The
data-sheet twin the prior is centred on, ``Twin()`` (``mwip robot show --datasheet``), stays
what the elements' defaults say.

To refresh it after a new calibration: ``mwip twin calibrate book --out cal`` and copy
``cal/robot.toml`` to ``mwip/robot/book.toml`` and ``cal/book-twin.json`` here (a test checks
that both are what ``--replay`` of ``docs/book_calibration/structures.parquet`` writes).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mwip.hardware.twin import Twin

__all__ = ["IDENTIFIED_FILE", "STATUS_FILE", "default_twin", "provenance", "datasheet_twin",
           "status"]

IDENTIFIED_FILE = Path(__file__).resolve().parent.parent / "robot" / "book.toml"


def default_twin() -> Twin:
    """The identified default twin: the default robot's (:func:`mwip.robot.default_robot`)."""
    from mwip.robot import default_robot

    return default_robot().twin


def datasheet_twin() -> Twin:
    """The data-sheet twin (every unknown at its data-sheet guess: the prior's centre)."""
    from mwip.hardware.twin import Twin

    return Twin()


def provenance() -> str:
    """Where the default twin comes from (the default robot's notes), as comment lines."""
    from mwip.robot import default_robot

    return "".join(f"# {line}\n" for line in default_robot().notes.splitlines())


STATUS_FILE = Path(__file__).with_name("book-twin.json")


@lru_cache(maxsize=1)
def _posterior() -> dict[str, Any]:
    import json

    try:
        doc = json.loads(STATUS_FILE.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(doc, dict):
        return {}
    from mwip.hardware.unknown import current_name

    # the record names the unknowns as the calibration's run did
    if isinstance(doc.get("map_values"), dict):
        doc["map_values"] = {current_name(k): v for k, v in doc["map_values"].items()}
    if isinstance(doc.get("members"), list):
        doc["members"] = [{current_name(k): v for k, v in m.items()} if isinstance(m, dict)
                          else m for m in doc["members"]]  # fmt: skip
    return doc


def status(twin: Any = None) -> dict[str, Any]:
    """The twin's status in words and numbers, for the run record and the report: whether
    ``twin`` (default: the default twin) is the identified one and, if so, the posterior it
    comes from (``book-twin.json``: the calibration's ``posterior.json``): its size, the
    facts conditioned on and dropped, how many Chapter 6 runs stand on it, and the held-out
    claims across the posterior (held / failed / undecided)."""
    identified = twin is None or twin == default_twin()
    if not identified:
        return {"identified": False,
                "text": "a twin given by the user (--robot FILE): not the identified one"}
    doc = _posterior()
    p = doc.get("posterior", {})
    stand = doc.get("map_standing", {})
    counts = doc.get("claim_counts", {})
    claims = [{k: c.get(k) for k in ("study", "id", "text", "verdict", "fraction", "interval",
                                     "effective_n", "default_twin", "decided_by")}
              for c in doc.get("claims", [])]  # fmt: skip
    n_up, n_runs = sum(bool(v) for v in stand.values()), len(stand)
    size = int(p.get("size", 0) or 0)
    drawn = int(p.get("n_prior", 0) or 0)
    s3 = p.get("sampler")
    # in plain words (issue 38 item 5): how many twins were drawn, how many are consistent
    pool = (f"{drawn:,} twins drawn, {size:,} consistent with the calibration facts; "
            if drawn else "")
    if s3 and s3.get("kind") == "importance":  # revision 9: the most probable structure's
        which = (f"the most probable member of twin structure {s3.get('structure')}, the most "
                 f"probable given the book's calibration facts (probability "
                 f"{float(s3.get('probability', 0)):.3g}; {pool}")
        s3 = None
    elif s3 and s3.get("kind") == "mixture":  # stages 4-5: a weighted pool, the most probable
        which = (f"the most probable of the {size:,} twins consistent with the book's "
                 f"calibration facts ({pool}")
        s3 = None
    elif s3:  # stage 3: every chain state ties with the default twin for most probable
        which = (f"the first twin found consistent with the book's calibration facts, of "
                 f"{size:,} twins from Markov chains that "
                 + ("converged" if s3.get("converged") else "did not converge") + f" ({pool}")
    else:
        which = ("the only twin found" if size == 1 else f"the most probable of {size:,} twins")
        which += f" consistent with the book's calibration facts ({pool}"
    text = (f"the default twin is {which}"
            f"{len(p.get('used', []))} facts conditioned on, {len(p.get('dropped', []))} met "
            f"with them by no twin drawn); {n_up} of {n_runs} "
            "Chapter 6 runs stand on it")  # fmt: skip
    return {"identified": True, "text": text, "provenance": provenance(),
            "size": p.get("size"), "effective_size": p.get("effective_size"),
            "used": p.get("used", []), "dropped": p.get("dropped", []),
            "conflicts": p.get("conflicts", []), "standing": stand,
            "claim_counts": counts, "claims": claims}  # fmt: skip


def wheel_torque_limit() -> float:
    """The default twin's largest wheel torque (N m per wheel,
    :meth:`~mwip.hardware.motor.DriveSpec.wheel_torque_limit`), from ``book-twin.json`` alone
    (no robot file is parsed and no compiled element imported: ``mwip simulate`` reports it for
    every run and stays fast; a test checks it against :func:`default_twin`)."""
    from mwip.hardware.motor_data import RE25, DriveSpec

    v = _posterior().get("map_values", {})
    drive = DriveSpec(gear_ratio=float(v.get("drive.gear_ratio", 23.0)),
                      current_limit=float(v.get("drive.current_limit", 4.0)))  # fmt: skip
    return drive.wheel_torque_limit(RE25)
