"""``micromaster4``: MICROMASTER 4 / SINAMICS convention for parameter numbers of 2000 and up.

PKE carries 11 bits of parameter number. These drives split a number into a base number 0..1999
in PKE bits 0..10 and a page number in IND bits 12..15: ``PNU = base + 2000 x page``, where
the page bits are weighted bit 15 = 1, bit 12 = 2, bit 13 = 4, bit 14 = 8, so page 1
(P2000..P3999, for example P2010) is IND bit 15 alone, and pages 0..15 reach P31999. Source:
Siemens MICROMASTER 420 Operating Instructions, issue 10/06 (6SE6400-5AA00-0BP0), section 3,
USS "parameter number (PNU)": "PNU = PNU1 + 2000 x PNU2", PNU2 in IND bits 12..15 with the
weights 2^0 (bit 15), 2^3, 2^2, 2^1; the SINAMICS G120 function manual (06/2012,
6SL3097-4AB10-0BP4, 9.5) describes the same page selection in the IND high byte.

IND bits 0..7 keep the subindex; arrays count from 0 (``micromaster4.toml``). Error numbers
above C Table 4.3 follow the SINAMICS list (same manual, Table 9-47): 101 "parameter number
currently deactivated", 102 "channel width insufficient" - which is what a job whose answer
does not fit the PKW area gets. The reserved request ID 10 is answered with 22, the PROFIdrive
number for an illegal parameter address (the project's reading: no documented number exists).
SINAMICS converters do not support broadcast telegrams (G120XA operating instructions 03/2019,
6.2.4.3: "Bit 5 = 1: Not supported in the converter"): broadcasts are ignored.

The PKE toggle bit 11 is reserved on these drives (G120 function manual 9.5: "Bit 11 (SPM) is
reserved and always = 0"): no spontaneous messages. Diagnostic parameters of the slave
(A 5.2.3): P2090..P2107.
"""

from __future__ import annotations

from pyuss.profiles.base import BroadcastForm, Profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout

PAGE_SIZE = 2000

PROFILE = Profile(
    name="micromaster4",
    title="MICROMASTER 4 / SINAMICS (parameters >= 2000 through IND page bits)",
    follows="none; MICROMASTER 420 operating instructions, USS parameter number",
    manufacturer="Siemens",
    default_layout=Layout(PKW_VARIABLE, 2),
    max_pzd=8,
    pnu_page_size=PAGE_SIZE,
    broadcast=BroadcastForm.NONE,
    error_meanings={
        11: "not in master control mode",
        12: "keyword missing",
        15: "no text array",
        17: "request cannot be processed in the present operating state",
        22: "illegal parameter address",
        101: "parameter number currently deactivated",
        102: "channel width insufficient for the response",
    },
    too_large_error=102,
    unsupported_error=22,
    diagnostic_pnu=2090,
)
