"""The lines and drives of a plant, written down once: ``uss.toml``, read by every command.

The file is the gateway's configuration (`pyuss.points.config`, docs/gateway.md): each
``[[bus]]`` table is a line (name, port, baud, profile, layout) and its ``[[bus.drive]]``
tables name the drives on it. The commands take a line by name (``--line line1``; with one
line in the file it is the default) and a drive by name where they take an address
(``uss read conveyor 1120``). Options given on the command line win over the file.

Where the file is looked for, first found wins (`find`):

1. ``--config FILE``;
2. the file named by the environment variable ``USS_CONFIG``;
3. ``uss.toml`` in the working directory;
4. ``uss.toml`` in the user's configuration folder (`pyuss.system.config_folder`):
   ``%APPDATA%\\pyuss`` on Windows, ``~/Library/Application Support/pyuss`` on macOS,
   ``$XDG_CONFIG_HOME/pyuss`` (without the variable ``~/.config/pyuss``) on Linux.

No file found: the commands work as without one. The file is read through `pyuss.userfile`
and checked whole before any port opens; a bad file, an unknown line or drive name (the
message lists the names the file has) and a drive name found on two lines without
``--line`` are `ConfigError`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pyuss import system
from pyuss.errors import ConfigError
from pyuss.userfile import in_file, parse_toml, read_text

if TYPE_CHECKING:
    from pyuss.points.config import BusConfig, DriveConfig, PlantConfig

__all__ = [
    "ENVIRONMENT",
    "FILE_NAME",
    "LineFile",
    "Target",
    "candidates",
    "find",
    "is_address",
    "load",
    "looked_in",
]

ENVIRONMENT = "USS_CONFIG"
"""The environment variable naming the file."""

FILE_NAME = "uss.toml"

TOP_KEYS = ("bus", "modbus", "mqtt", "opcua", "web")
"""The tables of the file: the lines, and those of ``uss gateway`` and ``uss web``
(`pyuss.gateway.config`), which the other commands leave alone."""


def candidates() -> list[Path]:
    """Where the file is looked for without ``--config`` or ``USS_CONFIG``, in order."""
    folder = system.config_folder()
    return [Path(FILE_NAME)] if folder is None else [Path(FILE_NAME), folder / FILE_NAME]


def find(explicit: str | None = None) -> Path | None:
    """The file to read: ``explicit`` (``--config``), else ``USS_CONFIG``, else the first of
    `candidates` that exists; None when there is none. A file named explicitly need not
    exist here: reading it says what is wrong."""
    if explicit is not None:
        return Path(explicit)
    named = os.environ.get(ENVIRONMENT, "")
    if named.strip():
        return Path(named)
    for path in candidates():
        if path.is_file():
            return path
    return None


def looked_in() -> str:
    """Where the file was looked for, for a message saying that none was found."""
    return "looked for " + ", ".join([f"${ENVIRONMENT}", *(str(p) for p in candidates())])


@dataclass(frozen=True, slots=True)
class Target:
    """What the command line and the file together say: the line (None: none of the file's)
    and the drive at the address (None: not in the file)."""

    line: BusConfig | None
    drive: DriveConfig | None
    address: int | None
    profile_named: bool
    """Whether the file names the line's or the drive's profile (else the drive is of
    unknown kind)."""

    @property
    def profile(self) -> str | None:
        """The profile the file names for the drive (its own, else its line's)."""
        if self.drive is not None and self.drive.profile is not None:
            return self.drive.profile
        if self.line is not None and self.profile_named:
            return self.line.profile
        return None

    @property
    def layout(self) -> str | None:
        """The layout the file names for the drive (its own, else its line's), as PKW,PZD."""
        for layout in (self.drive and self.drive.layout, self.line and self.line.layout):
            if layout:
                return str(layout)
        return None


@dataclass(frozen=True, slots=True)
class LineFile:
    """The lines of one file."""

    path: Path
    plant: PlantConfig
    profiles: frozenset[str]
    """The lines whose table names a profile."""

    @property
    def names(self) -> list[str]:
        return [bus.name for bus in self.plant.buses]

    def line(self, name: str) -> BusConfig:
        """The line ``name``; `ConfigError` naming the file's lines."""
        for bus in self.plant.buses:
            if bus.name == name:
                return bus
        raise ConfigError(
            f"--line {name}: {self.path} has no line of that name (lines: {', '.join(self.names)})"
        )

    def drives_named(
        self, name: str, line: BusConfig | None
    ) -> list[tuple[BusConfig, DriveConfig]]:
        buses = self.plant.buses if line is None else (line,)
        return [(bus, drive) for bus in buses for drive in bus.drives if drive.name == name]

    def drive_names(self, line: BusConfig | None) -> str:
        buses = self.plant.buses if line is None else (line,)
        return "; ".join(f"{bus.name}: {', '.join(d.name for d in bus.drives)}" for bus in buses)

    def target(self, line_name: str | None, drive: str | None, *, port_given: bool) -> Target:
        """The line and drive for ``--line`` (None: not given), the drive's name or address
        (None: the command takes none) and whether ``--port`` was given."""
        line = self.line(line_name) if line_name is not None else None
        found: DriveConfig | None = None
        address: int | None = None
        if drive is not None and is_address(drive):
            address = int(drive, 0)
            if line is None and not port_given and len(self.plant.buses) == 1:
                line = self.plant.buses[0]
            if line is not None:
                found = next((d for d in line.drives if d.address == address), None)
        elif drive is not None:
            matches = self.drives_named(drive, line)
            if not matches:
                where = f"on line {line.name}" if line is not None else f"in {self.path}"
                raise ConfigError(
                    f"no drive named {drive!r} {where} (drives: {self.drive_names(line)})"
                )
            if len(matches) > 1:
                lines = " and ".join(bus.name for bus, _ in matches)
                raise ConfigError(
                    f"drive {drive!r} is on lines {lines} of {self.path}: give --line NAME"
                )
            line, found = matches[0]
            address = found.address
        if line is None and not port_given:
            if len(self.plant.buses) > 1:
                raise ConfigError(
                    f"{self.path} has lines {', '.join(self.names)}: give --line NAME (or --port)"
                )
            line = self.plant.buses[0]
        named = line is not None and line.name in self.profiles
        return Target(line, found, address, named)

    def targets(self, line: BusConfig) -> list[Target]:
        """The drives of ``line`` as the file names them, each with its profile and layout
        (its own, else its line's)."""
        return [self.target(line.name, drive.name, port_given=True) for drive in line.drives]


def is_address(text: str) -> bool:
    """Whether ``text`` is a number (an address), not a drive's name."""
    try:
        int(text, 0)
    except ValueError:
        return False
    return True


def load(path: str | os.PathLike[str]) -> LineFile:
    """The lines of the file ``path``; `ConfigError` naming the file and the key."""
    from pyuss.points.config import Where, parse_plant  # here: commands without a file start sooner

    where = Path(path)
    text = read_text(where, "the configuration")
    data = parse_toml(text, str(where))
    try:
        Where("").table(data, TOP_KEYS)
        plant = parse_plant(data.get("bus"), Where("bus"), face_keys=("modbus",))
    except ConfigError as exc:
        raise in_file(where, text, exc) from None
    raw: Sequence[object] = data["bus"]
    profiles = frozenset(
        bus.name
        for bus, table in zip(plant.buses, raw, strict=True)
        if isinstance(table, Mapping) and "profile" in table
    )
    return LineFile(where, plant, profiles)
