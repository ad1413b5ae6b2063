"""MICROMASTER 420/440, SINAMICS G110, G120 (CU240S) and V20: the Siemens families that speak
USS the MICROMASTER 4 way.

What they share (their manuals, named in each parameter file's ``manual``):

- Parameter numbers of 2000 and above travel with a page number in IND bits 12..15 (bit 15 = 1,
  bit 12 = 2, bit 13 = 4, bit 14 = 8; ``micromaster4``); arrays count from index 0.
- The USS interface is set by P2010 (baud rate code; the rates are its value texts in the parameter
  file), P2011 (address), P2012 (PZD length), P2013 (PKW length 0, 3, 4 or 127 = variable) and P2014
  (telegram off time in ms, 0 = off): arrays over the drive's two USS interfaces. The simulator
  serves the RS-485 one, index 0 on every family (the "COM link" of the MICROMASTER 4, whose index 1
  is the BOP link; the RS-485 terminals of the G110, G120 CU240S and V20).
- Control word 1 (r0054) and status word 1 (r0052) extend C Tables 5.4/5.5: reverse in control
  bit 11, the motor potentiometer in bits 13/14; low-active warnings in status bits 11, 13, 15,
  the holding brake in bit 12 and the direction in bit 14 (`CONTROL_BITS`, `STATUS_BITS`).
- Setpoints and actual values are scaled by P2000 (reference frequency): 4000h = 100 %.
- Fault numbers F0001.. in r0947, warning numbers A0501.. in r2110 (their texts are the parameter
  files' ``[fault_texts]`` and ``[warning_texts]``); the telegram off time trips F0072 (USS on the
  RS-485 interface).
- Error numbers of response ID 7 as in ``micromaster4`` (101, 102, ...).
- Identification: r0964 index 0 is the manufacturer (42 = Siemens), index 1 the product type
  (1 = MICROMASTER 420, 2 = MICROMASTER 440: the MICROMASTER 4 parameter lists); the V20 is
  the one with P2023 (RS-485 protocol selection). G110 and G120 are not told apart by a
  parameter the project is sure of: `pyuss.profiles.identify` names them "Siemens, MICROMASTER
  4 kind" and uses ``micromaster4``.

SINAMICS G120 of firmware 4 (``sinamics-g120c``, ``sinamics-cu240e2``; their shared parameter
file is ``_sinamics_fw4.toml``) speaks USS the same way on the telegram level (the same IND
pages, SINAMICS G120C Operating Instructions 02/2023, 8.6) but numbers its interface p2020
(baud rate codes 4..13 = 2400..187500), p2021 (address 0..30), p2022 (PZD count 0..16),
p2023 (PKW count) and p2040 (monitoring time in ms, fault F01910), and wires control word 1
by BICO (p0840 = r2090.0 ..., `pyuss.protocol.bico`). Control word 1 bits 8, 9, 12 and 15
are reserved over USS, so no jog; status word 1 bits 11, 13 and 15 are low-active alarms
(torque limit, motor and converter overtemperature), bit 14 the direction (8.8). Their
diagnostic parameters are P29900.. (the project's choice: P2090.. are r2090 and p2103 on these
drives).
"""

from __future__ import annotations

from dataclasses import replace

from pyuss.profiles import micromaster4
from pyuss.profiles.base import IdentityRule
from pyuss.protocol.layout import PKW_VARIABLE, Layout

__all__ = [
    "CONTROL_BITS",
    "FW4_CONTROL_BITS",
    "FW4_STATUS_BITS",
    "MICROMASTER420",
    "MICROMASTER440",
    "PROFILES",
    "SIEMENS",
    "SINAMICS_CU240E2",
    "SINAMICS_G110",
    "SINAMICS_G120",
    "SINAMICS_G120C",
    "SINAMICS_V20",
    "STATUS_BITS",
]

SIEMENS = 42
"""r0964 index 0: the manufacturer number of Siemens."""


CONTROL_BITS: dict[int, str] = {
    0: "ON (1) / OFF1 ramp stop (0)",
    1: "no OFF2 (0 = coast to stop)",
    2: "no OFF3 (0 = quick stop)",
    3: "pulse enable",
    4: "ramp-function generator enable",
    5: "ramp-function generator start",
    6: "setpoint enable",
    7: "fault acknowledge (rising edge)",
    8: "jog right",
    9: "jog left",
    10: "control from PLC (process data valid)",
    11: "reverse (setpoint inverted)",
    13: "motor potentiometer up",
    14: "motor potentiometer down",
}
"""Control word 1 (r0054)."""

