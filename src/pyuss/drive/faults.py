"""Typed refusals of parameter jobs: the error numbers of C Table 4.3.

A drive that cannot execute a parameter job answers response ID 7 ("Auftrag nicht ausfuehrbar")
with an error number in PWE (C 4.2.1.1). Inside the simulator such a refusal is a
`ParameterFault`; the slave engine turns it into that answer.

C Table 4.3 defines 0..7 and declares the numbers up to 100 identical with the PROFIBUS profile
"variable-speed drives" it cites; numbers above 100 belong to the device. The table names 11, 12,
15 and 17 from that profile because the simulator uses them (write authority, keyword, text
array, operating state). 101..104 are Baumueller's device numbers (Baumueller manual 2.2.1, "Liste
des
indicatifs de defauts"); other profiles may use them in the same sense.

`NoWriteAuthority` (11) is special: on the USS parameter channel the lack of write authority is
not answered with ID 7 but with response ID 8 "keine PKW-Bedienhoheit" (C Table 4.2); the slave
engine catches it by class.
"""

from __future__ import annotations

import enum

from pyuss.errors import UssError
from pyuss.protocol.pkw import error_meaning


class DriveErrorNumber(enum.IntEnum):
    """Error numbers beyond C Table 4.3 (whose 0..7 are `pyuss.protocol.pkw.ErrorNumber`)."""

    NO_WRITE_AUTHORITY = 11
    KEYWORD_MISSING = 12
    NO_TEXT_ARRAY = 15
    WRONG_STATE = 17
    UNSPECIFIED = 101
    NOT_IMPLEMENTED = 102
    TOO_LARGE_FOR_PKW = 103
    NO_SUCH_ELEMENT = 104


MEANINGS: dict[int, str] = {
    DriveErrorNumber.NO_WRITE_AUTHORITY: "no parameter write authority",
    DriveErrorNumber.KEYWORD_MISSING: "keyword missing",
    DriveErrorNumber.NO_TEXT_ARRAY: "no text array",
    DriveErrorNumber.WRONG_STATE: "not executable in the present operating state",
    DriveErrorNumber.UNSPECIFIED: "unspecified fault",
    DriveErrorNumber.NOT_IMPLEMENTED: "service not implemented",
    DriveErrorNumber.TOO_LARGE_FOR_PKW: "format too large for the PKW area",
    DriveErrorNumber.NO_SUCH_ELEMENT: "description element does not exist",
}
"""Meanings of `DriveErrorNumber` (Baumueller's 101..104 after Baumueller manual 2.2.1)."""


def meaning(number: int) -> str:
    """The name of an error number (C Table 4.3, then `MEANINGS`)."""
    return error_meaning(number, MEANINGS)


class ParameterFault(UssError):
    """A parameter job the drive refuses; ``number`` is the error number for response ID 7.

    ``detail`` says in words what was wrong (for logs and the user), ``pnu`` and ``index`` say
    which job it was.
    """

    def __init__(
        self,
        number: int,
        detail: str = "",
        *,
        pnu: int | None = None,
        index: int | None = None,
    ) -> None:
        self.number = int(number)
        self.meaning = meaning(self.number)
        self.detail = detail
        self.pnu = pnu
        self.index = index
        where = "" if pnu is None else f"P{pnu}" + ("" if index is None else f".{index}") + ": "
        text = f"{where}error {self.number} ({self.meaning})"
        super().__init__(f"{text}: {detail}" if detail else text)


class NoWriteAuthority(ParameterFault):
    """The interface may read but not change parameters (answered with response ID 8, C 4.2.1.1)."""

    def __init__(self, interface: str, *, pnu: int | None = None, index: int | None = None) -> None:
        super().__init__(
            DriveErrorNumber.NO_WRITE_AUTHORITY,
            f"interface {interface!r} has no parameter write authority",
            pnu=pnu,
            index=index,
        )
        self.interface = interface
