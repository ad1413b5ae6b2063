"""A reader that knows how long the telegram it awaits is waits for all of it at once
(`QueuedTransport.wait_bytes`): the virtual bus hands a telegram over in three pieces, and the
master takes an answer of a fixed layout in one wake-up instead of three, the pieces keeping
the line's end times."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from pyuss.bus import VirtualBus
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.protocol.layout import Layout
from pyuss.transport.base import Chunk

BAUD = 19200
TC = 11 / BAUD
DATA = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")


async def _drain(station: Any) -> list[Chunk]:
    chunks = []
    while (chunk := await station.read(0)) is not None:
        chunks.append(chunk)
    return chunks


async def test_a_reader_is_woken_once_the_whole_telegram_is_in() -> None:
    bus = VirtualBus(BAUD)
    async with bus.attach("sender") as sender, bus.attach("reader") as reader:
        start = time.monotonic() + 0.02
        await sender.write_at(DATA, start)
        await reader.wait_bytes(len(DATA), 5.0)
        chunks = await _drain(reader)
        assert b"".join(c.data for c in chunks) == DATA
        # handed over in pieces, each with the end of its last character on the line
        assert len(chunks) > 1
        end = start
        for chunk in chunks:
            end += len(chunk.data) * TC
            assert abs(chunk.timestamp - end) < 1e-6


async def test_the_wait_ends_at_its_timeout_or_when_the_station_closes() -> None:
    bus = VirtualBus(BAUD)
    async with bus.attach("sender") as sender, bus.attach("reader") as reader:
        await sender.write(DATA[:3])
        before = time.monotonic()
        await reader.wait_bytes(len(DATA), 0.05)
        assert time.monotonic() - before >= 0.05
        assert b"".join(c.data for c in await _drain(reader)) == DATA[:3]
        waiting = asyncio.ensure_future(reader.wait_bytes(len(DATA), 30.0))
        await asyncio.sleep(0.01)
        assert not waiting.done()
        await reader.close()
        async with asyncio.timeout(5.0):
            await waiting


async def test_the_master_takes_each_answer_in_one_wake_up() -> None:
    """Without the whole-telegram wait the master is woken by each of the three pieces of
    every answer: a read that waited and got a piece."""
    bus = VirtualBus(BAUD)
    layout = Layout(3, 2)
    async with simulated_drives(bus, [(3, "generic", layout), (4, "generic", layout)]):
        station = bus.attach("master")
        woken = 0
        read = station.read

        async def counting_read(timeout: float | None = None) -> Chunk | None:
            nonlocal woken
            chunk = await read(timeout)
            woken += chunk is not None and timeout != 0
            return chunk

        station.read = counting_read  # type: ignore[method-assign]
        async with Master(station, layout=layout) as master:
            master.drive(3)
            master.drive(4)
            await master.drive(4).read(52)
            woken = 0
            answers = sum(master.drive(a).diagnostics().answers for a in (3, 4))
            for _ in range(10):
                await master.drive(3).next_update()
            answers = sum(master.drive(a).diagnostics().answers for a in (3, 4)) - answers
        assert answers >= 18
        assert woken <= 2, f"woken {woken} times by pieces of {answers} answers"
