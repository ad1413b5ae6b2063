"""Serve a simulated KS VARIO as a PROFIBUS-DP slave: the entry point for `uss ksvario
simulate` and for a general `uss simulate --profile ksvario`.

`serve(...)` opens the line (a new pty pair by default, or a serial port / pyserial URL), calls
``on_ready(device)`` with the path a DP master must open, and answers the master until
cancelled. The coupler is created with the example selection of seed 003 3.2 unless one is
given.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from pyuss.ksvario.coupler import CacheSelection, Coupler
from pyuss.ksvario.dp.line import PtyLine, SerialLine
from pyuss.ksvario.dp.server import run_slave
from pyuss.ksvario.dp.slave import DpSlave
from pyuss.transport.base import Transport


async def serve(
    *,
    station: int = 5,
    port: str | None = None,
    baud: int = 19200,
    channels: int = 30,
    coupler: Coupler | None = None,
    on_ready: Callable[[str], None] | None = None,
    stop: asyncio.Event | None = None,
) -> None:
    """Run the simulated coupler as DP slave ``station`` until cancelled or ``stop`` is set."""
    coupler = coupler or Coupler(channels=channels, selection=CacheSelection.example())
    slave = DpSlave(coupler, station)
    line: Transport
    if port is None:
        pty = PtyLine(baud)
        line = pty
    else:
        line = SerialLine(port, baud)
    await line.open()
    try:
        device = pty.device if port is None else port
        if on_ready is not None:
            on_ready(device)
        await run_slave(slave, line, stop)
    finally:
        await line.close()
