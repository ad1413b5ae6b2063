"""Run a `DpSlave` on a line: read bytes, find FDL frames, answer them."""

from __future__ import annotations

import asyncio
import logging

from pyuss.errors import TransportError
from pyuss.ksvario.dp.fdl import FrameReceiver
from pyuss.ksvario.dp.slave import DpSlave
from pyuss.log import log_frame
from pyuss.transport.base import Transport

log = logging.getLogger("pyuss.ksvario.dp")


async def run_slave(slave: DpSlave, line: Transport, stop: asyncio.Event | None = None) -> None:
    """Serve ``slave`` on an opened ``line`` until ``stop`` is set or the line fails."""
    receiver = FrameReceiver()
    stop = stop or asyncio.Event()
    while not stop.is_set():
        try:
            chunk = await line.read(timeout=0.05)
        except TransportError:
            if stop.is_set():
                return
            raise
        now = line.clock()
        slave.tick(now)
        if chunk is None:
            continue
        for frame in receiver.feed(chunk.data):
            log_frame("rx", frame.encode() if frame.sd != 0xE5 else b"\xe5", chunk.timestamp)
            answer = slave.handle(frame, now)
            if answer is not None:
                await line.write(answer)
                log_frame("tx", answer, line.clock())
