"""``generic``: the drive profile of the USS specification, SIMOVERT MASTERDRIVES style.

Follows the USS specification part C: interface parameters P683..P687 as arrays
over
the interfaces SST 1, SCB, SST 2 (C 3.2), the parameter examples of C 8, fixed (PKW 0, 3, 4) or
variable (127) PKW area with up to 16 PZD words (C 3.1, C 4.1), the optional broadcast mechanism
with the Broadcast Enable Array (appendix, C 5.2.3: defined for SIMOVERT MASTERDRIVES), the
timing of part A (start pause 2 characters, answer within 20 ms, A 5.1.2, A 5.2.1.1).

Error numbers: 0..7 from C Table 4.3; 11, 12, 15, 17 from the PROFIBUS drive profile the table
refers to for 0..100; the device numbers 101..104 are used in Baumueller's sense (Baumueller manual
2.2.1). A job whose answer does not fit the PKW area, or that needs the variable layout under a
fixed one, is answered with error 103 "format too large for the PKW area" (C 7, C 8.1 example 3,
whose device-specific number the project's vectors fix at 103). The reserved request ID 10 is
answered with 102 "service not implemented".

Spontaneous messages (C 4.2.1.2) are sent for the active parameters (P52, P947 in the file).

Diagnostic parameters (A 5.2.3) of the slave: P2030..P2047.
"""

from __future__ import annotations

from pyuss.drive.faults import MEANINGS
from pyuss.profiles.base import BroadcastForm, Profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout

PROFILE = Profile(
    name="generic",
    title="USS drive profile (SIMOVERT MASTERDRIVES style)",
    follows="USS specification part A, part C, appendix",
    default_layout=Layout(PKW_VARIABLE, 2),
    broadcast=BroadcastForm.ENABLE_ARRAY,
    spontaneous=True,
    error_meanings=dict(MEANINGS),
    too_large_error=103,
    unsupported_error=102,
    diagnostic_pnu=2030,
)
