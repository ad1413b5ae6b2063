"""Byte pipes. Every transport implements `pyuss.transport.base.Transport`.

- `SerialTransport`: serial ports through pyserial (any pyserial URL), RS-485 direction
  control, local-echo suppression, line errors where the port reports them.
- `PtyPort`: a pseudo-terminal pair; other programs open its ``device_path``.
- `TcpTransport` / `TcpServerTransport`: a serial line over TCP, client and server.
- `ReconnectingTransport`: re-opens a lost link with capped back-off.
- `open_transport(url, ...)`: picks one of these by URL.
"""

from pyuss.transport.base import Chunk, LineError, Transport
from pyuss.transport.pty import PtyPort
from pyuss.transport.queued import (
    BAUD_RATES,
    BITS_PER_CHAR,
    EchoError,
    QueuedTransport,
    TransportStats,
    char_time,
    check_baud,
)
from pyuss.transport.reconnect import LinkDown, ReconnectingTransport
from pyuss.transport.serialport import RS485Mode, SerialTransport
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from pyuss.transport.url import open_transport

__all__ = [
    "BAUD_RATES",
    "BITS_PER_CHAR",
    "Chunk",
    "EchoError",
    "LineError",
    "LinkDown",
    "PtyPort",
    "QueuedTransport",
    "RS485Mode",
    "ReconnectingTransport",
    "SerialTransport",
    "TcpServerTransport",
    "TcpTransport",
    "Transport",
    "TransportStats",
    "char_time",
    "check_baud",
    "open_transport",
]
