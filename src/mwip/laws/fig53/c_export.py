"""C template of the Fig. 5.3 fuzzy law (:mod:`mwip.laws.c_support`): the PDC balance law
(5.10) with the position and direction Mamdani FLSs of Section 5.3.2, IT2 or type 1, in the
kernel's order of operations, from the packed row and FLS blocks (:mod:`.packing`; the block
layout of :mod:`mwip.fuzzy._kernel`)."""

from __future__ import annotations

import numpy as np

from mwip.fuzzy.layout import HEAD
from mwip.laws.c_support import CExportError, Writer
from mwip.laws.packing import PackedLaw

__all__ = ["generate"]


def _fls_c(blk: np.ndarray, name: str, w: Writer) -> str:
    """One two-input Mamdani FLS block (min t-norm; BMM or type-1 centre of sets) as C:
    ``b * FLS(a1 x1, a2 x2)`` with the inputs saturated to the block's ranges."""
    nsets = int(blk[0])
    t1 = blk[1] != 0.0
    m_w, n_w, R1, R2, a1, a2, b = (float(v) for v in blk[2:HEAD])
    parts = []
    for k, (tag, R) in enumerate((("IN1", R1), ("IN2", R2))):
        o = HEAD + 5 * nsets * k
        c, la, lc, ua, uc = (blk[o + j * nsets : o + (j + 1) * nsets] for j in range(5))
        parts += [
            f"static const mwip_real {name}_{tag}_R = {w.num(R)};",
            w.arr(f"{name}_{tag}_C", c),
            w.arr(f"{name}_{tag}_LA", la), w.arr(f"{name}_{tag}_LC", lc),
            w.arr(f"{name}_{tag}_UA", ua), w.arr(f"{name}_{tag}_UC", uc),
        ]  # fmt: skip
    oy = HEAD + 10 * nsets
    parts.append(w.arr(f"{name}_Y", blk[oy : oy + nsets * nsets].reshape(nsets, nsets)))
    mem = lambda tag, i, which: (  # noqa: E731 - local template
        f"tri(x{i}, {name}_{tag}_{which}A[k], {name}_{tag}_C[k], {name}_{tag}_{which}C[k])"
    )
    out = "wa_hi" if t1 else "m * wa_lo + n * wa_hi"
    if b != 1.0:
        out = f"{w.num(b)} * ({out})"
    s1 = f"{w.num(a1)} * x1" if a1 != 1.0 else "x1"
    s2 = f"{w.num(a2)} * x2" if a2 != 1.0 else "x2"
    parts.append(f"""\
static mwip_real {name}(mwip_real x1, mwip_real x2)
{{
    mwip_real l1[{nsets}], u1[{nsets}], l2[{nsets}], u2[{nsets}];
    mwip_real sl = 0, sly = 0, su = 0, suy = 0;
    int k, i, j;
    x1 = mwip_min({name}_IN1_R, mwip_max(-{name}_IN1_R, {s1}));
    x2 = mwip_min({name}_IN2_R, mwip_max(-{name}_IN2_R, {s2}));
    for (k = 0; k < {nsets}; ++k) {{
        l1[k] = {mem("IN1", 1, "L")}; u1[k] = {mem("IN1", 1, "U")};
        l2[k] = {mem("IN2", 2, "L")}; u2[k] = {mem("IN2", 2, "U")};
    }}
    for (i = 0; i < {nsets}; ++i) {{
        for (j = 0; j < {nsets}; ++j) {{
            const mwip_real flo = mwip_min(l1[i], l2[j]), fhi = mwip_min(u1[i], u2[j]);
            sl += flo; sly += flo * {name}_Y[i][j];
            su += fhi; suy += fhi * {name}_Y[i][j];
        }}
    }}
    {{
        const mwip_real m = {w.num(m_w)}, n = {w.num(n_w)};
        const mwip_real wa_lo = sl > 0 ? sly / sl : (mwip_real)0;
        const mwip_real wa_hi = su > 0 ? suy / su : (mwip_real)0;
        (void)m; (void)n; (void)wa_lo;
        return {out};
    }}
}}""")
    return "\n".join(parts)


