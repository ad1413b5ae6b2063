"""The CSV file of a log: whole rows only, appended safely, rotated by size.

- A new file is created with its header line through `pyuss.atomicfile` (it appears complete
  or not at all); rows are then appended, each with one ``write`` of the whole line, flushed
  to the system at once and synced to the disk at least once a second. A program killed
  mid-way leaves whole rows.
- An existing file is never overwritten. ``append=True`` adds to it when its header is the
  same columns in the same order (else `ConfigError` naming the difference); a last line cut
  short by a crash or a full disk is removed first (`CsvLog.repaired` tells how many bytes).
- ``rotate=SIZE``: before a row would make the file larger than SIZE bytes, the file is
  renamed to ``NAME-YYYYMMDD-HHMMSS.csv`` (the time of the rename, local) and a new one with
  the header is begun under the original name, so ``NAME.csv`` is always the current file.
- A row the file cannot take (the disk is full, the file too large for the system) ends the
  log with `LogWriteError` (``cannot write NAME.csv: no space left on device``); the part of
  the row that was written is cut off again, so the file ends with the last whole row.
"""

from __future__ import annotations

import contextlib
import csv
import io
import os
import time
from collections.abc import Sequence
from pathlib import Path

from pyuss import system
from pyuss.atomicfile import check_target, write_atomically
from pyuss.errors import ConfigError, UssError

__all__ = ["CsvLog", "LogWriteError", "parse_size"]

SYNC_EVERY = 1.0
"""Seconds between two syncs of the file to the disk."""


def parse_size(text: str) -> int:
    """``10M``, ``500k``, ``1G`` or a number of bytes (at least 1 kB)."""
    raw = text.strip().upper().removesuffix("B")
    factor = 1
    if raw[-1:] in ("K", "M", "G"):
        factor = {"K": 1000, "M": 1000**2, "G": 1000**3}[raw[-1]]
        raw = raw[:-1]
    try:
        size = int(float(raw) * factor)
    except ValueError:
        raise ConfigError(f"size {text!r}: use a number of bytes or 500k, 10M, 1G") from None
    if size < 1000:
        raise ConfigError(f"size {text!r}: at least 1k (one row must fit)")
    return size


def _line(cells: Sequence[str]) -> bytes:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\r\n").writerow(cells)
    return buffer.getvalue().encode("utf-8")


class CsvLog:
    """One log file (see the module text); ``header`` names the columns."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        header: Sequence[str],
        *,
        append: bool = False,
        rotate: int | None = None,
    ) -> None:
        self.path = check_target(path, "the log")
        self.header = list(header)
        self.rotate = rotate
        self.repaired = 0
        self.rotated: list[Path] = []
        self.failed: LogWriteError | None = None
        """Why the file could not be written, once it could not: no row is written after."""
        self._header = _line(self.header)
        if rotate is not None and rotate < 2 * len(self._header):
            raise ConfigError(f"--rotate {rotate}: too small for the header and one row")
        if self.path.exists():
            if not append:
                raise ConfigError(
                    f"{self.path} exists: --append adds rows to it (same columns), "
                    "or give another file name"
                )
            self._check_existing()
        else:
            write_atomically(self.path, self._header, "the log")
        self._fd = self._open()
        self._synced = time.monotonic()

    def _check_existing(self) -> None:
        try:
            with open(self.path, "rb") as file:
                first = file.readline(65536)  # a header, not a device without end
        except OSError as exc:
            raise ConfigError(f"cannot read {self.path}: {exc.strerror or exc}") from None
        text = None
        if b"\0" not in first and first.endswith(b"\n"):  # else binary, or no header line
            with contextlib.suppress(UnicodeDecodeError):
                text = first.decode("utf-8")
        if text is None:
            raise ConfigError(f"{self.path} is not a CSV log of uss log")
        found = next(csv.reader([text.rstrip("\r\n")]), [])
        if found != self.header:
            raise ConfigError(
                f"{self.path} has other columns ({', '.join(found) or 'none'}) than this log "
                f"({', '.join(self.header)}): give another file name"
            )
        self._cut_partial_row()

    def _cut_partial_row(self) -> None:
        with open(self.path, "rb+") as file:
            size = file.seek(0, os.SEEK_END)
            if size == 0:
                return
            file.seek(max(0, size - 65536))
            tail = file.read()
            if tail.endswith(b"\n"):
                return
            keep = size - len(tail) + tail.rfind(b"\n") + 1
            if keep < len(self._header):
                keep = len(self._header)
            file.truncate(keep)
            self.repaired = size - keep

    def _open(self) -> int:
        try:
            return os.open(self.path, os.O_WRONLY | os.O_APPEND)
        except OSError as exc:
            raise ConfigError(f"cannot open {self.path}: {exc.strerror or exc}") from None

    def write(self, cells: Sequence[str]) -> None:
        """Append one row (as many cells as the header)."""
        if len(cells) != len(self.header):
            raise ValueError(f"{len(cells)} cells for {len(self.header)} columns")
        if self.failed is not None:
            raise self.failed
        line = _line(cells)
        try:
            if self.rotate is not None:
                size = os.fstat(self._fd).st_size
                if size > len(self._header) and size + len(line) > self.rotate:
                    self._rotate()
            self._append(line)
            now = time.monotonic()
            if now - self._synced >= SYNC_EVERY:
                os.fsync(self._fd)
                self._synced = now
        except OSError as exc:
            self.failed = LogWriteError(f"cannot write {self.path}: {_reason(exc)}")
            raise self.failed from None

    def _append(self, line: bytes) -> None:
        """Write the whole ``line`` or nothing: a row the disk took only part of is cut off
        again, so the file ends with the last whole row."""
        start = os.fstat(self._fd).st_size
        done = 0
        try:
            while done < len(line):
                done += os.write(self._fd, line[done:])
        except OSError:
            if done:
                with contextlib.suppress(OSError):
                    os.ftruncate(self._fd, start)
            raise

    def _rotate(self) -> None:
        os.fsync(self._fd)
        os.close(self._fd)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        target = self.path.with_name(f"{self.path.stem}-{stamp}{self.path.suffix}")
        number = 1
        while target.exists():
            target = self.path.with_name(f"{self.path.stem}-{stamp}-{number}{self.path.suffix}")
            number += 1
        self._fd = -1
        system.replace(self.path, target)
        self.rotated.append(target)
        try:
            write_atomically(self.path, self._header, "the log")
        except ConfigError as exc:  # the folder or the disk failed the new file
            self.failed = LogWriteError(str(exc))
            raise self.failed from None
        self._fd = self._open()

    def close(self) -> None:
        """Sync and close the file (once the log failed, without a second error)."""
        if self._fd < 0:
            return
        fd, self._fd = self._fd, -1
        try:
            os.fsync(fd)
        except OSError as exc:
            if self.failed is None:
                self.failed = LogWriteError(f"cannot write {self.path}: {_reason(exc)}")
                raise self.failed from None
        finally:
            os.close(fd)


class LogWriteError(UssError):
    """The log file cannot be written any more (the disk is full, ...); the rows before stay
    whole in it."""


def _reason(exc: OSError) -> str:
    """The system's reason in the middle of a sentence: ``no space left on device``."""
    reason = exc.strerror or str(exc)
    return reason[:1].lower() + reason[1:]
