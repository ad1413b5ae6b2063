"""Parameter sets: read a drive's parameters into a `Backup`, keep it in a file, read it back.

A `Backup` is a header - address, profile (`UNKNOWN_KIND`, ``"unknown"``, for a drive no
profile was named for: its values are the words as read; a file that says ``"generic"`` is a
drive of the generic profile, as files of earlier versions say of every drive), date (ISO 8601,
UTC), the drive's identity parameters where it has them, and how many parameters follow - and
one `Entry` per parameter:
number, name, unit, type, the value as the drive engineer reads it (typed and scaled, a list
for an array), the raw words as they travelled, and, for a parameter that could not be read,
the error instead of a value.

Files (`save`, `load`): TOML (``.toml``, written with `pyuss.tomlwrite`), JSON
(``.json``), and a CSV export (``.csv``, for a spreadsheet; not read back). They are written
atomically (`pyuss.atomicfile`): a backup that is killed leaves the old file or none, never
half of one; an existing file is replaced only when asked (``overwrite``). `load` refuses -
before anything is written to a drive - a file that is not a backup (read through
`pyuss.userfile`: missing, no text, empty, not TOML or JSON, nested too deep), whose
parameter count does not match the header (cut short), whose entries are broken (a missing
or wrongly typed field), or that holds a number no parameter can (infinity, NaN, an integer
beyond 64 bits), naming the parameter and the value.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pyuss import profiles, tomlwrite
from pyuss.atomicfile import check_regular, check_target, write_atomically
from pyuss.drive.database import NameStyle
from pyuss.errors import ConfigError, DriveRefusal, UssError, UssTimeout
from pyuss.master.drive import Drive
from pyuss.master.errors import JobTimeout
from pyuss.params.model import ParamInfo, Reading
from pyuss.params.names import param_name, parse_param_name
from pyuss.params.values import format_value, json_value
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import ErrorNumber
from pyuss.userfile import parse_json, parse_toml, read_text

__all__ = [
    "FORMAT_VERSION",
    "UNKNOWN_KIND",
    "Backup",
    "Entry",
    "LayoutTooSmall",
    "beyond_layout",
    "identity_parameters",
    "kind_of",
    "load",
    "read_entries",
    "read_parameters",
    "save",
    "take",
]

FORMAT_VERSION = 1
"""The ``pyuss_backup`` number of the file format."""

UNKNOWN_KIND = profiles.UNKNOWN_KIND
"""The ``profile`` of a backup of a drive of unknown kind (no profile named, none shown)."""


def kind_of(drive: Drive) -> str:
    """The ``profile`` a backup of ``drive`` records: its named profile, else `UNKNOWN_KIND`."""
    return drive.profile.name if drive.profile_named else UNKNOWN_KIND


IDENTITY_WORDS = ("firmware", "version", "serial", "identif", "drive type", "device type")
"""Words in a parameter's name that make it an identity parameter (when the profile names
none itself)."""

MAX_TIMEOUTS = 3
"""A drive that answers this many jobs in a row with nothing is gone: the backup stops."""

MAX_INTEGER = 2**64
"""Integers of a backup stay below this in magnitude."""

Progress = Callable[[int, int, str], object]


@dataclass(frozen=True, slots=True)
class Entry:
    """One parameter of a backup (``index`` None: a simple parameter or a whole array)."""

    pnu: int
    index: int | None = None
    name: str = ""
    unit: str = ""
    type: str | None = None
    value: Any = None
    """The value as read (typed; a list for a whole array; bytes as hex text), or None."""
    raw: tuple[int, ...] = ()
    """The words as they travelled (in the files as hex text, ``"4120 0000"``)."""
    access: str = ""
    """``rw``, ``ro`` or ``protected`` where known."""
    error: dict[str, Any] | None = None
    """Why it could not be read: ``message`` and, for a refusal, ``number`` and ``meaning``."""
    names: NameStyle = field(default=NameStyle.PROJECT, compare=False)
    """How the drive's family writes parameter numbers (`label`; not in the files)."""

    @property
    def label(self) -> str:
        """``P1120``, ``r0021``, ``P947.0``: as the drive's family writes it."""
        return param_name(self.pnu, self.index, style=self.names, read_only=self.access == "ro")

    @property
    def ok(self) -> bool:
        return self.error is None

    def text(self, info: ParamInfo | None = None) -> str:
        """The value as printed (``10.00 s``) or the error."""
        if self.error is not None:
            return f"(not read: {self.error.get('message', 'error')})"
        if info is not None:
            try:
                return format_value(info, self.value)
            except (TypeError, ValueError, AssertionError):
                pass
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.value}{unit}"

    @classmethod
    def of(cls, reading: Reading) -> Entry:
        info = reading.info
        return cls(
            reading.pnu,
            reading.index,
            info.name if info else "",
            info.unit if info else "",
            info.type_name if info else None,
            json_value(reading.value),
            reading.words,
            info.access.value if info else "",
            names=info.names if info else NameStyle.PROJECT,
        )

    def to_dict(self) -> dict[str, Any]:
        """The entry as the files hold it (no null values: TOML has none)."""
        data: dict[str, Any] = {"pnu": self.pnu}
        if self.index is not None:
            data["index"] = self.index
        data["label"] = self.label
        data["name"] = self.name
        if self.unit:
            data["unit"] = self.unit
        if self.type is not None:
            data["type"] = self.type
        if self.access:
            data["access"] = self.access
        if self.error is None:
            data["value"] = self.value
            data["raw"] = raw_text(self.raw)
        else:
            data["error"] = dict(self.error)
        return data

    @classmethod
    def from_dict(cls, data: Any, where: str) -> Entry:
        """An entry read from a file; `ConfigError` naming the entry and field if broken."""
        if not isinstance(data, dict):
            raise ConfigError(f"{where}: not a table of fields")
        pnu, index = data.get("pnu"), data.get("index")
        if isinstance(pnu, str):  # written by hand: r0021, P947.1 (pyuss.params.names)
            try:
                pnu, named = parse_param_name(pnu)
            except ConfigError as exc:
                raise ConfigError(f"{where}: field 'pnu': {exc}") from None
            if named is not None and index is not None and index != named:
                raise ConfigError(f"{where}: field 'pnu' names index {named}, 'index' {index}")
            index = named if named is not None else index
        if isinstance(pnu, bool) or not isinstance(pnu, int) or pnu < 0:
            raise ConfigError(f"{where}: field 'pnu' must be a parameter number")
        where = f"{where} ({param_name(pnu)})"
        if index is not None and (
            isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 254
        ):
            raise ConfigError(f"{where}: field 'index' must be 0..254")
        for key in ("name", "unit", "type", "access", "label"):
            if key in data and not isinstance(data[key], str):
                raise ConfigError(f"{where}: field {key!r} must be text")
        error = data.get("error")
        if error is not None:
            if not isinstance(error, dict) or not isinstance(error.get("message", ""), str):
                raise ConfigError(f"{where}: field 'error' must be a table with a message")
            value, raw = None, tuple[int, ...]()
        else:
            if "value" not in data:
                raise ConfigError(f"{where}: field 'value' missing (and no 'error')")
            value = data["value"]
            if not _plain_value(value):
                raise ConfigError(f"{where}: field 'value' must be a number, text or list")
            problem = _number_problem(value)
            if problem is not None:
                raise ConfigError(f"{where}: field 'value': {problem}")
            raw = raw_words(data.get("raw", ""), where)
        return cls(
            pnu,
            index,
            data.get("name", ""),
            data.get("unit", ""),
            data.get("type"),
            value,
            raw,
            data.get("access", ""),
            error,
        )


