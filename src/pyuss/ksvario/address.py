"""KS VARIO address map (KS VARIO interface description 9.2, docs/references.md item 11).

One 16-bit address names one datum of one area in one of three views:

* integer / FixPoint1: bits 15-14 format (00 integer, 01 FixPoint1), bits 13-9 area,
  bits 8-0 datum (0..511);
* float: bit 15 = 1, bits 14-10 area, bits 9-0 the float offset, which is 2 x datum
  ("Die Float-Modbusadressen sind also mit 2 zu multiplizieren", 9.2).

Areas: 0 device data, 1 visualisation area (the main process data of all 30 channels),
2..31 controller channels 1..30.

The interface description's example 4.5.4 addresses limit L of channel 30 as FD09h, an odd float
offset (109h).
The word is kept as given (an `Address` stores the raw offset, so FD09h decodes and encodes to
itself); the datum an odd float offset reaches is ``offset // 2``, the same datum as the even
offset below it. This is the project's reading; the interface description gives no rule for odd
offsets.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass

from pyuss.errors import ConfigError

#: Number of controller channels a KS VARIO bus coupler serves (9.2).
CHANNELS = 30
#: Data per area in the integer view (9 bits).
DATA_PER_AREA = 512
#: The FixPoint1 view adds 4000h to the integer address (9.2).
FIXPOINT1_OFFSET = 0x4000
#: The float view sets bit 15 (9.2).
FLOAT_OFFSET = 0x8000


class View(enum.IntEnum):
    """How a datum travels: 16-bit integer, 16-bit FixPoint1 (one decimal) or 32-bit float."""

    INTEGER = 0
    FIXPOINT1 = 1
    FLOAT = 2


class Area(enum.IntEnum):
    """The two special areas; areas 2..31 are channels 1..30 (`channel_area`)."""

    DEVICE = 0
    VISUALISATION = 1


def channel_area(channel: int) -> int:
    """Area number of controller channel 1..30 (channel + 1)."""
    if not 1 <= channel <= CHANNELS:
        raise ConfigError(f"channel {channel} is out of range 1..{CHANNELS}")
    return channel + 1


@dataclass(frozen=True, slots=True)
class Address:
    """One address word, decoded. ``offset`` is the raw low field: the datum number in the
    integer and FixPoint1 views (0..511), 2 x datum in the float view (0..1023)."""

    view: View
    area: int
    offset: int

    def __post_init__(self) -> None:
        if not 0 <= self.area <= 31:
            raise ConfigError(f"area {self.area} is out of range 0..31")
        limit = 1024 if self.view is View.FLOAT else DATA_PER_AREA
        if not 0 <= self.offset < limit:
            raise ConfigError(
                f"offset {self.offset} is out of range 0..{limit - 1} ({self.view.name})"
            )

    @classmethod
    def of(cls, view: View, area: int, datum: int) -> Address:
        """The address of ``datum`` (0..511) of ``area`` in ``view``."""
        if not 0 <= datum < DATA_PER_AREA:
            raise ConfigError(f"datum {datum} is out of range 0..{DATA_PER_AREA - 1}")
        return cls(view, area, 2 * datum if view is View.FLOAT else datum)

    @classmethod
    def channel(cls, channel: int, datum: int, view: View = View.INTEGER) -> Address:
        """The address of ``datum`` of controller channel 1..30."""
        return cls.of(view, channel_area(channel), datum)

    @classmethod
    def decode(cls, word: int) -> Address:
        """Decode a 16-bit address word (9.2)."""
        if not 0 <= word <= 0xFFFF:
            raise ConfigError(f"address {word} is not a 16-bit word")
        if word & 0x8000:
            return cls(View.FLOAT, (word >> 10) & 0x1F, word & 0x3FF)
        view = View.FIXPOINT1 if word & 0x4000 else View.INTEGER
        return cls(view, (word >> 9) & 0x1F, word & 0x1FF)

    def encode(self) -> int:
        """The 16-bit address word."""
        if self.view is View.FLOAT:
            return FLOAT_OFFSET | (self.area << 10) | self.offset
        base = FIXPOINT1_OFFSET if self.view is View.FIXPOINT1 else 0
        return base | (self.area << 9) | self.offset

    def __int__(self) -> int:
        return self.encode()

    @property
    def datum(self) -> int:
        """The datum number within the area (0..511)."""
        return self.offset // 2 if self.view is View.FLOAT else self.offset

    @property
    def channel_number(self) -> int | None:
        """Channel 1..30, or None for the device and visualisation areas."""
        return self.area - 1 if self.area >= 2 else None

    def as_view(self, view: View) -> Address:
        """The same datum seen through ``view`` (integer <-> FixPoint1 <-> float)."""
        if view is self.view:
            return self
        return Address.of(view, self.area, self.datum)

    def __str__(self) -> str:
        if self.area == Area.DEVICE:
            where = "device"
        elif self.area == Area.VISUALISATION:
            where = "visualisation"
        else:
            where = f"channel {self.area - 1}"
        return f"{self.encode():04X}h ({self.view.name.lower()}, {where}, datum {self.datum:#x})"


_VIEW_NAMES = {
    "int": View.INTEGER,
    "integer": View.INTEGER,
    "fix": View.FIXPOINT1,
    "fix1": View.FIXPOINT1,
    "fixpoint1": View.FIXPOINT1,
    "float": View.FLOAT,
    "real": View.FLOAT,
}


def _parse_number(text: str) -> int:
    t = text.strip().lower()
    try:
        if t.startswith("0x"):
            return int(t[2:], 16)
        if t.endswith("h"):
            return int(t[:-1], 16)
        return int(t, 10)
    except ValueError:
        raise ValueError(f"{text!r} is not a number (0x4496, 4496h or 17558)") from None


def parse_address(text: str) -> Address:
    """Parse an address a user typed.

    Accepted: a word in hex (``0x4496``, ``4496h``) or decimal (``17558``), or the symbolic
    form ``VIEW:AREA:DATUM`` with VIEW ``int|fix1|float``, AREA ``dev``, ``vis`` or ``chN``
    (N = 1..30) and DATUM a number (``fix1:ch1:0x96`` is 4496h).
    """
    t = text.strip()
    try:
        if ":" in t:
            parts = t.lower().split(":")
            if len(parts) != 3:
                raise ValueError("expected VIEW:AREA:DATUM")
            view_name, area_name, datum_text = parts
            if view_name not in _VIEW_NAMES:
                raise ValueError(f"unknown view {view_name!r} (int, fix1, float)")
            if area_name in ("dev", "device"):
                area = int(Area.DEVICE)
            elif area_name in ("vis", "visualisation", "visualization"):
                area = int(Area.VISUALISATION)
            elif re.fullmatch(r"ch\d+", area_name):
                area = channel_area(int(area_name[2:]))
            else:
                raise ValueError(f"unknown area {area_name!r} (dev, vis, ch1..ch30)")
            return Address.of(_VIEW_NAMES[view_name], area, _parse_number(datum_text))
        return Address.decode(_parse_number(t))
    except ConfigError as exc:
        raise ConfigError(f"bad address {text!r}: {exc}") from None
    except ValueError as exc:
        raise ConfigError(f"bad address {text!r}: {exc}") from None
