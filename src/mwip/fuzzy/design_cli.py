"""Body of the CLI command ``mwip design it2 --epsilon E --rho R [--json]``.

:func:`design_it2` solves the LMIs of Lemma 5.1 with the input bound of Lemma 5.2 ((5.12),
(5.19), (5.20)) on the nominal parameters and returns ``(document, text)``: a JSON-friendly
dict and the human-readable report (G1, G2, P, solver status, LMI checks, and the book's
printed gains for comparison). An infeasible problem, a solver failure or a solved point
that fails its check (:func:`~mwip.fuzzy.pdc.verify_design`: LMI residuals, vertex
closed-loop stability; whatever the solver's status) raises
:class:`~mwip.fuzzy.pdc.PDCInfeasibleError` whose one-line message the CLI prints (exit
status 1).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from mwip.fuzzy.pdc import BOOK_G1, BOOK_G2, check_design, design_pdc, uncertainty_models
from mwip.fuzzy.ts_model import Reading
from mwip.params import NOMINAL, Params

__all__ = ["design_it2"]


def design_it2(
    epsilon: float,
    rho: float,
    *,
    as_json: bool = False,
    robust: float | None = None,
    reading: Reading = "sector",
    decay: float = 0.0,
    solver: str = "CLARABEL",
    params: Params = NOMINAL,
) -> tuple[dict[str, Any], str]:
    """Design the IT2 PDC gains on ``params`` (the design model, default the book's nominal
    set, units damping reading); ``robust`` (e.g. 0.35) adds the +-rel parameter models.

    Returns ``(doc, text)``; ``text`` is JSON when ``as_json``.
    """
    model = uncertainty_models(params, robust, reading=reading) if robust else None
    d = design_pdc(model, epsilon=epsilon, rho=rho, reading=reading, decay=decay, solver=solver,
                   params=params)  # fmt: skip
    checks = check_design(d)
    doc: dict[str, Any] = {
        "state": ["theta", "theta_dot", "psi", "psi_dot"],
        "input": "u = u_r + u_l (N m), u = sum_i m_i(theta) G_i x",
        "G1": d.G[0].tolist(),
        "G2": d.G[1].tolist(),
        "P": d.P.tolist(),
        "status": d.status,
        "solver": d.solver,
        "epsilon": epsilon,
        "rho": rho,
        "robust": robust,
        "reading": reading,
        "decay": decay,
        "checks": checks,
        "book_G1": list(BOOK_G1),
        "book_G2": list(BOOK_G2),
    }
    if as_json:
        return doc, json.dumps(doc, indent=2)
    with np.printoptions(precision=5, suppress=False, linewidth=100):
        lines = [
            f"IT2 PDC design (Lemma 5.1/5.2), epsilon={epsilon:g}, rho={rho:g}, "
            f"reading={reading}, robust={robust}, decay={decay:g}",
            f"solver {d.solver}: status {d.status}",
            "state x = [theta, theta', psi, psi'], u = u_r + u_l = sum_i m_i G_i x (N m)",
            f"G1 = {d.G[0]}",
            f"G2 = {d.G[1]}",
            f"P =\n{d.P}",
            "checks (<0 ok for lmi_*/hurwitz/eps_ball/input, >0 for P_min/W_min): "
            + ", ".join(f"{k}={v:.3g}" for k, v in checks.items()),
            f"book (Sec. 5.4, other units/sign, see docs/fuzzy.md): G1 = {list(BOOK_G1)}, "
            f"G2 = {list(BOOK_G2)}",
        ]
    return doc, "\n".join(lines)
