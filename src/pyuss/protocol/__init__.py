"""The USS protocol without I/O: telegram codec, timing, receiver, net data (PKW/PZD), broadcast.

Everything here is pure: no I/O and no clock reads; times are passed in (seconds).
"""

from pyuss.protocol.diagnostics import Counters, Diagnostics, ErrorStatus, FaultKind
from pyuss.protocol.receiver import Event, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import (
    MAX_ADDRESS,
    MAX_LGE,
    MAX_NET_BYTES,
    MIN_LGE,
    STX,
    AddressError,
    AddressMode,
    BccError,
    LengthError,
    StxError,
    Telegram,
    adr_byte,
    bcc,
    parse_adr,
)
from pyuss.protocol.timing import (
    BAUD_RATES,
    MAX_RESPONSE_DELAY,
    LineTiming,
    char_time,
    check_baud,
    residual_time_flush,
    residual_time_max,
    response_delay_limit,
    start_pause,
)

__all__ = [
    "BAUD_RATES",
    "MAX_ADDRESS",
    "MAX_LGE",
    "MAX_NET_BYTES",
    "MAX_RESPONSE_DELAY",
    "MIN_LGE",
    "STX",
    "AddressError",
    "AddressMode",
    "BccError",
    "Counters",
    "Diagnostics",
    "ErrorStatus",
    "Event",
    "FaultKind",
    "LengthError",
    "LineTiming",
    "ReceiveFault",
    "Received",
    "Receiver",
    "StxError",
    "Telegram",
    "adr_byte",
    "bcc",
    "char_time",
    "check_baud",
    "parse_adr",
    "residual_time_flush",
    "residual_time_max",
    "response_delay_limit",
    "start_pause",
]
