"""Ending a task of one's own without losing a cancellation of one's own.

The usual ``task.cancel()`` then ``with suppress(CancelledError): await task`` swallows the
caller's own cancellation when it comes while the task ends: the caller then goes on as if
nobody had asked it to stop (a transport's close inside a reconnect that was itself being
stopped kept reconnecting, and whatever waited for it waited for ever). `cancel_and_wait`
takes the task's end and raises the caller's cancellation; `stopping` tells code that takes a
``CancelledError`` of something it waits for whether the cancellation is its own.
"""

from __future__ import annotations

import asyncio
from typing import Any

__all__ = ["cancel_and_wait", "stopping"]


def stopping() -> bool:
    """Whether the running task was asked to stop (cancelled, not yet taken back)."""
    task = asyncio.current_task()
    return task is not None and task.cancelling() > 0


async def cancel_and_wait(
    task: asyncio.Task[Any], *, ignore: tuple[type[Exception], ...] = ()
) -> None:
    """Cancel ``task`` and wait until it has ended. Its ``CancelledError`` is taken, and so
    is an error of ``ignore`` it ended with (another is raised as it is); if the calling
    task was cancelled meanwhile, ``CancelledError`` is raised once ``task`` has ended."""
    task.cancel()
    try:
        await task
    except asyncio.CancelledError:
        if stopping():
            raise
    except ignore:
        pass
    if stopping():
        raise asyncio.CancelledError
