"""KS VARIO diagnosis (KS VARIO interface description 6.1): 6 standard bytes and 9 device-specific
bytes.

Standard (6.1.1): byte 1 and 2 station status flags (`Status1`, `Status2`), byte 3 bit 7
ext_diag_overflow (`Status3`), byte 4 the master address (FFh before parameterisation),
bytes 5-6 the ident number 1030h.

Device-specific (6.1.2), sent unless the user parameters ask for standard diagnosis:
byte 7 revision number in bits 0..5 with bits 6 and 7 always 1; byte 8 block length 08h;
byte 9 status type 81h (status message); byte 10 slot 0 (device); byte 11 specifier 0;
byte 12 firmware version (bits 0..6, tenths: 10 = V1.0, as the GSD's value texts say);
byte 13 errors E.1..E.5 (`DeviceErrors`); byte 14 alarms Lim, HCA, SSR, Loop (`Alarms`);
byte 15 bit 0 Fail, sensor failure (`InputFlags`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from pyuss.errors import ConfigError, ProtocolError

IDENT_NUMBER = 0x1030
STANDARD_BYTES = 6
EXTENDED_BYTES = 15
NO_MASTER = 0xFF


class Status1(enum.IntFlag):
    """Byte 1 of the standard diagnosis."""

    NONE = 0
    STATION_NON_EXISTENT = 0x01
    STATION_NOT_READY = 0x02
    CFG_FAULT = 0x04
    EXT_DIAG = 0x08
    NOT_SUPPORTED = 0x10
    INVALID_SLAVE_RESPONSE = 0x20
    PRM_FAULT = 0x40
    MASTER_LOCK = 0x80


class Status2(enum.IntFlag):
    """Byte 2 of the standard diagnosis; bit 2 is always 1."""

    NONE = 0
    PRM_REQ = 0x01
    STAT_DIAG = 0x02
    ALWAYS_ONE = 0x04
    WD_ON = 0x08
    FREEZE_MODE = 0x10
    SYNC_MODE = 0x20
    DEACTIVATED = 0x80


class Status3(enum.IntFlag):
    NONE = 0
    EXT_DIAG_OVERFLOW = 0x80


class DeviceErrors(enum.IntFlag):
    """Byte 13: E.1 internal error (not recoverable), E.2 internal error (resettable),
    E.3 configuration error, E.4 hardware error, E.5 internal error of the DP module."""

    NONE = 0
    E1_INTERNAL = 0x01
    E2_INTERNAL_RESETTABLE = 0x02
    E3_CONFIGURATION = 0x04
    E4_HARDWARE = 0x08
    E5_DP_MODULE = 0x10


class Alarms(enum.IntFlag):
    """Byte 14: limit alarm, heating current alarm, heating current short circuit, loop alarm."""

    NONE = 0
    LIMIT = 0x01
    HEATING_CURRENT = 0x02
    SSR_SHORT = 0x04
    LOOP = 0x08


class InputFlags(enum.IntFlag):
    """Byte 15: sensor failure."""

    NONE = 0
    FAIL = 0x01


_BLOCK_HEADER = bytes((0x08, 0x81, 0x00, 0x00))


@dataclass(frozen=True, slots=True)
class DeviceDiagnosis:
    """Bytes 7..15."""

    revision: int = 1
    firmware: int = 10
    errors: DeviceErrors = DeviceErrors.NONE
    alarms: Alarms = Alarms.NONE
    inputs: InputFlags = InputFlags.NONE

    @property
    def firmware_text(self) -> str:
        return f"V{self.firmware // 10}.{self.firmware % 10}"

    @property
    def any_fault(self) -> bool:
        return bool(self.errors or self.alarms or self.inputs)

    def encode(self) -> bytes:
        if not 0 <= self.revision <= 0x3F:
            raise ConfigError(f"revision {self.revision} does not fit 6 bits")
        if not 0 <= self.firmware <= 0x7F:
            raise ConfigError(f"firmware {self.firmware} does not fit 7 bits")
        return (
            bytes((0xC0 | self.revision,))
            + _BLOCK_HEADER
            + bytes((self.firmware, int(self.errors), int(self.alarms), int(self.inputs)))
        )

    @classmethod
    def decode(cls, data: bytes) -> DeviceDiagnosis:
        if len(data) != EXTENDED_BYTES - STANDARD_BYTES:
            raise ProtocolError(f"device diagnosis is 9 bytes, got {len(data)}")
        if data[0] & 0xC0 != 0xC0:
            raise ProtocolError(f"byte 7 must have bits 6 and 7 set, got {data[0]:02X}h")
        if data[1:5] != _BLOCK_HEADER:
            raise ProtocolError(f"bytes 8..11 must be 08 81 00 00, got {data[1:5].hex(' ')}")
        return cls(
            data[0] & 0x3F,
            data[5] & 0x7F,
            DeviceErrors(data[6] & 0x1F),
            Alarms(data[7] & 0x0F),
            InputFlags(data[8] & 0x01),
        )


@dataclass(frozen=True, slots=True)
class Diagnosis:
    """A whole Slave_Diag answer."""

    status1: Status1 = Status1.NONE
    status2: Status2 = Status2.ALWAYS_ONE
    status3: Status3 = Status3.NONE
    master_address: int = NO_MASTER
    ident_number: int = IDENT_NUMBER
    device: DeviceDiagnosis | None = field(default=None)

    def encode(self) -> bytes:
        head = bytes(
            (
                int(self.status1),
                int(self.status2 | Status2.ALWAYS_ONE),
                int(self.status3),
                self.master_address,
                self.ident_number >> 8,
                self.ident_number & 0xFF,
            )
        )
        return head + (self.device.encode() if self.device is not None else b"")

    @classmethod
    def decode(cls, data: bytes) -> Diagnosis:
        if len(data) not in (STANDARD_BYTES, EXTENDED_BYTES):
            raise ProtocolError(
                f"KS VARIO diagnosis is {STANDARD_BYTES} or {EXTENDED_BYTES} bytes, got {len(data)}"
            )
        device = DeviceDiagnosis.decode(data[6:]) if len(data) == EXTENDED_BYTES else None
        return cls(
            Status1(data[0]),
            Status2(data[1] & ~0x40),
            Status3(data[2] & 0x80),
            data[3],
            (data[4] << 8) | data[5],
            device,
        )

    @property
    def ready_for_data_exchange(self) -> bool:
        bad = Status1.STATION_NON_EXISTENT | Status1.STATION_NOT_READY
        bad |= Status1.CFG_FAULT | Status1.PRM_FAULT
        return not (self.status1 & bad) and not (self.status2 & Status2.PRM_REQ)

    def flags(self) -> list[str]:
        """Every set flag by name, standard and device-specific."""
        names: list[str] = []
        for group in (self.status1, self.status2 & ~Status2.ALWAYS_ONE, self.status3):
            names += [f.name.lower() for f in type(group) if f and f.name and f in group]
        if self.device is not None:
            for dgroup in (self.device.errors, self.device.alarms, self.device.inputs):
                names += [f.name.lower() for f in type(dgroup) if f and f.name and f in dgroup]
        return names

    def describe(self) -> str:
        text = f"master {self.master_address}, ident {self.ident_number:04X}h"
        if self.device is not None:
            text += f", revision {self.device.revision}, firmware {self.device.firmware_text}"
        flags = self.flags()
        return text + (": " + ", ".join(flags) if flags else ": no flags")
