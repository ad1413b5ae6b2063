"""What both sides of `pyuss.system` share."""

from __future__ import annotations

from pyuss.errors import ConfigError

__all__ = ["PTY_ADVICE", "NoPty"]

PTY_ADVICE = (
    "pseudo-terminals exist on Linux and macOS only: on Windows give a COM port (COM3), "
    "tcp://HOST:PORT or bus://HOST:PORT instead, or make a pair of COM ports with com0com "
    "(docs/platforms.md)"
)


class NoPty(ConfigError):
    """A pseudo-terminal was asked for where the system has none (Windows)."""
