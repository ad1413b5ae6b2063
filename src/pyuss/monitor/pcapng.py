"""pcapng captures of a USS line: one packet per frame, readable by Wireshark.

Written with `struct` after the pcapng format (draft-ietf-opsawg-pcapng), in little-endian:

- a Section Header Block (``shb_userappl`` = ``pyuss <version>``);
- one Interface Description Block with a user link type, ``LINKTYPE_USER0`` (147) unless told
  otherwise (147..162 are reserved for private use), ``if_name`` ``uss``, ``if_description``
  naming the wiring, the baud rate, the monitor's gap and, if not 0, its timestamp tolerance
  (``USS 2-wire line, 19200 baud, gap 1.145833 ms, tolerance 20.000000 ms``), ``if_speed``
  = the baud rate and ``if_tsresol`` = 9 (timestamps in nanoseconds);
- one Enhanced Packet Block per frame, stamped with the start of its first character (Unix
  time), ``epb_flags`` giving the direction as seen from the master (request outbound, answer
  inbound, unknown 0) and an ``opt_comment`` with the receive fault's detail, if any.

The packet data are the 20-byte pseudo-header of `pyuss.monitor.records.PSEUDO_HEADER`
followed by the frame's bytes as they were on the line. The shipped Wireshark dissector
(``uss wireshark path``) decodes both.

The reader accepts either byte order, several sections, and skips blocks it does not know
(name resolution, statistics, ...); it needs packets of a user link type with the
pseudo-header.
"""

from __future__ import annotations

import math
import os
import re
import struct
from dataclasses import replace
from pathlib import Path

from pyuss import __version__
from pyuss.bus.recorder import MAX_TIME
from pyuss.errors import ConfigError
from pyuss.monitor.model import Direction
from pyuss.monitor.records import Capture, CaptureRecord, RecordWriter
from pyuss.protocol.timing import check_baud

__all__ = [
    "DEFAULT_LINKTYPE",
    "LINKTYPE_USER0",
    "LINKTYPE_USER15",
    "SHB_TYPE_BYTES",
    "PcapngWriter",
    "check_linktype",
    "read_pcapng",
]

LINKTYPE_USER0 = 147
LINKTYPE_USER15 = 162
DEFAULT_LINKTYPE = LINKTYPE_USER0
SHB_TYPE = 0x0A0D0D0A
SHB_TYPE_BYTES = b"\x0a\x0d\x0d\x0a"
IDB_TYPE = 1
EPB_TYPE = 6
BOM = 0x1A2B3C4D

OPT_END = 0
OPT_COMMENT = 1
SHB_USERAPPL = 4
IF_NAME = 2
IF_DESCRIPTION = 3
IF_SPEED = 8
IF_TSRESOL = 9
EPB_FLAGS = 2
_INBOUND, _OUTBOUND = 1, 2
_NS = 1_000_000_000
_GAP = re.compile(rb"gap ([0-9.]+) ms")
_TOLERANCE = re.compile(rb"tolerance ([0-9.]+) ms")
_PROFILE = re.compile(rb"profile ([A-Za-z0-9_.-]{1,64})")
#: Largest timestamp tolerance a capture may give (ms).
_MAX_TOLERANCE_MS = 1000


def check_linktype(linktype: int) -> int:
    """``linktype`` if it is one of the user link types 147..162, else `ConfigError`."""
    if isinstance(linktype, bool) or linktype not in range(LINKTYPE_USER0, LINKTYPE_USER15 + 1):
        raise ConfigError(
            f"link type {linktype!r}: use a user link type {LINKTYPE_USER0}..{LINKTYPE_USER15} "
            "(LINKTYPE_USER0..15)"
        )
    return linktype


def _pad(data: bytes) -> bytes:
    return data + b"\x00" * (-len(data) % 4)


def _option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + _pad(value)


def _options(items: list[tuple[int, bytes]]) -> bytes:
    if not items:
        return b""
    return b"".join(_option(code, value) for code, value in items) + _option(OPT_END, b"")


