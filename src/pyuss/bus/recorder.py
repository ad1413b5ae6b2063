"""Recording what goes over the virtual bus, as JSON lines, and replaying it.

A recording file starts with a header line, then one line per character on the wire::

    {"format": "pyuss-bus-recording", "version": 1, "baud": 19200, "seed": 0}
    {"t": 0.012345678, "start": 0.011772761, "from": "master", "byte": "02", "flags": []}
    {"t": 0.01291859, "start": 0.01234567, "from": "m", "byte": "0c", "flags": ["PARITY"],
     "notes": ["flip"]}                                      (one line in the file)

``t`` is the end of the character, ``start`` its start, both in seconds since the bus started;
``from`` the sender (colliding senders joined by ``+``); ``flags`` the line errors every
receiver saw (`LineError` names); ``notes`` the faults applied and ``collision``. Characters
come in time order; `load_recording` refuses times that are not finite numbers of seconds
(within `MAX_TIME`), a character that ends before it starts and one that comes before the
character above it, with the file and line.

`Recorder` is what the bus calls for each character. With a path it writes the lines to a
temporary file next to it as they come and, on `close`, syncs it to disk and renames it to the
path: a file with that name is always complete. A recording is read back with
`load_recording`; `Recording.chunks` gives what one station received, as `Chunk`s for a
receiver (timestamps in seconds since the bus started), and `replay` puts the characters on
another bus with their original spacing.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyuss.atomicfile import AtomicWriter
from pyuss.bus.core import Segment
from pyuss.bus.line import WireChar
from pyuss.errors import ConfigError
from pyuss.system import clock
from pyuss.transport.base import Chunk, LineError
from pyuss.transport.queued import check_baud

FORMAT = "pyuss-bus-recording"
VERSION = 1
_EPS = 1e-9


MAX_TIME = 2.0**33
"""Largest time a file may hold (seconds, about 272 years): a float still tells microseconds
apart there, well below the shortest character time (58 us at 187500 baud)."""


def check_seconds(value: Any, key: str) -> float:
    """A time of a record: a finite number of seconds within `MAX_TIME` (`ValueError`)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{key} {value!r} is not a number of seconds")
    seconds = float(value)
    if not math.isfinite(seconds):
        raise ValueError(f"{key} {value!r} is not a finite number of seconds")
    if abs(seconds) > MAX_TIME:
        raise ValueError(f"{key} {value!r} is out of range (at most {MAX_TIME:.0f} s)")
    return seconds


@dataclass(frozen=True, slots=True)
class Record:
    """One character of a recording (times in seconds since the bus started)."""

    t: float
    start: float
    sender: str
    byte: int
    flags: LineError = LineError.NONE
    notes: tuple[str, ...] = ()

    def to_json(self) -> str:
        item: dict[str, Any] = {
            "t": round(self.t, 9),
            "start": round(self.start, 9),
            "from": self.sender,
            "byte": f"{self.byte:02x}",
            "flags": [f.name for f in LineError if f and f in self.flags],
        }
        if self.notes:
            item["notes"] = list(self.notes)
        return json.dumps(item, separators=(", ", ": "))

    @classmethod
    def from_json(cls, item: Any) -> Record:
        if not isinstance(item, dict):
            raise ValueError("not a JSON object")
        flags = LineError.NONE
        for name in item.get("flags", []):
            if name not in LineError.__members__ or name == "NONE":
                raise ValueError(f"unknown line error {name!r}")
            flags |= LineError[name]
        byte = int(item["byte"], 16)
        if not 0 <= byte <= 255:
            raise ValueError(f"byte {item['byte']!r} out of range")
        t = check_seconds(item["t"], "t")
        start = check_seconds(item.get("start", t), "start")
        if start > t:
            raise ValueError(f"start {start!r} is after t {t!r}: a character ends after it starts")
        sender = item["from"]
        if not isinstance(sender, str) or not sender:
            raise ValueError("'from' must name the sender")
        notes = item.get("notes", [])
        if not isinstance(notes, list) or not all(isinstance(n, str) for n in notes):
            raise ValueError("'notes' must be a list of names")
        return cls(t, start, sender, byte, flags, tuple(notes))


