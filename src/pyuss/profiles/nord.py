"""``nord``: NORD frequency inverters (NORD BU 0050, BU0050 1.3.5 and 1.3.6).

NORD BU 0050 gives the timing: start pause at least 2 character times (11 bits each), response
delay at most 20 ms, maximum residual telegram time ``1.5 x (n + 4)`` character times, counted
from the start of STX. That is half a character more than A 6.3's ``1.5 x (n + 3)`` from the
end of STX (reading 3 reads the two as one rule; they differ by that half character), so the
profile gives the receiver ``residual_extra_chars=0.5``. The character delay time must stay
below the start pause.

Beyond the NORD manual the project follows NORD's public USS manual BU 0050 (section 1.5, "error
messages if the order cannot be executed"): error numbers 9 "description data not present",
201 "invalid order element in the last order received" and 202 "internal response label cannot
be depicted". A job whose answer does not fit the PKW area gets 202; the reserved request ID 10
gets 201. Broadcast follows the optional mechanism of the specification (appendix).

No spontaneous messages. Diagnostic parameters of the slave (A 5.2.3): P520..P537, beside the
USS settings P511..P513.
"""

from __future__ import annotations

from pyuss.profiles.base import BroadcastForm, Profile
from pyuss.protocol.layout import Layout

PROFILE = Profile(
    name="nord",
    title="NORD frequency inverter",
    follows="NORD BU 0050 1.3.5, 1.3.6",
    manufacturer="NORD",
    default_layout=Layout(4, 2),
    broadcast=BroadcastForm.ENABLE_ARRAY,
    residual_extra_chars=0.5,
    error_meanings={
        9: "description data not present",
        201: "invalid order element in the last order received",
        202: "internal response label cannot be depicted",
    },
    too_large_error=202,
    unsupported_error=201,
    diagnostic_pnu=520,
)
