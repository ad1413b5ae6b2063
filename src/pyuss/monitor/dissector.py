"""The Wireshark dissector shipped with pyuss: where it is, and installing it.

The Lua file is package data (``pyuss/monitor/wireshark/uss.lua``). Wireshark loads Lua
plugins from its personal plugins folder: ``~/.local/lib/wireshark/plugins`` on Linux and
macOS, ``%APPDATA%\\Wireshark\\plugins`` on Windows (Wireshark 2.5 and later; Help > About
Wireshark > Folders shows it). `install` copies the file there (atomically) unless an
identical copy is there already.
"""

from __future__ import annotations

import contextlib
import os
import sys
from importlib import resources
from pathlib import Path

from pyuss.atomicfile import write_atomically
from pyuss.errors import ConfigError

__all__ = ["DISSECTOR_NAME", "dissector_source", "install", "plugin_dir"]

DISSECTOR_NAME = "uss.lua"


def dissector_source() -> Path:
    """The path of the shipped ``uss.lua``."""
    path = Path(str(resources.files("pyuss.monitor") / "wireshark" / DISSECTOR_NAME))
    if not path.is_file():
        raise ConfigError(f"the Wireshark dissector is missing from the installation: {path}")
    return path


def plugin_dir(home: Path | None = None) -> Path:
    """Wireshark's personal Lua plugins folder for this user."""
    if sys.platform == "win32" and home is None:
        appdata = os.environ.get("APPDATA")
        if appdata:
            return Path(appdata) / "Wireshark" / "plugins"
    return (home or Path.home()) / ".local" / "lib" / "wireshark" / "plugins"


def install(directory: Path | None = None) -> tuple[Path, bool]:
    """Copy the dissector into ``directory`` (default: `plugin_dir`); returns the installed
    path and whether anything was written (False: an identical copy was there)."""
    source = dissector_source().read_bytes()
    target_dir = plugin_dir() if directory is None else Path(directory)
    target = target_dir / DISSECTOR_NAME
    with contextlib.suppress(OSError):
        if target.read_bytes() == source:
            return target, False
    try:
        target_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(
            f"cannot install the dissector into {target_dir}: {exc.strerror}"
        ) from None
    write_atomically(target, source, "the dissector")
    return target, True
