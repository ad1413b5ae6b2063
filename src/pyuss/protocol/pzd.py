"""Process data (PZD, C 5): control word, status word, setpoint and actual value scaling.

PZD1 is the control word (master to slave) or the status word (slave to master), PZD2 the main
setpoint or main actual value (C 5.1 Table 5.1). Bits 0..10 follow the PROFIBUS drive profile
(C 5.2.1, Tables 5.2..5.6); bits 11..15 are device-specific.

Several bits are "active low": the safe state is 0 and the bit must be 1 for the drive to run.
Their names say what a 1 means:

- control bit 0 `ControlWord.ON`: 1 = ON, 0 = OFF1 (ramp down, then switch off);
- control bit 1 `ControlWord.NO_OFF2` (alias ``NO_COAST_STOP``): 1 = no OFF2; 0 = OFF2, pulses
  off at once, the motor coasts;
- control bit 2 `ControlWord.NO_OFF3` (alias ``NO_QUICK_STOP``): 1 = no OFF3; 0 = OFF3, quick
  stop at the current limit;
- control bits 4 and 5: 0 sets the ramp generator output to 0 (bit 4) or freezes it (bit 5);
- status bits 4 and 5 `StatusWord.NO_OFF2`, `StatusWord.NO_OFF3`: 1 = no OFF2 / OFF3 command
  pending.

A typical start sequence sends 047Eh (OFF1 with control by PLC: leaves "switch-on inhibited")
and then 047Fh (ON).

Setpoints and actual values are normalised: 4000h = 100 % for 16-bit values, 4000 0000h =
100 % for 32-bit ones, signed (two's complement), so 16 bits span -200 % .. +199.99 %.
"""

from __future__ import annotations

import enum
import math

from pyuss.errors import ConfigError

__all__ = [
    "CONTROL_BITS",
    "FULL_SCALE_16",
    "FULL_SCALE_32",
    "STATUS_BITS",
    "SWITCHES_ON",
    "ControlWord",
    "StatusWord",
    "describe_bits",
    "join_dword",
    "percent_to_raw16",
    "percent_to_raw32",
    "raw16_to_percent",
    "raw32_to_percent",
    "split_dword",
]

FULL_SCALE_16 = 0x4000
"""16-bit raw value of 100 %."""
FULL_SCALE_32 = 0x4000_0000
"""32-bit raw value of 100 %."""


class ControlWord(enum.IntFlag):
    """PZD1 master to slave (C Tables 5.2..5.4); bits 11..15 are device-specific."""

    ON = 1 << 0
    """1 = ON (ready: main contactor on); 0 = OFF1 (ramp down, switch off)."""
    NO_OFF2 = 1 << 1
    """1 = operating condition; 0 = OFF2: pulses off at once, the motor coasts."""
    NO_OFF3 = 1 << 2
    """1 = operating condition; 0 = OFF3: quick stop, fastest possible ramp down."""
    ENABLE_OPERATION = 1 << 3
    """1 = enable operation (electronics and pulses); 0 = inhibit operation."""
    ENABLE_RAMP_GENERATOR = 1 << 4
    """1 = operating condition; 0 = ramp generator output set to 0."""
    START_RAMP_GENERATOR = 1 << 5
    """1 = ramp generator runs; 0 = ramp generator holds its current value."""
    ENABLE_SETPOINT = 1 << 6
    """1 = setpoint switched to the ramp generator input; 0 = input set to 0."""
    ACKNOWLEDGE_FAULT = 1 << 7
    """A rising edge acknowledges a fault."""
    JOG1 = 1 << 8
    """1 = jog 1 on (optional)."""
    JOG2 = 1 << 9
    """1 = jog 2 on (optional)."""
    CONTROL_BY_PLC = 1 << 10
    """1 = control from the interface, process data valid; 0 = process data ignored, the
    previous ones stay in force."""
    DEVICE_11 = 1 << 11
    DEVICE_12 = 1 << 12
    DEVICE_13 = 1 << 13
    DEVICE_14 = 1 << 14
    DEVICE_15 = 1 << 15
    NO_COAST_STOP = NO_OFF2
    NO_QUICK_STOP = NO_OFF3


SWITCHES_ON = ControlWord.ON | ControlWord.JOG1 | ControlWord.JOG2
"""The control bits of which each can set a motor turning: ON, and jog 1 and 2 (which switch a
drive on in some families)."""


