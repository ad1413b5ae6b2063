"""Quick construction of frozen dataclasses whose field values are known to be valid.

The values of the protocol (a telegram, a received event, a PKW area, the diagnostic
counters) are frozen, slotted dataclasses. Their ``__init__`` sets each field through
``object.__setattr__``, which a class with a ``__setattr__`` of its own (as frozen ones have)
makes slow: about a quarter of a microsecond a field, and some of them are made for every
telegram on the line. `builder` makes a function that fills the slots through their
descriptors instead - the same instance as the class call gives, in about half the time -
and runs no ``__post_init__``: it is for the paths that make values already checked (the
fields of a telegram the receiver framed, the words of a PKW area unpacked from one).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["builder"]

T = TypeVar("T")


def builder(cls: type[T]) -> Callable[..., T]:
    """A function ``build(*values)`` that makes an instance of the frozen, slotted dataclass
    ``cls`` from the values of all its fields, in their order, without ``__init__`` (see
    the module docstring): only for values that need no check and no conversion."""
    names = [field.name for field in dataclasses.fields(cls)]  # type: ignore[arg-type]
    namespace: dict[str, Any] = {"new": object.__new__, "cls": cls}
    for i, name in enumerate(names):
        namespace[f"set{i}"] = cls.__dict__[name].__set__  # the slot's member descriptor
    values = ", ".join(f"v{i}" for i in range(len(names)))
    fill = "".join(f"    set{i}(obj, v{i})\n" for i in range(len(names)))
    exec(f"def build({values}):\n    obj = new(cls)\n{fill}    return obj\n", namespace)
    build: Callable[..., T] = namespace["build"]
    build.__qualname__ = f"builder({cls.__qualname__})"
    return build
