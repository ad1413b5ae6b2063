"""Errors of the BASS service protocol (Baumueller manual part 1), all under
`pyuss.errors.UssError`.

    UssError
    +-- BassError                 base of everything BASS raises
        +-- BassTelegramError     a line that cannot be decoded (also a TelegramError); .fault
        +-- BassProtocolError     a well-formed line that breaks the exchange (also ProtocolError)
        |   +-- BassEchoError     the drive's echo is not the request line (Baumueller manual 1.2)
        +-- BassTimeout           no echo or no answer in time (also UssTimeout)
        +-- BassRefusal           status bit 2 set: error number of table 1.3 (also DriveRefusal)

The error numbers of table 1.3 (Baumueller manual 1.3) are `BassErrorNumber`; `BassRefusal` carries
the
number, its meaning, the drive address and the parameter ID.
"""

from __future__ import annotations

import enum

from pyuss.errors import DriveRefusal, ProtocolError, TelegramError, UssError, UssTimeout


class BassErrorNumber(enum.IntEnum):
    """Error numbers of the service channel (Baumueller manual 1.3 "Tableau des défauts")."""

    NO_ERROR = 0
    ELEMENT_NOT_AVAILABLE = 1
    DATA_TOO_SHORT = 2
    DATA_TOO_LONG = 3
    DATA_NOT_CHANGEABLE = 4
    WRITE_PROTECTED = 5
    BELOW_MINIMUM = 6
    ABOVE_MAXIMUM = 7
    DATA_NOT_VALID = 8
    ACCESS_NOT_VALID = 9

    @property
    def meaning(self) -> str:
        return _MEANINGS[self]


_MEANINGS: dict[BassErrorNumber, str] = {
    BassErrorNumber.NO_ERROR: "no error",
    BassErrorNumber.ELEMENT_NOT_AVAILABLE: "element not available",
    BassErrorNumber.DATA_TOO_SHORT: "data too short",
    BassErrorNumber.DATA_TOO_LONG: "data too long",
    BassErrorNumber.DATA_NOT_CHANGEABLE: "data cannot be changed",
    BassErrorNumber.WRITE_PROTECTED: "parameter is write-protected",
    BassErrorNumber.BELOW_MINIMUM: "data below the minimum",
    BassErrorNumber.ABOVE_MAXIMUM: "data above the maximum",
    BassErrorNumber.DATA_NOT_VALID: "data not valid",
    BassErrorNumber.ACCESS_NOT_VALID: "access to the parameter not valid",
}


def error_meaning(number: int) -> str:
    """The meaning of an error number of table 1.3; numbers outside 0..9 are named as such."""
    try:
        return BassErrorNumber(number).meaning
    except ValueError:
        return f"error number {number} (not in table 1.3)"


class FaultKind(enum.Enum):
    """Why a received line is malformed (what `BassLineReader` reports)."""

    MISSING_BOF = "missing '#'"
    MISSING_EOF = "missing CR LF"
    OVERLONG = "line too long"
    TOO_SHORT = "line too short"
    BAD_HEX = "not a hex digit"
    BAD_CHECKSUM = "bad checksum"
    BAD_TEXT = "bad text length words"


class BassError(UssError):
    """Base of every error of the BASS service protocol."""


class BassTelegramError(BassError, TelegramError):
    """A BASS line that cannot be encoded or decoded; ``fault`` says why (None: a field value)."""

    def __init__(self, message: str, fault: FaultKind | None = None) -> None:
        self.fault = fault
        super().__init__(message)


class BassProtocolError(BassError, ProtocolError):
    """A well-formed line arrived that does not fit the exchange (wrong address, ID, order)."""


class BassEchoError(BassProtocolError):
    """The first line back was not the echo of the request (Baumueller manual 1.2: echo before
    answer)."""

    def __init__(self, sent: bytes, received: bytes) -> None:
        self.sent = sent
        self.received = received
        super().__init__(f"echo mismatch: sent {sent!r}, got back {received!r}")


class BassTimeout(BassError, UssTimeout):
    """No echo, or an echo but no answer, within the time allowed."""


class BassRefusal(BassError, DriveRefusal):
    """The drive answered with status bit 2 set: an error of table 1.3 (Baumueller manual 1.2, 1.3).

    Drive models raise it too (`pyuss.bass.ring.OperatingData`) to refuse a job with a number.
    """

    def __init__(
        self, number: int, *, ident: int | None = None, address: int | None = None
    ) -> None:
        DriveRefusal.__init__(self, number, error_meaning(number), pnu=ident)
        self.ident = ident
        self.address = address
        who = "drive" if address is None else f"drive {address}"
        what = "" if ident is None else f" ID {ident}"
        self.args = (f"{who} refused{what}: error {number}: {self.meaning}",)

    @property
    def code(self) -> BassErrorNumber | None:
        """The number as `BassErrorNumber`, or None when it is not in table 1.3."""
        try:
            return BassErrorNumber(self.number)
        except ValueError:
            return None
