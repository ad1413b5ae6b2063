"""Sampling a drive into a CSV log.

`DataLogger` takes one row per sample from a drive on a cyclic `pyuss.master.Master` (the
handle comes from the command; the logger itself imports the drive model, not the master):

- samples are due at fixed times, ``1 / rate`` seconds apart from the start (a slot that is
  missed because the line is slower is skipped, the timetable does not drift);
- the process-data values (status word, state, actual values, status bits) are those of the
  first answer of the drive after the slot began, so every row holds fresh data; the row's
  time is when that answer came (wall clock, ISO 8601 with the UTC offset, milliseconds);
- parameters are read with a parameter job for every row, typed through the drive's parameter
  book (`pyuss.params`, ``Drive.read_param``); the actual values are those of the live-drive
  model (`pyuss.points.DrivePoints.actual_items`, the one scaling of process data the web
  page uses too): PZD2 in the unit of the profile's reference parameter, PZD3 and up
  converted by the parameters the profile maps them to;
- a drive that does not answer (no answer within ``max(1 / rate, 0.5 s)``, "slave does not
  send" of A 5.2.1.1, or a parameter job that timed out) gives a row with every value empty
  and ``no answer`` in the ``comm`` column: never the last values again. A parameter the
  drive refuses is empty with the refusal in ``comm``;
- a line too slow for the rate asked (9600 baud carries some 25 samples a second, fewer with
  parameters) is said, not hidden: when fewer than `SHORT` of the slots got a row, `run`
  tells ``on_short`` the rate reached once during the log, and the result carries it
  (`LogResult.reached`; `uss log` says it on stderr and in a ``#`` comment line at the end of
  the file).
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as _dt
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from pyuss.datalog.csvfile import CsvLog
from pyuss.datalog.values import Kind, Quantity
from pyuss.drive.datatypes import Value
from pyuss.errors import ConfigError, DriveRefusal, UssError, UssTimeout
from pyuss.params import ParamInfo, format_value
from pyuss.params.names import param_name
from pyuss.points import Drive, DrivePoints, DriveStatus, NoWriteAuthority
from pyuss.protocol.pzd import STATUS_BITS

__all__ = [
    "COMM_OK",
    "NO_ANSWER",
    "SHORT",
    "DataLogger",
    "LogResult",
    "iso_now",
    "rate_text",
    "write_comment",
]

NO_ANSWER = "no answer"
COMM_OK = "ok"
MIN_WAIT = 0.5
"""Seconds a sample waits at least for an answer before it is written as "no answer"."""
SHORT = 0.9
"""The rate counts as not reached when fewer than this share of the slots got a row."""
SHORT_AFTER = 20
"""Slots that pass before `DataLogger.run` judges the rate during the log."""


def iso_now() -> str:
    """The wall-clock time as ISO 8601 with the local UTC offset and milliseconds."""
    return _dt.datetime.now().astimezone().isoformat(timespec="milliseconds")


@dataclass(frozen=True, slots=True)
class LogResult:
    rows: int
    no_answer: int
    """Rows written as "no answer"."""
    rate: float = 0.0
    """Samples a second asked."""
    slots: int = 0
    """Slots that passed: rows written plus slots skipped because the line was slower or
    while a sample waited for a drive that did not answer."""
    silent_skipped: int = 0
    """Of the slots skipped, those that passed while a sample waited for a drive that did not
    answer (`MIN_WAIT`): the drive's silence, not the line's speed."""

    @property
    def reached(self) -> float:
        """Samples a second written: the rate asked times the share of slots that got a row."""
        return self.rate * self.rows / self.slots if self.slots else self.rate

    @property
    def short(self) -> bool:
        """Whether the rate asked was not reached (fewer than `SHORT` of the slots got a row)."""
        return self.slots > 0 and self.rows < SHORT * self.slots


def cell(info: ParamInfo | None, value: Value | Sequence[Value]) -> str:
    """A value as a CSV cell: a number as a spreadsheet reads it (scaled, the decimals of its
    parameter, no unit or value text: the header has the unit), a word of bits (V2: control
    and status words) in hex as 0237h, text without padding, bytes in hex, the elements of an
    array separated by blanks."""
    if isinstance(value, list | tuple):
        return " ".join(cell(info, v) for v in value)
    if isinstance(value, bytes):
        return value.hex(" ").upper()
    if isinstance(value, str):
        return value.rstrip()
    if info is not None and info.is_bit_field and isinstance(value, int):
        return f"{value:04X}h"  # a word of bits (control word, status word) in hex
    if info is None:
        return str(value)
    return format_value(info, value, unit=False, texts=False)


def rate_text(result: LogResult) -> str:
    """What a log that falls short of its rate says of it (no comma: a CSV cell unquoted)."""
    reached = f"{result.reached:.3g} samples a second reached of the {result.rate:g} asked"
    skipped = result.slots - result.rows
    silent = result.silent_skipped
    silence = "while the drive did not answer"
    if silent >= skipped:
        return f"{reached}: {skipped} of {result.slots} slots skipped {silence}"
    line = f"{reached}: the line is slower ({skipped - silent} of {result.slots} slots skipped"
    return line + (f"; {silent} more {silence})" if silent else ")")


def write_comment(log: CsvLog, text: str) -> None:
    """A ``#`` comment as a row of its own: the text in the first cell, the others empty (a
    CSV reader that skips comments, ``pandas.read_csv(comment="#")``, skips it)."""
    log.write([f"# {text}", *[""] * (len(log.header) - 1)])


async def read_parameter(drive: Drive, pnu: int, index: int | None, timeout: float) -> str:
    """One parameter's value as a CSV cell (`cell`), read and typed through the drive's
    parameter book."""
    reading = await drive.read_param(pnu, index, timeout=timeout)
    return cell(reading.info, reading.value)


class DataLogger:
    """Rows of ``quantities`` from ``drive`` (see the module text)."""

    def __init__(
        self,
        drive: Drive,
        quantities: Sequence[Quantity],
        *,
        rate: float,
        job_timeout: float = 1.0,
    ) -> None:
        if isinstance(rate, bool) or not (isinstance(rate, int | float) and 0 < rate <= 1000):
            raise ConfigError(f"rate {rate!r}: give 0 < HZ <= 1000 samples a second")
        if not math.isfinite(rate):
            raise ConfigError(f"rate {rate!r} is not a number")
        for quantity in quantities:
            if quantity.process and drive.layout.pzd == 0:
                raise ConfigError(
                    f"{quantity.text}: drive {drive.address} has layout {drive.layout}, "
                    "without process data"
                )
        self.drive = drive
        self.quantities = list(quantities)
        self.rate = float(rate)
        self.job_timeout = job_timeout
        self.points = DrivePoints.around(drive)
        """The drive's live points: its reference and the values of its process data."""

    async def prepare(self) -> None:
        """Read the reference (for actual values in units) and every parameter once (which
        also learns what the drive says of parameters no file knows, for the header): a
        parameter the drive refuses ends the log before it starts (`DriveRefusal`)."""
        if any(q.kind is Kind.ACTUAL for q in self.quantities):
            with contextlib.suppress(UssError):  # without it: PZD2 in percent
                await self.points.read_reference()
        for quantity in self.quantities:
            if quantity.kind is Kind.PARAMETER:
                with contextlib.suppress(UssTimeout):  # no answer now: the rows say so
                    await read_parameter(self.drive, quantity.pnu, quantity.index, self.job_timeout)

    @property
    def reference(self) -> tuple[float, str] | None:
        """The reference (100 % of PZD2) and its unit, once `prepare` read it."""
        value = self.points.reference
        return None if value is None else (value, self.points.model.unit)

    def _actual_columns(self) -> list[str]:
        names = []
        for number in range(2, self.drive.layout.pzd + 1):
            if number == 2:
                unit = self.reference[1] if self.reference else "%"
                names.append(f"actual PZD2 [{unit}]")
                continue
            param = self.points.process_parameter(number)
            if param is None:
                names.append(f"actual PZD{number}")
            else:
                unit = f" [{param.unit}]" if param.unit else ""
                names.append(f"actual PZD{number} {param.name}{unit}")
        return names

    def header(self) -> list[str]:
        """The CSV header: time, one column per value (units in brackets), comm."""
        names = ["time"]
        for quantity in self.quantities:
            if quantity.kind is Kind.STATUS:
                names.append("status word")
            elif quantity.kind is Kind.STATE:
                names.append("state")
            elif quantity.kind is Kind.ACTUAL:
                names += self._actual_columns()
            elif quantity.kind is Kind.BIT:
                names.append(f"bit {quantity.bit} {STATUS_BITS[quantity.bit][0]}")
            else:
                # the project's spelling whatever the family's: a log appended to keeps its
                # columns
                label = param_name(quantity.pnu, quantity.index)
                param = self.drive.params.get(quantity.pnu)
                if param is not None:
                    label += f" {param.name}" + (f" [{param.unit}]" if param.unit else "")
                names.append(label)
        names.append("comm")
        return names

    def _actual_cells(self, status: DriveStatus) -> list[str]:
        cells = []
        for number, (value, info) in enumerate(self.points.actual_items(status.actual), start=2):
            if number == 2 and isinstance(value, int | float):
                cells.append(f"{value:.3f}")
            elif info is not None:
                cells.append(cell(info, value))
            else:
                cells.append(str(value))  # the word as it came where nothing is known of it
        cells += [""] * (self.drive.layout.pzd - 1 - len(status.actual))
        return cells

    def _process_cells(self, quantity: Quantity, status: DriveStatus) -> list[str]:
        if quantity.kind is Kind.STATUS:
            return [f"{status.word:04X}h"]
        if quantity.kind is Kind.STATE:
            return [status.state]
        if quantity.kind is Kind.ACTUAL:
            return self._actual_cells(status)
        return [str(status.word >> quantity.bit & 1)]

    def _width(self, quantity: Quantity) -> int:
        return len(self._actual_columns()) if quantity.kind is Kind.ACTUAL else 1

    async def sample(self) -> tuple[list[str], bool]:
        """One row and whether the drive answered."""
        status: DriveStatus | None = None
        stamp = iso_now()
        if any(q.process for q in self.quantities):
            wait = max(1.0 / self.rate, MIN_WAIT)
            try:
                status = await self.drive.next_update(timeout=wait)
                stamp = iso_now()
            except ConfigError:
                raise
            except UssError:
                status = None
            if status is None or self.drive.not_sending:
                return self._silent(stamp), False
        cells: list[str] = [stamp]
        problems: list[str] = []
        for quantity in self.quantities:
            if quantity.kind is not Kind.PARAMETER:
                assert status is not None
                cells += self._process_cells(quantity, status)
                continue
            try:
                cells.append(
                    await read_parameter(self.drive, quantity.pnu, quantity.index, self.job_timeout)
                )
            except UssTimeout:
                return self._silent(stamp), False
            except (DriveRefusal, NoWriteAuthority) as exc:
                cells.append("")
                problems.append(f"{quantity.text}: {exc}")
            except ConfigError:
                raise
            except UssError as exc:
                cells.append("")
                problems.append(f"{quantity.text}: {exc}")
        cells.append("; ".join(problems) if problems else COMM_OK)
        return cells, True

    def _silent(self, stamp: str) -> list[str]:
        width = sum(self._width(q) for q in self.quantities)
        return [stamp, *([""] * width), NO_ANSWER]

    async def run(
        self,
        log: CsvLog,
        stop: asyncio.Event,
        *,
        count: int | None = None,
        duration: float | None = None,
        on_short: Callable[[LogResult], object] | None = None,
    ) -> LogResult:
        """Write rows to ``log`` until ``stop`` is set, ``count`` rows are written or
        ``duration`` seconds have passed. ``on_short(result so far)`` is called once, as soon
        as `SHORT_AFTER` slots have passed, when the rate asked is not reached."""
        period = 1.0 / self.rate
        start = time.monotonic()
        end = math.inf if duration is None else start + duration
        rows = silent = silent_skipped = 0
        slot = 0
        judged = on_short is None
        while not stop.is_set() and (count is None or rows < count):
            due = start + slot * period
            now = time.monotonic()
            if due > now:
                if due >= end:
                    break
                stopper = asyncio.ensure_future(stop.wait())
                try:
                    await asyncio.wait([stopper], timeout=due - now)
                finally:
                    stopper.cancel()
                if stop.is_set():
                    break
            elif now >= end:
                break
            cells, answered = await self.sample()
            log.write(cells)
            rows += 1
            silent += not answered
            # the next slot after now: skipped slots are not made up for
            after = max(slot + 1, math.floor((time.monotonic() - start) / period) + 1)
            if not answered:
                silent_skipped += after - slot - 1
            slot = after
            if not judged and slot >= SHORT_AFTER:
                judged = True
                so_far = LogResult(rows, silent, self.rate, slot, silent_skipped)
                if so_far.short and on_short is not None:
                    on_short(so_far)
        return LogResult(rows, silent, self.rate, slot, silent_skipped)
