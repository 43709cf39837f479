"""How the Fig. 5.3 fuzzy controller is laid out in arrays for its compiled kernel
(:mod:`mwip.laws.fig53.kernel`), without loading the compiler: the classes that build the
arrays (:mod:`mwip.laws.fig53.controller`, :mod:`mwip.fuzzy.mamdani`) import these, the kernel too.
"""

__all__ = ["HEAD", "ROW_WIDTH"]

#: Header length of an FLS block (``n, t1, m, nw, R1, R2, a1, a2, b``).
HEAD = 9
#: Columns of a Fig. 5.3 row: ``[kind (0 it2, 1 t1), G (8, row-major), p_d, alpha_d,
#: pos_on, dir_on, r_nom]``.
ROW_WIDTH = 14
