"""``nord-sk500e``: NORD SK 500E series frequency inverters.

The USS side is the ``nord`` profile's (NORD BU 0050 1.3.5: start pause 2 characters, answer within
20 ms, residual time 1.5 x (n + 4) characters from the start of STX; NORD's USS manual BU 0050
1.5: error numbers 9, 201, 202), with what the SK 500E manual BU 0500 adds:

- Fixed telegram length only, as PPO types (P507): PPO 1 = PKW 4 + PZD 2, PPO 2 = PKW 4 +
  PZD 6, PPO 3 = PKW 0 + PZD 2, PPO 4 = PKW 0 + PZD 6 (BU 0050 1.5.4: "the parameter area is
  only used with PPO type 1 and 2").
- P511 baud rate code (0 = 4800 .. 3 = 38400: its value texts in the parameter file), P512
  address 0..30, P513 telegram failure time in 0.1 s (0 = off); the time-out trips fault E010
  (bus time-out).
- Parameter numbers 0..999 in PKE alone; the parameter set of a set-dependent parameter is
  IND 0..3 (BU 0050 1.6.5: parameter set 2 is IND 1).
- Values are integers in the parameter's resolution: P102 ramp time in 0.01 s (1000 = 10 s,
  BU 0050 1.6.5), frequencies in 0.1 Hz. Setpoints and actual values are scaled by P105
  (maximum frequency) = 4000h.

Fault numbers are NORD's E groups (E010 = bus time-out ...), shown in P700 as group.detail
(10.0). No broadcasts are taken from the master (the SK 500E sends them itself with P503, which
the simulator does not do); no spontaneous messages. Diagnostic parameters of the simulated
slave (A 5.2.3): P580..P597, beside the USS settings.
"""

from __future__ import annotations

from dataclasses import replace

from pyuss.profiles import nord
from pyuss.profiles.base import BroadcastForm, IdentityRule
from pyuss.protocol.layout import Layout

__all__ = ["CONTROL_BITS", "PROFILE", "STATUS_BITS"]


CONTROL_BITS: dict[int, str] = {
    0: "ready to switch on (ON / OFF1)",
    1: "no OFF2 (0 = disable voltage)",
    2: "no OFF3 (0 = quick stop)",
    3: "enable operation",
    4: "enable pulses / ramp generator",
    5: "enable ramp",
    6: "enable setpoint",
    7: "acknowledge fault (rising edge)",
    8: "bus bit 8 (function set in P480)",
    9: "bus bit 9 (function set in P480)",
    10: "control data valid",
    11: "rotation right",
    12: "rotation left",
    14: "parameter set bit 0",
    15: "parameter set bit 1",
}
"""Control word bits as the SK 500E takes them (NORD BU 0050 1.5.3.3)."""

STATUS_BITS: dict[int, str] = {
    0: "ready to switch on",
    1: "ready for operation",
    2: "operation enabled",
    3: "fault",
    4: "OFF2 active (0 = active)",
    5: "OFF3 active (0 = active)",
    6: "switch-on inhibit",
    7: "warning",
    8: "setpoint = actual value",
    9: "bus control requested",
    10: "bus bit 10 (function set in P481)",
    11: "rotation right",
    12: "rotation left",
    14: "parameter set bit 0",
    15: "parameter set bit 1",
}
"""Status word bits of the SK 500E (NORD BU 0050 1.5.3.4)."""


PROFILE = replace(
    nord.PROFILE,
    name="nord-sk500e",
    title="NORD SK 500E series",
    follows="NORD BU 0050 1.3.5, 1.3.6, 1.5; NORD BU 0500",
    default_layout=Layout(4, 2),
    pkw_choices=(0, 4),
    max_pzd=6,
    broadcast=BroadcastForm.NONE,
    addresses=(0, 30),
    control_bits=CONTROL_BITS,
    status_bits=STATUS_BITS,
    identity=(
        IdentityRule(743),
        IdentityRule(707, 0),
        IdentityRule(964, 0, present=False),
    ),
    diagnostic_pnu=580,
    data="",
)
