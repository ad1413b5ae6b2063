"""The byte format between the virtual bus and its ``bus://`` stations in other processes.

The station opens a TCP connection and sends one JSON line, its hello:
``{"name": "m" | null, "echo": false, "listen_only": false, "timed": true, "hold": true}``. The
bus answers with one JSON line, ``{"ok": true, "name": "m", "baud": 19200, "timed": true,
"hold": true}`` or ``{"ok": false, "error": "..."}``. From then on the bus sends frames, each
the characters of one delivery (with ``"hold": true`` a run's first character when it ends and
the rest of the run when the run ends, `pyuss.bus.core.Segment.attach`)::

    timestamp  float64, big endian: the ideal end time of the last character (monotonic s)
    length     uint16: number of data bytes
    n_errors   uint16: number of flagged characters
    data       length bytes
    errors     n_errors x (uint16 position in data, uint8 LineError flags)

and the station sends what it puts on the line: raw bytes, or, when both sides said
``"timed": true``, send frames::

    start      float64, big endian: when the first character is to start (monotonic s);
               0 or a time already past: at once
    length     uint16: number of data bytes
    data       length bytes

A send frame lets a station keep a start pause or a response delay to the microsecond without
waking up at that moment: it hands its telegram over a little early, and the bus puts it on
the line at ``start`` (or when the station's previous characters have left the line, if
later). Nothing is put on the line before the bus received it, so the line stays causal; a
start more than `MAX_AHEAD` seconds ahead is a protocol error; a frame without data bytes puts
nothing on the line (and holds nothing back). A bus that does not answer
``"timed": true`` (an older one) gets raw bytes, and the station keeps its times itself.

A holding station may also say ``"hold_answer": true`` in its hello; a bus that answers the
same takes a send frame with no data bytes from it as the moment (``start``) by which the
first character of its next answer must reach it at the latest, and hands that answer over
whole where it ends before then (`pyuss.bus.core.Station.hold_answer`): a master sends one
after each request. A bus that does not answer it is sent none.

The hello is checked whole before the station is attached: ``name`` is a string or null (the
bus picks one), at most `MAX_NAME` printable characters without ``+``; the other keys, where
given, are ``true`` or ``false``. Any other value is refused with ``"ok": false`` and an error
naming the key; keys the bus does not know are left aside (a newer station asks for something
an older bus does not offer: the answer says what it does).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

from pyuss.errors import ConfigError, ProtocolError, cut
from pyuss.transport.base import LineError
from pyuss.userfile import json_depth

HEADER = struct.Struct(">dHH")
ERROR = struct.Struct(">HB")
SEND = struct.Struct(">dH")
#: Deliveries larger than this are cut into several frames.
MAX_DATA = 65535
MAX_AHEAD = 1.0
"""How far ahead (seconds) a send frame may ask for its start."""
MAX_NAME = 128
"""Characters of a station's name at most."""
MAX_HELLO = 4096
"""Bytes of a hello line (or of the bus's answer) at most."""
HELLO_FLAGS = ("echo", "listen_only", "timed", "hold", "hold_answer")
"""The yes/no keys of a hello."""


def check_name(name: object) -> str:
    """A station's name, or `ConfigError` saying what is wrong with it: a non-empty string of
    at most `MAX_NAME` printable characters without ``+`` (which joins colliding senders)."""
    if not isinstance(name, str) or not name:
        raise ConfigError(f"station name must be a non-empty string, not {cut(name)}")
    if len(name) > MAX_NAME:
        raise ConfigError(f"station name of {len(name)} characters: at most {MAX_NAME}")
    if "+" in name or not name.isprintable():
        raise ConfigError(f"station name {cut(name)}: printable characters only, and no '+'")
    return name


@dataclass(frozen=True, slots=True)
class Hello:
    """What a station asks for in its hello (see the module docstring)."""

    name: str | None = None
    echo: bool = False
    listen_only: bool = False
    timed: bool = False
    hold: bool = False
    hold_answer: bool = False


