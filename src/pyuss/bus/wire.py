"""The byte format between the virtual bus and its ``bus://`` stations in other processes.

The station opens a TCP connection and sends one JSON line, its hello:
``{"name": "m" | null, "echo": false, "listen_only": false}``. The bus answers with one JSON
line, ``{"ok": true, "name": "m", "baud": 19200}`` or ``{"ok": false, "error": "..."}``.
From then on the station sends raw bytes (what it puts on the line), and the bus sends
frames, each the characters of one delivery::

    timestamp  float64, big endian: the ideal end time of the last character (monotonic s)
    length     uint16: number of data bytes
    n_errors   uint16: number of flagged characters
    data       length bytes
    errors     n_errors x (uint16 position in data, uint8 LineError flags)
"""

from __future__ import annotations

import struct

from pyuss.errors import ProtocolError
from pyuss.transport.base import LineError

HEADER = struct.Struct(">dHH")
ERROR = struct.Struct(">HB")
#: Deliveries larger than this are cut into several frames.
MAX_DATA = 65535


def encode_frame(timestamp: float, data: bytes, errors: tuple[tuple[int, LineError], ...]) -> bytes:
    if len(data) > MAX_DATA:
        raise ValueError("frame too long")
    parts = [HEADER.pack(timestamp, len(data), len(errors)), data]
    parts += [ERROR.pack(pos, int(flags)) for pos, flags in errors]
    return b"".join(parts)


class FrameDecoder:
    """Cuts the bus's byte stream back into deliveries."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[tuple[bytes, float, tuple[tuple[int, LineError], ...]]]:
        self._buf += data
        out = []
        while len(self._buf) >= HEADER.size:
            timestamp, length, count = HEADER.unpack_from(self._buf)
            size = HEADER.size + length + count * ERROR.size
            if len(self._buf) < size:
                break
            body = bytes(self._buf[HEADER.size : size])
            del self._buf[:size]
            payload = body[:length]
            errors = []
            for i in range(count):
                pos, flags = ERROR.unpack_from(body, length + i * ERROR.size)
                if pos >= length:
                    raise ProtocolError(f"bus frame flags position {pos} beyond {length} bytes")
                errors.append((pos, LineError(flags)))
            out.append((payload, timestamp, tuple(errors)))
        return out
