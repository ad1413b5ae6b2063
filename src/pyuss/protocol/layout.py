"""The net data layout: how many PKW and PZD words a telegram carries (C 2, C 3, C 4.1, C 7).

A layout is the pair of interface parameters PKW_ANZ and PZD_ANZ (C 3.1):

- PKW 0 (no parameter channel), 3 (PKE, IND, PWE1), 4 (PKE, IND, PWE1, PWE2) or 127 =
  `PKW_VARIABLE` (PKE, IND and m PWE words, 1 <= m <= 124 - PZD; C 4.1.2, reading 5).
- PZD 0..16 words (C 2).
- At most 126 words of net data (252 bytes, A 4.2).

Fixed layouts have the same length in both directions (C 7); with the variable layout the PZD
count stays fixed and the PKW area grows with the job.

Packing places PWE words by the rules of C 4.2.3 and reading 6: with PKW 4 a single word goes to
PWE2 and PWE1 is 0; with PKW 3 and the variable layout it goes to PWE1; a double word is
PWE1 = high, PWE2 = low; a PKW area without values is filled with zeros up to its minimum
(3 or 4 words; 3 for the variable layout). Unpacking returns the PWE words exactly as received,
so ``pack(unpack(data)) == data``; `pyuss.protocol.pkw.Pkw.word` reads a word from PWE1 or
PWE2 as the count of words says.

Values that do not fit the layout raise `ConfigError` when packing (the caller asked for
something impossible), bytes that do not fit it raise `TelegramError` when unpacking.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.frozen import builder
from pyuss.protocol.pkw import Pkw, unpacked_pkw

__all__ = ["MAX_PZD", "MAX_WORDS", "PKW_VARIABLE", "Layout", "NetData"]

PKW_VARIABLE = 127
"""PKW_ANZ value for a variable-length PKW area (C 3.1)."""
MAX_PZD = 16
"""At most 16 PZD words (C 2)."""
MAX_WORDS = 126
"""At most 126 words (252 bytes) of net data (A 4.2, C 3.1)."""

_PKW_CHOICES = (0, 3, 4, PKW_VARIABLE)
_VARIABLE_WORDS = ("v", "var", "variable", "127")
_NO_JOB = Pkw(0)


@cache
def _words(count: int) -> struct.Struct:
    """The struct of ``count`` big-endian words (compiled once per count)."""
    return struct.Struct(f">{count}H")


def _check_pzd(pzd: Sequence[int]) -> None:
    """Refuse PZD words that are not 16-bit words, naming the first one."""
    for i, word in enumerate(pzd, 1):
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"PZD{i} must be a 16-bit word 0..65535, got {word!r}")


@dataclass(frozen=True, slots=True)
class NetData:
    """The unpacked net data: the PKW area (None for PKW 0) and the PZD words."""

    pkw: Pkw | None
    pzd: tuple[int, ...]


_net_data = builder(NetData)
"""`NetData` of words unpacked from a telegram (`pyuss.protocol.frozen.builder`)."""


@dataclass(frozen=True, slots=True)
class Layout:
    """PKW word count (0, 3, 4 or `PKW_VARIABLE`) and PZD word count (0..16)."""

    pkw: int
    pzd: int

    def __post_init__(self) -> None:
        if isinstance(self.pkw, bool) or self.pkw not in _PKW_CHOICES:
            raise ConfigError(f"PKW count must be 0, 3, 4 or 127 (variable), got {self.pkw!r}")
        if isinstance(self.pzd, bool) or not isinstance(self.pzd, int):
            raise ConfigError(f"PZD count must be an integer 0..{MAX_PZD}, got {self.pzd!r}")
        if not 0 <= self.pzd <= MAX_PZD:
            raise ConfigError(f"PZD count must be 0..{MAX_PZD}, got {self.pzd}")

    @classmethod
    def parse(cls, text: str) -> Layout:
        """Read ``"PKW,PZD"``: PKW is 0, 3, 4 or ``v`` (also ``var``, ``variable``, ``127``),
        PZD 0..16; for example ``"3,2"``, ``"v,2"``, ``"4,0"``."""
        parts = [p.strip().lower() for p in str(text).split(",")]
        if len(parts) != 2 or not parts[1].isdigit():
            raise ConfigError(
                f"bad layout {text!r}: expected PKW,PZD such as 3,2 or v,2 "
                "(PKW 0, 3, 4 or v; PZD 0..16)"
            )
        if parts[0] in _VARIABLE_WORDS:
            pkw = PKW_VARIABLE
        elif parts[0].isdigit():
            pkw = int(parts[0])
        else:
            raise ConfigError(f"bad layout {text!r}: PKW must be 0, 3, 4 or v, got {parts[0]!r}")
        return cls(pkw, int(parts[1]))

    def __str__(self) -> str:
        return f"{'v' if self.variable else self.pkw},{self.pzd}"

    @property
    def variable(self) -> bool:
        """True for the variable-length PKW area (PKW_ANZ 127)."""
        return self.pkw == PKW_VARIABLE

    @property
    def max_pwe(self) -> int:
        """How many PWE words the PKW area can hold: 0, 1, 2, or 124 - PZD when variable."""
        if self.variable:
            return MAX_WORDS - 2 - self.pzd
        return max(self.pkw - 2, 0)

    @property
    def words(self) -> int | None:
        """Net data words of a fixed layout; None for the variable one."""
        return None if self.pkw == PKW_VARIABLE else self.pkw + self.pzd

    @property
    def lge(self) -> int | None:
        """LGE of every telegram of a fixed layout (``2 x words + 2``); None when variable.
        This is the value a `pyuss.protocol.receiver.Receiver` takes in ``fixed_lengths``."""
        return None if self.pkw == PKW_VARIABLE else 2 * (self.pkw + self.pzd) + 2

    # -- packing --------------------------------------------------------------------------

    def _pwe(self, pkw: Pkw) -> tuple[int, ...]:
        values = pkw.values
        if self.variable:
            if len(values) > self.max_pwe:
                raise ConfigError(
                    f"{len(values)} PWE words do not fit layout {self}: the variable PKW area "
                    f"holds at most {self.max_pwe} with {self.pzd} PZD (C 4.1.2)"
                )
            return values or (0,)
        if self.pkw == 3:
            if len(values) > 1:
                raise ConfigError(
                    f"{len(values)} PWE words do not fit layout {self}: PKW 3 holds one word; "
                    "a double word needs PKW 4, longer values the variable layout (C 7)"
                )
            return values or (0,)
        if len(values) > 2:
            raise ConfigError(
                f"{len(values)} PWE words do not fit layout {self}: PKW 4 holds two words; "
                "longer values need the variable layout (C 7)"
            )
        return (0, *values) if len(values) == 1 else (values or (0, 0))

    def pack(self, pkw: Pkw | None, pzd: Sequence[int]) -> bytes:
        """The net data bytes for a PKW area and PZD words; ``pkw=None`` with a PKW area sends
        "no job" (all zero)."""
        if len(pzd) != self.pzd:
            raise ConfigError(f"layout {self} carries {self.pzd} PZD words, got {len(pzd)}")
        words: list[int] = []
        if self.pkw:
            job = pkw if pkw is not None else _NO_JOB
            words += (job.pke, job.index, *self._pwe(job))
        elif pkw is not None:
            raise ConfigError(f"layout {self} has no PKW area, but a parameter job was given")
        for word in pzd:
            if type(word) is not int or not 0 <= word <= 0xFFFF:
                _check_pzd(pzd)  # not a plain word: an IntFlag is one, anything else is refused
                break
        words += pzd
        return _words(len(words)).pack(*words)

    def unpack(self, data: bytes | bytearray | memoryview) -> NetData:
        """Split net data bytes into the PKW area and the PZD words."""
        data = bytes(data)
        if len(data) % 2:
            raise TelegramError(f"{len(data)} net bytes are not whole words")
        count = len(data) // 2
        if self.pkw == PKW_VARIABLE:  # (`variable`, without the call: at every answer)
            least = self.pzd + 3
            if not least <= count <= MAX_WORDS:
                raise TelegramError(
                    f"{count} net data words do not fit layout {self}: the variable layout "
                    f"needs {least}..{MAX_WORDS} (PKE, IND, at least one PWE, {self.pzd} PZD)"
                )
            pkw_words = count - self.pzd
        else:
            if count != self.pkw + self.pzd:
                raise TelegramError(
                    f"{count} net data words do not fit layout {self}: it needs "
                    f"{self.pkw + self.pzd} ({len(data)} bytes instead of "
                    f"{2 * (self.pkw + self.pzd)})"
                )
            pkw_words = self.pkw
        words = _words(count).unpack(data)
        pkw = unpacked_pkw(words[:pkw_words]) if pkw_words else None
        return _net_data(pkw, words[pkw_words:])
