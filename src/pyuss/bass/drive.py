"""A simulated drive as a BASS station: one drive model behind USS (RS-485) and BASS (RS-232).

`DriveOperatingData` makes a `pyuss.drive.ParameterMemory` (normally the `SimulatedDrive` a
`pyuss.slave.SlaveEngine` serves over USS) the `pyuss.bass.ring.OperatingData` of a station on
the BASS ring (Baumueller manual 1.4.2). Both interfaces work on the same parameter values, so a
change
made over one is seen over the other at once, and a BASS write of an ACTIVE parameter is
reported to the USS side, whose slave engine sends it as a spontaneous message (C 4.2.1.2).

- **IDs are parameter numbers.** A BASS element ID n is parameter n of the drive. The data of
  an element take 4 hex digits for a one-word parameter (8 and 16 bits, V2), 8 for a
  double-word one (32 bits, float as its IEEE 754 bit pattern), two's complement for negative
  values. Arrays and strings have no single-element form on BASS: error 9.
- **Writes** go through every rule of the drive (`ParameterMemory.write_words`) under the
  interface name ``"bass"``; refusals (`ParameterFault`, C Table 4.3) become the error numbers
  of Baumueller manual table 1.3 (`bass_error`, table below).
- **Write authority** (Baumueller manual 1.5): the service interface may change parameters only
  while
  bit 0 of parameter 126 ("source de communication M") is 1 - the drive's own ``write_enable``
  setting, so `ParameterMemory.has_write_authority` decides for both interfaces. While it is 0,
  every BASS write is refused with error 5, ID 126 included ("seule la lecture ... est
  permise"); the drive's panel or the USS master (for which the write-enable parameter stays
  writable) gives it back.
- **ID 170 "SV state"** is computed from the drive: bits 0..3 = 1 (RUN) while the service
  interface has write authority, 0 (STOP) otherwise; bits 4..11 the DIP address; bits 12..15
  zero. Parameter 170 of the drive is kept equal to it (after each BASS job and whenever an
  active parameter such as 126 changes), so the USS side reads the same word.
- **ID 171 "SV baud rate"** is the drive's parameter 171 (read-only, 9600): a write is refused
  with error 4 like that of any read-only parameter.
- **Time.** With a ``clock`` (the USS side's time base) the drive's ramps and timers are
  advanced to now before each BASS job, so a BASS read of the actual value is current even
  when no USS master is polling.

Refusals of the drive and the BASS numbers they are answered with (Baumueller manual 1.3):

====  ==========================================  ====================================
C 4.3 meaning                                      BASS
====  ==========================================  ====================================
0     illegal PNU                                 1 element not available
1     not changeable (read-only)                  4 data cannot be changed
2     limits: below the minimum                   6 data below the minimum
2     limits: above the maximum                   7 data above the maximum
2     limits: not an allowed value, not a number  8 data not valid
3, 4  faulty IND, no array                        9 access to the parameter not valid
5     wrong data type                             8 data not valid
6     reset only (only 0 may be written)          8 data not valid
7     description element not changeable          4 data cannot be changed
11    no write authority                          5 parameter is write-protected
12    keyword missing (protected parameter)       5 parameter is write-protected
15    no text array                               9 access to the parameter not valid
17    not in this operating state                 4 data cannot be changed
other device numbers (101 ...)                    9 access to the parameter not valid
====  ==========================================  ====================================

The width checks of the station come first (2 data too short, 3 too long), as for every
`OperatingData`; the order of all checks is in ``docs/bass.md``.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable, Iterable
from typing import Final

from pyuss.bass.errors import BassErrorNumber, BassRefusal
from pyuss.bass.ring import ID_SV_STATE, SV_STATE_RUN, SV_STATE_STOP, BassRing, BassStation
from pyuss.drive.database import Parameter
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import DriveErrorNumber, ParameterFault
from pyuss.drive.memory import ParameterChange, ParameterMemory
from pyuss.drive.simulated import SimulatedDrive
from pyuss.errors import ConfigError
from pyuss.protocol.pkw import ErrorNumber

__all__ = ["FAULT_TO_BASS", "INTERFACE", "DriveOperatingData", "bass_error", "drive_ring"]

log = logging.getLogger("pyuss.bass.drive")

INTERFACE: Final = "bass"
"""The interface name BASS writes carry in the drive (`pyuss.drive.memory`)."""

E = BassErrorNumber

FAULT_TO_BASS: Final[dict[int, BassErrorNumber]] = {
    ErrorNumber.ILLEGAL_PNU: E.ELEMENT_NOT_AVAILABLE,
    ErrorNumber.NOT_CHANGEABLE: E.DATA_NOT_CHANGEABLE,
    ErrorNumber.LIMIT_EXCEEDED: E.DATA_NOT_VALID,
    ErrorNumber.BAD_INDEX: E.ACCESS_NOT_VALID,
    ErrorNumber.NOT_ARRAY: E.ACCESS_NOT_VALID,
    ErrorNumber.WRONG_TYPE: E.DATA_NOT_VALID,
    ErrorNumber.SET_NOT_ALLOWED: E.DATA_NOT_VALID,
    ErrorNumber.DESCRIPTION_NOT_CHANGEABLE: E.DATA_NOT_CHANGEABLE,
    DriveErrorNumber.NO_WRITE_AUTHORITY: E.WRITE_PROTECTED,
    DriveErrorNumber.KEYWORD_MISSING: E.WRITE_PROTECTED,
    DriveErrorNumber.NO_TEXT_ARRAY: E.ACCESS_NOT_VALID,
    DriveErrorNumber.WRONG_STATE: E.DATA_NOT_CHANGEABLE,
}
"""Error number of a `ParameterFault` (C Table 4.3) -> BASS error number (Baumueller manual 1.3).
Numbers not listed give `ACCESS_NOT_VALID`; limit faults are refined by `bass_error`."""


def bass_error(
    fault: ParameterFault, param: Parameter | None = None, value: int | float | None = None
) -> BassErrorNumber:
    """The BASS error number answering ``fault`` (`FAULT_TO_BASS`). A limit fault (2) of a
    write of ``value`` to ``param`` is 6 below the parameter's lower limit, 7 above its upper
    limit, else 8 (not one of the allowed values, not a finite number)."""
    if fault.number == ErrorNumber.LIMIT_EXCEEDED and param is not None and value is not None:
        if value < param.low:
            return E.BELOW_MINIMUM
        if value > param.high:
            return E.ABOVE_MAXIMUM
    return FAULT_TO_BASS.get(fault.number, E.ACCESS_NOT_VALID)


class DriveOperatingData:
    """The operating data of a BASS station, taken from ``drive`` (see the module docstring).

    ``address`` is the station's DIP address 0..255; ``interface`` the name the drive knows
    BASS writes by; ``clock`` (optional) the time base of the drive's state machine, read before
    each job to advance it. `close` ends the subscription to the drive's change reports.
    """

    def __init__(
        self,
        drive: ParameterMemory,
        address: int,
        *,
        interface: str = INTERFACE,
        clock: Callable[[], float] | None = None,
    ) -> None:
        if isinstance(address, bool) or not isinstance(address, int) or not 0 <= address <= 0xFF:
            raise ConfigError(f"DIP address must be an integer 0..255, not {address!r}")
        self.drive = drive
        self.interface = interface
        self._address = address
        self._clock = clock
        self._unsubscribe: Callable[[], None] | None = drive.subscribe(interface, self._on_change)
        self.refresh()

    def close(self) -> None:
        """Stop following the drive's changes (the drive lives on)."""
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None

    # -- the service interface's own IDs (Baumueller manual 1.5)
    # --------------------------------------

    @property
    def dip_address(self) -> int:
        return self._address

    def write_authorized(self) -> bool:
        """ID 126 bit 0 (the drive's ``write_enable``), unless BASS was denied explicitly."""
        return self.drive.has_write_authority(self.interface)

    def sv_state(self) -> int:
        """ID 170: 1 = RUN (write authority) or 0 = STOP in bits 0..3, DIP address in 4..11."""
        state = SV_STATE_RUN if self.write_authorized() else SV_STATE_STOP
        return state | self._address << 4

    def refresh(self) -> None:
        """Show the present SV state in the drive's parameter 170 (if the drive has one)."""
        if ID_SV_STATE not in self.drive.db:
            return
        try:
            self.drive.update(ID_SV_STATE, self.sv_state())
        except ParameterFault as exc:  # a parameter file with another type for 170
            log.warning("drive %d: cannot show the SV state in P170: %s", self._address, exc)

    def _on_change(self, change: ParameterChange) -> None:
        self.refresh()  # the write-enable parameter may have changed

    # -- OperatingData -----------------------------------------------------------------------

    def _parameter(self, ident: int) -> Parameter:
        try:
            param = self.drive.parameter(ident)
        except ParameterFault:
            raise BassRefusal(E.ELEMENT_NOT_AVAILABLE, ident=ident) from None
        if param.is_array or param.word_count not in (1, 2):
            raise BassRefusal(E.ACCESS_NOT_VALID, ident=ident)
        return param

    def _step(self) -> None:
        if self._clock is not None and isinstance(self.drive, SimulatedDrive):
            self.drive.step(self._clock())

    def digits(self, ident: int) -> int:
        """4 hex digits for a one-word parameter, 8 for a double word; error 1 or 9 otherwise."""
        return 4 * self._parameter(ident).word_count

    def read(self, ident: int) -> int:
        self._parameter(ident)
        self._step()
        if ident == ID_SV_STATE:
            self.refresh()
        return _pattern(self.drive.read_words(ident))

    def write(self, ident: int, value: int) -> None:
        param = self._parameter(ident)
        self._step()
        words = (
            (value & 0xFFFF,) if param.word_count == 1 else (value >> 16 & 0xFFFF, value & 0xFFFF)
        )
        try:
            self.drive.write_words(ident, words, interface=self.interface)
        except ParameterFault as fault:
            raise BassRefusal(
                bass_error(fault, param, _number(param, words)), ident=ident
            ) from None
        finally:
            self.refresh()


