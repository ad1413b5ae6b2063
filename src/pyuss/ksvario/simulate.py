"""Serve a simulated KS VARIO as a PROFIBUS-DP slave: the entry point for `uss ksvario
simulate` and for a general `uss simulate --profile ksvario`.

`serve(...)` opens the line (a new `PtyPort` by default, or any transport URL of
`pyuss.transport.url`: a serial port or pyserial URL at 8E1, tcp://, tcp-listen://, bus://),
calls ``on_ready(device)`` with what a DP master must open (the pty's path, ``tcp://HOST:PORT``
with the port listened on for ``tcp-listen://HOST:0``, ``bus://HOST:PORT``, else the URL), and
answers the master until cancelled or ``stop`` is set. The coupler is created with the example
selection of the KS VARIO PROFIBUS-DP interface description 3.2 unless one is given.
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
from pyuss.transport.tcp import TcpServerTransport
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
        device = _device(line, port)
        if on_ready is not None:
            on_ready(device)
        await run_slave(slave, line, stop)
    finally:
        await line.close()


def _device(line: Transport, port: str | None) -> str:
    """What a master opens to reach the station on ``line``."""
    if isinstance(line, PtyPort):
        return line.device_path
    if isinstance(line, TcpServerTransport):
        return f"tcp://{line.host}:{line.port}"  # the port chosen for port 0
    url = port or ""
    return url.partition("?")[0] if url.lower().startswith("bus://") else url
