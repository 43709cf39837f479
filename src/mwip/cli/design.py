"""``mwip design lqr | hodo | it2``: gain designs (LQR, the disturbance observer's LMI of
Theorem 3.2, the IT2 PDC LMIs of Lemmas 5.1/5.2), printed as text or JSON."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from mwip.cli._common import DAMPING, in_range, params_value

if TYPE_CHECKING:  # NumPy and the designs load with the command that needs them
    import numpy as np

    from mwip.fuzzy.ts_model import Reading
    from mwip.params import Params

__all__ = ["design", "design_it2"]


@click.group()
def design() -> None:
    """Gain design: LQR, disturbance-observer LMIs, IT2 PDC LMIs."""


def _matrix_text(M: np.ndarray) -> str:
    return "\n".join("  [" + ", ".join(f"{v:10.4f}" for v in row) + "]" for row in M)


@design.command("lqr")
@click.option(
    "--Ts",
    "Ts",
    type=float,
    default=None,
    help="Design for this sample period (discrete Riccati on the ZOH model); "
    "default: the continuous (book's) gain, with the 5 ms gain alongside.",
)
@click.option(
    "--params",
    "params_name",
    default="nominal",
    show_default=True,
    help="real, nominal or a TOML file.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def design_lqr_cmd(Ts: float | None, params_name: str, as_json: bool) -> None:
    """LQR gain K (u = -K x, x = [theta, alpha, theta', v, alpha']) for the book's Q, R."""
    from mwip.laws.lqr.controller import BOOK_Q, BOOK_R, design_lqr

    if Ts is not None:
        in_range("--Ts", Ts, 0.0, 1.0)
    p = params_value(params_name, "--params")
    main_d = design_lqr(p, Ts=Ts)
    other = design_lqr(p, Ts=0.005) if Ts is None else design_lqr(p, Ts=None)

    def block(d: Any) -> dict[str, Any]:
        return {
            "Ts": d.Ts,
            "K": d.K.tolist(),
            ("poles" if d.Ts is None else "eigenvalues"): [
                [float(z.real), float(z.imag)] for z in d.poles
            ],
        }

    doc = {**block(main_d), "Q": BOOK_Q.tolist(), "R": BOOK_R.tolist(), "params": params_name,
           "state": ["theta", "alpha", "theta_dot", "v", "alpha_dot"], "input": ["u_r", "u_l"],
           "sampled" if Ts is None else "continuous": block(other)}  # fmt: skip
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(doc, indent=2))
        return
    for d in (main_d, other):
        kind = "continuous (book)" if d.Ts is None else f"sampled, Ts = {d.Ts:g} s"
        click.echo(f"K, {kind}, designed on {params_name} parameters:")
        click.echo(_matrix_text(d.K))
        if d.Ts is None:
            click.echo("  closed-loop poles: " + ", ".join(f"{z.real:.4g}" for z in d.poles))
        else:
            click.echo("  |eig(Ad - Bd K)|: " + ", ".join(f"{abs(z):.3g}" for z in d.poles))


