"""The Wireshark dissector shipped with pyuss: where it is, and installing it.

The Lua file is package data (``pyuss/monitor/wireshark/uss.lua``). Wireshark loads Lua
plugins from its personal plugins folder: ``~/.local/lib/wireshark/plugins`` on Linux and
macOS, ``%APPDATA%\\Wireshark\\plugins`` on Windows (Wireshark 2.5 and later; Help > About
Wireshark > Folders shows it; ``tshark -G folders``: "Personal Lua Plugins"). `install` copies
the file there (atomically: the name only ever holds a whole file). It replaces an earlier copy
of pyuss's dissector, recognised by its first line, but not a ``uss.lua`` of someone else's
unless told to (``force``).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from pyuss import system
from pyuss.atomicfile import write_atomically
from pyuss.errors import ConfigError

__all__ = ["DISSECTOR_NAME", "InstallConflict", "dissector_source", "install", "plugin_dir"]

DISSECTOR_NAME = "uss.lua"
_FIRST_LINE = (
    b'-- USS (Siemens "Universal Serial Interface") dissector for Wireshark, shipped with pyuss.'
)


class InstallConflict(ConfigError):
    """The plugins folder holds a ``uss.lua`` that is not pyuss's dissector."""


def dissector_source() -> Path:
    """The path of the shipped ``uss.lua``."""
    path = Path(str(resources.files("pyuss.monitor") / "wireshark" / DISSECTOR_NAME))
    if not path.is_file():
        raise ConfigError(f"the Wireshark dissector is missing from the installation: {path}")
    return path


def plugin_dir(home: Path | None = None) -> Path:
    """Wireshark's personal Lua plugins folder for this user."""
    return system.wireshark_plugin_folder(home)


def install(directory: Path | None = None, *, force: bool = False) -> tuple[Path, str]:
    """Copy the dissector into ``directory`` (default: `plugin_dir`). Returns the installed path
    and what happened: ``installed``, ``updated`` (an earlier copy of pyuss's dissector was
    replaced) or ``up to date`` (an identical copy was there, nothing written).

    A ``uss.lua`` there that is not pyuss's raises `InstallConflict` unless ``force``; a
    ``directory`` that is a file, or cannot be written, raises `ConfigError`."""
    source = dissector_source().read_bytes()
    target_dir = plugin_dir() if directory is None else Path(directory)
    target = target_dir / DISSECTOR_NAME
    if target_dir.exists() and not target_dir.is_dir():
        raise ConfigError(f"cannot install the dissector into {target_dir}: not a folder")
    try:
        old = target.read_bytes() if target.is_file() else None
    except OSError:
        old = None
    if target.exists() and old is None and not force:
        raise InstallConflict(f"{target} exists and is not a file; move it away first")
    if old == source:
        return target, "up to date"
    if old is not None and not old.startswith(_FIRST_LINE) and not force:
        raise InstallConflict(
            f"{target} exists and is not the pyuss dissector: move it away, or use --force "
            "to replace it"
        )
    try:
        target_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(
            f"cannot install the dissector into {target_dir}: {exc.strerror}"
        ) from None
    write_atomically(target, source, "the dissector")
    return target, "installed" if old is None else "updated"
