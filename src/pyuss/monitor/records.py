"""Capture records: what a capture file holds of each frame, in either format, and the base
of the writers (`pyuss.monitor.capture` picks the format; `pyuss.monitor.pcapng` and
`pyuss.monitor.jsonl` write and read them).

Each record (`CaptureRecord`) holds the frame (bytes, start and end time, direction, receive
fault), the flags of its exchange (`CaptureFlag`: no answer, late answer, ...) and the layout
the monitor decoded it with, with where that layout came from. In pcapng the record's fields
other than the bytes and the start time travel in a 20-byte pseudo-header in front of the
telegram (`PSEUDO_HEADER`, documented in docs/monitor.md and decoded by the dissector).

Times in files are Unix time (seconds): the writer adds ``epoch`` to the monitor's times.

Files are written to a temporary file next to the target and renamed into place on `close`
after an fsync; `discard` (or an error) removes the temporary file, so the target name only
ever holds a complete capture.
"""

from __future__ import annotations

import enum
import heapq
import itertools
import math
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from pyuss.atomicfile import AtomicWriter
from pyuss.errors import ConfigError
from pyuss.monitor.infer import LayoutChoice
from pyuss.monitor.model import Direction, Exchange, Frame, LayoutSource, Problem, telegram_in
from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import check_baud
from pyuss.transport.base import Chunk

__all__ = [
    "FAULT_CODES",
    "PSEUDO_HEADER",
    "PSEUDO_VERSION",
    "Capture",
    "CaptureFlag",
    "CaptureRecord",
    "CaptureWriter",
    "RecordWriter",
    "records_of",
]

PSEUDO_VERSION = 1
PSEUDO_HEADER = struct.Struct(">BBBBHBBIiI")
"""version, header length, direction, fault, flags, PKW count, PZD count, duration in
whole microseconds, response delay in microseconds (answers; ``NO_DELAY`` for none), the
nanoseconds of the duration beyond its whole microseconds (0..999). Readers take the header
length from byte 1: a 16-byte header (before the nanoseconds were added) is read as well."""
_SHORT_HEADER = 16
NS = 1_000_000_000
NO_FAULT = 0xFF
NO_LAYOUT = 0xFF
FAULT_CODES: dict[FaultKind, int] = {
    FaultKind.FRAMING: 0,
    FaultKind.OVERRUN: 1,
    FaultKind.PARITY: 2,
    FaultKind.NO_STX: 3,
    FaultKind.BCC: 4,
    FaultKind.RESIDUAL_TIME: 5,
    FaultKind.BAD_LGE: 6,
    FaultKind.BAD_ADR: 8,
}
"""The fault byte of the pseudo-header: a file-format code of its own (the dissector's table),
kept apart from the values of `FaultKind` so that captures stay readable across versions."""
_FAULT_KINDS = {code: kind for kind, code in FAULT_CODES.items()}
NO_DELAY = -(2**31)
_MAX_US = 2**32 - 1


class CaptureFlag(enum.IntFlag):
    """Flags of a captured frame (pseudo-header bytes 4..5, JSON ``flags``)."""

    NONE = 0
    GUESSED_DIRECTION = 0x0001
    """The direction comes from timing and position (2-wire line), not from the port."""
    UNSURE = 0x0002
    """The pairing of the exchange is a guess (see the exchange's ``unsure``)."""
    LAYOUT_GIVEN = 0x0004
    """The layout was given by the user."""
    LAYOUT_GUESSED = 0x0008
    """The layout is a guess (neither given nor clearly inferred)."""
    NO_ANSWER = 0x0010
    LATE_ANSWER = 0x0020
    EARLY_ANSWER = 0x0040
    WRONG_ADDRESS = 0x0080
    UNEXPECTED = 0x0100
    MIRROR = 0x0200
    LAYOUT = 0x0400
    """The net data do not fit the layout."""
    PORT_1 = 0x0800
    """Received on the second port (slave to master on a 4-wire line)."""


