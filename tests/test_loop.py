"""`pyuss.loop`: event loops with microsecond timers and precise waits on any loop."""

from __future__ import annotations

import asyncio
import os
import selectors
import time

import pytest

from pyuss import loop as fine


def test_a_fine_loop_waits_on_epoll_with_select_and_is_known_as_fine() -> None:
    async def inside() -> bool:
        return fine.fine_timers()

    assert fine.run(inside()) is True
    with asyncio.Runner(loop_factory=asyncio.SelectorEventLoop) as runner:
        assert runner.run(inside()) is False  # asyncio's own loop sleeps in milliseconds
    loop = fine.new_event_loop(least_slack=False)
    try:
        assert fine.fine_timers(loop)
        if hasattr(selectors, "EpollSelector"):
            assert isinstance(loop._selector, selectors.EpollSelector)  # type: ignore[attr-defined]
    finally:
        loop.close()


def test_a_fine_loop_still_serves_descriptors_while_it_sleeps() -> None:
    async def main() -> bytes:
        read, write = os.pipe()
        got: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        asyncio.get_running_loop().add_reader(read, lambda: got.set_result(os.read(read, 10)))
        asyncio.get_running_loop().call_later(0.02, os.write, write, b"x")
        try:
            async with asyncio.timeout(5):
                return await got  # woken by the pipe, not by a timer
        finally:
            asyncio.get_running_loop().remove_reader(read)
            os.close(read)
            os.close(write)

    assert fine.run(main()) == b"x"


@pytest.mark.parametrize("kind", ["fine", "asyncio"])
def test_sleep_until_never_returns_early_on_any_loop(kind: str) -> None:
    async def main() -> list[float]:
        late = []
        for step in (0.0001, 0.0007, 0.003):
            target = time.monotonic() + step
            await fine.sleep_until(target, time.monotonic)
            late.append(time.monotonic() - target)
        await fine.sleep_until(time.monotonic() - 1, time.monotonic)  # past: at once
        return late

    factory = fine.new_event_loop if kind == "fine" else asyncio.SelectorEventLoop
    with asyncio.Runner(loop_factory=factory) as runner:
        assert all(late >= 0 for late in runner.run(main()))


def test_installed_makes_asyncio_run_use_fine_loops_for_a_while() -> None:
    async def inside() -> bool:
        return fine.fine_timers()

    policy = asyncio.get_event_loop_policy()
    with fine.installed(least_slack=False):
        assert asyncio.run(inside()) is True
    assert asyncio.get_event_loop_policy() is policy