@design.command("hodo")
@click.option("--order", "-n", type=int, required=True, help="Observer order n, in [1, 8].")
@click.option(
    "--ie",
    "ie_target",
    type=float,
    default=None,
    help="Prescribed impulse-to-energy gain: the slowest gains with ie <= IE "
    "(the book picks 0.3). Default: minimise ie, the LMI (3.36).",
)
@click.option(
    "--radius",
    type=float,
    default=None,
    help="Bound on |eig(D_n)| (rad/s) for the minimisation; without it (3.36) has "
    "no minimiser and the gains grow to the solver's tolerance.",
)
@click.option(
    "--solver",
    type=click.Choice(["CLARABEL", "SCS"]),
    default="CLARABEL",
    show_default=True,
    help="cvxpy solver.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def design_hodo_cmd(
    order: int, ie_target: float | None, radius: float | None, solver: str, as_json: bool
) -> None:
    """Observer gains L_1..L_n by the LMI of Theorem 3.2 (3.36), or for a prescribed ie."""
    from mwip.observers.design import ObserverDesignError, design_for_ie, solve_ie_lmi

    if not 1 <= order <= 8:
        raise click.BadParameter(f"must be in [1, 8], got {order}", param_hint="--order")
    if ie_target is not None:
        in_range("--ie", ie_target, 0.0, 1e6)
        if radius is not None:
            raise click.BadParameter("use either --ie or --radius", param_hint="--radius")
    if radius is not None:
        in_range("--radius", radius, 0.0, 1e9)
    try:
        if ie_target is not None:
            d = design_for_ie(order, ie_target, solver=solver)
        else:
            d = solve_ie_lmi(order, radius=radius, solver=solver)
    except ObserverDesignError as exc:
        raise click.ClickException(f"observer design failed: {exc}") from None
    import numpy as np

    eig = np.sort_complex(d.eigenvalues)
    doc = {
        "order": order,
        "problem": "prescribed ie" if ie_target is not None else "min ie (3.36)",
        "ie_target": ie_target,
        "radius": d.radius,
        "v": list(d.scalar_gains) if d.scalar_gains is not None else None,
        "L": [g.tolist() for g in d.gains],
        "ie": d.ie,
        "ie_lmi": d.ie_lmi,
        "eigenvalues": [[float(z.real), float(z.imag)] for z in eig],
        "solver": d.solver,
        "status": d.status,
    }
    note = None
    if ie_target is None and radius is None:
        note = (
            "(3.36) without a pole bound has no minimiser (ie -> 0 as the gains grow): "
            "these gains are set by the solver's tolerance; use --radius or --ie"
        )
        doc["note"] = note
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(doc, indent=2))
        return
    click.echo(f"order {order}, {doc['problem']}, solver {d.solver}: {d.status}")
    if d.scalar_gains is not None:
        click.echo("  L_i = v_i I3, v = (" + ", ".join(f"{v:.6g}" for v in d.scalar_gains) + ")")
    else:
        for i, g in enumerate(d.gains, 1):
            click.echo(f"  L_{i} =\n" + _matrix_text(g))
    click.echo(f"  ie = {d.ie:.6g} (recomputed from the gains, (3.39)-(3.41)); "
               f"LMI bound {d.ie_lmi:.6g}")  # fmt: skip
    uniq = sorted({(round(z.real, 6), round(abs(z.imag), 6)) for z in eig})
    click.echo("  eig(D_n): " + ", ".join(
        f"{re:.5g}" + (f" +- {im:.5g}j" if im else "") for re, im in uniq))  # fmt: skip
    if note:
        click.echo(f"  note: {note}")


@design.command("it2")
@click.option(
    "--epsilon",
    type=float,
    required=True,
    help="Radius of the initial-state ball of Lemma 5.2 (5.20), > 0.",
)
@click.option("--rho", type=float, required=True, help="Input bound of Lemma 5.2 (N m), > 0.")
@click.option(
    "--robust",
    type=float,
    default=None,
    help="Also stabilise +-ROBUST relative parameter variations (e.g. 0.35).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@DAMPING
def design_it2_cmd(
    epsilon: float, rho: float, robust: float | None, as_json: bool, damping: str
) -> None:
    """IT2 PDC balance gains G1, G2 from the LMIs of Lemma 5.1/5.2 (5.12)-(5.20), on the
    book's nominal set. Every design is checked (LMI residuals, vertex closed-loop
    stability); one that fails exits 1 with a one-line error, whatever the solver's status."""
    from mwip.fuzzy.pdc import PDCInfeasibleError
    from mwip.params import book_params

    in_range("--epsilon", epsilon, 0.0, 10.0)
    in_range("--rho", rho, 0.0, 1e6)
    if robust is not None:
        in_range("--robust", robust, 0.0, 0.9)
    try:
        _, text = design_it2(
            epsilon, rho, as_json=as_json, robust=robust, params=book_params("nominal", damping)
        )
    except PDCInfeasibleError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(text)


def design_it2(
    epsilon: float,
    rho: float,
    *,
    as_json: bool = False,
    robust: float | None = None,
    reading: Reading = "sector",
    decay: float = 0.0,
    solver: str = "CLARABEL",
    params: Params | None = None,
) -> tuple[dict[str, Any], str]:
    """The body of ``mwip design it2``: the IT2 PDC gains designed on ``params`` (the design
    model, default the book's nominal set, units damping reading) by the LMIs of Lemma 5.1
    with the input bound of Lemma 5.2 ((5.12), (5.19), (5.20)); ``robust`` (e.g. 0.35) adds
    the +-rel parameter models.

    Returns ``(doc, text)``: a JSON-friendly dict and the report (G1, G2, P, solver status,
    LMI checks, and the book's printed gains for comparison); ``text`` is JSON when
    ``as_json``. An infeasible problem, a solver failure or a solved point that fails its
    check (:func:`~mwip.fuzzy.pdc.verify_design`: LMI residuals, vertex closed-loop
    stability; whatever the solver's status) raises
    :class:`~mwip.fuzzy.pdc.PDCInfeasibleError`, whose one-line message the command prints
    (exit status 1).
    """
    import numpy as np

    from mwip.fuzzy.pdc import BOOK_G1, BOOK_G2, check_design, design_pdc, uncertainty_models
    from mwip.params import NOMINAL

    params = NOMINAL if params is None else params
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
        from mwip.io import json_text

        return doc, json_text(doc, indent=2)
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
