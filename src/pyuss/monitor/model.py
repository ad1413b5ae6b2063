"""What the monitor sees: frames (one per telegram or run of bad bytes) and exchanges.

A `Frame` is one telegram, or one run of bytes that forms no good telegram, as a receiver cut
it out of the line (A 5.2): its bytes, when it began and ended, which way it went (`Direction`,
known on a 4-wire line, inferred from timing and position on a 2-wire line) and, for bad
bytes, the receive fault (`pyuss.protocol.FaultKind`, A 5.2.2). A frame whose bytes still hold
a whole telegram (wrong BCC, a line error, no start pause before it) keeps the decoded
`Telegram` as well, so the monitor can show what it would have said.

An `Exchange` is what the monitor prints one line for: a request and its answer, a request
without an answer, an answer nobody asked for, or noise. Each carries its `Issue`s: the
receive faults of its frames and the faults of the exchange itself (no answer, late answer,
answer from the wrong address, ...), each a `Problem`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.layout import Layout, NetData
from pyuss.protocol.telegram import (
    MAX_LGE,
    MIN_LGE,
    MIN_TELEGRAM_BYTES,
    STX,
    AddressError,
    AddressMode,
    Telegram,
)

__all__ = [
    "Direction",
    "Exchange",
    "Frame",
    "Issue",
    "LayoutSource",
    "Problem",
    "ms",
    "problem_of",
    "telegram_in",
]


class Direction(enum.IntEnum):
    """Which way a frame went; the value is the one stored in capture files."""

    UNKNOWN = 0
    REQUEST = 1
    """Master to slave (Auftragstelegramm)."""
    RESPONSE = 2
    """Slave to master (Antworttelegramm)."""

    @property
    def label(self) -> str:
        """``unknown``, ``request`` or ``response``."""
        return self.name.lower()


class Problem(enum.StrEnum):
    """Everything the monitor reports as an error, receive faults and exchange faults.

    The first eight are the receive faults of A 5.2.2 (`FaultKind`, same names); the others
    concern the exchange as a whole.
    """

    FRAMING = "framing"
    """A character with a framing error (or a break)."""
    OVERRUN = "overrun"
    """The port lost characters (overrun)."""
    PARITY = "parity"
    """A character with a parity error."""
    NO_STX = "no_stx"
    """Bytes without a valid start: no STX after a start pause, or no start pause (A 5.1.2)."""
    BCC = "bcc"
    """Wrong block check character (A 4.4)."""
    RESIDUAL_TIME = "residual_time"
    """The telegram was not complete within its residual time (A 5.2.1.2, A 6.3)."""
    BAD_LGE = "bad_lge"
    """LGE out of range, or not the fixed length of the address (A 4.2, A 5.2)."""
    BAD_ADR = "bad_adr"
    """ADR bits 5..7 in a combination the spec leaves undefined (A 4.3)."""
    NO_ANSWER = "no_answer"
    """The addressed slave did not answer within the response delay limit (A 5.2.1.1)."""
    LATE_ANSWER = "late_answer"
    """The answer began after the response delay limit (A 5.2.1.1)."""
    EARLY_ANSWER = "early_answer"
    """The answer began less than a start pause after the request (A 5.2.1.1)."""
    WRONG_ADDRESS = "wrong_address"
    """The answer carries another address than the request (A 5.2)."""
    UNEXPECTED = "unexpected"
    """An answer to a broadcast (A 3) or to no request at all."""
    MIRROR = "mirror"
    """The answer to a mirror telegram is not the same bytes (A 5.3)."""
    LAYOUT = "layout"
    """The net data do not fit the layout given for the address (C 3.1, C 7)."""

    @property
    def fault(self) -> FaultKind | None:
        """The receive fault this problem stands for, if it is one."""
        return _FAULTS.get(self)


_FAULTS = {Problem[kind.name]: kind for kind in FaultKind}


def problem_of(kind: FaultKind) -> Problem:
    """The `Problem` of a receive fault."""
    return Problem[kind.name]


class LayoutSource(enum.StrEnum):
    """Where the layout used to decode an address came from."""

    GIVEN = "given"
    """Given by the user (``--layout``)."""
    INFERRED = "inferred"
    """Inferred from the traffic, with clear evidence."""
    GUESSED = "guessed"
    """Inferred from the traffic, but other layouts fit nearly as well: a guess."""


def ms(seconds: float) -> str:
    """A duration as the monitor's texts show it: milliseconds to the microsecond."""
    return f"{seconds * 1000:.3f} ms"


