"""C template of the terminal sliding-mode law (:mod:`mwip.laws.c_support`): (4.30)-(4.32) with
(4.43), in the kernel's order of operations, from the packed parameters (:mod:`.packing`)."""

from __future__ import annotations

from mwip.laws.c_support import Writer, coef_args
from mwip.laws.packing import PackedLaw

__all__ = ["generate"]


def generate(law: PackedLaw, w: Writer, prefix: str) -> tuple[list[str], str, str]:
    """(4.30)-(4.32) with the cubics (4.43) fitted on the board at init (the packed cubics
    of a simulation are not used)."""
    f = law.fields()
    c = f["coef"]
    n = w.num
    sat = bool(f["sat"])
    Tf = float(f["Tf"])
    switch = "mwip_clip1(sv / PHI_SW)" if sat else "mwip_sgn(sv)"
    D, IDinv, C, Gam = f["D"], f["IDinv"], f["C"], f["Gamma"]
    refs = f["refs"]
    phi_line = f"static const mwip_real PHI_SW = {n(float(f['phi']))};" if sat else ""
    code = f"""\
static const mwip_real C[2] = {{{n(C[0])}, {n(C[1])}}};
static const mwip_real GAM[2] = {{{n(Gam[0])}, {n(Gam[1])}}};
static const mwip_real D[2][2] = {{{{{n(D[0, 0])}, {n(D[0, 1])}}}, {{{n(D[1, 0])}, {n(D[1, 1])}}}}};
static const mwip_real IDINV[2][2] = {{{{{n(IDinv[0, 0])}, {n(IDinv[0, 1])}}},
                                      {{{n(IDinv[1, 0])}, {n(IDinv[1, 1])}}}}};
static const mwip_real RATIO = {n(float(f['ratio']))}, TF = {n(Tf)};
static const mwip_real TF2 = {n(Tf**2)}, TF3 = {n(Tf**3)};
{phi_line}
static const mwip_real REFS[3] = {{{n(refs[0])}, {n(refs[1])}, {n(refs[2])}}};

void {prefix}_init({prefix}_state *s, const mwip_real y[8])
{{
    /* (4.43): cubics fitted to the first errors so that s(0) = 0; t = 0 at the first call */
    int j;
    const mwip_real e[2] = {{y[1] - REFS[0], y[2] - REFS[1] - REFS[2] * (mwip_real)0}};
    const mwip_real ed[2] = {{y[4], y[5] - REFS[2]}};
    for (j = 0; j < 2; ++j) {{
        s->cf[j][0] = e[j];
        s->cf[j][1] = ed[j];
        s->cf[j][2] = ((mwip_real)-3 * e[j]) / TF2 - ((mwip_real)2 * ed[j]) / TF;
        s->cf[j][3] = ((mwip_real)2 * e[j]) / TF3 + ed[j] / TF2;
    }}
    s->t0 = 0;
}}

void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    /* (4.30)-(4.32), as mwip.laws.tsmc.kernel.tsmc_step */
    int j;
    mwip_real f1, f2, f3, g1, g2, g3, F[2], e[2], ed[2], nt[2], wv[2], swv[2], k[2];
    mwip_real rhs0, rhs1, w0, w1;
    const mwip_real tau = t - s->t0;
    mwip_f_g({coef_args(w, c)}, y[1], y[3], y[4], y[5], &f1, &f2, &f3, &g1, &g2, &g3);
    F[0] = f2; F[1] = f3;
    e[0] = y[1] - REFS[0]; e[1] = (y[2] - REFS[1]) - REFS[2] * t;
    ed[0] = y[4]; ed[1] = y[5] - REFS[2];
    for (j = 0; j < 2; ++j) {{
        mwip_real a, ad, add, sv;
        if (tau > TF) {{
            a = ad = add = 0;
        }} else {{
            const mwip_real *cf = s->cf[j];
            a = ((cf[0] + cf[1] * tau) + cf[2] * (tau * tau)) + cf[3] * (tau * tau * tau);
            ad = (cf[1] + ((mwip_real)2 * cf[2]) * tau) + ((mwip_real)3 * cf[3]) * (tau * tau);
            add = (mwip_real)2 * cf[2] + ((mwip_real)6 * cf[3]) * tau;
        }}
        sv = ((ed[j] + C[j] * e[j]) - ad) - C[j] * a;
        swv[j] = {switch};
        nt[j] = ((F[j] + C[j] * ed[j]) - add) - C[j] * ad;
        wv[j] = ((((-F[j]) - C[j] * ed[j]) + add) + C[j] * ad);
    }}
    rhs0 = ((RATIO * MWIP_FABS(F[0]) + D[0][0] * MWIP_FABS(nt[0])) + D[0][1] * MWIP_FABS(nt[1]))
           + GAM[0];
    rhs1 = ((RATIO * MWIP_FABS(F[1]) + D[1][0] * MWIP_FABS(nt[0])) + D[1][1] * MWIP_FABS(nt[1]))
           + GAM[1];
    for (j = 0; j < 2; ++j) k[j] = IDINV[j][0] * rhs0 + IDINV[j][1] * rhs1;
    w0 = wv[0] - k[0] * swv[0];
    w1 = wv[1] - k[1] * swv[1];
    u[0] = ((mwip_real)0.5 * w0) / g2 + ((mwip_real)0.5 * w1) / g3;
    u[1] = ((mwip_real)0.5 * w0) / g2 - ((mwip_real)0.5 * w1) / g3;
}}"""
    return ["mwip_real cf[2][4]", "mwip_real t0"], code, "tsmc"
