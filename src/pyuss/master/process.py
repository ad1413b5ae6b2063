"""Process data on the master side (C 5): the control words sent and the status received.

Control words the `Drive` commands build (C Tables 5.2..5.4):

- `OPERATE` 047Eh: every "operating condition" bit set, operation enabled, ramp generator
  enabled and running, setpoint enabled, control by the interface (bit 10), ON (bit 0) off.
  This is OFF1 with the drive under the master's control; it also leaves "switch-on inhibited".
- ``OPERATE | ON`` 047Fh: run.
- OFF2 clears bit 1 (coast stop), OFF3 bit 2 (quick stop); both clear ON as well, so that the
  drive stays off afterwards (it must pass OFF1 before ON again, C Table 5.5 bit 6).

Until the user sends a command the control word is 0000h: bit 10 clear means "no control by
the interface: process data not valid, the previous ones stay" (C Table 5.4), so a master
that only reads parameters leaves the drive alone.

`DriveStatus` is what one answer reports: the status word decoded, the actual values, and the
drive state the status bits spell out (C Tables 5.5, 5.6).
"""

from __future__ import annotations

from dataclasses import dataclass

from pyuss.protocol.pzd import (
    STATUS_BITS,
    ControlWord,
    StatusWord,
    describe_bits,
    join_dword,
    raw16_to_percent,
    raw32_to_percent,
)

__all__ = ["OPERATE", "DriveStatus", "state_of"]

OPERATE = (
    ControlWord.NO_OFF2
    | ControlWord.NO_OFF3
    | ControlWord.ENABLE_OPERATION
    | ControlWord.ENABLE_RAMP_GENERATOR
    | ControlWord.START_RAMP_GENERATOR
    | ControlWord.ENABLE_SETPOINT
    | ControlWord.CONTROL_BY_PLC
)
"""047Eh: OFF1 with every enable set and control by the interface."""


_FAULT = int(StatusWord.FAULT)
_INHIBITED = int(StatusWord.SWITCH_ON_INHIBITED)
_NO_OFF2 = int(StatusWord.NO_OFF2)
_NO_OFF3 = int(StatusWord.NO_OFF3)
_ENABLED = int(StatusWord.OPERATION_ENABLED)
_READY = int(StatusWord.READY)
_READY_TO_SWITCH_ON = int(StatusWord.READY_TO_SWITCH_ON)


def state_of(word: int) -> str:
    """The drive state the status bits show (PROFIBUS drive profile, C Tables 5.5/5.6)."""
    # plain ints: this runs for every answer a face shows, and flag arithmetic costs tenfold
    if word & _FAULT:
        return "fault"
    if word & _INHIBITED:
        return "switch-on inhibited"
    if not word & _NO_OFF2:
        return "OFF2 (coasting)"
    if not word & _NO_OFF3:
        return "OFF3 (quick stop)"
    if word & _ENABLED:
        return "operation enabled"
    if word & _READY:
        return "ready"
    if word & _READY_TO_SWITCH_ON:
        return "ready to switch on"
    return "not ready to switch on"


@dataclass(frozen=True, slots=True)
class DriveStatus:
    """The process data of one answer: status word (PZD1), actual values (PZD2...), when."""

    address: int
    word: int
    actual: tuple[int, ...]
    time: float
    control: int
    """The control word of the request this answers."""

    @property
    def status(self) -> StatusWord:
        return StatusWord(self.word)

    @property
    def state(self) -> str:
        """See `state_of`."""
        return state_of(self.word)

    @property
    def fault(self) -> bool:
        return bool(self.word & StatusWord.FAULT)

    @property
    def warning(self) -> bool:
        return bool(self.word & StatusWord.WARNING)

    @property
    def running(self) -> bool:
        """Operation enabled (status bit 2)."""
        return bool(self.word & StatusWord.OPERATION_ENABLED)

    @property
    def in_tolerance(self) -> bool:
        return bool(self.word & StatusWord.IN_TOLERANCE)

    @property
    def target_reached(self) -> bool:
        return bool(self.word & StatusWord.TARGET_REACHED)

    @property
    def actual_percent(self) -> float | None:
        """The main actual value (PZD2) in percent, 4000h = 100 %; None without PZD2."""
        return raw16_to_percent(self.actual[0]) if self.actual else None

    def actual_percent32(self) -> float | None:
        """PZD2 (high) and PZD3 (low) read as one 32-bit value in percent."""
        if len(self.actual) < 2:
            return None
        return raw32_to_percent(join_dword(self.actual[0], self.actual[1]))

    def bits(self) -> list[tuple[int, bool, str]]:
        """Each status bit with its meaning (`pyuss.protocol.pzd.describe_bits`)."""
        return describe_bits(self.word, STATUS_BITS)

    def to_dict(self) -> dict[str, object]:
        return {
            "address": self.address,
            "status": self.word,
            "status_hex": f"{self.word:04X}",
            "state": self.state,
            "actual": list(self.actual),
            "actual_percent": self.actual_percent,
            "control": self.control,
            "time": self.time,
        }
