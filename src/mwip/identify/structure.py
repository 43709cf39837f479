"""Does the twin's structure fit the logs? The residual against the floor the twin's own
structure leaves, and intervals widened by their ratio (issue 37, item 3).

The fit's standard errors (:func:`mwip.identify.fit.cluster_covariance`) are a statement
about the twin's structure: how the estimates would scatter over repetitions of the same
experiment **if** the robot were a member of the twin's family. A real robot differs a little
in structure (another gear efficiency, the rotor's inertia reflected through a lossy gearbox,
another friction law, a delay or a clamp that is not the twin's), and then the estimates are
pulled by the misfit, by many standard errors, while the standard errors stay small.

**The test.** A member of the twin's family leaves a residual of a known size: the
encoders' quantisation, the PWM's rounding, the sensors' noise, as the robot file declares
them, passed through the multiple-shooting fit. That floor is measured, not assumed: the
twin with the fitted values and the robot file's sensors is run on the logs' own commands
and modes (:func:`mwip.identify.synth.stand_log_on`, noise seed 0), and the synthetic log's
encoder residual RMS is computed exactly as the fit's, with the same segments and the
parameters held (:func:`mwip.identify.fit.predict_error`). The Birge ratio

    R = (the fit's encoder residual RMS) / (the floor's)

is about 1 on a member of the family (a little below: the fit also adjusts the globals to its
noise). The structure is **rejected** when ``R > R_CRIT`` (:data:`R_CRIT`): the twin cannot
reproduce the robot's encoders to its own sensors' resolution.

**The widened intervals** (reported always, used where the structure is rejected):
``se_w = se * max(1, R)``, the Birge-ratio inflation used to reconcile inconsistent data
(Birge 1932, Phys. Rev. 40, 207-227; the CODATA adjustments' expansion factor). It treats the
misfit as noise of the size it has; it cannot know how a missing structure biases a
parameter, so it is not guaranteed to cover the truth, and the rates measured on an
independent simulator (docs/twin_fit.md, "How well it works on a robot of another
structure"; ``benchmarks/coverage_structure.py``; ``tests/test_identify_structure.py``) are
the statement of what it does. The constants below were fixed on the development seeds
(``benchmarks/coverage_structure.py`` seeds 0-19 of the ``off``, ``near`` and ``twin``
structures) before the test's seeds were drawn.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["R_CRIT", "StructureCheck", "check_structure", "residual_floor"]

#: The structure is rejected when the fit's encoder residual exceeds the floor of the twin's
#: own structure by this factor.
R_CRIT = 2.0


@dataclass(frozen=True)
class StructureCheck:
    """The structure test of :func:`check_structure` (module docstring)."""

    rms: float  # the fit's encoder residual RMS, rad
    floor: float  # the twin's own structure's, rad
    ratio: float  # R
    rejected: bool
    widened: dict[str, float]  # se * max(1, R) per fitted stand parameter

    def to_json(self) -> dict[str, Any]:
        return {
            "method": "encoder residual RMS against the twin's own floor (Birge ratio); "
                      "docs/twin_fit.md",
            "rms": self.rms, "floor": self.floor, "ratio": self.ratio, "r_crit": R_CRIT,
            "rejected": self.rejected, "stderr_widened": dict(self.widened),
        }  # fmt: skip

    def summary(self) -> str:
        """One line for the terminal and the notes."""
        if self.rejected:
            return (f"structure: rejected: the encoder residual ({self.rms:.3g} rad RMS) is "
                    f"{self.ratio:.3g} times the floor the twin's own structure leaves on these "
                    f"commands ({self.floor:.3g} rad; the limit is {R_CRIT:g}): the robot is "
                    "not a member of the twin's family, and the drive estimates are its best "
                    "imitation, biased by what it lacks; their standard errors are widened by "
                    f"the ratio (stderr_widened), which is not guaranteed to cover the truth "
                    "(docs/twin_fit.md)")  # fmt: skip
        return (f"structure: consistent: the encoder residual ({self.rms:.3g} rad RMS) is "
                f"{self.ratio:.3g} times the floor of the twin's own structure "
                f"({self.floor:.3g} rad; the limit is {R_CRIT:g})")  # fmt: skip


def check_structure(rms: float, floor: float, stderr: Mapping[str, float]) -> StructureCheck:
    """The test and the widened standard errors (module docstring)."""
    ratio = float(rms / floor) if floor > 0 else float("inf")
    k = max(1.0, ratio)
    return StructureCheck(float(rms), float(floor), ratio, bool(ratio > R_CRIT),
                          {n: float(s * k) for n, s in stderr.items()})


def residual_floor(logs: Sequence[Any], values: Mapping[str, float], twin: Any, body: Any,
                   known: Any, segment: int) -> float | None:  # fmt: skip
    """The encoder residual RMS the twin's own structure leaves on the wheels-off-ground rows
    of ``logs`` (module docstring): the twin ``twin`` with ``values``, the robot's ``body``
    (``None``: Table 6.1),
    each log's commands (a torque log's as the duties its firmware wrote, by the torque gain
    and the fitted gear ratio) and modes; ``None`` without such rows."""
    from mwip.identify import synth
    from mwip.identify.fit import predict_error
    from mwip.identify.logs import Log
    from mwip.params import REAL

    body = REAL if body is None else body
    tw = synth.twin_for(values, twin)
    num = den = 0.0
    for lg in logs:
        on = lg.mode == "wheels-off-ground"
        if not on.any():
            continue
        cmd = lg.command
        if lg.inputs != "duty":
            gain = values["drive.gear_ratio"] * known.eta * known.ke
            cmd = cmd * known.torque_gain * known.R / (gain * known.Vs)
        mode = np.where(on, "wheels-off-ground", "static")  # (only these rows are compared)
        cols = synth.stand_log_on(tw, body, np.clip(cmd, -1.0, 1.0), mode, seed=0)
        sim = Log(lg.path, lg.sha256, {k: np.asarray(v, dtype=float) for k, v in cols.items()
                                       if k != "mode"}, np.asarray(cols["mode"]),
                  inputs="duty")  # fmt: skip
        err = predict_error(sim, values, known, segment, twin=twin, body=body)
        if "enc_rms" in err:
            n = float(np.sum(on))
            num += n * err["enc_rms"] ** 2
            den += n
    return float(np.sqrt(num / den)) if den else None