STATUS_BITS: dict[int, str] = {
    0: "drive ready",
    1: "drive ready to run",
    2: "drive running",
    3: "fault active",
    4: "OFF2 active (0 = active)",
    5: "OFF3 active (0 = active)",
    6: "switch-on inhibit active",
    7: "warning active",
    8: "setpoint/actual deviation (0 = active)",
    9: "PZD control (always 1)",
    10: "maximum frequency reached",
    11: "motor current limit warning (0 = active)",
    12: "motor holding brake active",
    13: "motor overload (0 = active)",
    14: "motor turns right",
    15: "inverter overload (0 = active)",
}
"""Status word 1 (r0052)."""


def _micromaster(drive_type: int) -> tuple[IdentityRule, ...]:
    """How a MICROMASTER 4 of ``drive_type`` (r0964 index 1) is told: Siemens in r0964 index 0,
    that drive type, and no P2023 (which the SINAMICS V20 has)."""
    return (
        IdentityRule(964, 0, frozenset({SIEMENS})),
        IdentityRule(964, 1, frozenset({drive_type})),
        IdentityRule(2023, present=False),
    )


_BASE = replace(
    micromaster4.PROFILE,
    follows="the manuals named in the parameter file",
    default_layout=Layout(PKW_VARIABLE, 2),
    control_bits={**CONTROL_BITS, 15: "local / remote"},
    status_bits=STATUS_BITS,
)

MICROMASTER420 = replace(
    _BASE,
    name="micromaster420",
    title="MICROMASTER 420",
    max_pzd=4,
    identity=_micromaster(1),
)
MICROMASTER440 = replace(
    _BASE,
    name="micromaster440",
    title="MICROMASTER 440",
    control_bits={**CONTROL_BITS, 15: "command data set bit 0 (local / remote)"},
    identity=_micromaster(2),
)
SINAMICS_G110 = replace(
    _BASE,
    name="sinamics-g110",
    title="SINAMICS G110",
    max_pzd=4,
    control_bits=CONTROL_BITS,
)
SINAMICS_G120 = replace(
    _BASE,
    name="sinamics-g120",
    title="SINAMICS G120 with CU240S control unit",
    addresses=(0, 30),
    control_bits={**CONTROL_BITS, 15: "command data set bit 0"},
)
SINAMICS_V20 = replace(
    _BASE,
    name="sinamics-v20",
    title="SINAMICS V20",
    control_bits=CONTROL_BITS,
    identity=(
        IdentityRule(964, 0, frozenset({SIEMENS})),
        IdentityRule(2023),
    ),
)

FW4_CONTROL_BITS: dict[int, str] = {
    **{bit: text for bit, text in CONTROL_BITS.items() if bit not in (8, 9)},
    11: "direction reversal (setpoint inverted)",
}
"""Control word 1 of firmware 4 over USS (G120C Operating Instructions 02/2023, 8.8): bits 8,
9, 12 and 15 reserved."""

FW4_STATUS_BITS: dict[int, str] = {
    **{bit: text for bit, text in STATUS_BITS.items() if bit < 11},
    8: "speed deviation within tolerance",
    10: "comparison speed reached",
    11: "torque limit reached (0 = active)",
    13: "motor overtemperature alarm (0 = active)",
    14: "motor turns clockwise",
    15: "converter overload alarm (0 = active)",
}
"""Status word 1 of firmware 4 (8.8): bit 12 reserved."""

_FW4 = replace(
    _BASE,
    addresses=(0, 30),
    max_pzd=16,
    control_bits=FW4_CONTROL_BITS,
    status_bits=FW4_STATUS_BITS,
    diagnostic_pnu=29900,
)

SINAMICS_G120C = replace(_FW4, name="sinamics-g120c", title="SINAMICS G120C (firmware 4)")
SINAMICS_CU240E2 = replace(
    _FW4, name="sinamics-cu240e2", title="SINAMICS G120 with CU240E-2 (firmware 4)"
)

PROFILES = (
    MICROMASTER420,
    MICROMASTER440,
    SINAMICS_G110,
    SINAMICS_G120,
    SINAMICS_V20,
    SINAMICS_G120C,
    SINAMICS_CU240E2,
)
