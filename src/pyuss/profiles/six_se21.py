"""``6se21``: SIMOVERT P 6SE21 / early MICROMASTER (SIMOVERT P 6SE21 manual, manual section 7.5).

- Every telegram is 14 bytes: LGE fixed at 12, PKW 3 + PZD 2 (SIMOVERT P 6SE21 manual 7.5); other
  layouts are
  refused.
- "IND: unused on the 6SE21, answer telegrams always set IND to 0" (7.5).
- The answer comes about 2 characters after the request: between 2.5 and 17.5 ms at 9600 baud
  (7.5); the window is kept in milliseconds at other rates, and never below the start pause.
- P20 shows the state, 003 = switch-on mode after power-up; PZD1 047Eh (OFF1 with control by
  PLC) clears it (7.5.1.1). That is the drive's state machine and its parameter file
  (``6se21.toml``).

The device knows no broadcast processing (SIMOVERT P 6SE21 manual names none). Error numbers beyond
C Table 4.3
are not documented for the device; jobs that do not fit PKW 3 get 103, the reserved request ID
102, as in the generic profile. No spontaneous messages. Diagnostic parameters of the slave:
P980..P997.
"""

from __future__ import annotations

from pyuss.drive.faults import MEANINGS
from pyuss.profiles.base import BroadcastForm, Profile
from pyuss.protocol.layout import Layout

PROFILE = Profile(
    name="6se21",
    title="SIMOVERT P 6SE21 / early MICROMASTER",
    follows="SIMOVERT P 6SE21 manual 7.5",
    manufacturer="Siemens",
    default_layout=Layout(3, 2),
    fixed_layout=Layout(3, 2),
    pkw_choices=(3,),
    max_pzd=2,
    response_delay_min=0.0025,
    response_delay_max=0.0175,
    delayed_response_max=0.0175,
    answer_index_zero=True,
    broadcast=BroadcastForm.NONE,
    error_meanings={n: MEANINGS[n] for n in (102, 103)},
    too_large_error=103,
    unsupported_error=102,
    diagnostic_pnu=980,
)
