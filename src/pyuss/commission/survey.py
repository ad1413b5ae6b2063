"""A line surveyed: the drives a scan finds, who each is, and the line description
(``uss.toml``, docs/lines.md) that the other commands then read.

- `identify`: asks a drive found by `pyuss.master.scan.scan` who it is, on the scanning
  master while its rate is open: its family (`pyuss.master.identify.identify_on`) and, where
  the family's parameter file names one (the ``firmware`` role of ``[drive]``), its firmware
  version.
- `line_table`: the ``[[bus]]`` table of one line (``line1``) with a ``[[bus.drive]]`` table per
  drive (``drive<ADDRESS>``, its address and profile), at the rate most drives answered at
  (`line_rate`); `save_line` writes it atomically with `pyuss.tomlwrite`, refusing to replace
  a file unless asked.
- `bus_settings`: what to check on the drives when none answered - the parameters each family
  keeps its bus address and baud rate in (the ``[interface]`` table of its parameter file).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyuss import tomlwrite
from pyuss.atomicfile import check_regular, check_target, write_atomically
from pyuss.errors import ConfigError, UssError
from pyuss.master.identify import IDENTIFY_PROFILE, identify_on
from pyuss.master.scan import Found
from pyuss.master.scheduler import Master
from pyuss.params.model import from_parameter
from pyuss.params.values import decode, format_value
from pyuss.profiles import PROFILES, Profile, get_profile

__all__ = [
    "LINE_NAME",
    "Surveyed",
    "bus_settings",
    "identify",
    "line_rate",
    "line_table",
    "save_line",
]

LINE_NAME = "line1"
"""The name of the line `line_table` describes."""


@dataclass(frozen=True, slots=True)
class Surveyed:
    """A drive found, and what it told of itself."""

    found: Found
    family: str | None = None
    """What it is, for people ("SINAMICS V20"); None when it shows no family."""
    profile: str | None = None
    """The profile to talk to it with; None: a drive of unknown kind."""
    firmware: str | None = None
    """Its firmware version as its family's parameter shows it; None where not told."""

    @property
    def address(self) -> int:
        return self.found.address

    def to_dict(self) -> dict[str, Any]:
        return {
            **self.found.to_dict(),
            "family": self.family,
            "profile": self.profile,
            "firmware": self.firmware,
        }


async def identify(bus: Master, found: Found, *, timeout: float) -> Surveyed:
    """Who the drive ``found`` is, asked on ``bus`` (each read may take ``timeout`` seconds).
    A drive without a parameter area, one that shows no family, or one that stops answering
    is of unknown kind."""
    try:
        identity = await identify_on(bus, found.address, found.layout, timeout=timeout)
    except UssError:
        return Surveyed(found)
    if identity is None or identity.profile is None:
        return Surveyed(found)
    firmware = await _firmware(bus, found, get_profile(identity.profile), timeout)
    return Surveyed(found, identity.text, identity.profile, firmware)


async def _firmware(bus: Master, found: Found, profile: Profile, timeout: float) -> str | None:
    """The firmware version, read on the handle the identification made (the master keeps
    one profile per slave) and decoded by the family's file."""
    ref = profile.database().roles.get("firmware")
    if ref is None:
        return None
    info = from_parameter(profile.database().parameter(ref.pnu))
    drive = bus.drive(
        found.address, layout=found.layout, profile=get_profile(IDENTIFY_PROFILE), poll=False
    )
    try:
        words = await drive.read_raw(ref.pnu, ref.index, timeout=timeout)
        value = decode(info, words, ref.index)
    except UssError:
        return None
    return format_value(info, value, unit=False, texts=False)


def line_rate(drives: Sequence[Surveyed]) -> int:
    """The rate of the line: the one most drives answered at (the first of those in a tie)."""
    if not drives:
        raise ValueError("no drives")
    counts = Counter(d.found.baud for d in drives)
    best = max(counts.values())
    return next(d.found.baud for d in drives if counts[d.found.baud] == best)


def _most(values: Iterable[str]) -> str | None:
    counts = Counter(values)
    return counts.most_common(1)[0][0] if counts else None


def line_table(
    port: str, drives: Sequence[Surveyed], *, name: str = LINE_NAME
) -> tuple[dict[str, Any], list[Surveyed]]:
    """The ``[[bus]]`` table of the line at ``port`` with the drives found at its rate
    (`line_rate`), each once, and the drives left out (found at another rate only). The line
    names the layout most drives answered with and a profile only when every drive has that
    one (so a drive of unknown kind stays one); each drive names its own profile, and its
    layout where it differs from the line's."""
    baud = line_rate(drives)
    here: dict[int, Surveyed] = {}
    for drive in drives:
        if drive.found.baud == baud:
            here.setdefault(drive.address, drive)
    left = [d for d in drives if d.address not in here]
    on_line = list(here.values())
    layout = _most(str(d.found.layout) for d in on_line)
    profiles = {d.profile for d in on_line}
    table: dict[str, Any] = {"name": name, "port": port, "baud": baud}
    if len(profiles) == 1 and None not in profiles:
        table["profile"] = next(iter(profiles))
    if layout is not None:
        table["layout"] = layout
    table["drive"] = [_drive_table(d, layout) for d in on_line]
    return {"bus": [table]}, _once(left)


def _drive_table(drive: Surveyed, line_layout: str | None) -> dict[str, Any]:
    table: dict[str, Any] = {"name": f"drive{drive.address}", "address": drive.address}
    if drive.profile is not None:
        table["profile"] = drive.profile
    if str(drive.found.layout) != line_layout:
        table["layout"] = str(drive.found.layout)
    return table


def _once(drives: Iterable[Surveyed]) -> list[Surveyed]:
    seen: dict[int, Surveyed] = {}
    for drive in drives:
        seen.setdefault(drive.address, drive)
    return list(seen.values())


HEADER = "# the line as uss scan found it (docs/lines.md)\n"


def check_new(path: str | Path, *, overwrite: bool = False) -> Path:
    """`ConfigError` naming ``path`` when the line description cannot be written there: a
    folder, a folder missing, a device, or (unless ``overwrite``) a file that exists."""
    target = check_target(path, "the line description")
    check_regular(target, "the line description goes into a file of its own")
    if not overwrite and (target.exists() or target.is_symlink()):
        raise ConfigError(f"{target} exists: --force replaces it, or give another file name")
    return target


def save_line(data: dict[str, Any], path: str | Path, *, overwrite: bool = False) -> None:
    """Write the line description ``data`` (`line_table`) to ``path`` atomically."""
    check_new(path, overwrite=overwrite)
    write_atomically(path, (HEADER + tomlwrite.dumps(data)).encode("utf-8"), "the line")


def bus_settings(profile: Profile | None = None) -> list[str]:
    """Where each family keeps its bus address and baud rate (its ``[interface]`` table),
    one line per set of parameters with the profiles that share it: ``profile`` alone when
    given, else every built-in profile that names them."""
    groups: dict[str, list[str]] = {}
    for prof in (profile,) if profile is not None else PROFILES.values():
        db = prof.database()
        parts = []
        for role, what in (("baud", "baud rate"), ("address", "address")):
            ref = db.interface.get(role)
            if ref is not None:
                parts.append(f"{prof.label(ref.pnu, ref.index)} {what}")
        if parts:
            groups.setdefault(", ".join(parts), []).append(prof.name)
    return [f"{', '.join(names)}: {where}" for where, names in groups.items()]