class StatusWord(enum.IntFlag):
    """PZD1 slave to master (C Tables 5.5, 5.6); bits 11..15 are device-specific."""

    READY_TO_SWITCH_ON = 1 << 0
    """1 = ready to switch on (power on, electronics initialised, pulses off)."""
    READY = 1 << 1
    """1 = ready to operate (see control bit 0)."""
    OPERATION_ENABLED = 1 << 2
    """1 = operation enabled (see control bit 3)."""
    FAULT = 1 << 3
    """1 = fault, the drive is out of operation."""
    NO_OFF2 = 1 << 4
    """1 = no OFF2 command pending; 0 = OFF2 pending."""
    NO_OFF3 = 1 << 5
    """1 = no OFF3 command pending; 0 = OFF3 pending."""
    SWITCH_ON_INHIBITED = 1 << 6
    """1 = switch-on inhibited: switch on again only by OFF1 and then ON."""
    WARNING = 1 << 7
    """1 = warning, the drive keeps running."""
    IN_TOLERANCE = 1 << 8
    """1 = actual value within the tolerance band of the setpoint."""
    CONTROL_REQUESTED = 1 << 9
    """1 = the drive asks the automation system to take control; 0 = local operation only."""
    TARGET_REACHED = 1 << 10
    """1 = frequency or speed reached the comparison value; 0 = below it."""
    DEVICE_11 = 1 << 11
    DEVICE_12 = 1 << 12
    DEVICE_13 = 1 << 13
    DEVICE_14 = 1 << 14
    DEVICE_15 = 1 << 15


CONTROL_BITS: dict[int, tuple[str, str]] = {
    0: ("ON", "OFF1: ramp down and switch off"),
    1: ("no OFF2", "OFF2: coast stop, pulses off"),
    2: ("no OFF3", "OFF3: quick stop"),
    3: ("enable operation", "inhibit operation"),
    4: ("ramp generator enabled", "ramp generator output set to 0"),
    5: ("ramp generator running", "ramp generator held"),
    6: ("setpoint enabled", "setpoint set to 0"),
    7: ("acknowledge fault (rising edge)", "no acknowledge"),
    8: ("jog 1 on", "jog 1 off"),
    9: ("jog 2 on", "jog 2 off"),
    10: ("control by PLC (process data valid)", "no control by PLC (process data ignored)"),
}
"""Meaning of each standard control bit when 1 and when 0 (C Tables 5.2..5.4)."""

STATUS_BITS: dict[int, tuple[str, str]] = {
    0: ("ready to switch on", "not ready to switch on"),
    1: ("ready to operate", "not ready to operate"),
    2: ("operation enabled", "operation inhibited"),
    3: ("fault", "no fault"),
    4: ("no OFF2", "OFF2 pending"),
    5: ("no OFF3", "OFF3 pending"),
    6: ("switch-on inhibited", "switch-on not inhibited"),
    7: ("warning", "no warning"),
    8: ("actual value in tolerance", "actual value out of tolerance"),
    9: ("control requested", "local operation"),
    10: ("comparison value reached", "below comparison value"),
}
"""Meaning of each standard status bit when 1 and when 0 (C Tables 5.5, 5.6)."""


def describe_bits(word: int, table: dict[int, tuple[str, str]]) -> list[tuple[int, bool, str]]:
    """Spell out a control or status word: ``(bit, is set, meaning)`` for bits 0..15, using
    `CONTROL_BITS` or `STATUS_BITS`; bits 11..15 read "device-specific"."""
    rows = []
    for bit in range(16):
        on = bool(word >> bit & 1)
        meaning = table[bit][0 if on else 1] if bit in table else "device-specific"
        rows.append((bit, on, meaning))
    return rows


def _to_raw(percent: float, full: int, bits: int) -> int:
    if (
        isinstance(percent, bool)
        or not isinstance(percent, int | float)
        or not math.isfinite(percent)
    ):
        raise ConfigError(f"percentage must be a finite number, got {percent!r}")
    raw = round(percent * full / 100)
    low, high = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    if not low <= raw <= high:
        lo_pct, hi_pct = low * 100 / full, high * 100 / full
        raise ConfigError(f"{percent} % is outside {lo_pct:g} % .. {hi_pct:.4f} % ({bits} bits)")
    return raw & ((1 << bits) - 1)


def _to_percent(raw: int, full: int, bits: int) -> float:
    if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw < (1 << bits):
        raise ConfigError(f"raw value must be a {bits}-bit word, got {raw!r}")
    signed = raw - (1 << bits) if raw >> (bits - 1) else raw
    return signed * 100 / full


def percent_to_raw16(percent: float) -> int:
    """Percent to a 16-bit PZD word, 4000h = 100 %, negative values as two's complement."""
    return _to_raw(percent, FULL_SCALE_16, 16)


def raw16_to_percent(raw: int) -> float:
    """A 16-bit PZD word (signed) to percent, 4000h = 100 %."""
    return _to_percent(raw, FULL_SCALE_16, 16)


def percent_to_raw32(percent: float) -> int:
    """Percent to a 32-bit value, 4000 0000h = 100 % (send with `split_dword`)."""
    return _to_raw(percent, FULL_SCALE_32, 32)


def raw32_to_percent(raw: int) -> float:
    """A 32-bit value (signed) to percent, 4000 0000h = 100 %."""
    return _to_percent(raw, FULL_SCALE_32, 32)


def split_dword(value: int) -> tuple[int, int]:
    """A 32-bit value as two PZD words, high word first (C 6)."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFF_FFFF:
        raise ConfigError(f"double word must be 0..FFFFFFFFh, got {value!r}")
    return (value >> 16, value & 0xFFFF)


def join_dword(high: int, low: int) -> int:
    """Two PZD words, high word first, as one 32-bit value."""
    for word in (high, low):
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"PZD word must be 0..FFFFh, got {word!r}")
    return (high << 16) | low
