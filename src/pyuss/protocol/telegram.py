"""The USS telegram frame: STX, LGE, ADR, net data, BCC (A 4).

A telegram on the wire is::

    STX  LGE  ADR  n net bytes  BCC

- ``STX`` is 02h (A 4.1).
- ``LGE`` counts ADR, the n net bytes and BCC: ``LGE = n + 2``, 2..254, so a telegram has
  ``LGE + 2`` bytes in all and at most 252 net bytes (A 4.2, reading 4).
- ``ADR`` holds the slave address (bits 0..4, 0..31) and the telegram type in bits 5..7
  (A 4.3 Table 4.1, A 5.4 Table 5.2, reading 1)::

      bit 7 6 5
          0 0 0   normal telegram
          0 1 0   mirror telegram: the slave sends it back unchanged (A 5.3)
          0 0 1   broadcast: address bits not evaluated, nobody answers (A 3)
          1 0 0   special telegram: dropped by slaves without special telegrams (A 5.4)
          1 0 1   special broadcast (A 5.4)

  The other combinations (011, 110, 111) are undefined: `adr_byte` refuses them and
  `parse_adr` / `Telegram.decode` raise `AddressError` for them.
- ``BCC`` is the exclusive-or of every byte before it, STX included (A 4.4).

Words in the net data travel high byte first (A 4); that is the business of
`pyuss.protocol.layout`, not of this module, which treats net data as bytes.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from pyuss.errors import TelegramError

__all__ = [
    "MAX_ADDRESS",
    "MAX_LGE",
    "MAX_NET_BYTES",
    "MAX_TELEGRAM_BYTES",
    "MIN_LGE",
    "MIN_TELEGRAM_BYTES",
    "STX",
    "AddressError",
    "AddressMode",
    "BccError",
    "LengthError",
    "StxError",
    "Telegram",
    "adr_byte",
    "bcc",
    "parse_adr",
]

STX = 0x02
"""Start of text, the first byte of every telegram (A 4.1)."""
MIN_LGE = 2
"""Smallest LGE: ADR and BCC without net data (A 4.2, reading 4)."""
MAX_LGE = 254
"""Largest LGE: 252 net bytes (A 4.2)."""
MAX_NET_BYTES = MAX_LGE - 2
"""At most 252 net bytes (126 words) per telegram (A 4.2)."""
MIN_TELEGRAM_BYTES = MIN_LGE + 2
"""STX, LGE, ADR, BCC."""
MAX_TELEGRAM_BYTES = MAX_LGE + 2
"""256 bytes (A 4.2)."""
MAX_ADDRESS = 31
"""Slave addresses are 0..31 (ADR bits 0..4)."""

_ADDRESS_MASK = 0x1F
_MODE_MASK = 0xE0


class AddressMode(enum.IntEnum):
    """The telegram type carried in ADR bits 5..7; the value is those bits in place (A 4.3)."""

    NORMAL = 0x00
    """Normal data exchange with the addressed slave (Table 4.1: 000)."""
    MIRROR = 0x40
    """Mirror telegram: the addressed slave returns it unchanged (Table 4.1: 010, A 5.3)."""
    BROADCAST = 0x20
    """Broadcast to every slave; address bits not evaluated; no answer (Table 4.1: 001, A 3)."""
    SPECIAL = 0x80
    """Special telegram for a slave with special-telegram handling (Table 5.2: 100, A 5.4)."""
    SPECIAL_BROADCAST = 0xA0
    """Broadcast to every slave with special-telegram handling; no answer (Table 5.2: 101)."""

    @property
    def is_broadcast(self) -> bool:
        """True for the two broadcast types: no slave may answer them (A 3, A 5.4)."""
        return self in (AddressMode.BROADCAST, AddressMode.SPECIAL_BROADCAST)

    @property
    def label(self) -> str:
        """Lower-case name used in text and JSON output: ``normal``, ``mirror``, ..."""
        return self.name.lower()


class StxError(TelegramError):
    """The first byte is not STX (A 4.1)."""


class LengthError(TelegramError):
    """LGE is out of range or does not match the number of bytes (A 4.2)."""


class BccError(TelegramError):
    """The BCC byte does not match the exclusive-or of the bytes before it (A 4.4)."""

    def __init__(self, message: str, *, expected: int, received: int) -> None:
        super().__init__(message)
        self.expected = expected
        self.received = received


class AddressError(TelegramError):
    """An address out of 0..31 or an ADR bit combination the spec leaves undefined (A 4.3)."""


def adr_byte(address: int, mode: AddressMode | int = AddressMode.NORMAL) -> int:
    """The ADR byte for ``address`` (0..31) and telegram type ``mode`` (A 4.3).

    ``mode`` may be an `AddressMode` or its integer value (bits 5..7 in place); an undefined
    combination (for example 60h, mirror + broadcast) raises `AddressError`.
    """
    if not isinstance(address, int) or not 0 <= address <= MAX_ADDRESS:
        raise AddressError(f"slave address must be 0..{MAX_ADDRESS}, got {address!r}")
    try:
        kind = AddressMode(mode)
    except ValueError:
        if isinstance(mode, bool) or not isinstance(mode, int) or mode & ~_MODE_MASK:
            raise AddressError(
                f"telegram type must be ADR bits 5..7 in place (00h, 20h, 40h, 80h or A0h), "
                f"got {mode!r}"
            ) from None
        raise AddressError(
            f"ADR bits 7..5 = {mode >> 5:03b} is a combination the USS spec leaves "
            "undefined (A 4.3 Table 4.1, A 5.4 Table 5.2)"
        ) from None
    return kind.value | address


_MODES = {mode.value: mode for mode in AddressMode}
"""The telegram types by their ADR bits (a dictionary look-up costs less than the enum's)."""


def parse_adr(byte: int) -> tuple[int, AddressMode]:
    """Split an ADR byte into ``(address, mode)``; undefined combinations raise `AddressError`."""
    if not 0 <= byte <= 0xFF:
        raise AddressError(f"ADR must be a byte, got {byte!r}")
    mode = _MODES.get(byte & _MODE_MASK)
    if mode is None:
        raise AddressError(
            f"ADR {byte:02X}h: bits 7..5 = {byte >> 5:03b} is a combination the USS spec leaves "
            "undefined (A 4.3 Table 4.1, A 5.4 Table 5.2)"
        )
    return byte & _ADDRESS_MASK, mode


def bcc(data: bytes | bytearray | memoryview, initial: int = 0) -> int:
    """The block check character: exclusive-or of all bytes, starting from ``initial`` (A 4.4).

    ``bcc(frame[:-1])`` is the BCC a sender appends; over a whole valid telegram the result is 0.
    """
    n = len(data)
    if n == 0:
        return initial
    # Fold the bytes as one integer: XOR the upper half onto the lower half until one byte is left.
    x = int.from_bytes(data, "little")
    while n > 1:
        half = (n + 1) // 2
        bits = 8 * half
        x = (x & ((1 << bits) - 1)) ^ (x >> bits)
        n = half
    return x ^ initial


@dataclass(frozen=True, slots=True)
class Telegram:
    """One USS telegram: the slave ``address``, the telegram type ``mode`` and the net ``data``.

    The frame bytes (STX, LGE, ADR, BCC) are derived: `encode` builds them, `decode` checks
    them. Construction validates: address 0..31, a defined mode, at most 252 net bytes.
    """

    address: int
    mode: AddressMode
    data: bytes

    def __post_init__(self) -> None:
        if not isinstance(self.address, int) or not 0 <= self.address <= MAX_ADDRESS:
            raise AddressError(f"slave address must be 0..{MAX_ADDRESS}, got {self.address!r}")
        if not isinstance(self.mode, AddressMode):
            try:
                object.__setattr__(self, "mode", AddressMode(self.mode))
            except ValueError:
                raise AddressError(
                    f"telegram type {self.mode!r} is not one of the ADR types of A 4.3"
                ) from None
        if not isinstance(self.data, bytes):
            if not isinstance(self.data, bytearray | memoryview):
                raise TelegramError(f"net data must be bytes, got {type(self.data).__name__}")
            object.__setattr__(self, "data", bytes(self.data))
        if len(self.data) > MAX_NET_BYTES:
            raise LengthError(
                f"{len(self.data)} net bytes do not fit a telegram (at most {MAX_NET_BYTES})"
            )

    @property
    def lge(self) -> int:
        """LGE: net bytes + 2 (ADR and BCC)."""
        return len(self.data) + 2

    @property
    def adr(self) -> int:
        """The ADR byte."""
        return self.mode.value | self.address

    @property
    def expects_answer(self) -> bool:
        """False for broadcasts, which no slave may answer (A 3, A 5.4)."""
        return not self.mode.is_broadcast

    def encode(self) -> bytes:
        """The telegram's bytes on the wire, BCC included."""
        frame = bytes((STX, len(self.data) + 2, self.mode.value | self.address)) + self.data
        return frame + bytes((bcc(frame),))

    @classmethod
    def decode(cls, raw: bytes | bytearray | memoryview, *, check_bcc: bool = True) -> Telegram:
        """Parse exactly one telegram. Raises a `TelegramError` subclass naming what is wrong:
        `StxError`, `LengthError` (too short, LGE out of range or not matching the byte count),
        `BccError` (unless ``check_bcc`` is false) or `AddressError` (undefined ADR).
        """
        raw = bytes(raw)
        if len(raw) < MIN_TELEGRAM_BYTES:
            raise LengthError(
                f"{len(raw)} bytes are too short for a telegram "
                f"(at least {MIN_TELEGRAM_BYTES}: STX, LGE, ADR, BCC)"
            )
        if raw[0] != STX:
            raise StxError(f"first byte is {raw[0]:02X}h, not STX (02h)")
        lge = raw[1]
        if not MIN_LGE <= lge <= MAX_LGE:
            raise LengthError(f"LGE {lge} is out of range {MIN_LGE}..{MAX_LGE}")
        if len(raw) != lge + 2:
            raise LengthError(f"LGE {lge} announces {lge + 2} bytes, got {len(raw)}")
        if check_bcc:
            expected = bcc(raw[:-1])
            if expected != raw[-1]:
                raise BccError(
                    f"BCC is {raw[-1]:02X}h, expected {expected:02X}h",
                    expected=expected,
                    received=raw[-1],
                )
        address, mode = parse_adr(raw[2])
        return cls(address, mode, raw[3:-1])
