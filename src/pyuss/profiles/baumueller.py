"""``baumueller``: USS as Baumueller drives implement it (Baumueller manual part 2).

- Fixed telegram length only (2, 2.4): PKW 0, 3 or 4 words (parameter 183), PZD 0..3 words
  (parameter 184, 2.2.2); a double-word parameter needs PKW 4 (2.4).
- Start pause of 33 bit times (3 characters) before master and slave telegrams (2.1).
- The drive answers within 2 ms (2.5, parameter 181 bit 2). With the response-delay mode on
  (181 bit 2 = 1) it first processes the request and then answers, at a moment that is not
  precisely known: the project allows up to the 20 ms of A 5.2.1.1. Without it, the answer sent
  is the one prepared after the previous request ("une imbrication des reponses"): the slave
  engine implements that pipeline.
- Request IDs 0..4 only (2.2.1: no job, read value, write word, write double word, read
  description element); the others are answered with 102 "service not implemented". The Baumueller
  manual
  lists no spontaneous messages: none are sent.
- Parameter description elements 1 (attribute), 2 (info), 5 (minimum) and 6 (maximum) with the
  bit layouts of 2.2.1 (the drive's ``baumueller`` description style); other elements: 104.
- Error numbers 101 unspecified fault, 102 service not implemented, 103 format too large for the
  PKW area, 104 description element does not exist (2.2.1 "Liste des indicatifs de defauts").
- Broadcast (2.2, reading 9): the control word in PZD1 is merged through the mask in PWE1, only
  with PKW >= 3, PZD >= 2 and request ID 0; with PKW 0 it is taken unmasked; setpoints and PKW
  jobs are not taken. With "broadcast coding" (181 bit 1, PKW >= 3, PZD >= 3) PZD2 (high word)
  and PZD3 (low word) hold a 32-bit mask of the addresses that react: bit n = address n (the
  figure of the Baumueller manual's example with addresses 0, 9 and 23 was lost; the project
  numbers the
  bits from the least significant one). `address_mask` and `masked_control_pkw` build these
  for a master.
- Setpoint and actual value channel (185, 186, 2.5): with PZD count 2 a 16-bit value travels in
  PZD2; with count 3 a 16-bit value in PZD3, a 32-bit one as PZD2 (high word) and PZD3 (low
  word); a 32-bit value with count 2 cannot travel: USS state bit 9 (setpoint) or 8 (actual) is
  set. `value_words` and `join_value` do that mapping.

Diagnostic parameters of the slave (A 5.2.3): P190..P207, beside the USS parameters 180..186.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from pyuss.drive.faults import MEANINGS
from pyuss.errors import ConfigError
from pyuss.profiles.base import BitRef, BroadcastForm, Profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import MAX_ADDRESS

__all__ = [
    "ACTUAL_FORMAT_FAULT",
    "BROADCAST_CODING",
    "DELAY_MODE",
    "MODE_PNU",
    "PROFILE",
    "SETPOINT_FORMAT_FAULT",
    "STATE_PNU",
    "address_mask",
    "addresses_in_mask",
    "join_value",
    "masked_control_pkw",
    "value_words",
]

STATE_PNU = 180
"""USS state (2.5, parameter 180)."""
MODE_PNU = 181
"""USS mode (2.5, parameter 181)."""
SETPOINT_PNU = 185
"""ID of the parameter the setpoint of the master telegram is written to."""
ACTUAL_PNU = 186
"""ID of the parameter sent back as actual value."""
BROADCAST_CODING = BitRef(MODE_PNU, 1)
DELAY_MODE = BitRef(MODE_PNU, 2)
ACTUAL_FORMAT_FAULT = 1 << 8
"""USS state bit 8: the actual value's format does not fit the PZD count."""
SETPOINT_FORMAT_FAULT = 1 << 9
"""USS state bit 9: the setpoint's format does not fit the PZD count."""

