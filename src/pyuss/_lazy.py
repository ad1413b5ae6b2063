"""Package namespaces that import their modules on first use (PEP 562).

``from pyuss.drive import SimulatedDrive`` works as before, but importing ``pyuss.drive.database``
no longer loads the whole drive simulator with it: a command starts with the modules it uses.
Each package lists its names by module for `lazy_exports` and imports them under
``TYPE_CHECKING`` for the type checker (a test keeps the two lists equal).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

__all__ = ["lazy_exports", "not_installed"]


def lazy_exports(
    package: str, names: Mapping[str, Sequence[str]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``, whose public ``names`` live in the
    modules given (``{"pyuss.drive.database": ("ParameterDatabase", ...)}``)."""
    where = {name: module for module, members in names.items() for name in members}
    namespace = importlib.import_module(package).__dict__

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *where})

    return __getattr__, __dir__


def not_installed(exc: ImportError, module: str) -> bool:
    """Whether ``exc``, raised by importing ``module``, says that ``module`` (or a package it
    belongs to) is not installed, rather than that it is installed and failed to import (a
    library of its own missing, a DLL that does not load): the user is then told to install
    it in the first case, and shown the error as it is in the second."""
    name = exc.name if isinstance(exc, ModuleNotFoundError) else None
    return name is not None and (module == name or module.startswith(name + "."))
