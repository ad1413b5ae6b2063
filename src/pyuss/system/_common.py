"""What both sides of `pyuss.system` share."""

from __future__ import annotations

from pyuss.errors import ConfigError

__all__ = ["PTY_ADVICE", "NoPty"]

PTY_ADVICE = (
    "pseudo-terminals exist on Linux and macOS only: on Windows serve the line with --tcp "
    "HOST:PORT or --bus-tcp HOST:PORT (masters then take tcp://HOST:PORT or bus://HOST:PORT) "
    "or on a COM port (COM3; a pair of COM ports made with com0com) (docs/platforms.md)"
)


class NoPty(ConfigError):
    """A pseudo-terminal was asked for where the system has none (Windows)."""
