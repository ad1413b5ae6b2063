"""Serve a simulated KS VARIO as a PROFIBUS-DP slave: the entry point for `uss ksvario
simulate` and for a general `uss simulate --profile ksvario`.

`serve(...)` opens the line (a new `PtyPort` by default, or any transport URL of
`pyuss.transport.url`: a serial port or pyserial URL at 8E1, tcp://, bus://), calls
``on_ready(device)`` with the path a DP master must open, and answers the master until
cancelled. The coupler is created with the example selection of seed 003 3.2 unless one is
given.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from pyuss.ksvario.coupler import CacheSelection, Coupler
from pyuss.ksvario.dp.fdl import check_baud
from pyuss.ksvario.dp.server import run_slave
from pyuss.ksvario.dp.slave import DpSlave
from pyuss.transport.base import Transport
from pyuss.transport.pty import PtyPort
from pyuss.transport.url import open_transport


def dp_line(port: str | None = None, *, baud: int = 19200) -> Transport:
    """The line of a DP station or master, not opened yet: a new `PtyPort` when ``port`` is
    None, else the transport ``port`` names, serial ports with PROFIBUS characters (8E1).
    ``baud`` must be a PROFIBUS-DP rate the lines carry (`pyuss.ksvario.dp.fdl.check_baud`)."""
    check_baud(baud)
    if port is None:
        return PtyPort(baud=baud)
    return open_transport(port, baud=baud, parity="E", stopbits=1)


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
    line = dp_line(port, baud=baud)
    await line.open()
    try:
        device = line.device_path if isinstance(line, PtyPort) else port or ""
        if on_ready is not None:
            on_ready(device)
        await run_slave(slave, line, stop)
    finally:
        await line.close()
