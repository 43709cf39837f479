"""C template of the adaptive super-twisting family (:mod:`mwip.laws.c_support`): (4.1),
(4.3)-(4.5), (4.7) and ASMC, in the kernel's order of operations, from the packed parameters
(:mod:`.packing`)."""

from __future__ import annotations

from mwip.laws.c_support import Writer, coef_args
from mwip.laws.packing import PackedLaw

__all__ = ["generate"]


def generate(law: PackedLaw, w: Writer, prefix: str) -> tuple[list[str], str, str]:
    """(4.1), (4.3)-(4.5), (4.7) (ASTA) or the ASMC baseline (``asmc``)."""
    f = law.fields()
    c = f["coef"]
    n = w.num
    l1, l2, l3 = f["lam"]
    ref = f["ref"]
    asmc = bool(f["asmc"])
    K, rate, G0 = f["K"], f["rate"], f["Gamma0"]
    # u_i = (-a_i + sta_i + extra_i) / b_i, sta_i = (-K_i) sqrt|s_i| sgn s_i (4.3), (4.7)
    extra = "(-s->Gamma[i]) * mwip_sgn(sg[i])" if asmc else "s->w[i]"
    advance_w = (
        ""
        if asmc
        else ("        s->w[i] = s->w[i] - (TS * s->Gamma[i]) * mwip_sgn(sg[i]); /* (4.4) */\n")
    )
    code = f"""\
static const mwip_real L1 = {n(l1)}, L2 = {n(l2)}, L3 = {n(l3)};
static const mwip_real KSTA[2] = {{{n(K[0])}, {n(K[1])}}};
static const mwip_real RATE[2] = {{{n(rate[0])}, {n(rate[1])}}};
static const mwip_real GAMMA0[2] = {{{n(G0[0])}, {n(G0[1])}}};
static const mwip_real EPS = {n(float(f['eps']))}, TS = {n(float(f['Ts']))};
static const mwip_real REF[4] = {{{", ".join(n(x) for x in ref)}}};

void {prefix}_init({prefix}_state *s, const mwip_real y[8])
{{
    int i;
    (void)y;
    for (i = 0; i < 2; ++i) {{ s->Gamma[i] = GAMMA0[i]; s->w[i] = 0; }}
}}

void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    int i;
    mwip_real f1, f2, f3, g1, g2, g3, sg[2], a[2], b[2], uab[2];
    (void)t;
    /* (4.1) and (4.10)-(4.11), as mwip.laws.asta.kernel.asta_terms */
    mwip_f_g({coef_args(w, c)}, y[1], y[3], y[4], y[5], &f1, &f2, &f3, &g1, &g2, &g3);
    sg[0] = y[4] + L1 * (y[1] - REF[1]) + L2 * (y[3] - REF[0]);
    sg[1] = (y[5] - REF[3]) + L3 * (y[2] - REF[2]);
    a[0] = f2 + L2 * f1 + L1 * y[4];
    a[1] = f3 + L3 * y[5];
    b[0] = g2 + L2 * g1;
    b[1] = g3;
    for (i = 0; i < 2; ++i) {{
        const mwip_real sta = ((-KSTA[i]) * MWIP_SQRT(MWIP_FABS(sg[i]))) * mwip_sgn(sg[i]);
        uab[i] = (((-a[i]) + sta) + {extra}) / b[i];
    }}
    u[0] = (mwip_real)0.5 * (uab[0] + uab[1]);
    u[1] = (mwip_real)0.5 * (uab[0] - uab[1]);
    for (i = 0; i < 2; ++i) {{ /* forward Euler over the sample: (4.4), then (4.5) */
        const mwip_real mag = MWIP_FABS(sg[i]);
{advance_w}        s->Gamma[i] = s->Gamma[i] + TS * (mag >= EPS ? RATE[i] * mag : (mwip_real)0);
    }}
}}"""
    return ["mwip_real Gamma[2]", "mwip_real w[2]"], code, "asmc" if asmc else "asta"