def _block(kind: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack("<II", kind, length) + body + struct.pack("<I", length)


class PcapngWriter(RecordWriter):
    """Writes exchanges to a pcapng file (see the module text), atomically."""

    def header(self) -> bytes:
        linktype = check_linktype(DEFAULT_LINKTYPE if self.linktype is None else self.linktype)
        wiring = "4-wire" if self.four_wire else "2-wire"
        description = f"USS {wiring} line, {self.baud} baud"
        if self.gap is not None:
            description += f", gap {self.gap * 1000:.6f} ms"
        if self.tolerance:
            description += f", tolerance {self.tolerance * 1000:.6f} ms"
        if self.profile is not None:
            description += f", profile {self.profile}"
        self._epoch_ns = round(self.epoch * _NS)
        shb = struct.pack("<IHHq", BOM, 1, 0, -1) + _options(
            [(SHB_USERAPPL, f"pyuss {__version__}".encode())]
        )
        idb = struct.pack("<HHI", linktype, 0, 0) + _options(
            [
                (IF_NAME, b"uss"),
                (IF_DESCRIPTION, description.encode()),
                (IF_SPEED, struct.pack("<Q", self.baud)),
                (IF_TSRESOL, bytes((9,))),
            ]
        )
        return _block(SHB_TYPE, shb) + _block(IDB_TYPE, idb)

    def write_record(self, record: CaptureRecord) -> None:
        frame = record.frame
        data = record.pseudo_header() + frame.raw
        # whole nanoseconds added, not seconds: a Unix time in a float has lost them
        stamp = max(0, self._epoch_ns + round(frame.start * _NS))
        flags = {Direction.REQUEST: _OUTBOUND, Direction.RESPONSE: _INBOUND}.get(frame.direction, 0)
        options = [(EPB_FLAGS, struct.pack("<I", flags))]
        if frame.detail:
            options.append((OPT_COMMENT, frame.detail.encode("utf-8")))
        body = (
            struct.pack("<IIIII", 0, stamp >> 32, stamp & 0xFFFFFFFF, len(data), len(data))
            + _pad(data)
            + _options(options)
        )
        self._file.write(_block(EPB_TYPE, body))


def _parse_options(body: bytes, offset: int, order: str) -> dict[int, list[bytes]]:
    out: dict[int, list[bytes]] = {}
    while offset + 4 <= len(body):
        code, length = struct.unpack_from(order + "HH", body, offset)
        offset += 4
        if code == OPT_END:
            break
        value = body[offset : offset + length]
        offset += length + (-length % 4)
        out.setdefault(code, []).append(value)
    return out


def _tsresol(options: dict[int, list[bytes]]) -> float:
    value = options.get(IF_TSRESOL, [b"\x06"])[0]
    v = value[0] if value else 6
    return 2.0 ** -(v & 0x7F) if v & 0x80 else 10.0**-v


class _Reader:
    def __init__(self, name: str, data: bytes) -> None:
        self.name = name
        self.data = data
        self.order = "<"
        self.interfaces: list[tuple[int, float, int | None]] = []
        self.records: list[CaptureRecord] = []
        self.baud: int | None = None
        self.four_wire = False
        self.gap: float | None = None
        self.tolerance = 0.0
        self.profile: str | None = None
        self.packet = 0
        self.base: int | None = None
        """The timestamp of the first packet (in its interface's units): times count from it."""
        self.base_time = 0.0
        self.base_resolution = 0.0

    def fail(self, offset: int, what: str) -> ConfigError:
        return ConfigError(f"{self.name}: bad pcapng at byte {offset}: {what}")

    def run(self) -> Capture:
        offset, data = 0, self.data
        while offset < len(data):
            if len(data) - offset < 12:
                raise self.fail(offset, "truncated: the file ends inside a block header")
            if data[offset : offset + 4] == SHB_TYPE_BYTES:
                bom = data[offset + 8 : offset + 12]
                if bom == struct.pack("<I", BOM):
                    self.order = "<"
                elif bom == struct.pack(">I", BOM):
                    self.order = ">"
                else:
                    raise self.fail(offset, "section header without a valid byte-order magic")
                self.interfaces = []
            elif offset == 0:
                raise self.fail(0, "no section header block")
            kind, length = struct.unpack_from(self.order + "II", data, offset)
            if length < 12 or length % 4:
                raise self.fail(offset, f"block length {length} (a multiple of 4, at least 12)")
            if offset + length > len(data):
                raise self.fail(
                    offset,
                    f"truncated: a block of {length} bytes, the file ends after "
                    f"{len(data) - offset}",
                )
            body = data[offset + 8 : offset + length - 4]
            self.block(kind, body, offset)
            offset += length
        if self.baud is None:
            raise ConfigError(f"{self.name}: no USS interface (user link type) in the capture")
        return Capture(
            self.baud,
            tuple(self.records),
            four_wire=self.four_wire,
            kind="pcapng",
            gap=self.gap,
            tolerance=self.tolerance,
            epoch=self.base_time,
            profile=self.profile,
        )

    def block(self, kind: int, body: bytes, offset: int) -> None:
        order = self.order
        if kind == IDB_TYPE:
            if len(body) < 8:
                raise self.fail(offset, "short interface description")
            linktype, _, _ = struct.unpack_from(order + "HHI", body)
            options = _parse_options(body, 8, order)
            baud = None
            if IF_SPEED in options and len(options[IF_SPEED][0]) == 8:
                baud = struct.unpack(order + "Q", options[IF_SPEED][0])[0]
            description = b"".join(options.get(IF_DESCRIPTION, []))
            self.interfaces.append((linktype, _tsresol(options), baud))
            if LINKTYPE_USER0 <= linktype <= LINKTYPE_USER15:
                if baud is None:
                    raise self.fail(offset, "USS interface without if_speed (the baud rate)")
                try:
                    self.baud = check_baud(baud)
                except ConfigError as exc:
                    raise self.fail(offset, str(exc)) from None
                self.four_wire = self.four_wire or b"4-wire" in description
                found = _GAP.search(description)
                if found:
                    self.gap = float(found.group(1)) / 1000
                found = _PROFILE.search(description)
                if found:
                    self.profile = found.group(1).decode()
                found = _TOLERANCE.search(description)
                if found:
                    try:
                        tolerance = float(found.group(1))
                    except ValueError:
                        tolerance = math.nan
                    if not 0 <= tolerance <= _MAX_TOLERANCE_MS:
                        raise self.fail(offset, f"tolerance {found.group(1).decode()} ms")
                    self.tolerance = tolerance / 1000
        elif kind == EPB_TYPE:
            self.packet += 1
            if len(body) < 20:
                raise self.fail(offset, "short enhanced packet block")
            iface, high, low, captured, _ = struct.unpack_from(order + "IIIII", body)
            if iface >= len(self.interfaces):
                raise self.fail(offset, f"packet for undeclared interface {iface}")
            linktype, resolution, _ = self.interfaces[iface]
            if not LINKTYPE_USER0 <= linktype <= LINKTYPE_USER15:
                return
            if 20 + captured > len(body):
                raise self.fail(offset, "packet data beyond the block")
            packet = body[20 : 20 + captured]
            options = _parse_options(body, 20 + captured + (-captured % 4), order)
            stamp = (high << 32) | low
            start = stamp * resolution
            where = f"{self.name}: packet {self.packet}"
            if not start <= MAX_TIME:
                raise ConfigError(
                    f"{where}: timestamp {start:.6g} s is out of range (at most {MAX_TIME:.0f} s)"
                )
            if self.base is None:
                self.base, self.base_time, self.base_resolution = stamp, start, resolution
            # from the first packet on, in whole units: the nanoseconds stay
            if resolution == self.base_resolution:
                since = (stamp - self.base) * resolution
            else:  # an interface of other units (a merged capture)
                since = start - self.base_time
            record = CaptureRecord.from_packet(packet, since, where)
            comments = options.get(OPT_COMMENT)
            if comments and record.frame.fault is not None:
                detail = comments[0].decode("utf-8", "replace")
                record = replace(record, frame=replace(record.frame, detail=detail))
            self.records.append(record)


def read_pcapng(path: str | os.PathLike[str]) -> Capture:
    """Read a pcapng capture written by `PcapngWriter` (or re-saved by Wireshark)."""
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read capture {name}: {exc.strerror or exc}") from None
    return _Reader(name, data).run()