MAX_HELLO_DEPTH = 2
"""How deep brackets may nest in a hello: its object, and a list in it (none is used today)."""


def read_hello(line: bytes) -> Hello:
    """A station's hello line, checked whole (see the module docstring); `ConfigError` naming
    what is wrong."""
    if len(line) > MAX_HELLO:
        raise ConfigError(f"hello of {len(line)} bytes: at most {MAX_HELLO}")
    depth = json_depth(line.decode("latin-1"))  # brackets and quotes are ASCII
    if depth > MAX_HELLO_DEPTH:
        # checked here, not left to json: Python 3.13 parses any depth, 3.11 and 3.12 raise
        # RecursionError; a hello is one flat object on every version
        raise ConfigError(f"hello nested too deep: {depth} levels, at most {MAX_HELLO_DEPTH}")
    try:
        hello = json.loads(line)
    except RecursionError:
        raise ConfigError("hello nested too deep") from None
    except ValueError as exc:
        raise ConfigError(f"hello is no JSON: {exc}") from None
    if not isinstance(hello, dict):
        raise ConfigError(f"hello is not a JSON object: {cut(hello)}")
    name = hello.get("name")
    flags: dict[str, bool] = {}
    for key in HELLO_FLAGS:
        value = hello.get(key, False)
        if not isinstance(value, bool):
            raise ConfigError(f"hello: {key} must be true or false, not {cut(value)}")
        flags[key] = value
    return Hello(None if name is None else check_name(name), **flags)


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
        # Frames are cut from ``data`` itself when nothing is left over from before (the
        # usual case: the bus's frames come whole), else from the buffer it is added to.
        if self._buf:
            self._buf += data
            source: bytes | bytearray = self._buf
        else:
            source = data
        out: list[tuple[bytes, float, tuple[tuple[int, LineError], ...]]] = []
        end = len(source)
        pos = 0
        while end - pos >= HEADER.size:
            timestamp, length, count = HEADER.unpack_from(source, pos)
            start = pos + HEADER.size
            size = HEADER.size + length + count * ERROR.size
            if end - pos < size:
                break
            payload = bytes(source[start : start + length])
            pos += size
            if not count:
                out.append((payload, timestamp, ()))
                continue
            errors = []
            for i in range(count):
                where, flags = ERROR.unpack_from(source, start + length + i * ERROR.size)
                if where >= length:
                    self._keep(source, pos)
                    raise ProtocolError(f"bus frame flags position {where} beyond {length} bytes")
                errors.append((where, LineError(flags)))
            out.append((payload, timestamp, tuple(errors)))
        if pos < end or source is self._buf:  # (else nothing to keep: the frames came whole)
            self._keep(source, pos)
        return out

    def _keep(self, source: bytes | bytearray, pos: int) -> None:
        """Keep what follows ``source[:pos]`` (the frames taken) for the next feed."""
        if source is self._buf:
            del self._buf[:pos]
        elif pos < len(source):  # (else the buffer stays empty)
            self._buf = bytearray(source[pos:])


def encode_send(start: float, data: bytes) -> bytes:
    """A send frame (station to bus): ``data`` to start at ``start`` (0: at once)."""
    if len(data) <= MAX_DATA:  # a telegram: one frame
        return SEND.pack(start, len(data)) + data
    parts = []
    for i in range(0, max(len(data), 1), MAX_DATA):
        part = data[i : i + MAX_DATA]
        parts += [SEND.pack(start if i == 0 else 0.0, len(part)), part]
    return b"".join(parts)


class SendDecoder:
    """Cuts a station's stream of send frames back into ``(start, data)``."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[tuple[float, bytes]]:
        self._buf += data
        out = []
        while len(self._buf) >= SEND.size:
            start, length = SEND.unpack_from(self._buf)
            size = SEND.size + length
            if len(self._buf) < size:
                break
            if start != start or start in (float("inf"), float("-inf")):
                raise ProtocolError("send frame with a start time that is not a number")
            out.append((start, bytes(self._buf[SEND.size : size])))
            del self._buf[:size]
        return out
