"""Mutation check of the control-law kernels: does the equality test catch every sign flip?

For each kernel (src/mwip/laws/<family>/kernel.py for lqr, smc, tsmc, asta, fig53, and
src/mwip/observers/_hodo_kernel.py) every arithmetic operator and sign is flipped, one at a
time:

- binary ``+`` <-> ``-``, ``*`` <-> ``/``, ``**`` -> ``*`` (also in ``+=``-style updates);
- unary ``-x`` -> ``x``;
- a non-zero numeric constant ``c`` -> ``-c``;
- comparisons ``<`` <-> ``>``, ``<=`` <-> ``>=``.

Each mutant's source is executed as a fresh module and the mismatch functions of
tests/test_kernels.py (the kernel against its NumPy oracle on random, non-zero inputs; for
the fuzzy kernel also its batch FLS and its pairwise sum against NumPy's) are run on it; a
mutant is *killed* when a mismatch exceeds the test's tolerance or it raises.
Every mutant is compiled by numba as the real kernel is, without mwip's on-disk cache (it would
hand a mutant the real kernel's machine code), about a second each.

Usage::

    python benchmarks/mutate_kernels.py [--verbose] [--kernel laws/smc/kernel.py]

Prints one line per kernel (mutants, killed, survivors with their line and change) and exits
1 if any mutant survives. Score recorded in BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import ast
import copy
import sys
import time
import types
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KERNELS = {  # module file under src/mwip -> [(kernel function, mismatch function in test_kernels)]
    "laws/smc/kernel.py": [("smc_step", "smc_mismatch"), ("step", "smc_packed_mismatch")],
    "laws/tsmc/kernel.py": [("tsmc_step", "tsmc_mismatch"), ("step", "tsmc_packed_mismatch")],
    "laws/asta/kernel.py": [("asta_terms", "asta_mismatch"),
                            ("asta_sample", "asta_sample_mismatch"),
                            ("step", "asta_packed_mismatch")],
    "laws/lqr/kernel.py": [("lqr_law", "lqr_mismatch"), ("step", "lqr_packed_mismatch")],
    "fuzzy/_kernel.py": [("fls_batch", "fls_mismatch"), ("_pairwise", "pairwise_mismatch"),
                         ("pdc_weights_batch", "pdc_mismatch")],
    "laws/fig53/kernel.py": [("fig53_law", "fig53_mismatch"), ("step", "fig53_packed_mismatch")],
    "observers/_hodo_kernel.py": [("hodo_update", "hodo_mismatch")],
}  # fmt: skip
_BIN = {ast.Add: ast.Sub, ast.Sub: ast.Add, ast.Mult: ast.Div, ast.Div: ast.Mult,
        ast.Pow: ast.Mult}  # fmt: skip
_CMP = {ast.Lt: ast.Gt, ast.Gt: ast.Lt, ast.LtE: ast.GtE, ast.GtE: ast.LtE}


def _operands(tree: ast.AST) -> set[int]:
    """``id`` of the numeric constants that are arithmetic operands (of ``+ - * / **``, a
    comparison, ``min``/``max``), not array indices or loop bounds (flipping ``D[1, 0]`` to
    ``D[-1, 0]`` on a 2 x 2 array is the same element: no arithmetic sign)."""
    out: set[int] = set()
    for node in ast.walk(tree):
        kids: list[ast.AST] = []
        if isinstance(node, ast.BinOp):
            kids = [node.left, node.right]
        elif isinstance(node, ast.AugAssign):
            kids = [node.value]
        elif isinstance(node, ast.Compare):
            kids = [node.left, *node.comparators]
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") in ("min", "max"):
            kids = list(node.args)
        out |= {id(k) for k in kids if isinstance(k, ast.Constant)}
    return out


def _changes(node: ast.AST, operands: set[int]) -> list[str]:
    """The mutations of one node, described."""
    if isinstance(node, ast.BinOp | ast.AugAssign) and type(node.op) in _BIN:
        return [f"{type(node.op).__name__} -> {_BIN[type(node.op)].__name__}"]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return ["drop unary minus"]
    if (isinstance(node, ast.Constant) and id(node) in operands
            and isinstance(node.value, int | float) and not isinstance(node.value, bool)
            and node.value != 0):  # fmt: skip
        return [f"constant {node.value!r} -> {-node.value!r}"]
    if isinstance(node, ast.Compare):
        return [f"{type(op).__name__} -> {_CMP[type(op)].__name__}" for op in node.ops
                if type(op) in _CMP]  # fmt: skip
    return []


def _sites(tree: ast.AST) -> list[tuple[int, int, str]]:
    """``(node number in ast.walk order, change number, description)`` of every mutation."""
    operands = _operands(tree)
    return [
        (i, j, f"line {getattr(node, 'lineno', '?')}: {desc}")
        for i, node in enumerate(ast.walk(tree))
        for j, desc in enumerate(_changes(node, operands))
    ]


def _mutate(tree: ast.Module, where: int, which: int) -> ast.Module:
    """A copy of ``tree`` with change ``which`` applied to node number ``where``."""
    new = copy.deepcopy(tree)
    node = next(n for i, n in enumerate(ast.walk(new)) if i == where)
    if isinstance(node, ast.BinOp | ast.AugAssign):
        node.op = _BIN[type(node.op)]()
    elif isinstance(node, ast.UnaryOp):
        node.op = ast.UAdd()
    elif isinstance(node, ast.Constant):
        node.value = -node.value
    elif isinstance(node, ast.Compare):
        idx = [i for i, op in enumerate(node.ops) if type(op) in _CMP][which]
        node.ops[idx] = _CMP[type(node.ops[idx])]()
    return ast.fix_missing_locations(new)


def _load(tree: ast.Module, name: str, path: Path) -> types.ModuleType:
    mod = types.ModuleType(f"mutant_{name.replace('/', '_')}")
    mod.__file__ = str(path)
    # bounds checked: a mutated index (``a + 1`` -> ``a - 1`` on an unsigned index) raises
    # IndexError (a caught mutant) instead of reading outside the array
    src = ast.unparse(tree)
    import numba  # noqa: PLC0415

    import mwip.jit_cache as jc  # noqa: PLC0415 - after sys.path

    def plain(*args: object, **options: object) -> object:
        """numba.njit without the on-disk cache: numba keys a cached function by its file's
        path and time stamp, which a mutant shares with the real kernel, so a cached mutant
        would run the real kernel's machine code (and survive)."""
        if args and callable(args[0]) and len(args) == 1 and not options:
            return numba.njit(boundscheck=True)(args[0])
        return lambda fn: numba.njit(boundscheck=True, **options)(fn)

    real, jc.njit = jc.njit, plain  # type: ignore[assignment]
    try:
        exec(compile(src, str(path), "exec"), mod.__dict__)  # noqa: S102 - our own source
    finally:
        jc.njit = real  # type: ignore[assignment]
    return mod


