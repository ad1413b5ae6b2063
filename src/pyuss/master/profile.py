"""What the master needs to know about a device profile: the master's view of it.

A `MasterProfile` holds the few facts the master side uses:

- how a parameter number travels (PKE bits 0..10 and, for profiles that define it, IND bits
  10..15, C 4.2.1.3, C Table 4.7, NOTES 8): `MasterProfile.encode_pnu` /
  `MasterProfile.decode_pnu`;
- the meaning of device error numbers above 100 in a response 7 (C Table 4.3);
- timing: the response delay limit the master waits (A 5.2.1.1, NOTES 10) and the start pause
  in character times (A 5.1.2, NOTES 2: a profile may demand more than 2);
- the telegram layout the drives of the profile use (fixed only, or also variable, C 7);
- how array elements are counted (from 0 or 1) and which parameter description layout the
  drives use (C 6);
- the broadcast form (the appendix's Broadcast Enable Array or a profile's own form, NOTES 9);
- whether answers repeat IND (some early drives answer IND 0 always).

`resolve_profile` turns a name (or a profile object of `pyuss.profiles`) into a
`MasterProfile`; `GENERIC` is the specification's own drive profile (part C) and the default.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyuss.errors import ConfigError
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import MAX_PNU, Pkw, error_meaning
from pyuss.protocol.timing import MAX_RESPONSE_DELAY, START_PAUSE_CHARS

__all__ = [
    "GENERIC",
    "BroadcastForm",
    "DescriptionStyle",
    "MasterProfile",
    "resolve_profile",
]


class BroadcastForm(enum.Enum):
    """How a profile's drives read a broadcast telegram (NOTES 9)."""

    ENABLE_ARRAY = "enable-array"
    """The appendix: a 4-word Broadcast Enable Array in the PKW area."""
    MASKED_CONTROL = "masked-control"
    """Baumueller (seed 004, NOTES 9): the control word merged through the mask in PWE1."""


class DescriptionStyle(enum.Enum):
    """Which parameter description (PBE) layout the drives use (C 6)."""

    PROFIBUS = "profibus"
    BAUMUELLER = "baumueller"


def _plain_encode(pnu: int) -> tuple[int, int]:
    return pnu, 0


def _plain_decode(bits: int, index: int) -> int:
    del index
    return bits


@dataclass(frozen=True)
class MasterProfile:
    """The master's view of a device profile (see the module docstring)."""

    name: str = "generic"
    default_layout: Layout = field(default_factory=lambda: Layout(4, 2))
    fixed_only: bool = False
    index_base: int = 1
    max_pnu: int = MAX_PNU
    response_delay: float = MAX_RESPONSE_DELAY
    start_pause_chars: float = START_PAUSE_CHARS
    error_meanings: Mapping[int, str] = field(default_factory=dict)
    description: DescriptionStyle = DescriptionStyle.PROFIBUS
    broadcast: BroadcastForm = BroadcastForm.ENABLE_ARRAY
    index_in_answers: bool = True
    pnu_encoder: Callable[[int], tuple[int, int]] = _plain_encode
    pnu_decoder: Callable[[int, int], int] = _plain_decode

    def encode_pnu(self, pnu: int) -> tuple[int, int]:
        """``(PNU bits for PKE, bits for IND 10..15 already in place)`` for parameter ``pnu``;
        `ConfigError` when the profile cannot address it."""
        if isinstance(pnu, bool) or not isinstance(pnu, int) or pnu < 0:
            raise ConfigError(f"parameter number must be a non-negative integer, got {pnu!r}")
        if pnu > self.max_pnu:
            how = (
                "the PKE holds 11 bits (C 4.2.1.3); a profile that extends the number "
                "through IND bits (for example micromaster4) reaches further"
                if self.max_pnu <= MAX_PNU
                else f"profile {self.name} reaches P{self.max_pnu}"
            )
            raise ConfigError(f"P{pnu} is out of range 0..{self.max_pnu}: {how}")
        bits, high = self.pnu_encoder(pnu)
        return bits, high

    def decode_pnu(self, pkw: Pkw) -> int:
        """The parameter number a PKW area names (inverse of `encode_pnu`)."""
        return self.pnu_decoder(pkw.pnu, pkw.index)

    def meaning(self, number: int) -> str:
        """The meaning of error ``number`` of a response 7 (C Table 4.3 and the profile)."""
        return error_meaning(number, self.error_meanings)

    def answers(self, answer: Pkw, request: Pkw) -> bool:
        """True when ``answer`` belongs to ``request`` (C 4.2.1.1): `Pkw.is_answer_to`, the
        same parameter number as the profile reads it, and IND only where the drives repeat it.
        """
        if not self.index_in_answers:
            answer = Pkw(answer.id, answer.pnu, request.index, answer.spm_toggle, answer.values)
        if not answer.is_answer_to(request):
            return False
        return self.decode_pnu(answer) == self.decode_pnu(request)

    def check_layout(self, layout: Layout) -> Layout:
        """``layout`` if the profile's drives can use it, else `ConfigError`."""
        if self.fixed_only and layout.variable:
            raise ConfigError(
                f"profile {self.name} drives use fixed telegram lengths only; layout {layout} "
                "is variable"
            )
        return layout


GENERIC = MasterProfile()
"""The specification's drive profile (part C): PNU 0..2047, arrays from index 1 (C 3.2)."""


def _from_object(obj: Any) -> MasterProfile:
    """A `MasterProfile` from a profile object of `pyuss.profiles` (duck-typed)."""
    return MasterProfile(name=str(getattr(obj, "name", "custom")))


def resolve_profile(profile: MasterProfile | str | Any | None) -> MasterProfile:
    """The `MasterProfile` for ``profile``: None gives `GENERIC`, a name is looked up."""
    if profile is None:
        return GENERIC
    if isinstance(profile, MasterProfile):
        return profile
    if isinstance(profile, str):
        if profile == GENERIC.name:
            return GENERIC
        raise ConfigError(f"unknown profile {profile!r} (known: {GENERIC.name})")
    return _from_object(profile)
