"""Process data between the telegram and the drive (C 5), and broadcasts (A 3, appendix, reading 9).

`StandardProcess`: PZD1 control word / status word, PZD2 main setpoint / actual value, PZD3 ..
the parameters of the file's ``[process]`` table (`pyuss.drive.SimulatedDrive.exchange`).

`BaumuellerProcess` (Baumueller manual 2.5, parameters 185 and 186): PZD1 control word / status
word;
the setpoint is written to the parameter whose number parameter 185 holds and the actual value
read from the one parameter 186 names. PZD count 2 carries a 16-bit value in PZD2; count 3 a
16-bit value in PZD3 or a 32-bit value in PZD2 (high) and PZD3 (low); a 32-bit value with count
2 cannot travel and sets USS state bit 9 (setpoint) or 8 (actual value) of parameter 180. The
setpoint also drives the ramp-function generator (a 32-bit one as 4000 0000h = 100 %).

Broadcasts are applied with `apply_broadcast` in the profile's form (`BroadcastForm`):

- ``ENABLE_ARRAY``: the 4-word Broadcast Enable Array in the PKW area selects PZD words and
  bits; everything else keeps the value of the process data in force: the last non-broadcast
  telegram whose control word bit 10 was 1 (appendix, C Table 5.4). A slave
  whose layout has no 4-word PKW area cannot take it (the broadcast carries a different length).
- ``MASKED_CONTROL``: PZD1 merges into the control word in force through the mask in PWE1
  (PKW >= 3, PZD >= 2, request ID 0); with PKW 0 the control word is taken whole; setpoints and
  parameter jobs are not taken; with broadcast coding on (PKW >= 3, PZD >= 3) only the addresses
  selected in PZD2/PZD3 react (reading 9).
- ``NONE``: nothing is taken.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from pyuss.drive.faults import ParameterFault
from pyuss.drive.simulated import SimulatedDrive
from pyuss.profiles import baumueller
from pyuss.profiles.base import BitRef, BroadcastForm, Profile
from pyuss.protocol.broadcast import BroadcastEnableArray, apply_broadcast
from pyuss.protocol.layout import Layout, NetData

__all__ = [
    "BaumuellerProcess",
    "BroadcastAction",
    "ProcessMapping",
    "StandardProcess",
    "bit_set",
    "broadcast_action",
    "process_mapping",
]


class ProcessMapping(Protocol):
    """How a device maps PZD words to its drive."""

    def exchange(self, drive: SimulatedDrive, words: Sequence[int], now: float) -> tuple[int, ...]:
        """Take the received PZD words, return the PZD words of the answer (same count)."""

    def control(self, drive: SimulatedDrive, word: int, now: float) -> None:
        """Take a control word alone (a broadcast)."""


def bit_set(drive: SimulatedDrive, ref: BitRef | None) -> bool:
    """Whether the bit ``ref`` names is 1 (False without a reference or parameter)."""
    if ref is None or ref.pnu not in drive.db:
        return False
    value = drive.value(ref.pnu, ref.index)
    return isinstance(value, int) and bool(value >> ref.bit & 1)


class StandardProcess:
    """PZD1 control/status word, PZD2 main setpoint/actual, PZD3.. from ``[process]``."""

    def exchange(self, drive: SimulatedDrive, words: Sequence[int], now: float) -> tuple[int, ...]:
        return drive.exchange(words, now)

    def control(self, drive: SimulatedDrive, word: int, now: float) -> None:
        drive.apply_control(word, None, now)


class BaumuellerProcess:
    """The setpoint and actual value channel of Baumueller manual 2.5 (parameters 180, 185, 186)."""

    def exchange(self, drive: SimulatedDrive, words: Sequence[int], now: float) -> tuple[int, ...]:
        count = len(words)
        if count == 0:
            drive.step(now)
            return ()
        faults = 0
        setpoint: int | None = None
        double = False
        target = _target(drive, baumueller.SETPOINT_PNU)
        if target is not None and count >= 2:
            param = drive.db.parameter(target)
            double = param.word_count == 2
            signed = param.dtype.name.startswith("INT")
            setpoint = baumueller.join_value(words[1:], double=double, signed=signed)
            if setpoint is None:
                faults |= baumueller.SETPOINT_FORMAT_FAULT
        accepted = drive.apply_control(
            words[0], setpoint, now, bits=32 if double and setpoint is not None else 16
        )
        if accepted and setpoint is not None and target is not None:
            with contextlib.suppress(ParameterFault):  # a value out of the parameter's range
                drive.update(target, setpoint)
        answer = [drive.status_word()]
        actual = _target(drive, baumueller.ACTUAL_PNU)
        if actual is not None and count >= 2:
            param = drive.db.parameter(actual)
            raw = drive.read_words(actual)
            value = raw[0] << 16 | raw[1] if len(raw) == 2 else raw[0]
            carried = baumueller.value_words(value, count, double=param.word_count == 2)
            if carried is None:
                faults |= baumueller.ACTUAL_FORMAT_FAULT
            else:
                answer.extend(carried)
        _set_state_bits(drive, faults)
        answer.extend([0] * (count - len(answer)))
        return tuple(answer[:count])

    def control(self, drive: SimulatedDrive, word: int, now: float) -> None:
        drive.apply_control(word, None, now)


def _target(drive: SimulatedDrive, pointer: int) -> int | None:
    """The parameter number held by parameter ``pointer`` (185/186), if it names a parameter."""
    if pointer not in drive.db:
        return None
    value = drive.value(pointer)
    if not isinstance(value, int) or value not in drive.db:
        return None
    param = drive.db.parameter(value)
    if param.is_array or param.dtype.is_string or param.word_count > 2:
        return None
    return value


def _set_state_bits(drive: SimulatedDrive, faults: int) -> None:
    if baumueller.STATE_PNU not in drive.db:
        return
    mask = baumueller.SETPOINT_FORMAT_FAULT | baumueller.ACTUAL_FORMAT_FAULT
    old = drive.value(baumueller.STATE_PNU)
    assert isinstance(old, int)
    drive.update(baumueller.STATE_PNU, (old & ~mask) | faults)


def process_mapping(profile: Profile) -> ProcessMapping:
    """The process data mapping of ``profile``."""
    return BaumuellerProcess() if profile.name == baumueller.PROFILE.name else StandardProcess()


@dataclass(frozen=True, slots=True)
class BroadcastAction:
    """What a broadcast gives one slave: a whole PZD image to take (``pzd``), or a control
    word merged through ``mask`` into the one in force (``control``), or nothing (``reason``
    says why)."""

    pzd: tuple[int, ...] | None = None
    control: int | None = None
    mask: int = 0xFFFF
    reason: str = ""


def broadcast_action(
    profile: Profile,
    layout: Layout,
    net: NetData,
    previous: Sequence[int],
    *,
    address: int,
    coding: bool,
) -> BroadcastAction:
    """The effect of a broadcast on the slave at ``address`` (see the module docstring);
    ``previous`` is the PZD of the last non-broadcast telegram, ``coding`` whether broadcast
    address coding is on."""
    form = profile.broadcast
    if form is BroadcastForm.ENABLE_ARRAY:
        if net.pkw is None or len(net.pkw.words()) != 4:
            return BroadcastAction(reason="no 4-word Broadcast Enable Array in the PKW area")
        bea = BroadcastEnableArray.from_pkw(net.pkw)
        if not bea.flag:
            return BroadcastAction(reason="broadcast flag (word a bit 0) not set")
        return BroadcastAction(pzd=tuple(apply_broadcast(previous, net.pzd, bea)))
    if form is BroadcastForm.MASKED_CONTROL:
        if not net.pzd:
            return BroadcastAction(reason="no PZD area")
        if net.pkw is None:
            return BroadcastAction(control=net.pzd[0])
        if len(net.pzd) < 2 or net.pkw.id != 0:
            return BroadcastAction(reason="needs PZD >= 2 and request ID 0 (Baumueller manual 2.2)")
        selected = baumueller.addresses_in_mask(*net.pzd[1:3]) if len(net.pzd) >= 3 else None
        if coding and selected is not None and address not in selected:
            return BroadcastAction(reason="address not selected by the broadcast coding")
        mask = net.pkw.values[0] if net.pkw.values else 0
        return BroadcastAction(control=net.pzd[0], mask=mask)
    return BroadcastAction(reason=f"profile {profile.name} takes nothing from broadcasts")
