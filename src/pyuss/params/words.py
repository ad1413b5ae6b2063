"""Control and status words as a person reads them: the word in hex and what its set bits mean.

One line, the same on every face (`uss read`, `uss status`, `uss monitor --profile`, the web
page, the gateway's MQTT state)::

    0231h  ready to switch on, no OFF2, no OFF3, control requested

- the word in four hex digits with ``h``, then two blanks;
- the bits that are 1, lowest first, each by what its 1 means, separated by ``", "``;
  ``no bit set`` for 0000h;
- bits 0..10 by the USS specification (control word C Tables 5.2..5.4, status word C Tables
  5.5, 5.6: `pyuss.protocol.pzd.CONTROL_BITS`, `STATUS_BITS`), the same on every family;
- bits 11..15 by the drive's family (`Profile.control_bits`, `Profile.status_bits`: the
  SINAMICS/MICROMASTER "reverse", NORD's "parameter set bit 0"); a bit the family marks
  low-active ("motor overload (0 = active)") reads as what its 1 means ("no motor
  overload"); a bit the family does not name, and every bit 11..15 of a drive of unknown
  kind (no profile), reads ``bit 11``.

The notes in parentheses of a meaning (``(rising edge)``, ``(process data valid)``) are left
out, so the line stays short; the bit tables (`bit_names`) keep one name per bit, different
from every other bit's name of that word, so a line names each set bit unmistakably.
`word_kind` tells whether a parameter is the family's control or status word (the parameter
file's ``[drive]`` roles ``control_word`` and ``status_word``: Siemens r0054 and r0052).
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pyuss.errors import ConfigError
from pyuss.protocol.pzd import CONTROL_BITS, STATUS_BITS

if TYPE_CHECKING:  # the module loads neither: `uss decode` starts without the drive model
    from pyuss.params.model import Reading
    from pyuss.profiles.base import Profile

__all__ = [
    "NO_BIT_SET",
    "WordKind",
    "WordText",
    "bit_names",
    "changed_bits",
    "describe_word",
    "format_word",
    "reading_text",
    "word_kind",
    "word_of",
]

NO_BIT_SET = "no bit set"
"""What the line says of a word without a bit set (0000h)."""

_STANDARD_BITS = 11
_LOW_ACTIVE = "(0 = active)"
_NOTE = re.compile(r"\s*\([^()]*\)\s*$")


class WordKind(enum.StrEnum):
    """Which word: the control word a master sends (PZD1 of a request) or the status word a
    drive answers with (PZD1 of an answer)."""

    CONTROL = "control"
    STATUS = "status"


def _short(text: str) -> str:
    """A meaning without its trailing notes in parentheses; a low-active bit's text as what
    its 1 means ("motor overload (0 = active)" -> "no motor overload")."""
    low_active = text.rstrip().endswith(_LOW_ACTIVE)
    while (short := _NOTE.sub("", text)) != text:
        text = short
    text = text.strip()
    if low_active:
        text = "no " + text.removesuffix(" active")
    return text


def bit_names(kind: WordKind, profile: Profile | None = None) -> dict[int, str]:
    """What a 1 means in each bit 0..15 of the word (see the module text): the
    specification's for bits 0..10, the family's of ``profile`` for 11..15 (None: a drive of
    unknown kind, ``bit 11`` ...)."""
    standard = CONTROL_BITS if kind is WordKind.CONTROL else STATUS_BITS
    family: Mapping[int, str] = {}
    if profile is not None:
        family = profile.control_bits if kind is WordKind.CONTROL else profile.status_bits
    names: dict[int, str] = {}
    for bit in range(16):
        if bit < _STANDARD_BITS:
            names[bit] = _short(standard[bit][0])
        else:
            names[bit] = _short(family[bit]) if bit in family else f"bit {bit}"
    return names


@dataclass(frozen=True, slots=True)
class WordText:
    """One control or status word and the bits of it that are 1, named."""

    kind: WordKind
    word: int
    bits: tuple[tuple[int, str], ...]
    """Each bit that is 1, lowest first, with what its 1 means."""

    @property
    def hex(self) -> str:
        """``047F``."""
        return f"{self.word:04X}"

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for _, name in self.bits)

    def text(self) -> str:
        """``047Fh  ON, no OFF2, ...`` (the module text)."""
        return f"{self.hex}h  {', '.join(self.names) or NO_BIT_SET}"

    def __str__(self) -> str:
        return self.text()

    def to_dict(self) -> dict[str, Any]:
        """``word`` (the number), ``hex``, ``bits`` (each set bit: ``bit``, ``name``) and
        ``text`` (the line)."""
        return {
            "word": self.word,
            "hex": self.hex,
            "bits": [{"bit": bit, "name": name} for bit, name in self.bits],
            "text": self.text(),
        }


def describe_word(word: int, kind: WordKind, profile: Profile | None = None) -> WordText:
    """``word`` with its set bits named by ``profile``'s family (None: of unknown kind)."""
    if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
        raise ConfigError(f"a {kind} word is a 16-bit number 0..FFFFh, not {word!r}")
    names = bit_names(kind, profile)
    return WordText(kind, word, tuple((bit, names[bit]) for bit in range(16) if word >> bit & 1))


def format_word(word: int, kind: WordKind, profile: Profile | None = None) -> str:
    """The line of ``word``: ``047Fh  ON, no OFF2, ...``."""
    return describe_word(word, kind, profile).text()


def word_kind(profile: Profile | None, pnu: int, index: int | None = None) -> WordKind | None:
    """Whether parameter ``pnu`` (element ``index``) is the family's control or status word
    (its parameter file's ``[drive]`` roles); None for any other and for a drive of unknown
    kind."""
    if profile is None:
        return None
    roles = profile.database().roles
    for kind, role in ((WordKind.CONTROL, "control_word"), (WordKind.STATUS, "status_word")):
        ref = roles.get(role)
        if ref is not None and ref.pnu == pnu and ref.index in (None, index):
            return kind
    return None


def word_of(reading: Reading, profile: Profile | None) -> WordText | None:
    """The control or status word ``reading`` holds, its bits named (`word_kind`); None for
    any other parameter."""
    kind = word_kind(profile, reading.pnu, reading.index)
    if kind is None or len(reading.words) != 1:
        return None
    return describe_word(reading.words[0], kind, profile)


def reading_text(reading: Reading, profile: Profile | None) -> str:
    """The line of a value read: a control or status word as its word with the set bits
    named (``r0052 (Status word 1) = EA40h  switch-on inhibited, ...``), any other parameter
    as `Reading.text` prints it."""
    word = word_of(reading, profile)
    if word is None:
        return reading.text()
    name = f" ({reading.info.name})" if reading.info is not None and reading.info.name else ""
    return f"{reading.label}{name} = {word}"


def changed_bits(before: int, after: int, kind: WordKind, profile: Profile | None = None) -> str:
    """The bits that changed from ``before`` to ``after``, lowest first: ``+name`` for a bit
    that became 1, ``-name`` for one that became 0 (``+switch-on inhibited, -no OFF2``); ""
    when none did."""
    for word in (before, after):
        describe_word(word, kind)  # a 16-bit word, or ConfigError
    names = bit_names(kind, profile)
    return ", ".join(
        ("+" if after >> bit & 1 else "-") + names[bit]
        for bit in range(16)
        if (before ^ after) >> bit & 1
    )
