"""The two readings of the damping coefficients printed in the book's tables (SPEC.md section 2).

The tables print ``Db``, ``Dw`` in N s/m, while (2.32) needs rotational coefficients in
N m s/rad:

- ``"units"`` (the default): the printed value times ``r**2``;
- ``"literal"``: the printed numbers taken as N m s/rad (the brief's earlier reading).

:func:`mwip.params.book_params` applies them. This module holds only the names, so that the
command line can offer them without loading NumPy.
"""

__all__ = ["DAMPING_READINGS"]

#: The damping readings of the book's tables, default first.
DAMPING_READINGS: tuple[str, ...] = ("units", "literal")
