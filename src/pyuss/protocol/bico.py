"""BICO sources in the parameter value: which connector or binector a SINAMICS input reads.

A SINAMICS drive of firmware 4 (G120C, G120 with CU240E-2, CU230P-2) wires its functions by
BICO: a signal sink such as p0840 (ON/OFF1) holds the number of the signal source it reads,
r0722.2 (digital input 2) or r2090.0 (bit 0 of the control word received over the fieldbus).
Over USS such a value travels as two PWE words (SINAMICS G120C Operating Instructions 02/2023,
8.6, table "Parameter value or connector"; the G120X Operating Instructions 06/2019, 6.3.6.7,
work the example p0840[1] = 722.2 through)::

    PWE1  bits 15..0   number of the source parameter            722  -> 02D2h
    PWE2  bits 15..10  3Fh (the drive object; always 63 on G120)  3Fh
          bits  9..0   index or bit number of the source           2  -> FC02h

so ``p0840[1] = r722.2`` is PWE1 02D2h, PWE2 FC02h, and as one 32-bit value (high word
first, as a U32 parameter travels) 02D2FC02h.

`Bico` is that value: an `int` (the 32-bit word pair, so it goes wherever an unsigned 32-bit
value goes: the parameter memory, the EEPROM store, the PKW codec) that knows its source
parameter and index and prints as ``r722.2``. `parse_bico` reads what a person writes:
``r722.2``, ``722.2``, ``r0722.2``, ``r722[2]``, ``r722`` (index 0); anything else is
refused with a `BicoError` that says what a source looks like. Pure: no I/O.

Not here: which parameters are BICO inputs (the parameter file's ``bico = true``), and the
value of a sink connected to a fixed 0 or 1, which no page read gives in this form (a pair of
words without 3Fh in PWE2 bits 15..10 is no `Bico`: `from_raw` refuses it).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from pyuss.errors import ConfigError

__all__ = [
    "DRIVE_OBJECT",
    "MAX_INDEX",
    "MAX_SOURCE",
    "Bico",
    "BicoError",
    "is_bico",
    "parse_bico",
    "to_bico",
]

DRIVE_OBJECT = 0x3F
"""PWE2 bits 15..10 of a BICO value: the drive object, 63 on SINAMICS G120."""

MAX_SOURCE = 0xFFFF
"""The highest source parameter number PWE1 can carry."""

MAX_INDEX = 0x3FF
"""The highest index or bit number PWE2 bits 9..0 can carry."""

_MARK = DRIVE_OBJECT << 10
_SOURCE = re.compile(r"[rRpP]?0*([0-9]+)(?:\.([0-9]+)|\[([0-9]+)\])?")
EXAMPLE = "a source such as r722.2 (parameter 722, index or bit 2), 722.2 or r2090[0]"


class BicoError(ConfigError):
    """A text or a pair of words that is no BICO source."""


class Bico(int):
    """A BICO source: parameter ``pnu``, index or bit ``index``; its `int` value is the
    32-bit word pair PWE1 << 16 | PWE2 (see the module text)."""

    __slots__ = ()

    def __new__(cls, pnu: int, index: int = 0) -> Bico:
        if isinstance(pnu, bool) or not isinstance(pnu, int) or not 0 <= pnu <= MAX_SOURCE:
            raise BicoError(f"the source parameter must be 0..{MAX_SOURCE}, not {pnu!r}")
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= MAX_INDEX:
            raise BicoError(f"the source index must be 0..{MAX_INDEX}, not {index!r}")
        return super().__new__(cls, pnu << 16 | _MARK | index)

    @classmethod
    def from_raw(cls, raw: int) -> Bico:
        """The source a 32-bit value carries; `BicoError` when PWE2 bits 15..10 are not 3Fh."""
        if isinstance(raw, Bico):
            return raw
        if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw <= 0xFFFF_FFFF:
            raise BicoError(f"a BICO value is a 32-bit word pair, not {raw!r}")
        if raw & 0xFC00 != _MARK:
            raise BicoError(
                f"{raw >> 16:04X}h {raw & 0xFFFF:04X}h is no BICO source: PWE2 bits 15..10 "
                f"are {(raw >> 10) & 0x3F:02X}h, not {DRIVE_OBJECT:02X}h"
            )
        return cls(raw >> 16, raw & MAX_INDEX)

    @classmethod
    def from_words(cls, words: Sequence[int]) -> Bico:
        """The source PWE1, PWE2 carry."""
        if len(words) != 2 or any(not 0 <= w <= 0xFFFF for w in words):
            raise BicoError(f"a BICO value takes two 16-bit words, not {list(words)!r}")
        return cls.from_raw(words[0] << 16 | words[1])

    @property
    def pnu(self) -> int:
        """The source parameter (PWE1)."""
        return int(self) >> 16

    @property
    def index(self) -> int:
        """The source's index or bit number (PWE2 bits 9..0)."""
        return int(self) & MAX_INDEX

    @property
    def words(self) -> tuple[int, int]:
        """(PWE1, PWE2)."""
        return (int(self) >> 16, int(self) & 0xFFFF)

    def text(self) -> str:
        """``r722.2``."""
        return f"r{self.pnu}.{self.index}"

    def __str__(self) -> str:
        return self.text()

    def __repr__(self) -> str:
        return f"Bico({self.pnu}, {self.index})"

    def __format__(self, spec: str) -> str:
        return self.text() if not spec else format(int(self), spec)


def is_bico(raw: int) -> bool:
    """Whether a 32-bit value carries a BICO source (3Fh in PWE2 bits 15..10)."""
    return 0 <= raw <= 0xFFFF_FFFF and raw & 0xFC00 == _MARK


def parse_bico(text: str) -> Bico:
    """The source ``text`` names (see the module text); `BicoError` otherwise."""
    if not isinstance(text, str):
        raise BicoError(f"{text!r} is not {EXAMPLE}")
    match = _SOURCE.fullmatch(text.strip())
    if match is None:
        raise BicoError(f"{text!r} is not {EXAMPLE}")
    pnu = int(match.group(1))
    index_text = match.group(2) if match.group(2) is not None else match.group(3)
    index = 0 if index_text is None else int(index_text)
    if pnu > MAX_SOURCE:
        raise BicoError(f"{text!r}: the source parameter must be 0..{MAX_SOURCE}")
    if index > MAX_INDEX:
        raise BicoError(f"{text!r}: the index or bit must be 0..{MAX_INDEX}")
    return Bico(pnu, index)


def to_bico(value: object) -> Bico:
    """``value`` - a `Bico`, its text or its 32-bit value - as a `Bico`; `BicoError` for
    anything else."""
    if isinstance(value, str):
        return parse_bico(value)
    if isinstance(value, int) and not isinstance(value, bool):
        return Bico.from_raw(value)
    raise BicoError(f"{value!r} is not {EXAMPLE}")
