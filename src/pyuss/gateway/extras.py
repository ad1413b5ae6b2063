"""Which library each face needs, and the one line that says how to install it.

The base install of pyuss is pyserial only; each face is an extra (``pip install
'pyuss[modbus]'``, ``[mqtt]``, ``[opcua]`` or ``[all]``). Each face's entry in the registry
(`pyuss.gateway.faces`) names its `Library` (imported from here too) and extra. `require` is
called before a face starts, so a missing or unsuitable library is one line naming the pip
install to run, before any port opens.
"""

from __future__ import annotations

import importlib
import importlib.metadata

from pyuss._lazy import not_installed
from pyuss.errors import ConfigError
from pyuss.gateway.faces import Library, faces

__all__ = ["Library", "MissingExtra", "require"]


class MissingExtra(ConfigError, ImportError):
    """A face's library is not installed, or not in the versions the face supports."""


def _version(text: str) -> tuple[int, int]:
    parts = []
    for item in text.split(".")[:2]:
        digits = "".join(ch for ch in item if ch.isdigit())
        parts.append(int(digits or 0))
    while len(parts) < 2:
        parts.append(0)
    return parts[0], parts[1]


def require(face: str) -> None:
    """Check that the library of ``face`` can be imported in a supported version (a face
    without a library, Modbus, needs nothing)."""
    spec = faces().get(face)
    if spec is None or spec.library is None:
        return
    library = spec.library
    module, dist, low, high = library.module, library.distribution, library.low, library.high
    install = spec.install
    try:
        importlib.import_module(module)
    except ImportError as exc:
        if not_installed(exc, module):
            raise MissingExtra(f"the {face} face needs {dist} ({exc}): {install}") from None
        raise MissingExtra(
            f"the {face} face needs {dist}, which is installed but fails to load: {exc}"
        ) from None
    try:
        version = _version(importlib.metadata.version(dist))
    except importlib.metadata.PackageNotFoundError:
        return
    if (low is not None and version < low) or (high is not None and version >= high):
        have = ".".join(map(str, version))
        want = f">={'.'.join(map(str, low or (0, 0)))},<{'.'.join(map(str, high or (99, 0)))}"
        raise MissingExtra(
            f"the {face} face needs {dist} {want}, this is {have}: {install} --upgrade"
        )