_PROBLEM_FLAGS = {
    Problem.NO_ANSWER: CaptureFlag.NO_ANSWER,
    Problem.LATE_ANSWER: CaptureFlag.LATE_ANSWER,
    Problem.EARLY_ANSWER: CaptureFlag.EARLY_ANSWER,
    Problem.WRONG_ADDRESS: CaptureFlag.WRONG_ADDRESS,
    Problem.UNEXPECTED: CaptureFlag.UNEXPECTED,
    Problem.MIRROR: CaptureFlag.MIRROR,
    Problem.LAYOUT: CaptureFlag.LAYOUT,
}


@dataclass(frozen=True, slots=True)
class CaptureRecord:
    """One frame of a capture; ``delay`` is the response delay of an answer (seconds)."""

    frame: Frame
    flags: CaptureFlag = CaptureFlag.NONE
    layout: LayoutChoice | None = None
    delay: float | None = None

    def pseudo_header(self) -> bytes:
        """The 20-byte pseudo-header that precedes the telegram bytes in pcapng."""
        f = self.frame
        pkw = pzd = NO_LAYOUT
        if self.layout is not None:
            pkw, pzd = self.layout.layout.pkw, self.layout.layout.pzd
        # the end as the writers stamp it: the rounded start plus the rounded duration is the
        # rounded end, so a replay measures the same delays to the nanosecond
        nanos = max(0, round(f.end * NS) - round(f.start * NS))
        duration, extra = min(_MAX_US, nanos // 1000), nanos % 1000
        delay = NO_DELAY
        if self.delay is not None:
            delay = max(NO_DELAY + 1, min(2**31 - 1, round(self.delay * 1e6)))
        return PSEUDO_HEADER.pack(
            PSEUDO_VERSION,
            PSEUDO_HEADER.size,
            int(f.direction),
            NO_FAULT if f.fault is None else FAULT_CODES[f.fault],
            int(self.flags),
            pkw,
            pzd,
            duration,
            delay,
            extra,
        )

    @classmethod
    def from_packet(cls, data: bytes, start: float, where: str) -> CaptureRecord:
        """Parse pseudo-header and telegram bytes; `ConfigError` naming ``where`` if bad."""
        if len(data) < 2 or data[0] != PSEUDO_VERSION or data[1] < _SHORT_HEADER:
            raise ConfigError(f"{where}: not a USS capture packet (pseudo-header version 1)")
        if len(data) < data[1]:
            raise ConfigError(f"{where}: packet shorter than its pseudo-header")
        head = bytes(data[: data[1]]).ljust(PSEUDO_HEADER.size, b"\0")
        _, size, direction, fault, flags, pkw, pzd, duration, delay, extra = (
            PSEUDO_HEADER.unpack_from(head)
        )
        if extra > 999:
            raise ConfigError(f"{where}: bad pseudo-header: {extra} ns beyond the microseconds")
        raw = bytes(data[size:])
        try:
            kind = None if fault == NO_FAULT else _FAULT_KINDS[fault]
            side = Direction(direction)
            layout = None
            if pkw != NO_LAYOUT:
                source = (
                    LayoutSource.GIVEN
                    if flags & CaptureFlag.LAYOUT_GIVEN
                    else LayoutSource.GUESSED
                    if flags & CaptureFlag.LAYOUT_GUESSED
                    else LayoutSource.INFERRED
                )
                layout = LayoutChoice(Layout(pkw, pzd), source)
        except (ValueError, KeyError, ConfigError) as exc:
            raise ConfigError(f"{where}: bad pseudo-header: {exc}") from None
        return cls.make(
            raw,
            start,
            (round(start * NS) + duration * 1000 + extra) / NS,
            side,
            CaptureFlag(flags),
            kind,
            "",
            layout,
            None if delay == NO_DELAY else delay / 1e6,
        )

    @classmethod
    def make(
        cls,
        raw: bytes,
        start: float,
        end: float,
        direction: Direction,
        flags: CaptureFlag,
        fault: FaultKind | None,
        detail: str,
        layout: LayoutChoice | None,
        delay: float | None,
    ) -> CaptureRecord:
        """A record from its stored fields (the telegram is decoded from ``raw``)."""
        frame = Frame(
            raw,
            start,
            end,
            direction=direction,
            guessed=bool(flags & CaptureFlag.GUESSED_DIRECTION),
            fault=fault,
            detail=detail,
            telegram=telegram_in(raw),
            port=1 if flags & CaptureFlag.PORT_1 else 0,
        )
        return cls(frame, flags, layout, delay)


def records_of(exchange: Exchange) -> list[CaptureRecord]:
    """The capture records of an exchange's frames, in time order."""
    out = []
    for frame, where in ((exchange.request, "request"), (exchange.answer, "answer")):
        if frame is None:
            continue
        flags = CaptureFlag.NONE
        if frame.guessed:
            flags |= CaptureFlag.GUESSED_DIRECTION
        if exchange.unsure:
            flags |= CaptureFlag.UNSURE
        if frame.port == 1:
            flags |= CaptureFlag.PORT_1
        for issue in exchange.issues:
            flag = _PROBLEM_FLAGS.get(issue.problem)
            if flag is not None and issue.where in (where, "exchange"):
                if issue.where == "exchange" and where != "request":
                    continue
                flags |= flag
        layout = None
        if exchange.layout is not None and exchange.layout_source is not None:
            layout = LayoutChoice(exchange.layout, exchange.layout_source)
            if exchange.layout_source is LayoutSource.GIVEN:
                flags |= CaptureFlag.LAYOUT_GIVEN
            elif exchange.layout_source is LayoutSource.GUESSED:
                flags |= CaptureFlag.LAYOUT_GUESSED
        delay = exchange.delay if where == "answer" else None
        out.append(CaptureRecord(frame, flags, layout, delay))
    return out


@dataclass(frozen=True, slots=True)
class Capture:
    """A capture read back: the line's baud rate, its records (frames), or, for a recording
    of the virtual bus, its characters as chunks for a receiver."""

    baud: int
    records: tuple[CaptureRecord, ...] = ()
    chunks: tuple[Chunk, ...] = ()
    four_wire: bool = False
    kind: str = "pcapng"
    gap: float | None = None
    """The gap the monitor that wrote the capture framed with (seconds), if known."""
    tolerance: float = 0.0
    """The tolerance of the timestamps the monitor judged timing with (seconds; 0 when the
    capture does not say: a recording of the virtual bus, or a capture whose gap held it)."""
    epoch: float = 0.0
    """The Unix time of time 0 of the records (a pcapng capture counts from its first packet,
    so that times keep their nanoseconds)."""
    profile: str | None = None
    """The device profile the monitor that wrote the capture decoded with (``--profile``)."""


class CaptureWriter(Protocol):
    """What `open_writer` returns."""

    path: Path

    def write(self, exchange: Exchange) -> None: ...

    def close(self) -> None: ...

    def discard(self) -> None: ...


class RecordWriter:
    """Base of the capture writers: an `AtomicWriter`, the line's settings and a record count.
    A subclass implements `header` (the bytes the file begins with, written here) and
    `write_record`. ``linktype`` is for pcapng only (None: its default)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        baud: int,
        four_wire: bool = False,
        epoch: float = 0.0,
        gap: float | None = None,
        tolerance: float = 0.0,
        profile: str | None = None,
        linktype: int | None = None,
    ) -> None:
        self.baud = check_baud(baud)
        self.four_wire = four_wire
        self.epoch = epoch
        self.profile = profile
        self.gap = gap
        self.tolerance = tolerance
        self.linktype = linktype
        header = self.header()  # bad settings are refused before a file is made
        self._file = AtomicWriter(path, "a capture")
        self.path = self._file.path
        self.packets = 0
        self._held: list[tuple[float, int, CaptureRecord]] = []
        self._seq = itertools.count()
        self._file.write(header)

    def header(self) -> bytes:
        raise NotImplementedError

    def write(self, exchange: Exchange) -> None:
        """Write the frames of ``exchange``. Frames go into the file in time order: those of
        an exchange are held until no later exchange can bring an earlier frame (noise after
        a request is reported after the request's exchange, but came before its answer)."""
        for record in records_of(exchange):
            heapq.heappush(self._held, (record.frame.start, next(self._seq), record))
        self._flush(exchange.time)

    def _flush(self, upto: float) -> None:
        while self._held and self._held[0][0] <= upto:
            self.write_record(heapq.heappop(self._held)[2])
            self.packets += 1

    def write_record(self, record: CaptureRecord) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Finish the file and rename it into place."""
        self._flush(math.inf)
        self._file.close()

    def discard(self) -> None:
        """Drop what was written."""
        self._held.clear()
        self._file.discard()
