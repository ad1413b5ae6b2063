"""The master on a line that is lost and reopened (a reconnecting TCP line whose server goes
away and comes back): it sends nothing meanwhile, refuses what needs the line at once and
changes nothing for it, tells `on_line` of the loss and the return, and goes on - in acyclic
mode too, where only a request would send a telegram."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest

from pyuss.bus import VirtualBus
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import TransportError
from pyuss.master import ACYCLIC, CYCLIC, Master
from pyuss.master.scheduler import Mode
from pyuss.master.testing import simulated_drives
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.telegram import Telegram
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.reconnect import LinkDown
from pyuss.transport.tcp import TcpServerTransport
from pyuss.transport.url import open_transport
from support.network import free_port
from support.waiting import eventually

BAUD = 38400


@contextlib.asynccontextmanager
async def _drive_on_tcp(port: int, seen: list[int]) -> AsyncIterator[None]:
    """Drive 5 (generic, 3,2) on a TCP line at ``port`` for the block; ``seen`` gets the
    control word of every telegram it takes."""
    line = TcpServerTransport("127.0.0.1", port, baud=BAUD)
    await line.open()
    engine = SlaveEngine(
        5, SimulatedDrive.from_profile("generic"), get_profile("generic"), layout=Layout(3, 2)
    )
    handle = engine.handle

    def taking(telegram: Telegram, now: float) -> Telegram | None:
        seen.append(Layout(3, 2).unpack(telegram.data).pzd[0])
        return handle(telegram, now)

    engine.handle = taking  # type: ignore[method-assign]
    stop = asyncio.Event()
    task = asyncio.create_task(SlaveServer(line, engine).run(stop))
    try:
        yield
    finally:
        stop.set()
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        await line.close()


@pytest.mark.parametrize("mode", [CYCLIC, ACYCLIC])
async def test_nothing_goes_out_while_the_line_is_down_and_the_master_goes_on(mode: Mode) -> None:
    port = free_port()
    seen: list[int] = []
    told: list[TransportError | None] = []
    transport = open_transport(f"tcp://127.0.0.1:{port}", baud=BAUD, reconnect=True)
    master = Master(transport, layout="3,2", mode=mode)
    master.on_line(told.append)
    drive = master.drive(5)
    try:
        async with _drive_on_tcp(port, seen):
            await master.start()
            await drive.control_word(0x047E)
            assert master.online
        await eventually(lambda: not master.online, what="the line down")  # its server gone
        with pytest.raises(LinkDown, match="not sent"):
            await drive.control_word(0x047F)  # refused at once
        assert drive.control == 0x047E  # and nothing changed for it
        assert isinstance(told[-1], LinkDown) and master.lost is None
        assert drive.not_sending
        with pytest.raises(LinkDown):
            await drive.read(52)
        seen.clear()
        async with _drive_on_tcp(port, seen):
            await eventually(lambda: master.online, timeout=30, what="the line back")
            assert told[-1] is None
            status = await master.exchange(5, timeout=5)
            assert status.address == 5 and not drive.not_sending
            assert set(seen) == {0x047E}  # what was in force; nothing asked while it was down
    finally:
        await master.close()


async def test_a_reconnecting_bus_station_keeps_its_timed_sends() -> None:
    # the gateway opens bus:// reconnecting by default: the master still hands each telegram
    # over with its start time (docs/bus.md "Timed sends"), and a drive answers through it
    bus = VirtualBus(BAUD)
    try:
        host, port = await bus.serve_tcp(framed=True)
        async with simulated_drives(bus, [(5, "generic", Layout(3, 2))]):
            transport = open_transport(f"bus://{host}:{port}", baud=BAUD, reconnect=True)
            async with Master(transport, layout="3,2") as master:
                assert master.wire.write_at is not None
                assert await master.drive(5).read(52) == 16384
    finally:
        await bus.close()