def _pattern(words: Iterable[int]) -> int:
    pattern = 0
    for word in words:
        pattern = pattern << 16 | word
    return pattern


def _number(param: Parameter, words: tuple[int, ...]) -> int | float:
    """What ``words`` mean for ``param``, without its type's range check: a word read signed
    for signed types (FFFFh of an int8 is -1, 00FFh is 255: above its maximum); a float's
    bit pattern as IEEE 754 single."""
    raw = _pattern(words)
    if param.dtype is DataType.FLOAT:
        number: float = struct.unpack(">f", raw.to_bytes(4, "big"))[0]
        return number  # NaN compares with no limit: error 8
    bits = 16 * len(words)
    signed = param.dtype in (DataType.INT8, DataType.INT16, DataType.INT32)
    return raw - (1 << bits) if signed and raw >> (bits - 1) else raw


def drive_ring(
    drives: Iterable[tuple[int, ParameterMemory]],
    *,
    clock: Callable[[], float] | None = None,
    interface: str = INTERFACE,
) -> BassRing:
    """A closed RS-232 loop of ``drives`` - ``(DIP address, drive)`` - wired in address order
    (Baumueller manual 1.4.2: up to 16)."""
    data = [
        DriveOperatingData(drive, address, interface=interface, clock=clock)
        for address, drive in sorted(drives, key=lambda item: item[0])
    ]
    try:
        return BassRing([BassStation(item) for item in data])
    except ConfigError:
        for item in data:
            item.close()
        raise
