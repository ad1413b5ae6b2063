"""Packages that load their modules on first use still offer every name they list, the same
names the type checker sees (`pyuss._lazy`)."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "pyuss"
LAZY = ["pyuss.bus", "pyuss.drive", "pyuss.master", "pyuss.protocol"]


def _checked_names(package: str) -> set[str]:
    """The names imported under ``if TYPE_CHECKING:`` in the package's ``__init__``."""
    path = SRC / package.removeprefix("pyuss.") / "__init__.py"
    names: set[str] = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            for inner in node.body:
                if isinstance(inner, ast.ImportFrom):
                    names.update(alias.asname or alias.name for alias in inner.names)
    return names


@pytest.mark.parametrize("package", LAZY)
def test_every_listed_name_is_there(package: str) -> None:
    module = importlib.import_module(package)
    names = set(module.__all__)
    assert names == _checked_names(package)
    for name in names:
        assert getattr(module, name) is not None
    assert names <= set(dir(module))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        module.nothing  # noqa: B018


def test_a_module_of_a_package_does_not_load_its_siblings() -> None:
    code = "import sys, pyuss.drive.database; print('pyuss.drive.simulated' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
