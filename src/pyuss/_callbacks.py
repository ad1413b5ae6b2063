"""Callbacks kept in a list: adding one, with the function that removes it again, and calling
them all, each failure logged and none stopping the others.

Where the callbacks run for every answer on the line (a drive's process data), the caller loops
itself: a call more per answer is measured there (docs/bench.md).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import TypeVar

__all__ = ["add", "call_each"]

C = TypeVar("C")
V = TypeVar("V")


def add(callbacks: list[C], callback: C) -> Callable[[], None]:
    """Append ``callback`` to ``callbacks``; return a function that removes it (a second call
    of it removes nothing)."""
    callbacks.append(callback)

    def remove() -> None:
        if callback in callbacks:
            callbacks.remove(callback)

    return remove


def call_each(
    callbacks: Sequence[Callable[[V], object]],
    value: V,
    log: logging.Logger,
    failed: str,
    *args: object,
) -> None:
    """Call each of ``callbacks`` (as they are now: one may remove itself) with ``value``; a
    callback that raises is logged with ``failed % args`` and the traceback, and the others
    are still called."""
    for callback in list(callbacks):
        try:
            callback(value)
        except Exception:
            log.exception(failed, *args)
