"""JSON-lines captures of a USS line: a header line, then one line per frame.

::

    {"format": "pyuss-monitor-capture", "version": 1, "baud": 19200, "four_wire": false,
     "gap_ms": 2.0}                                                      (one line in the file)
    {"start": 1700000000.0123, "end": 1700000000.0203, "hex": "02 0C 05 ...",
     "direction": "request", "port": 0, "fault": null, "detail": "", "flags": ["guessed_direction"],
     "layout": "3,2", "layout_source": "inferred", "delay_ms": null}    (one line in the file)

``start``/``end``: Unix time of the start of the first and the end of the last character;
``direction``: ``request``, ``response`` or ``unknown``; ``fault``: the receive fault
(``bcc``, ``parity``, ... as `pyuss.protocol.FaultKind` names in lower case) or null;
``flags``: `pyuss.monitor.records.CaptureFlag` names in lower case; ``layout``: ``PKW,PZD``
the monitor decoded the frame with (null if none) and ``layout_source`` where it came from
(``given``, ``inferred``, ``guessed``); ``delay_ms``: the response delay of an answer. The
header's ``gap_ms`` is the idle time the monitor framed telegrams with, ``tolerance_ms`` (left
out when 0) how late its port could stamp a byte.

`read_jsonl` also reads the character recordings of the virtual bus
(``pyuss-bus-recording``, `pyuss.bus.recorder`): they come back as chunks for a receiver.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from pyuss.bus.recorder import FORMAT as BUS_FORMAT
from pyuss.bus.recorder import check_seconds, load_recording
from pyuss.errors import ConfigError
from pyuss.monitor.infer import LayoutChoice
from pyuss.monitor.model import Direction, LayoutSource
from pyuss.monitor.records import Capture, CaptureFlag, CaptureRecord, RecordWriter
from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import check_baud

__all__ = ["FORMAT", "VERSION", "JsonlWriter", "read_jsonl"]

FORMAT = "pyuss-monitor-capture"
VERSION = 1
MAX_TOLERANCE_MS = 1000
"""Largest timestamp tolerance a capture may give (ms)."""


def record_json(record: CaptureRecord, epoch: float = 0.0) -> dict[str, Any]:
    """One frame line of a JSON-lines capture."""
    frame = record.frame
    layout = record.layout
    return {
        "start": round(frame.start + epoch, 9),
        "end": round(frame.end + epoch, 9),
        "hex": frame.raw.hex(" ").upper(),
        "direction": frame.direction.label,
        "port": frame.port,
        "fault": None if frame.fault is None else frame.fault.name.lower(),
        "detail": frame.detail,
        "flags": [f.name.lower() for f in CaptureFlag if f and f.name and f in record.flags],
        "layout": None if layout is None else str(layout.layout),
        "layout_source": None if layout is None else layout.source.value,
        "delay_ms": None if record.delay is None else round(record.delay * 1000, 6),
    }


def record_from_json(item: Any) -> CaptureRecord:
    """Parse one frame line (`ValueError`, `KeyError` or `TypeError` when it is bad)."""
    if not isinstance(item, dict):
        raise ValueError("not a JSON object")
    raw = bytes.fromhex(str(item["hex"]))
    start, end = check_seconds(item["start"], "start"), check_seconds(item["end"], "end")
    if end < start:
        raise ValueError(f"end {end} is before start {start}")
    direction = Direction[str(item.get("direction", "unknown")).upper()]
    fault = item.get("fault")
    kind = None if fault is None else FaultKind[str(fault).upper()]
    flags = CaptureFlag.NONE
    for name in item.get("flags", []):
        flags |= CaptureFlag[str(name).upper()]
    if item.get("port", 0) == 1:
        flags |= CaptureFlag.PORT_1
    layout = None
    if item.get("layout") is not None:
        source = LayoutSource(item.get("layout_source") or "guessed")
        layout = LayoutChoice(Layout.parse(str(item["layout"])), source)
    delay = item.get("delay_ms")
    if delay is not None and not math.isfinite(float(delay)):
        raise ValueError(f"delay_ms {delay} is not a finite number")
    return CaptureRecord.make(
        raw,
        start,
        end,
        direction,
        flags,
        kind,
        str(item.get("detail", "")),
        layout,
        None if delay is None else float(delay) / 1000,
    )


class JsonlWriter(RecordWriter):
    """Writes exchanges as JSON lines (see the module text), atomically."""

    def header(self) -> bytes:
        header: dict[str, Any] = {
            "format": FORMAT,
            "version": VERSION,
            "baud": self.baud,
            "four_wire": self.four_wire,
        }
        if self.gap is not None:
            header["gap_ms"] = round(self.gap * 1000, 6)
        if self.tolerance:
            header["tolerance_ms"] = round(self.tolerance * 1000, 6)
        if self.profile is not None:
            header["profile"] = self.profile
        return (json.dumps(header) + "\n").encode()

    def write_record(self, record: CaptureRecord) -> None:
        line = json.dumps(record_json(record, self.epoch), separators=(", ", ": "))
        self._file.write((line + "\n").encode())


def read_jsonl(path: str | os.PathLike[str]) -> Capture:
    """Read a JSON-lines capture of the monitor or a recording of the virtual bus."""
    name = str(path)
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read capture {name}: {exc}") from None
    try:
        header = json.loads(lines[0]) if lines else None
    except json.JSONDecodeError:
        header = None
    if isinstance(header, dict) and header.get("format") == BUS_FORMAT:
        recording = load_recording(path)
        return Capture(recording.baud, chunks=tuple(recording.chunks()), kind="bus recording")
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ConfigError(f"{name}:1: not a capture (no {FORMAT} or {BUS_FORMAT} header)")
    if header.get("version") != VERSION:
        raise ConfigError(f"{name}:1: capture version {header.get('version')!r} is unknown")
    try:
        baud = check_baud(header.get("baud"))  # type: ignore[arg-type]
    except ConfigError as exc:
        raise ConfigError(f"{name}:1: {exc}") from None
    records = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        try:
            records.append(record_from_json(json.loads(line)))
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{name}:{number}: bad frame: {exc}") from None
    gap = header.get("gap_ms")
    if gap is not None and (
        isinstance(gap, bool) or not isinstance(gap, int | float) or not 0 < gap < math.inf
    ):
        raise ConfigError(f"{name}:1: gap_ms {gap!r} is not a positive number of milliseconds")
    tolerance = header.get("tolerance_ms", 0)
    if isinstance(tolerance, bool) or not isinstance(tolerance, int | float):
        tolerance = math.nan
    if not 0 <= tolerance <= MAX_TOLERANCE_MS:
        raise ConfigError(
            f"{name}:1: tolerance_ms {header.get('tolerance_ms')!r} is not a number of "
            f"milliseconds 0..{MAX_TOLERANCE_MS}"
        )
    return Capture(
        baud,
        tuple(records),
        four_wire=bool(header.get("four_wire")),
        kind="JSON lines",
        gap=None if gap is None else float(gap) / 1000,
        tolerance=float(tolerance) / 1000,
        profile=_profile(name, header.get("profile")),
    )


def _profile(name: str, value: object) -> str | None:
    """The header's ``profile``: a profile's name, or absent."""
    if value is None:
        return None
    if not isinstance(value, str) or not value or len(value) > 64:
        raise ConfigError(f"{name}:1: profile {value!r} is not the name of a device profile")
    return value
