"""C template of the sliding-mode family (:mod:`mwip.laws.c_support`): (3.49)-(3.50) and the
observer (3.20)-(3.23), in the kernel's order of operations, from the packed parameters
(:mod:`.packing`)."""

from __future__ import annotations

import numpy as np

from mwip.laws.c_support import Writer, coef_args
from mwip.laws.packing import PackedLaw

__all__ = ["generate"]


#: Hold codes (:data:`mwip.core.HOLD_CODES`) by number.
_HOLDS = {0: "start", 1: "end", 2: "trapezoid"}


def _observer_parts(f: dict[str, np.ndarray], w: Writer, c: np.ndarray
                    ) -> tuple[list[str], str, str, str]:  # fmt: skip
    """State fields, constants, init and update code of the observer (3.20)-(3.23) (exact
    sampled form) from the packed ``Phi``, ``Gamma``, ``obs_Ts`` and ``hold``."""
    k = int(f["m"])
    fields = [f"mwip_real z[{k}]", "mwip_real q_prev[3]", "mwip_real qd_prev[3]",
              "mwip_real u_prev[2]", "int has_u"]  # fmt: skip
    consts = "\n".join(
        [
            w.arr("PHI", f["Phi"]),
            w.arr("GAMMA_OBS", f["Gamma"]),
            f"#define OBS_K {k}",
            f"static const mwip_real OBS_TS = {w.num(float(f['obs_Ts']))};",
        ]
    )
    init = """\
    for (i = 0; i < OBS_K; ++i) s->z[i] = 0;
    for (i = 0; i < 3; ++i) { s->q_prev[i] = y[i]; s->qd_prev[i] = y[3 + i]; }
    s->has_u = 0;"""
    args = coef_args(w, c)
    model = {
        "end": "model(y[1], y[3], y[4], y[5], uA, uB, f);",
        "start": "model(s->q_prev[1], s->qd_prev[0], s->qd_prev[1], s->qd_prev[2], uA, uB, f);",
        "trapezoid": (
            "model(s->q_prev[1], s->qd_prev[0], s->qd_prev[1], s->qd_prev[2], uA, uB, fa);\n"
            "        model(y[1], y[3], y[4], y[5], uA, uB, fb);\n"
            "        for (i = 0; i < 3; ++i) f[i] = (mwip_real)0.5 * (fa[i] + fb[i]);"
        ),
    }[_HOLDS[int(f["hold"])]]
    update = f"""\
    if (s->has_u) {{ /* (3.20)-(3.23) over the sample just ended: z <- Phi z + Gamma d */
        mwip_real f[3], fa[3], fb[3], d[3], zn[OBS_K];
        const mwip_real uA = s->u_prev[0] + s->u_prev[1], uB = s->u_prev[0] - s->u_prev[1];
        (void)fa; (void)fb;
        {model}
        for (i = 0; i < 3; ++i) d[i] = (y[3 + i] - s->qd_prev[i]) / OBS_TS - f[i];
        for (i = 0; i < OBS_K; ++i) {{
            mwip_real acc = 0, acc2 = 0;
            for (j = 0; j < OBS_K; ++j) acc += s->z[j] * PHI[i][j];
            for (j = 0; j < 3; ++j) acc2 += d[j] * GAMMA_OBS[i][j];
            zn[i] = acc + acc2;
        }}
        for (i = 0; i < OBS_K; ++i) s->z[i] = zn[i];
        for (i = 0; i < 3; ++i) {{ s->q_prev[i] = y[i]; s->qd_prev[i] = y[3 + i]; }}
    }}
    for (i = 0; i < 3; ++i) tau[i] = s->z[i];"""
    model_fn = f"""\
/* F + G [u_A, u_B] of (2.36) on the nominal model */
static void model(mwip_real th, mwip_real psid, mwip_real thd, mwip_real ald, mwip_real uA,
                  mwip_real uB, mwip_real out[3])
{{
    mwip_real f1, f2, f3, g1, g2, g3;
    mwip_f_g({args}, th, psid, thd, ald, &f1, &f2, &f3, &g1, &g2, &g3);
    out[0] = f1 + g1 * uA;
    out[1] = f2 + g2 * uA;
    out[2] = f3 + g3 * uB;
}}"""
    return fields, consts + "\n\n" + model_fn, init, update


def generate(law: PackedLaw, w: Writer, prefix: str) -> tuple[list[str], str, str]:
    """(3.49)-(3.50), with the observer (3.20)-(3.23) when the law has one (``m > 0``)."""
    f = law.fields()
    c = f["coef"]
    l1, l2, l3, l4 = f["lam"]
    sat = bool(f["sat"])
    fields: list[str] = []
    consts, init_obs, update = "", "", "    for (i = 0; i < 3; ++i) tau[i] = 0;"
    if int(f["m"]) > 0:
        fields, consts, init_obs, update = _observer_parts(f, w, c)
    switch = ("w1 = mwip_clip1(s1 / PHI_SW); w2 = mwip_clip1(s2 / PHI_SW);" if sat
              else "w1 = mwip_sgn(s1); w2 = mwip_sgn(s2);")  # fmt: skip
    n = w.num
    phi_line = f"static const mwip_real PHI_SW = {n(float(f['phi']))};" if sat else ""
    keep_u = ("    for (i = 0; i < 2; ++i) s->u_prev[i] = u[i];\n    s->has_u = 1;"
              if fields else "")  # fmt: skip
    code = f"""\
{consts}
static const mwip_real L1 = {n(l1)}, L2 = {n(l2)}, L3 = {n(l3)}, L4 = {n(l4)};
static const mwip_real K1 = {n(float(f['K1']))}, K2 = {n(float(f['K2']))};
{phi_line}
static const mwip_real Q1D = {n(float(f['q1d_dot']))}, Q3D = {n(float(f['q3d']))};

void {prefix}_init({prefix}_state *s, const mwip_real y[8])
{{
    int i;
    (void)i; (void)s; (void)y;
{init_obs}
}}

void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    int i, j;
    mwip_real tau[3], f1, f2, f3, g1, g2, g3, s1, s2, w1, w2, uA, uB;
    (void)j; (void)s;
{update}
    /* (3.49)-(3.50), as mwip.laws.smc.kernel.smc_step */
    mwip_f_g({coef_args(w, c)}, y[1], y[3], y[4], y[5], &f1, &f2, &f3, &g1, &g2, &g3);
    s1 = y[4] + L1 * y[1] + L2 * (y[0] - Q1D * t) + L3 * (y[3] - Q1D);
    s2 = y[5] + L4 * (y[2] - Q3D);
    {switch}
    uA = ((((((-f2) - L3 * f1) - L1 * y[4]) - L2 * (y[3] - Q1D)) - tau[1]) - L3 * tau[0]
          - K1 * w1) / (g2 + L3 * g1);
    uB = ((((-f3) - L4 * y[5]) - tau[2]) - K2 * w2) / g3;
    u[0] = (mwip_real)0.5 * (uA + uB);
    u[1] = (mwip_real)0.5 * (uA - uB);
{keep_u}
}}"""
    return fields, code, "smc"