PROFILE = Profile(
    name="baumueller",
    title="Baumueller drive (USS with fixed telegram length)",
    follows="Baumueller manual part 2",
    manufacturer="Baumueller",
    default_layout=Layout(3, 2),
    pkw_choices=(0, 3, 4),
    max_pzd=3,
    start_pause_chars=3.0,
    response_delay_max=0.002,
    delayed_response_max=0.020,
    broadcast=BroadcastForm.MASKED_CONTROL,
    request_ids=frozenset(range(5)),
    error_meanings={n: MEANINGS[n] for n in (101, 102, 103, 104)},
    too_large_error=103,
    unsupported_error=102,
    diagnostic_pnu=190,
    delay_mode=DELAY_MODE,
    broadcast_coding=BROADCAST_CODING,
)


def address_mask(addresses: Iterable[int]) -> tuple[int, int]:
    """The broadcast coding words ``(PZD2, PZD3)`` that select ``addresses`` (bit n =
    address n; PZD2 holds bits 16..31, PZD3 bits 0..15)."""
    mask = 0
    for address in addresses:
        if isinstance(address, bool) or not isinstance(address, int):
            raise ConfigError(f"bus address must be an integer 0..{MAX_ADDRESS}, got {address!r}")
        if not 0 <= address <= MAX_ADDRESS:
            raise ConfigError(f"bus address must be 0..{MAX_ADDRESS}, got {address}")
        mask |= 1 << address
    return mask >> 16, mask & 0xFFFF


def addresses_in_mask(high: int, low: int) -> frozenset[int]:
    """The addresses a broadcast coding ``(PZD2, PZD3)`` selects."""
    mask = (high & 0xFFFF) << 16 | (low & 0xFFFF)
    return frozenset(a for a in range(MAX_ADDRESS + 1) if mask >> a & 1)


def masked_control_pkw(mask: int, pkw_count: int = 3) -> Pkw:
    """The PKW area of a masked control-word broadcast: request ID 0, PWE1 = ``mask``.

    With a PKW area of 4 words a single value would travel in PWE2 (C 4.2.3), so PWE2 is given
    explicitly as 0 and the mask stays in PWE1, where the drives read it (reading 9)."""
    if isinstance(mask, bool) or not isinstance(mask, int) or not 0 <= mask <= 0xFFFF:
        raise ConfigError(f"control word mask must be 0..FFFFh, got {mask!r}")
    if pkw_count not in (3, 4):
        raise ConfigError(f"the masked broadcast needs a PKW area of 3 or 4 words, not {pkw_count}")
    return Pkw(0, values=(mask,) if pkw_count == 3 else (mask, 0))


def value_words(value: int, pzd_count: int, *, double: bool) -> tuple[int, ...] | None:
    """The PZD words from PZD2 on that carry a setpoint or actual value (2.5, 185/186):
    ``pzd_count`` 2: a 16-bit value in PZD2; 3: a 16-bit value in PZD3 (PZD2 = 0) or a 32-bit
    value as PZD2 = high, PZD3 = low. None when the value cannot travel (a 32-bit value with
    count 2); an empty tuple for counts 0 and 1 (no value channel)."""
    if pzd_count < 2:
        return ()
    if double:
        if pzd_count == 2:
            return None
        raw = value & 0xFFFF_FFFF
        return (raw >> 16, raw & 0xFFFF)
    raw16 = value & 0xFFFF
    return (raw16,) if pzd_count == 2 else (0, raw16)


def join_value(words: Sequence[int], *, double: bool, signed: bool) -> int | None:
    """The setpoint carried by the PZD words from PZD2 on (the inverse of `value_words`);
    None when there is no value channel or the value cannot travel."""
    count = len(words) + 1
    if count < 2:
        return None
    if double:
        if count == 2:
            return None
        raw = (words[0] << 16) | words[1]
        return raw - (1 << 32) if signed and raw & 0x8000_0000 else raw
    raw = words[0] if count == 2 else words[1]
    return raw - 0x10000 if signed and raw & 0x8000 else raw