def telegram_in(raw: bytes) -> Telegram | None:
    """The telegram ``raw`` holds if its frame is whole (STX, LGE matching the byte count,
    defined ADR), the BCC not checked; None otherwise."""
    n = len(raw)
    if n < MIN_TELEGRAM_BYTES or raw[0] != STX or not MIN_LGE <= raw[1] <= MAX_LGE:
        return None
    if n != raw[1] + 2:
        return None
    try:
        return Telegram.decode(raw, check_bcc=False)
    except (AddressError, ValueError):
        return None


@dataclass(frozen=True, slots=True)
class Frame:
    """One telegram or run of bad bytes on the line (see the module text).

    ``start`` is the start of the first character, ``end`` the end of the last one (seconds in
    the time base of the timestamps fed). ``guessed`` is true when ``direction`` comes from
    timing and position (2-wire line), not from the port. ``port`` is 0 (or the only port) or
    1 (slave to master on a 4-wire line).
    """

    raw: bytes
    start: float
    end: float
    direction: Direction = Direction.UNKNOWN
    guessed: bool = False
    fault: FaultKind | None = None
    detail: str = ""
    telegram: Telegram | None = None
    port: int = 0

    @property
    def ok(self) -> bool:
        """A telegram received without fault."""
        return self.fault is None and self.telegram is not None

    @property
    def address(self) -> int | None:
        """The address in ADR when the bytes hold a telegram."""
        return None if self.telegram is None else self.telegram.address

    @property
    def mode(self) -> AddressMode | None:
        """The telegram type in ADR when the bytes hold a telegram."""
        return None if self.telegram is None else self.telegram.mode


@dataclass(frozen=True, slots=True)
class Issue:
    """One problem of an exchange: ``where`` is ``request``, ``answer`` or ``exchange``."""

    problem: Problem
    where: str
    text: str


@dataclass(frozen=True, slots=True)
class Exchange:
    """A request and its answer (either may be missing), decoded.

    ``layout`` is the layout the net data were decoded with and ``layout_source`` where it came
    from; ``request_data``/``answer_data`` the unpacked net data (None when the frame is
    missing, damaged beyond decoding, a special or mirror telegram, or does not fit).
    ``delay`` is the response delay: from the end of the request to the start of the answer
    (A 5.2.1.1). ``unsure`` says why the pairing is a guess (2-wire line), empty when it is
    not. ``control_before``/``status_before`` are the address's previous control and status
    words (to show which bits changed). ``notes`` are remarks that are not errors.
    """

    request: Frame | None
    answer: Frame | None
    address: int | None = None
    layout: Layout | None = None
    layout_source: LayoutSource | None = None
    request_data: NetData | None = None
    answer_data: NetData | None = None
    delay: float | None = None
    issues: tuple[Issue, ...] = ()
    unsure: str = ""
    notes: tuple[str, ...] = ()
    control_before: int | None = None
    status_before: int | None = None
    index: int = field(default=0, compare=False)

    @property
    def kind(self) -> str:
        """``exchange`` (request and answer), ``request`` (no answer), ``answer`` (no request)
        or ``noise`` (bytes that form no telegram and belong to nothing)."""
        if self.request is not None and self.answer is not None:
            return "exchange"
        if self.answer is not None:
            return "answer"
        assert self.request is not None
        if self.request.telegram is None and self.request.fault is not None:
            return "noise"
        return "request"

    @property
    def time(self) -> float:
        """When the exchange began."""
        first = self.request if self.request is not None else self.answer
        assert first is not None
        return first.start

    @property
    def frames(self) -> tuple[Frame, ...]:
        """The frames of the exchange in time order."""
        return tuple(f for f in (self.request, self.answer) if f is not None)

    @property
    def problems(self) -> tuple[Problem, ...]:
        """The problems of the issues, in order."""
        return tuple(issue.problem for issue in self.issues)

    @property
    def mode(self) -> AddressMode | None:
        """The telegram type of the request (or of the answer without a request)."""
        for frame in self.frames:
            if frame.telegram is not None:
                return frame.telegram.mode
        return None