_TRI = """\
static mwip_real tri(mwip_real x, mwip_real a, mwip_real b, mwip_real c)
{
    /* triangular membership (feet a, c, apex b), as mwip.fuzzy.sets.triangle */
    const mwip_real rise = b > a ? (x - a) / (b - a) : (mwip_real)(x >= b);
    const mwip_real fall = c > b ? (c - x) / (c - b) : (mwip_real)(x <= b);
    return mwip_min(1, mwip_max(0, mwip_min(rise, fall)));
}"""


def generate(law: PackedLaw, w: Writer, prefix: str) -> tuple[list[str], str, str]:
    """Fig. 5.3: PDC (5.10) on ``theta - theta_off`` plus the direction FLS."""
    from mwip.fuzzy.ts_model import LOWER_HALF_WIDTH, THETA_VERTEX, UPPER_HALF_WIDTH

    if law.rows != 1:
        raise CExportError("a fuzzy controller with several rows (one per robot) cannot be "
                           "exported: build it for one robot")  # fmt: skip
    f = law.fields()
    row, fls = f["row"], f["fls"]
    c = int(row[0])
    kind = "t1" if c == 1 else "it2"
    n = w.num
    G = row[1:9].reshape(2, 4)
    p_d, alpha_d, r_nom = float(row[9]), float(row[10]), float(row[13])
    pos_on, dir_on = row[11] != 0.0, row[12] != 0.0
    weights = (
        """\
    {   /* Nie-Tan weights of Fig. 5.1, (5.8): normalised lower + upper memberships */
        const mwip_real th = mwip_min(TH_V, mwip_max(-TH_V, y[1]));
        const mwip_real lo1 = mwip_max(0, 1 - MWIP_FABS(th) / LW);
        const mwip_real up1 = mwip_max(0, 1 - MWIP_FABS(th) / UW);
        const mwip_real w0 = lo1 + up1, w1 = (1 - up1) + (1 - lo1), sum = w0 + w1;
        m[0] = w0 / sum; m[1] = w1 / sum;
    }"""
        if kind == "it2"
        else """\
    {   /* type-1: M1 the triangle at the middle of the footprint */
        const mwip_real a = MWIP_FABS(mwip_min(TH_V, mwip_max(-TH_V, y[1])));
        m[0] = mwip_max(0, 1 - a / ((mwip_real)0.5 * (LW + UW)));
        m[1] = 1 - m[0];
    }"""
    )
    targets = "\n".join(
        ([f"static const mwip_real R_NOM = {n(r_nom)}, P_D = {n(p_d)};"] if pos_on else [])
        + ([f"static const mwip_real ALPHA_D = {n(alpha_d)};"] if dir_on else []))  # fmt: skip
    blocks = "\n\n".join(([_fls_c(fls[c], "fls_pos", w)] if pos_on else [])
                         + ([_fls_c(fls[2 + c], "fls_dir", w)] if dir_on else []))  # fmt: skip
    tri = _TRI if (pos_on or dir_on) else ""
    code = f"""\
{tri}
{blocks}

{w.arr("G", G)}
static const mwip_real TH_V = {n(THETA_VERTEX)};
static const mwip_real LW = {n(LOWER_HALF_WIDTH)}, UW = {n(UPPER_HALF_WIDTH)};
{targets}

void {prefix}_init({prefix}_state *s, const mwip_real y[8]) {{ (void)s; (void)y; }}

void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    /* Fig. 5.3: PDC (5.10) on theta - theta_off plus the direction FLS (Section 5.3.2) */
    mwip_real m[2], x[4], theta_off = 0, u_a = 0, u_p = 0;
    int i, j;
    (void)s; (void)t;
{"    theta_off = fls_pos(R_NOM * y[0] - P_D, y[4]);" if pos_on else ""}
{"    u_a = fls_dir(y[2] - ALPHA_D, y[5]);" if dir_on else ""}
{weights}
    x[0] = y[1] - theta_off; x[1] = y[4]; x[2] = {"0" if pos_on else "y[0]"}; x[3] = y[3];
    for (i = 0; i < 2; ++i) {{
        mwip_real gx = 0;
        for (j = 0; j < 4; ++j) gx += G[i][j] * x[j];
        u_p += m[i] * gx;
    }}
    u_p = (mwip_real)0.5 * u_p;
    u[0] = u_p + u_a;
    u[1] = u_p - u_a;
}}"""
    return [], code, f"fig53-{kind}"