def _names_of(profile: str) -> NameStyle:
    """How the family of the built-in ``profile`` writes parameter numbers (the project's
    style for a profile this pyuss does not know)."""
    from pyuss.profiles import get_profile

    try:
        return get_profile(profile).database().profile.names
    except ConfigError:
        return NameStyle.PROJECT


def raw_text(words: Sequence[int]) -> str:
    """The raw words as the files hold them: hex, blank between words (``4120 0000``)."""
    return " ".join(f"{w:04X}" for w in words)


def raw_words(text: Any, where: str) -> tuple[int, ...]:
    """Words back from `raw_text` (`ConfigError` naming the entry when it is not that)."""
    if not isinstance(text, str):
        raise ConfigError(f"{where}: field 'raw' must be hex words such as \"4120 0000\"")
    try:
        words = tuple(int(part, 16) for part in text.split())
    except ValueError:
        raise ConfigError(f"{where}: field 'raw' must be hex words such as \"4120 0000\"") from None
    if any(not 0 <= w <= 0xFFFF for w in words):
        raise ConfigError(f"{where}: field 'raw' has a word beyond FFFF")
    return words


def _number_problem(value: Any) -> str | None:
    """Why ``value`` (or an element of it) is a number no parameter holds, or None: infinity,
    NaN, or an integer beyond 64 bits (the words of a parameter carry 32)."""
    for number in value if isinstance(value, list) else [value]:
        if isinstance(number, float) and not math.isfinite(number):
            return f"{number} is not a finite number"
        if isinstance(number, int) and abs(number) >= MAX_INTEGER:
            digits = str(abs(number))
            return f"{digits[:6]}... ({len(digits)} digits) is beyond the range of any parameter"
    return None


