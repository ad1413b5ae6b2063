"""Stopping a task of one's own keeps one's own stop: a close that is itself cancelled while
the task it ends is still ending does not go on as if nobody had asked it to stop (a gateway
stopped while its line was being reopened kept reopening it, and its stop waited for ever)."""

from __future__ import annotations

import asyncio

import pytest

from pyuss._tasks import cancel_and_wait


async def _slow_to_end() -> None:
    try:
        await asyncio.sleep(10)
    except asyncio.CancelledError:
        await asyncio.sleep(0.05)  # it takes a moment to end, as a transport's close does
        raise


async def test_a_close_cancelled_while_its_task_ends_stops_too() -> None:
    child = asyncio.create_task(_slow_to_end())
    await asyncio.sleep(0)
    went_on: list[bool] = []

    async def closer() -> None:
        await cancel_and_wait(child)
        went_on.append(True)  # a reconnect going on to its next try

    task = asyncio.create_task(closer())
    await asyncio.sleep(0.01)  # the closer waits for the child to end
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert child.cancelled() and went_on == []


async def test_the_tasks_own_end_is_taken_and_its_error_raised() -> None:
    child = asyncio.create_task(_slow_to_end())
    await asyncio.sleep(0)
    await cancel_and_wait(child)  # its cancellation is taken
    assert child.cancelled()

    async def failing() -> None:
        try:
            await asyncio.sleep(10)
        except asyncio.CancelledError:
            raise RuntimeError("broke while ending") from None

    broken = asyncio.create_task(failing())
    await asyncio.sleep(0)
    with pytest.raises(RuntimeError, match="broke while ending"):
        await cancel_and_wait(broken)


async def test_a_task_that_ends_of_itself_while_its_closer_is_stopped_stops_the_closer() -> None:
    # the task takes its cancellation and returns (or ends with an error it is allowed to
    # end with): the closer, cancelled meanwhile, still stops
    async def returns() -> None:
        try:
            await asyncio.sleep(10)
        except asyncio.CancelledError:
            await asyncio.sleep(0.05)
            raise ConnectionError("closed") from None

    child = asyncio.create_task(returns())
    await asyncio.sleep(0)
    went_on: list[bool] = []

    async def closer() -> None:
        await cancel_and_wait(child, ignore=(ConnectionError,))
        went_on.append(True)

    task = asyncio.create_task(closer())
    await asyncio.sleep(0.01)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert went_on == []
