"""Package attributes imported on first use (PEP 562), so that ``import mwip`` and the CLI's
start-up pay only for what a command uses (issue 18: ``mwip --help`` in under 0.3 s; a plain
``simulate`` without SciPy, cvxpy or matplotlib).

A package lists its public names and the module each lives in::

    __getattr__, __dir__ = exports(__name__, {"Twin": "mwip.hardware.twin", ...})

``from package import Twin`` then imports ``mwip.hardware.twin`` at that moment. Type
checkers do not follow ``__getattr__``; such packages repeat the imports under
``typing.TYPE_CHECKING``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["exports"]


def exports(
    package: str, names: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` whose attribute ``name`` is
    ``names[name]``'s attribute of the same name, or the module ``names[name]`` itself when
    that is ``package.name`` (a submodule), imported when first asked for."""
    table = dict(names)

    def __getattr__(name: str) -> Any:
        try:
            module = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        mod = importlib.import_module(module)
        value = mod if module == f"{package}.{name}" else getattr(mod, name)
        import sys

        setattr(sys.modules[package], name, value)  # later lookups skip this function
        return value

    def __dir__() -> list[str]:
        import sys

        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__
