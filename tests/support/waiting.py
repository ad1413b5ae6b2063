"""The one way the tests wait: for a condition, bounded, never asserting how long it took."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable


async def eventually(
    check: Callable[[], object], timeout: float = 15.0, *, what: str = "condition"
) -> None:
    """Wait (generously: a loaded machine) until ``check()`` is true; fail the test, naming
    ``what`` was awaited, if it is not within ``timeout`` seconds (a bound against hanging,
    not a timing that is asserted)."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not check():
        if loop.time() > end:
            raise AssertionError(f"{what} not reached within {timeout} s")
        await asyncio.sleep(0.01)


def eventually_sync(check: Callable[[], object], what: str, timeout: float = 30.0) -> None:
    """`eventually` for a test that runs no event loop of its own (the page's and a broker
    client's run on threads): wait until ``check()`` is true, fail naming ``what``."""
    end = time.monotonic() + timeout
    while not check():
        if time.monotonic() > end:
            raise AssertionError(f"{what} not reached within {timeout} s")
        time.sleep(0.05)
