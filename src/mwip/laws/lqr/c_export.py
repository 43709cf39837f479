"""C template of the LQR law (:mod:`mwip.laws.c_support`): ``u = -K (x - x_ref)``, in the kernel's
order of operations, from the packed parameters (:mod:`.packing`)."""

from __future__ import annotations

from mwip.laws.c_support import Writer
from mwip.laws.packing import PackedLaw

__all__ = ["generate"]


def generate(law: PackedLaw, w: Writer, prefix: str) -> tuple[list[str], str, str]:
    """``u = y[:6] @ gain + offset`` (Sec. 4.4.2)."""
    f = law.fields()
    gain, offset = f["gain"], f["offset"]  # (6, 2), (2,)
    consts = [w.arr("GAIN", gain), w.arr("OFFSET", offset)]
    step = f"""\
void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2])
{{
    int j, i;
    (void)s; (void)t;
    for (j = 0; j < 2; ++j) {{
        mwip_real acc = 0;
        for (i = 0; i < 6; ++i) acc += y[i] * GAIN[i][j];
        u[j] = acc + OFFSET[j];
    }}
}}"""
    init = f"void {prefix}_init({prefix}_state *s, const mwip_real y[8]) {{ (void)s; (void)y; }}"
    return [], "\n".join(consts) + "\n\n" + init + "\n\n" + step, "static"