def _plain_value(value: Any) -> bool:
    if isinstance(value, list):
        return all(_plain_value(v) and not isinstance(v, list) for v in value)
    return isinstance(value, int | float | str) and not isinstance(value, bool)


@dataclass(slots=True)
class Backup:
    """A drive's parameter set with the header that says whose it is."""

    address: int
    profile: str
    entries: list[Entry] = field(default_factory=list)
    date: str = ""
    """When it was taken, ISO 8601 in UTC."""
    identity: list[Entry] = field(default_factory=list)
    """The drive's identity parameters (firmware, type ...) where it has them."""
    port: str = ""
    source: str = ""
    """The file it was read from ('' for one taken from a drive)."""

    def find(self, pnu: int, index: int | None = None) -> Entry | None:
        for entry in self.entries:
            if entry.pnu == pnu and entry.index == index:
                return entry
        return None

    @property
    def failed(self) -> list[Entry]:
        return [e for e in self.entries if not e.ok]

    def to_dict(self) -> dict[str, Any]:
        return {
            "pyuss_backup": FORMAT_VERSION,
            "address": self.address,
            "profile": self.profile,
            "date": self.date,
            "port": self.port,
            "count": len(self.entries),
            "identity": [e.to_dict() for e in self.identity],
            "parameter": [e.to_dict() for e in self.entries],
        }

    @classmethod
    def from_dict(cls, data: Any, where: str) -> Backup:
        if not isinstance(data, dict) or data.get("pyuss_backup") is None:
            raise ConfigError(f"{where}: not a pyuss backup (no 'pyuss_backup' field)")
        if data["pyuss_backup"] != FORMAT_VERSION:
            raise ConfigError(
                f"{where}: backup format {data['pyuss_backup']!r}, this pyuss reads "
                f"{FORMAT_VERSION}"
            )
        address = data.get("address")
        if isinstance(address, bool) or not isinstance(address, int) or not 0 <= address <= 31:
            raise ConfigError(f"{where}: field 'address' must be 0..31")
        for key in ("profile", "date", "port"):
            if not isinstance(data.get(key, ""), str):
                raise ConfigError(f"{where}: field {key!r} must be text")
        if not data.get("profile"):
            raise ConfigError(f"{where}: field 'profile' missing")
        params = data.get("parameter", [])
        ident = data.get("identity", [])
        if not isinstance(params, list) or not isinstance(ident, list):
            raise ConfigError(f"{where}: 'parameter' and 'identity' must be lists of tables")
        count = data.get("count")
        if isinstance(count, bool) or not isinstance(count, int):
            raise ConfigError(f"{where}: field 'count' missing")
        if count != len(params):
            raise ConfigError(
                f"{where}: the header counts {count} parameters, the file holds {len(params)} "
                "(cut short or edited by hand?)"
            )
        style = _names_of(data["profile"])
        entries = [
            replace(Entry.from_dict(p, f"{where}: parameter {n}"), names=style)
            for n, p in enumerate(params, 1)
        ]
        seen: set[tuple[int, int | None]] = set()
        for entry in entries:
            if (entry.pnu, entry.index) in seen:
                raise ConfigError(f"{where}: {entry.label} is in the file twice")
            seen.add((entry.pnu, entry.index))
        return cls(
            address,
            data["profile"],
            entries,
            data.get("date", ""),
            [
                replace(Entry.from_dict(p, f"{where}: identity {n}"), names=style)
                for n, p in enumerate(ident, 1)
            ],
            data.get("port", ""),
            where,
        )


# -- reading a drive --------------------------------------------------------------------------


