"""SlaveServer on a line that stops taking its answers: the drive goes on serving. The line is a
pty whose kernel buffer the client stops emptying (a socket's peer that stops reading is
disconnected by the TCP server instead: tests/transport)."""

from __future__ import annotations

import asyncio
import contextlib
import os

import pytest

from pyuss.drive import SimulatedDrive
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.pty import PtyPort
from slave.harness import frame

READ_P52 = frame(5, "1034 0000 0000 047E 0000")  # C 8.1 example 2
ANSWER_P52 = bytes.fromhex("02 0C 05 10 34 00 00 40 00 02 31 00 00 5C")


def _drain(fd: int) -> None:
    with contextlib.suppress(BlockingIOError):
        while os.read(fd, 65536):
            pass


async def _fill(pty: PtyPort) -> None:
    """Write until the kernel takes nothing more, also after a pause (it makes room late)."""
    while True:
        taken = 0
        while n := pty.write_nowait(bytes(4096)):
            taken += n
        if not taken and pty.stats.bytes_out:
            return
        await asyncio.sleep(0.05)


async def _read(fd: int, size: int) -> bytes:
    got = b""
    while len(got) < size:
        with contextlib.suppress(BlockingIOError):
            got += os.read(fd, size - len(got))
        await asyncio.sleep(0.005)
    return got


@pytest.mark.pty
async def test_an_answer_the_line_does_not_take_is_dropped_and_the_drive_keeps_serving() -> None:
    import tty

    pty = PtyPort(baud=187500, write_timeout=0.05)
    await pty.open()
    profile = get_profile("generic")
    drive = SimulatedDrive(profile.database(), now=pty.clock())
    engine = SlaveEngine(5, drive, profile, layout=Layout(3, 2), now=pty.clock())
    server = SlaveServer(pty, engine)
    stop = asyncio.Event()
    serving = asyncio.create_task(server.run(stop))
    fd = os.open(pty.device_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    tty.setraw(fd)
    try:
        await _fill(pty)  # the client has stopped reading: its buffer is full
        os.write(fd, READ_P52)
        async with asyncio.timeout(10):
            while server.stats.unsent == 0 and not serving.done():
                await asyncio.sleep(0.01)
        assert not serving.done(), serving.exception()
        # The client reads again: the drive still answers.
        _drain(fd)
        os.write(fd, READ_P52)
        async with asyncio.timeout(10):
            assert await _read(fd, len(ANSWER_P52)) == ANSWER_P52
        assert server.stats.answers == 1
    finally:
        os.close(fd)
        stop.set()
        await asyncio.wait_for(serving, 10)
        server.close()
        await pty.close()