@dataclass(frozen=True, slots=True)
class Recording:
    """A recording read back: the bus's baud rate and every character in order."""

    baud: int
    records: tuple[Record, ...]
    seed: int = 0

    def chunks(self, station: str | None = None, *, hears_own: bool = False) -> list[Chunk]:
        """What ``station`` received (all characters when ``None``): contiguous characters
        grouped in one chunk, stamped with the end of the last one (seconds since the bus
        started), ready for a receiver's ``feed``."""
        out: list[Chunk] = []
        buf = bytearray()
        errors: list[tuple[int, LineError]] = []
        last_end = 0.0
        for rec in self.records:
            if station is not None and not hears_own and station in rec.sender.split("+"):
                continue
            if buf and rec.start > last_end + _EPS:
                out.append(Chunk(bytes(buf), last_end, tuple(errors)))
                buf.clear()
                errors.clear()
            if rec.flags:
                errors.append((len(buf), rec.flags))
            buf.append(rec.byte)
            last_end = rec.t
        if buf:
            out.append(Chunk(bytes(buf), last_end, tuple(errors)))
        return out

    def gaps(self, sender: str) -> list[float]:
        """Idle time between consecutive characters of ``sender`` (seconds)."""
        mine = [r for r in self.records if r.sender == sender]
        return [b.start - a.t for a, b in itertools.pairwise(mine)]


class Recorder:
    """Collects every character the bus puts on the wire; see the module docstring.

    ``keep`` holds the records in memory too (`records`, `recording()`).
    """

    def __init__(self, path: str | os.PathLike[str] | None = None, *, keep: bool = True) -> None:
        self.path = None if path is None else Path(path)
        self.keep = keep
        self.records: list[Record] = []
        self._bus: Segment | None = None
        self._file: AtomicWriter | None = None

    def attach(self, bus: Segment) -> Recorder:
        """Record ``bus`` from now on (and create the temporary file)."""
        if self._bus is not None:
            raise ConfigError("a recorder records one bus")
        self._bus = bus
        if self.path is not None:
            self._file = AtomicWriter(self.path, "a recording", text=True)
            header = {"format": FORMAT, "version": VERSION, "baud": bus.baud, "seed": bus.seed}
            self._file.write(json.dumps(header) + "\n")
        bus.on_char.append(self)
        return self

    def __call__(self, char: WireChar) -> None:
        assert self._bus is not None
        epoch = self._bus.epoch
        rec = Record(
            char.end - epoch, char.start - epoch, char.sender, char.byte, char.flags, char.notes
        )
        if self.keep:
            self.records.append(rec)
        if self._file is not None:
            self._file.write(rec.to_json() + "\n")

    def recording(self) -> Recording:
        if self._bus is None:
            raise ConfigError("the recorder is not attached to a bus")
        return Recording(self._bus.baud, tuple(self.records), self._bus.seed)

    def close(self) -> None:
        """Finish the file: sync, then rename into place. Idempotent."""
        if self._bus is not None and self in self._bus.on_char:
            self._bus.on_char.remove(self)
        if self._file is not None:
            file, self._file = self._file, None
            file.close()

    def discard(self) -> None:
        """Drop the temporary file without writing the recording."""
        if self._file is not None:
            file, self._file = self._file, None
            file.discard()


def load_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording file; `ConfigError` naming the file and line when it is not one."""
    name = str(path)
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read recording {name}: {exc}") from None
    if not lines:
        raise ConfigError(f"{name}: empty file, not a bus recording")
    try:
        header = json.loads(lines[0])
    except json.JSONDecodeError:
        header = None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ConfigError(f"{name}:1: not a bus recording (no {FORMAT} header)")
    if header.get("version") != VERSION:
        raise ConfigError(f"{name}:1: recording version {header.get('version')!r} is unknown")
    try:
        baud = header.get("baud")
        if isinstance(baud, bool) or not isinstance(baud, int):
            raise ConfigError(f"baud rate {baud!r} is not a whole number")
        baud = check_baud(baud)
    except ConfigError as exc:
        raise ConfigError(f"{name}:1: {exc}") from None
    records: list[Record] = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        try:
            record = Record.from_json(json.loads(line))
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{name}:{number}: bad record: {exc}") from None
        if records and (record.t < records[-1].t or record.start < records[-1].start):
            before = records[-1]
            raise ConfigError(
                f"{name}:{number}: out of time order: this character (start {record.start!r}, "
                f"t {record.t!r}) comes before the one on the line above (start "
                f"{before.start!r}, t {before.t!r}); a recording holds the line in time order"
            )
        records.append(record)
    seed = header.get("seed", 0)
    return Recording(baud, tuple(records), seed if isinstance(seed, int) else 0)


async def replay(recording: Recording, bus: Segment, *, lead: float = 0.01) -> None:
    """Put the recorded characters on ``bus`` with their recorded spacing, starting ``lead``
    seconds from now, each as its recorded sender sent it (with its recorded line errors);
    returns once all were delivered. The bus must run at the recording's baud rate."""
    if bus.baud != recording.baud:
        raise ConfigError(f"recording is at {recording.baud} baud, the bus at {bus.baud}")
    if not recording.records:
        return
    base = clock() + lead - recording.records[0].start
    for rec in recording.records:
        # A garbled character is replayed as the one character the receivers saw.
        bus.inject(rec.sender, base + rec.start, rec.byte, rec.flags)
    await bus.drain()
    await asyncio.sleep(0)
