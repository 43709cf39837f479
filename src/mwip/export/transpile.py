"""Translate a scalar Python kernel into a C99 function: one source for the model equations.

The closed forms of (2.36) exist once, as :func:`mwip.models.reduced.f_g_terms` (NumPy on
arrays, compiled by Numba for the simulations). The C code for the robot is generated from the
same source: :func:`to_c_function` reads the function's syntax tree and writes it as C, with
every operation fully parenthesised in Python's own evaluation order, so the C arithmetic is
the same sequence of IEEE operations.

The accepted subset is what a scalar kernel needs and nothing more: a function whose body is
assignments of one name (or a tuple of names from a tuple) to an arithmetic expression, and a
final ``return`` of a tuple of expressions; expressions of names, numeric constants, ``+ - *
/``, unary minus, ``x ** 2`` / ``x ** 3`` (as products), and ``np.sin/np.cos/np.sqrt/abs``.
Anything else raises ``ValueError`` naming the construct, so an edit of the kernel that leaves
the subset is caught by the export tests rather than mistranslated.
"""

from __future__ import annotations

import ast
import inspect
import math
import textwrap
from collections.abc import Callable
from typing import Any

__all__ = ["to_c_function", "c_literal", "check_constant", "CONSTANT_RANGE"]

_FUNCS = {"sin": "SIN", "cos": "COS", "sqrt": "SQRT", "abs": "FABS", "fabs": "FABS"}
_OPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/"}


#: The magnitudes a nonzero exported constant may have, by precision: at least the smallest
#: normal number and at most the square root of the largest (a constant below would be
#: flushed or truncated to zero, one above overflows -- in a literal, ``-Werror`` fails the
#: float build -- or does in the first product with another constant).
CONSTANT_RANGE = {"float": (1.1754944e-38, 1.8e19), "double": (2.2250738585072014e-308, 1.3e154)}


def check_constant(x: float, precision: str = "double") -> str | None:
    """Why ``x`` cannot be a C constant of ``precision`` (see :data:`CONSTANT_RANGE`), or
    ``None`` when it can."""
    lo, hi = CONSTANT_RANGE[precision]
    if not math.isfinite(x):
        return f"the non-finite constant {x!r} cannot be written to C"
    if abs(x) > hi or (x != 0 and abs(x) < lo):
        return (f"the constant {x:.6g} is outside what a {precision} C constant may hold "
                f"(0 or {lo:.3g} <= |x| <= {hi:.3g})")  # fmt: skip
    return None


def c_literal(x: float, precision: str = "double") -> str:
    """A C floating literal that round-trips ``x`` (17 significant digits; ``f`` for float).
    A constant outside :data:`CONSTANT_RANGE` (or not finite) is a ``ValueError``."""
    why = check_constant(float(x), precision if precision in CONSTANT_RANGE else "double")
    if why is not None:
        raise ValueError(why)
    text = repr(float(x))
    if "." not in text and "e" not in text:
        text += ".0"
    return text + ("f" if precision == "float" else "")


class _Expr(ast.NodeVisitor):
    def __init__(self, precision: str) -> None:
        self.precision = precision

    def generic_visit(self, node: ast.AST) -> str:
        raise ValueError(f"cannot translate {type(node).__name__} to C: {ast.unparse(node)!r}")

    def visit_Name(self, node: ast.Name) -> str:
        return node.id

    def visit_Constant(self, node: ast.Constant) -> str:
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            raise ValueError(f"cannot translate the constant {node.value!r} to C")
        return c_literal(float(node.value), self.precision)

    def visit_UnaryOp(self, node: ast.UnaryOp) -> str:
        if isinstance(node.op, ast.USub):
            return f"(-{self.visit(node.operand)})"
        if isinstance(node.op, ast.UAdd):
            return self.visit(node.operand)
        return self.generic_visit(node)

    def visit_BinOp(self, node: ast.BinOp) -> str:
        if isinstance(node.op, ast.Pow):
            exp = node.right
            if isinstance(exp, ast.Constant) and isinstance(exp.value, int) and exp.value in (2, 3):
                base = self.visit(node.left)
                return "(" + " * ".join([base] * exp.value) + ")"
            return self.generic_visit(node)
        op = _OPS.get(type(node.op))
        if op is None:
            return self.generic_visit(node)
        return f"({self.visit(node.left)} {op} {self.visit(node.right)})"

    def visit_Call(self, node: ast.Call) -> str:
        fn = node.func
        name = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", None)
        if name not in _FUNCS or len(node.args) != 1 or node.keywords:
            return self.generic_visit(node)
        return f"MWIP_{_FUNCS[name]}({self.visit(node.args[0])})"


def to_c_function(
    fn: Callable[..., Any], name: str, precision: str = "double", real: str = "mwip_real"
) -> str:
    """C99 source of ``static void name(real args..., real *out...)`` for the scalar kernel
    ``fn``; its tuple return becomes output pointers named after the returned variables.

    >>> def k(a, b):
    ...     s = a * b
    ...     return s, -a
    >>> print(to_c_function(k, "k"))  # doctest: +NORMALIZE_WHITESPACE
    static void k(mwip_real a, mwip_real b, mwip_real *out0, mwip_real *out1)
    {
        const mwip_real s = (a * b);
        *out0 = s;
        *out1 = (-a);
    }
    """
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    func = tree.body[0]
    if not isinstance(func, ast.FunctionDef):
        raise ValueError(f"{fn.__name__} is not a plain function")
    expr = _Expr(precision)
    args = [a.arg for a in func.args.args]
    body = [s for s in func.body if not (isinstance(s, ast.Expr) and
                                         isinstance(s.value, ast.Constant))]  # fmt: skip
    lines: list[str] = []
    returned: list[str] | None = None
    for stmt in body:
        if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1:
            target = stmt.targets[0]
            if isinstance(target, ast.Name):
                lines.append(f"    const {real} {target.id} = {expr.visit(stmt.value)};")
                continue
            if isinstance(target, ast.Tuple) and isinstance(stmt.value, ast.Tuple):
                for t, v in zip(target.elts, stmt.value.elts, strict=True):
                    if not isinstance(t, ast.Name):
                        raise ValueError(f"cannot translate the target {ast.unparse(t)!r}")
                    lines.append(f"    const {real} {t.id} = {expr.visit(v)};")
                continue
        if isinstance(stmt, ast.Return) and isinstance(stmt.value, ast.Tuple):
            returned = [expr.visit(v) for v in stmt.value.elts]
            continue
        raise ValueError(f"cannot translate the statement {ast.unparse(stmt)!r} to C")
    if returned is None:
        raise ValueError(f"{fn.__name__} must end with 'return a, b, ...'")
    outs = [f"out{i}" for i in range(len(returned))]
    sig = ", ".join([f"{real} {a}" for a in args] + [f"{real} *{o}" for o in outs])
    lines += [f"    *{o} = {v};" for o, v in zip(outs, returned, strict=True)]
    return f"static void {name}({sig})\n{{\n" + "\n".join(lines) + "\n}"
