"""The optional Siemens broadcast mechanism: the Broadcast Enable Array (appendix, C 5.2.3).

A broadcast telegram (ADR bit 5) carries the same net data layout as the individual ones; its
4-word PKW area holds the Broadcast Enable Array instead of a parameter job (C 5.2.3,
appendix, reading 9):

- word a: bit 0 is the broadcast flag, bit k (1..15) enables PZD word k;
- words b, c, d: enable single bits of PZD words 1, 4 and 5 (which may be command words).

A received broadcast is applied word by word (appendix table):

=================  ==================================================
PZD word           taken from the broadcast when
=================  ==================================================
1                  a bit 1, and only the bits set in b
2, 3               a bit 2, a bit 3
4                  a bit 4, and only the bits set in c
5                  a bit 5, and only the bits set in d
6 .. 15            a bits 6 .. 15
16                 never (not broadcast-capable)
=================  ==================================================

Everything not enabled keeps the value of the last non-broadcast telegram, so the ``previous``
image given to `apply_broadcast` must be the PZD of the last *non-broadcast* telegram (a slave
keeps that image and applies each broadcast to it). An array whose flag (word a bit 0) is not
set enables nothing: `apply_broadcast` then returns ``previous`` unchanged.

Baumueller's masked control word (reading 9) is a different mechanism and belongs to its profile.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.pkw import Pkw

__all__ = ["BROADCAST_FLAG", "BroadcastEnableArray", "apply_broadcast"]

BROADCAST_FLAG = 0x0001
"""Word a bit 0: the array is a Broadcast Enable Array."""

_BIT_WORDS = {1: "b", 4: "c", 5: "d"}
_LAST_WORD = 15


@dataclass(frozen=True, slots=True)
class BroadcastEnableArray:
    """The four words a, b, c, d of the appendix."""

    a: int
    b: int = 0
    c: int = 0
    d: int = 0

    def __post_init__(self) -> None:
        for name in "abcd":
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF:
                raise ConfigError(f"enable word {name} must be 0..FFFFh, got {value!r}")

    @classmethod
    def from_selection(
        cls, words: Iterable[int] = (), bits: Mapping[int, int] | None = None
    ) -> BroadcastEnableArray:
        """Build the array from what the broadcast shall set: ``words`` are PZD word numbers
        (1..15) taken whole; ``bits`` maps PZD word 1, 4 or 5 to the mask of its bits to take.
        A word 1, 4 or 5 listed in ``words`` without a mask is taken whole (all 16 bits
        enabled, as the appendix asks). The flag bit is always set.
        """
        a = BROADCAST_FLAG
        masks = {1: 0, 4: 0, 5: 0}
        for number in words:
            if number == 16:
                raise ConfigError("PZD word 16 is never taken from a broadcast (appendix)")
            if isinstance(number, bool) or not isinstance(number, int) or not 1 <= number <= 15:
                raise ConfigError(f"PZD word numbers are 1..15, got {number!r}")
            a |= 1 << number
            if number in masks:
                masks[number] = 0xFFFF
        for number, mask in (bits or {}).items():
            if number not in _BIT_WORDS:
                raise ConfigError(
                    f"single bits can be enabled in PZD words 1, 4 and 5 only, got word {number}"
                )
            if isinstance(mask, bool) or not isinstance(mask, int) or not 0 <= mask <= 0xFFFF:
                raise ConfigError(f"bit mask for PZD word {number} must be 0..FFFFh, got {mask!r}")
            a |= 1 << number
            masks[number] = mask
        return cls(a, masks[1], masks[4], masks[5])

    @classmethod
    def from_words(cls, words: Sequence[int]) -> BroadcastEnableArray:
        """Read the array from the 4 words of a broadcast's PKW area."""
        if len(words) != 4:
            raise TelegramError(
                f"a Broadcast Enable Array has 4 words (PKW 4), got {len(words)} (C 5.2.3)"
            )
        return cls(*words)

    @classmethod
    def from_pkw(cls, pkw: Pkw) -> BroadcastEnableArray:
        """Read the array from an unpacked PKW area (layout with PKW 4)."""
        return cls.from_words(pkw.words())

    def to_pkw_words(self) -> tuple[int, int, int, int]:
        """The four words a, b, c, d for the PKW area."""
        return (self.a, self.b, self.c, self.d)

    def to_pkw(self) -> Pkw:
        """The array as a `Pkw`, to pack with a PKW 4 layout."""
        return Pkw.from_words(self.to_pkw_words())

    @property
    def flag(self) -> bool:
        """Word a bit 0, the broadcast flag."""
        return bool(self.a & BROADCAST_FLAG)

    @property
    def enabled_words(self) -> frozenset[int]:
        """PZD word numbers enabled in word a (1..15)."""
        return frozenset(k for k in range(1, _LAST_WORD + 1) if self.a >> k & 1)

    def mask(self, word: int) -> int:
        """The bit mask the broadcast applies to PZD ``word`` (1-based): 0 when not enabled,
        b/c/d for words 1/4/5, FFFFh for the other enabled words, 0 for word 16."""
        if not self.flag or not 1 <= word <= _LAST_WORD or not self.a >> word & 1:
            return 0
        name = _BIT_WORDS.get(word)
        return int(getattr(self, name)) if name else 0xFFFF


def apply_broadcast(
    previous: Sequence[int], received: Sequence[int], bea: BroadcastEnableArray
) -> list[int]:
    """The PZD image after a broadcast: each bit from ``received`` where ``bea`` enables it,
    from ``previous`` (the last non-broadcast telegram's PZD) everywhere else."""
    if len(previous) != len(received):
        raise TelegramError(
            f"the broadcast carries {len(received)} PZD words, the image has {len(previous)}"
        )
    result = []
    for number, (old, new) in enumerate(zip(previous, received, strict=True), 1):
        mask = bea.mask(number)
        result.append((old & ~mask & 0xFFFF) | (new & mask))
    return result
