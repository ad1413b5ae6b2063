"""Line timing of USS: character time, start pause, residual times, response delay.

All times are in seconds (floats); nothing here reads a clock.

- Character time: one character is 11 bits (start, 8 data, even parity, stop), so
  ``char_time = 11 / baud`` (A 6.1, B 3.2).
- Start pause: at least 2 character times of silence before every STX; only an STX after a
  start pause starts a telegram (A 5.1.2, Table 5.1, reading 2). Profiles may demand more
  (Baumueller: 3 characters); the receiver takes any gap of at least the start pause as a start.
- Flush residual time: LGE, ADR, n net bytes and BCC sent back to back: ``(n + 3)`` character
  times (A 6.2).
- Maximum residual time: 1.5 times the flush residual time, counted from the end of STX
  (A 6.3, reading 3). Before LGE is known a receiver uses n = 252 (A 5.2.1.2). NORD (NORD BU 0050
  1.3.5) writes ``1.5 x (n + 4)`` counted from the start of STX: half a character more than
  A 6.3 (``1 + 1.5 x (n + 3)`` from the start of STX). A device profile that counts that way
  gives the half character as ``LineTiming(residual_extra_chars=0.5)``.
- Response delay: from the end of the request's BCC to the start of the answer's STX; at most
  20 ms, and never less than the start pause (A 5.2.1.1, reading 10). At low baud rates the start
  pause is longer than 20 ms (300 baud: 73.3 ms), so the limit is the larger of the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pyuss.errors import ConfigError
from pyuss.protocol.telegram import MAX_NET_BYTES

__all__ = [
    "BAUD_RATES",
    "BITS_PER_CHAR",
    "MAX_RESPONSE_DELAY",
    "START_PAUSE_CHARS",
    "LineTiming",
    "char_time",
    "check_baud",
    "residual_time_flush",
    "residual_time_max",
    "response_delay_limit",
    "start_pause",
    "transmit_time",
]

BAUD_RATES: tuple[int, ...] = (
    300,
    600,
    1200,
    2400,
    4800,
    9600,
    19200,
    38400,
    57600,
    76800,
    93750,
    115200,
    187500,
)
"""The 13 baud rates of B 2.4."""

BITS_PER_CHAR = 11
"""Start bit, 8 data bits, even parity, stop bit (B 3.2)."""
START_PAUSE_CHARS = 2
"""The start pause in character times (A 5.1.2)."""
MAX_RESPONSE_DELAY = 0.020
"""Response delay limit of A 5.2.1.1: 20 ms (but never below the start pause)."""


def _positive_baud(baud: float) -> float:
    if isinstance(baud, bool) or not isinstance(baud, int | float) or not baud > 0:
        raise ConfigError(f"baud rate must be a positive number, got {baud!r}")
    return baud


def check_baud(baud: int) -> int:
    """Return ``baud`` if it is one of the 13 rates of B 2.4, else raise `ConfigError`."""
    if baud not in BAUD_RATES:
        rates = ", ".join(str(b) for b in BAUD_RATES)
        raise ConfigError(f"{baud!r} is not a USS baud rate (B 2.4: {rates})")
    return baud


def char_time(baud: float) -> float:
    """Time of one 11-bit character on the line (A 6.1). Any positive baud rate is accepted."""
    return BITS_PER_CHAR / _positive_baud(baud)


def transmit_time(baud: float, nbytes: int) -> float:
    """Time to send ``nbytes`` characters back to back."""
    return nbytes * char_time(baud)


def start_pause(baud: float) -> float:
    """The minimum start pause: 2 character times (A 5.1.2, Table 5.1)."""
    return START_PAUSE_CHARS * char_time(baud)


def _check_n(n: int) -> int:
    if not isinstance(n, int) or not 0 <= n <= MAX_NET_BYTES:
        raise ConfigError(f"net byte count must be 0..{MAX_NET_BYTES}, got {n!r}")
    return n


def residual_time_flush(baud: float, n: int) -> float:
    """LGE, ADR, ``n`` net bytes and BCC back to back: ``(n + 3)`` character times (A 6.2)."""
    return (_check_n(n) + 3) * char_time(baud)


def residual_time_max(baud: float, n: int) -> float:
    """Deadline for the rest of a telegram after the end of STX: ``1.5 (n + 3)`` characters
    (A 6.3, reading 3)."""
    return 1.5 * residual_time_flush(baud, n)


def response_delay_limit(baud: float, limit: float = MAX_RESPONSE_DELAY) -> float:
    """How long a master waits for the start of an answer: ``limit`` (20 ms by A 5.2.1.1), but
    never less than the start pause (A 5.2.1.1, reading 10).

    A larger ``limit`` is accepted for devices that document a slower answer (the spec's 20 ms
    is then exceeded on purpose, by the caller's choice).
    """
    if isinstance(limit, bool) or not isinstance(limit, int | float) or not limit > 0:
        raise ConfigError(f"response delay limit must be a positive number, got {limit!r}")
    return max(float(limit), start_pause(baud))


@dataclass(frozen=True, slots=True)
class LineTiming:
    """The timing figures of one line, computed once for ``baud`` (seconds)."""

    baud: float
    char_time: float = field(init=False)
    """One 11-bit character (A 6.1)."""
    start_pause: float = field(init=False)
    """2 character times (A 5.1.2)."""
    response_delay_limit: float = field(init=False)
    """max(20 ms, start pause) (A 5.2.1.1)."""
    residual_extra_chars: float = 0.0
    """Character times a device allows beyond A 6.3's maximum residual time (NORD: 0.5)."""

    def __post_init__(self) -> None:
        extra = self.residual_extra_chars
        if isinstance(extra, bool) or not isinstance(extra, int | float) or not 0 <= extra < 252:
            raise ConfigError(f"residual_extra_chars must be 0..252 character times, not {extra!r}")
        object.__setattr__(self, "char_time", char_time(self.baud))
        object.__setattr__(self, "start_pause", start_pause(self.baud))
        object.__setattr__(self, "response_delay_limit", response_delay_limit(self.baud))

    def residual_flush(self, n: int) -> float:
        """`residual_time_flush` for this line."""
        return residual_time_flush(self.baud, n)

    def residual_max(self, n: int) -> float:
        """`residual_time_max` for this line, plus ``residual_extra_chars``;
        ``residual_max(252)`` is the deadline loaded at STX."""
        return residual_time_max(self.baud, n) + self.residual_extra_chars * self.char_time

    def transmit(self, nbytes: int) -> float:
        """Time to send ``nbytes`` characters back to back."""
        return nbytes * self.char_time
