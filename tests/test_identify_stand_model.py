"""The fit's wheels-off-ground model (:func:`mwip.identify.model.stand_rollout`) is the twin's
drive chain written batch-first with its dead-band and Coulomb sign smoothed for a
derivative-based fit (docs/twin_fit.md). With the smoothing widths at 0 it must be the
compiled drive chain (:class:`mwip.hardware.twin.TwinActuator`, the elements' one
implementation) exactly, up to round-off: driven by the same duty schedule on a stand (body
fixed, each wheel free, ``J w' = T - D w`` integrated exactly as the log generator does), the
two give the same wheel angles (to 1e-9 of their range: the round-off of 600 steps is
~1e-15), for parameters drawn over the prior and for a robot whose body and gear ratio
differ from the book's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mwip.hardware.twin import TwinActuator
from mwip.identify import excite, synth
from mwip.identify.model import Known, stand_rollout
from mwip.params import REAL


def _chain_on_stand(truth: dict[str, float], duty: np.ndarray, body) -> np.ndarray:  # noqa: ANN001
    """Wheel angles (n, 2) of the compiled drive chain on a stand, as synth.stand_log moves
    the wheels."""
    tw = synth.twin_for(truth)
    m, d, Ts = tw.motor, tw.drive, tw.Ts
    N = d.gear_ratio
    J = float(body.Iwa) + N * N * m.rotor_inertia
    D = d.emf_damping(m) + tw.gearbox.viscous + float(body.Db)
    a = np.exp(-D * Ts / J)
    br = float(body.b / body.r)
    act = TwinActuator(body, tw, mobility=1.0 / J)
    act.reset(1)
    gain = N * d.gear_efficiency * m.k_t
    phi, w = np.zeros(2), np.zeros(2)
    out = np.zeros((duty.shape[0], 2))
    for k in range(duty.shape[0]):
        psi, alpha = 0.5 * (phi[0] + phi[1]), (phi[0] - phi[1]) / (2 * br)
        dpsi, dalpha = 0.5 * (w[0] + w[1]), (w[0] - w[1]) / (2 * br)
        state = np.array([[psi, 0.0, alpha, dpsi, 0.0, dalpha, 0.0, 0.0]])
        u = duty[k] * d.supply_voltage * gain / m.resistance
        T = act(k * Ts, u[None, :], state)[0]
        wss = T / D
        phi = phi + wss * Ts + (w - wss) * (J / D) * (1.0 - a)
        w = wss + (w - wss) * a
        out[k] = phi
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("robot", ["book", "other"])
def test_the_unsmoothed_stand_model_is_the_compiled_chain(seed: int, robot: str) -> None:
    truth = synth.draw_truth(seed)
    body = REAL if robot == "book" else replace(REAL, r=0.05, Iwa=2.5 * REAL.Iwa, Db=0.02)
    if robot == "other":
        truth = {**truth, "drive.gear_ratio": 12.0}
    _, duty, _ = excite.schedule(static=0.3, step=0.07, chirp=0.6)
    duty = duty[:600]
    phi_chain = _chain_on_stand(truth, duty, body)
    tw = synth.twin_for(truth)
    k = Known.from_twin(tw, tw.Ts, body)
    cmd = np.concatenate([np.zeros((1, 2)), duty])[None]  # the sample before: no command
    phi_model, _ = stand_rollout(truth, cmd, np.array([True]), np.zeros((1, 2)), k,
                                 widths=(0.0, 0.0))  # fmt: skip
    # phi_model[k]: the angle at sample k, relative to the start (0 at k = 0); phi_chain[k]:
    # the angle after sample k's command was held
    scale = np.max(np.abs(phi_chain))
    assert scale > 1.0  # the schedule turns the wheels (radians), so the check has teeth
    assert np.all(phi_model[0, 0] == 0.0)
    err = np.max(np.abs(phi_model[0, 1:] - phi_chain[:-1]))
    assert err <= 1e-9 * scale, (err, scale)
