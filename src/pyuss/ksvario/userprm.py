"""User parameters of the KS VARIO (KS VARIO interface description 6): 4 bytes in Set_Prm after the
7 standard bytes.

Bytes 1..3 are reserved for DP-V1 and 0 in DP-V0 operation. Byte 4: bit 0 byte order of
values (0 Motorola / IEEE, 1 Intel), bit 1 diagnosis format (0 extended, 1 standard),
bit 2 fail-safe (0 last value, 1 zero), bits 3..7 reserved (0). All defaults are 0.

A master whose GSD reader builds the user parameters from ``Ext_User_Prm_Data_Const`` alone
may send fewer than 4 bytes; missing bytes are taken as their default 0. More than 4 bytes or
reserved bits set are a parameterisation fault.

Fail-safe (2.3, 2.4) decides what happens on bus failure or master stop: with "last value"
the coupler keeps working with the last values and sets forced analogue inputs to FAIL; with
"zero" forced analogue inputs go to FAIL and forced digital inputs and forced outputs to 0.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from pyuss.errors import ConfigError
from pyuss.ksvario.channel import ByteOrder

USER_PRM_BYTES = 4


class DiagnosisFormat(enum.IntEnum):
    EXTENDED = 0
    STANDARD = 1


class FailSafe(enum.IntEnum):
    LAST_VALUE = 0
    ZERO = 1


@dataclass(frozen=True, slots=True)
class UserParameters:
    byte_order: ByteOrder = ByteOrder.MOTOROLA
    diagnosis: DiagnosisFormat = DiagnosisFormat.EXTENDED
    fail_safe: FailSafe = FailSafe.LAST_VALUE
    dpv1: bytes = b"\x00\x00\x00"

    def encode(self) -> bytes:
        if len(self.dpv1) != 3:
            raise ConfigError("the DP-V1 part of the user parameters is 3 bytes")
        flags = int(self.byte_order) | int(self.diagnosis) << 1 | int(self.fail_safe) << 2
        return bytes(self.dpv1) + bytes((flags,))

    @classmethod
    def decode(cls, data: bytes) -> UserParameters:
        if len(data) > USER_PRM_BYTES:
            raise ConfigError(f"user parameters are {USER_PRM_BYTES} bytes, got {len(data)}")
        data = bytes(data).ljust(USER_PRM_BYTES, b"\x00")
        flags = data[3]
        if flags & 0xF8:
            raise ConfigError(f"reserved user parameter bits set in byte 4 ({flags:02X}h)")
        return cls(
            ByteOrder(flags & 1),
            DiagnosisFormat((flags >> 1) & 1),
            FailSafe((flags >> 2) & 1),
            data[:3],
        )

    def describe(self) -> str:
        return (
            f"byte order {self.byte_order.name.lower()}, diagnosis {self.diagnosis.name.lower()}, "
            f"fail-safe {self.fail_safe.name.lower().replace('_', ' ')}"
        )