def identity_parameters(drive: Drive) -> list[tuple[int, int | None]]:
    """The parameters that say which drive it is: those the profile's identity rules read
    (`pyuss.profiles.base.IdentityRule`) if it has any, else the known parameters whose name
    speaks of firmware, version, serial number or type."""
    rules = getattr(drive.profile, "identity", None) if drive.profile_named else None
    if rules:
        found: list[tuple[int, int | None]] = []
        for rule in rules:
            key = (int(rule.pnu), getattr(rule, "index", None))
            if rule.pnu in drive.params and key not in found and getattr(rule, "present", True):
                found.append(key)
        return found
    return [
        (info.pnu, None)
        for info in drive.params
        if any(word in info.name.casefold() for word in IDENTITY_WORDS)
    ]


class LayoutTooSmall(UssError):
    """The telegram layout cannot carry the parameter's value: not asked, nothing sent."""


def beyond_layout(layout: Layout, info: ParamInfo | None) -> str | None:
    """Why a value of ``info`` cannot travel in ``layout`` (a 32-bit value in PKW 3, whose one
    PWE word carries 16 bits, C 4.2.3), or None."""
    if info is None or layout.variable or layout.pkw == 0 or info.words <= layout.pkw - 2:
        return None
    needs = "PKW 4 or the variable layout" if info.words <= 2 else "the variable layout"
    return (
        f"needs {needs}: its {info.type_name} value takes {info.words} words, layout "
        f"{layout} carries {layout.pkw - 2}"
    )


def error_dict(exc: UssError) -> dict[str, Any]:
    """``type``, ``message``, for a refusal ``number`` and ``meaning``, and ``hint`` (what to
    do) where the error carries one."""
    data: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, DriveRefusal):
        data.update(number=exc.number, meaning=exc.meaning)
    hint = getattr(exc, "hint", "")
    if hint:
        data["hint"] = hint
    return data


async def read_parameters(
    drive: Drive,
    wanted: Sequence[tuple[int, int | None]],
    *,
    progress: Progress | None = None,
) -> list[Entry]:
    """Read each ``(pnu, index)`` (index None: simple or whole array) into an `Entry`; a
    parameter that fails is recorded with its error and the others are still read. Stops with
    the drive's `UssTimeout` when it answered `MAX_TIMEOUTS` jobs in a row with nothing."""
    entries: list[Entry] = []
    silent = 0
    for done, (pnu, index) in enumerate(wanted):
        if progress is not None:
            progress(done, len(wanted), drive.params.label(pnu, index))
        info = drive.params.get(pnu)
        try:
            too_long = beyond_layout(drive.layout, info)
            if too_long is not None:
                raise LayoutTooSmall(f"{drive.params.label(pnu, index)}: {too_long}")
            reading = await drive.read_param(pnu, index)
        except ConfigError:
            raise
        except UssError as exc:
            silent = silent + 1 if isinstance(exc, UssTimeout) else 0
            if silent >= MAX_TIMEOUTS:
                raise
            entries.append(
                Entry(
                    pnu,
                    index,
                    info.name if info else "",
                    info.unit if info else "",
                    info.type_name if info else None,
                    access=info.access.value if info else "",
                    error=error_dict(exc),
                    names=drive.params.names,
                )
            )
            continue
        silent = 0
        entries.append(Entry.of(reading))
    if progress is not None:
        progress(len(wanted), len(wanted), "")
    return entries


async def read_entries(
    drive: Drive,
    backup: Backup,
    entries: Sequence[Entry] | None = None,
    *,
    progress: Progress | None = None,
) -> list[Entry]:
    """What ``drive`` holds now of the parameters of ``backup``'s ``entries`` (default: all
    of them), as `read_parameters`; a parameter the drive's book cannot take (a number beyond
    the family's, an index beyond the array) is a `ConfigError` naming the file."""
    wanted = backup.entries if entries is None else entries
    try:
        return await read_parameters(drive, [(e.pnu, e.index) for e in wanted], progress=progress)
    except ConfigError as exc:
        raise ConfigError(f"{backup.source or 'the backup'}: {exc}") from None