def run(verbose: bool, only: str | None = None) -> int:
    """Mutate every kernel, run the equality checks; returns the number of survivors."""
    sys.path.insert(0, str(ROOT / "tests"))
    sys.path.insert(0, str(ROOT / "src"))
    import test_kernels  # noqa: PLC0415 - after sys.path

    survivors = 0
    for fname, pairs in KERNELS.items():
        if only is not None and fname != only:
            continue
        path = ROOT / "src" / "mwip" / fname
        tree = ast.parse(path.read_text())
        checks: list[tuple[str, Callable[..., float]]] = [
            (kname, getattr(test_kernels, mname)) for kname, mname in pairs
        ]

        def worst(mod: types.ModuleType, checks: list[tuple[str, Callable[..., float]]] = checks
                  ) -> float:  # fmt: skip
            return max(check(getattr(mod, kname)) for kname, check in checks)

        base = worst(_load(tree, fname, path))
        assert base < test_kernels.TOL, f"{fname}: the unmutated kernel fails ({base:.3g})"
        sites = list(_sites(tree))
        killed, alive = 0, []
        t0 = time.perf_counter()
        for where, which, desc in sites:
            try:
                err = worst(_load(_mutate(tree, where, which), fname, path))
                dead = not (err < test_kernels.TOL)
            except Exception:  # noqa: BLE001 - a crash is a caught mutant
                dead = True
            killed += dead
            if not dead:
                alive.append(desc)
            if verbose:
                print(f"  {fname} {desc}: {'killed' if dead else 'SURVIVED'}")
        survivors += len(alive)
        print(f"{fname}: {len(sites)} mutants, {killed} killed, {len(alive)} survived "
              f"({time.perf_counter() - t0:.1f} s)" + "".join(f"\n  survivor: {d}"
                                                          for d in alive))  # fmt: skip
    return survivors


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kernel", choices=sorted(KERNELS), help="only this kernel")
    ap.add_argument("--verbose", "-v", action="store_true", help="one line per mutant")
    args = ap.parse_args(argv)
    return 1 if run(args.verbose, args.kernel) else 0


if __name__ == "__main__":
    sys.exit(main())
