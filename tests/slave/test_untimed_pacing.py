"""On a line without timing (a pty), the simulator's answer reaches the master when a real line
of its baud rate would have brought it: its last character's end, not its start."""

from __future__ import annotations

import asyncio
import contextlib
import os
import time
import tty

from pyuss.drive import SimulatedDrive
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.pty import PtyPort
from slave.harness import frame

BAUD = 9600
TC = 11 / BAUD
READ_P52 = frame(5, "1034 0000 0000 047E 0000")  # 14 characters, and so is the answer


async def test_the_answer_comes_when_its_last_character_would_have_ended() -> None:
    pty = PtyPort(baud=BAUD)
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
        await asyncio.sleep(0.05)
        sent = time.monotonic()
        os.write(fd, READ_P52)
        got = b""
        async with asyncio.timeout(5):
            while len(got) < len(READ_P52):
                with contextlib.suppress(BlockingIOError):
                    got += os.read(fd, 64)
                await asyncio.sleep(0.0005)
        came = time.monotonic()
    finally:
        stop.set()
        await serving
        server.close()
        os.close(fd)
        await pty.close()
    assert got[:3] == bytes.fromhex("02 0C 05")
    # request (14 characters) + start pause (2) + answer (14), as on a real 9600-baud line
    assert came - sent >= (14 + 2 + 14) * TC