async def scan(drive: Drive, pnus: Iterable[int], *, progress: Progress | None = None) -> list[int]:
    """The parameters of ``pnus`` the drive has. Known ones are not asked for. The others are
    found as `Drive.info` finds what is known of a parameter: by their descriptions (C 6),
    learnt into the drive's book, where the book's policy asks for them; for a drive without
    descriptions (none expected of its profile, or one refused or not answered) by reading the
    value (request 1): a parameter is there unless the drive refuses it with error 0
    ("illegal parameter number", C Table 4.3). A drive that answers nothing at all ends the
    scan with its `UssTimeout`."""
    candidates = list(pnus)
    found = []
    for done, pnu in enumerate(candidates):
        if progress is not None:
            progress(done, len(candidates), f"{drive.params.label(pnu)}?")
        if pnu in drive.params:
            found.append(pnu)
            continue
        try:
            if await drive.info(pnu) is None:
                await drive.read_raw(pnu)
        except DriveRefusal as refusal:
            if refusal.number != ErrorNumber.ILLEGAL_PNU:
                found.append(pnu)  # there, though not to be read as asked
            continue
        except JobTimeout as silence:
            if not silence.sent:
                raise  # the drive answers nothing at all
            continue
        except ConfigError:
            raise
        except UssError:
            continue
        found.append(pnu)
    if progress is not None:
        progress(len(candidates), len(candidates), "")
    return found


async def take(
    drive: Drive,
    *,
    pnus: Sequence[int] | None = None,
    port: str = "",
    progress: Progress | None = None,
    now: Callable[[], float] = time.time,
) -> Backup:
    """A backup of ``drive``: every parameter its book knows (or ``pnus``), arrays whole."""
    numbers = sorted(set(drive.params.pnus() if pnus is None else pnus))
    identity = await read_parameters(drive, identity_parameters(drive))
    entries = await read_parameters(drive, [(p, None) for p in numbers], progress=progress)
    date = datetime.fromtimestamp(now(), UTC).isoformat(timespec="seconds")
    return Backup(drive.address, kind_of(drive), entries, date, identity, port)


# -- files --------------------------------------------------------------------------------------

FORMATS = ("toml", "json", "csv")


def file_format(path: str | Path, given: str | None = None) -> str:
    """``toml``, ``json`` or ``csv``: ``given``, else from the file name's ending."""
    fmt = given or Path(path).suffix.lstrip(".").lower()
    if fmt not in FORMATS:
        raise ConfigError(
            f"{path}: give a file ending in .toml, .json or .csv (or --format), not {fmt!r}"
        )
    return fmt


def dumps(backup: Backup, fmt: str) -> str:
    """The text of a backup file."""
    if fmt == "json":
        return json.dumps(backup.to_dict(), indent=1) + "\n"
    if fmt == "csv":
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(["pnu", "index", "label", "name", "value", "unit", "type", "raw", "error"])
        for entry in backup.entries:
            value = entry.value if entry.ok else ""
            if isinstance(value, list):
                value = " ".join(str(v) for v in value)
            writer.writerow(
                [
                    entry.pnu,
                    "" if entry.index is None else entry.index,
                    entry.label,
                    entry.name,
                    value,
                    entry.unit,
                    entry.type or "",
                    raw_text(entry.raw),
                    "" if entry.error is None else entry.error.get("message", ""),
                ]
            )
        return out.getvalue()
    head = f"# pyuss parameter backup of drive {backup.address} ({backup.profile}), {backup.date}\n"
    return head + tomlwrite.dumps(backup.to_dict())


def check_new(path: str | Path, *, overwrite: bool = False) -> None:
    """`ConfigError` naming ``path`` when a backup cannot be written there: a folder, a folder
    missing, a device, pipe or socket (never replaced, even with ``overwrite``: the file would
    take its place), or (unless ``overwrite``) a file that is there already."""
    target = check_target(path, "the backup")
    check_regular(target, "a backup goes into a file of its own")
    if not overwrite and (target.exists() or target.is_symlink()):
        raise ConfigError(f"{target} exists: --force replaces it, or give another file name")


def save(
    backup: Backup, path: str | Path, fmt: str | None = None, *, overwrite: bool = True
) -> None:
    """Write ``backup`` to ``path`` atomically (format from the ending or ``fmt``); an
    existing file is replaced only with ``overwrite``."""
    fmt = file_format(path, fmt)
    check_new(path, overwrite=overwrite)
    write_atomically(path, dumps(backup, fmt).encode("utf-8"), "the backup")


def load(path: str | Path) -> Backup:
    """Read and check a backup file (TOML or JSON); `ConfigError` naming what is wrong."""
    path = Path(path)
    return loads(read_text(path, "the backup"), str(path))


def loads(text: str, where: str = "<backup>") -> Backup:
    if text.lstrip().startswith("{"):
        data = parse_json(text, where, problem="broken JSON")
    else:
        data = parse_toml(text, where, problem="not a TOML or JSON backup")
    return Backup.from_dict(data, where)


def with_entries(backup: Backup, entries: list[Entry]) -> Backup:
    return replace(backup, entries=entries)
