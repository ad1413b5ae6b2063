"""The one exception tree of pyuss. Everything pyuss raises on purpose derives from `UssError`.

    UssError
    +-- ConfigError          bad argument, value, layout, profile or file given by the user
    +-- ProtocolError        the bytes on the wire break a rule of the specification
    |   +-- TelegramError    a telegram that cannot be decoded (STX, LGE, ADR, BCC, length)
    +-- TransportError       the byte pipe failed (port gone, link dropped, closed)
    +-- UssTimeout           no (matching) answer within the allowed time
    +-- DriveRefusal         the drive answered a parameter job with response ID 7 (C 4.2.1.1)

Sub-packages add their own subclasses of these (for example ``pyuss.bass`` and
``pyuss.ksvario``), never parallel trees.
"""

from __future__ import annotations


class UssError(Exception):
    """Base of every error pyuss raises on purpose."""


class ConfigError(UssError, ValueError):
    """A value, argument, layout, profile or file given by the user is not acceptable."""


class ProtocolError(UssError):
    """Bytes or a telegram that break a rule of the specification."""


class TelegramError(ProtocolError, ValueError):
    """A telegram cannot be encoded or decoded (STX, LGE, ADR, BCC, length)."""


class TransportError(UssError, OSError):
    """The byte pipe failed: port missing, link dropped, transport closed."""


class UssTimeout(UssError, TimeoutError):
    """No answer, or no matching answer, arrived within the time allowed."""


class DriveRefusal(UssError):
    """A drive refused a parameter job: response ID 7 with an error number (C 4.2.1.1).

    ``number`` is the error number from PWE, ``meaning`` its name (C Table 4.3 for 0..7 and 17..,
    or the drive profile's own numbers above 100), ``pnu`` and ``index`` say which job it was,
    ``label`` how the drive's family writes that parameter (``P0310.0``; without it ``PNU
    310.0``), ``hint`` what to do (`pyuss.profiles.Profile.error_hint`; "" where nothing is
    known). The message says all of it: ``drive refused the job (P0310.0): error 17: ...;
    <what to do>``.
    """

    def __init__(
        self,
        number: int,
        meaning: str,
        *,
        pnu: int | None = None,
        index: int | None = None,
        label: str | None = None,
        hint: str = "",
    ) -> None:
        self.number = number
        self.meaning = meaning
        self.pnu = pnu
        self.index = index
        self.hint = hint
        if label is None and pnu is not None:
            label = f"PNU {pnu}" + ("" if index is None else f".{index}")
        where = "" if label is None else f" ({label})"
        todo = f"; {hint}" if hint else ""
        super().__init__(f"drive refused the job{where}: error {number}: {meaning}{todo}")


def cut(value: object, width: int = 40) -> str:
    """``repr(value)`` for an error message, cut short at ``width`` characters (what a user
    or a peer sent may be a 400-digit number or a name of 10 kB)."""
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."
