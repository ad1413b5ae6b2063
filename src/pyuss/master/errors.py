"""Errors of the master, all under `pyuss.errors.UssError`.

- `NoWriteAuthority`: the drive answered a change job with response ID 8, "keine
  PKW-Bedienhoheit" (C Table 4.2): another interface holds the right to change parameters.
  Response 8 carries no error number, so it is its own class rather than a `DriveRefusal`
  with an invented number; it derives from `PermissionError` as well, which is what it is.
  Catch ``(DriveRefusal, NoWriteAuthority)`` for "the drive said no".
- `JobTimeout`: a parameter job got no answer belonging to it within its time (C 4.2.1.1).
  Its `JobOutcome` says what is known of a change job: never sent (the drive did not get
  it), or sent without an answer of its own (it may have been carried out: read it back, or
  write with ``verify=True``).
- `NotSending`: the slave did not answer within its response delay ("Teilnehmer x sendet
  nicht", A 5.2.1.1): raised by operations that need one exchange (mirror, process data).
- `DriveFault`: the drive reports a fault (status bit 3, C Table 5.5).
- `StatusTimeout`: the drive answered, but its status did not show what was waited for
  (`Drive.wait_until`) in time; it carries the last status.
- `MirrorMismatch`: a mirror telegram came back changed (A 5.3).
- `MasterClosed`: the master was closed while the operation waited.
- `ValueDiffers`: the drive answered a write with another value than the one written (it
  limits or rounds): it holds that one, not the one asked for.
"""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING

from pyuss.errors import ProtocolError, TransportError, UssError, UssTimeout

if TYPE_CHECKING:
    from pyuss.master.process import DriveStatus
    from pyuss.protocol.pkw import Pkw

__all__ = [
    "DriveFault",
    "JobOutcome",
    "JobTimeout",
    "MasterClosed",
    "MirrorMismatch",
    "NoWriteAuthority",
    "NotInControl",
    "NotSending",
    "StatusTimeout",
    "ValueDiffers",
]


class NoWriteAuthority(UssError, PermissionError):
    """Response ID 8: the interface has no right to change parameters (C Table 4.2).

    Reading still works; every change and EEPROM job is refused this way (C 4.2.1.1).
    ``label``: the parameter as the drive's family writes it (``P1120``; without it ``P1120``
    in the generic style); ``hint``: what to do (`pyuss.profiles.Profile.no_authority_hint`:
    on a MICROMASTER 4 or SINAMICS drive, P0927).
    """

    def __init__(
        self,
        *,
        address: int,
        pnu: int,
        index: int | None = None,
        label: str | None = None,
        hint: str = "",
    ) -> None:
        self.address = address
        self.pnu = pnu
        self.index = index
        self.hint = hint
        where = label or (f"P{pnu}" + ("" if index is None else f".{index}"))
        todo = f": {hint}" if hint else ""
        super().__init__(
            f"slave {address}: no parameter change rights for {where} (response ID 8: another "
            f"interface holds the parameter write authority){todo}"
        )


class JobOutcome(enum.Enum):
    """What is known of a parameter job that got no answer of its own (`JobTimeout.outcome`).

    A drive carries out a job when a telegram carrying it arrives and then answers it
    (C 4.2.1.1); a lost answer says nothing about the job itself.
    """

    NOT_SENT = "not_sent"
    """The job never went out (held back until the drive's old answer cleared, or the drive
    got no turn): the drive did not get it and changed nothing."""
    UNKNOWN = "unknown"
    """The job was sent but no answer of its own came back: the drive may have carried it
    out (a lost answer) or not (a lost request). Read the value back to know."""
    APPLIED = "applied"
    """Read back after the timeout: the drive holds the value written (`Drive.write` with
    ``verify=True`` then returns normally)."""
    NOT_APPLIED = "not_applied"
    """Read back after the timeout: the drive does not hold the value written; it did not
    carry out the job, which may be repeated."""


class JobTimeout(UssTimeout):
    """A parameter job got no answer belonging to it in time (C 4.2.1.1).

    ``outcome`` (a `JobOutcome`): `NOT_SENT` or `UNKNOWN` as the master saw it, `NOT_APPLIED`
    after a read-back (``verify=True``) found the old value. ``may_have_applied`` is true for
    a change job whose outcome is unknown. ``elapsed``: seconds from the moment the job was
    due to the moment it was given up, on the transport's clock (the virtual bus's timeline
    on the virtual bus); ``timeout``: the time it had; ``sent``: telegrams that carried it;
    ``request``: the PKW area of the job (None when not known).
    """

    def __init__(
        self,
        message: str,
        *,
        address: int,
        pnu: int | None,
        sent: int,
        index: int | None = None,
        outcome: JobOutcome | None = None,
        elapsed: float | None = None,
        timeout: float | None = None,
        request: Pkw | None = None,
    ) -> None:
        self.address = address
        self.pnu = pnu
        self.index = index
        self.sent = sent
        self.outcome = outcome or (JobOutcome.NOT_SENT if sent == 0 else JobOutcome.UNKNOWN)
        self.elapsed = elapsed
        self.timeout = timeout
        self.request = request
        super().__init__(message)

    @property
    def changes(self) -> bool:
        """Whether the job changes a value (a write, an EEPROM write, a text write)."""
        return self.request is not None and job_changes(self.request)

    @property
    def may_have_applied(self) -> bool:
        """A change job whose outcome is unknown: the drive may hold the new value."""
        return self.changes and self.outcome is JobOutcome.UNKNOWN


def job_changes(request: Pkw) -> bool:
    """Whether ``request`` changes something in the drive (request 15 only with IND bit 8,
    "write text", C Table 4.5)."""
    from pyuss.protocol.pkw import RequestId, TextIndex

    try:
        rid = RequestId(request.id)
    except ValueError:  # pragma: no cover - Pkw ids are 0..15, all named
        return False
    if rid is RequestId.TEXT:
        return bool(request.index & TextIndex.WRITE)
    return rid.is_change


class NotSending(UssTimeout):
    """ "Slave x does not send": no answer within the response delay (A 5.2.1.1)."""

    def __init__(self, address: int, detail: str = "") -> None:
        self.address = address
        extra = f": {detail}" if detail else ""
        super().__init__(f"slave {address} does not send{extra}; {NOT_SENDING_HINT}")


NOT_SENDING_HINT = "check address, baud rate and wiring"
"""What to do when a slave does not send (A 5.2.1.1), whichever the family."""


class DriveFault(UssError):
    """The drive reports a fault: status bit 3 (C Table 5.5). ``status`` is that answer."""

    def __init__(self, status: DriveStatus) -> None:
        self.address = status.address
        self.status = status
        super().__init__(
            f"slave {status.address} reports a fault: status word {status.word:04X}h "
            "(bit 3, C Table 5.5)"
        )


class StatusTimeout(UssTimeout):
    """The drive's status did not meet a condition within ``timeout`` seconds while the drive
    kept answering (`Drive.wait_until`). ``status`` is its last status (None: no answer came
    at all, which is reported as `NotSending` when the slave does not send)."""

    def __init__(
        self,
        address: int,
        timeout: float,
        status: DriveStatus | None,
        what: str = "the state waited for",
    ) -> None:
        self.address = address
        self.timeout = timeout
        self.status = status
        if status is None:
            shown = "no answer yet"
        else:
            actual = status.actual_percent
            value = "" if actual is None else f", actual value {actual:.2f} %"
            shown = f"it reports status word {status.word:04X}h ({status.state}{value})"
        super().__init__(f"slave {address}: did not reach {what} within {timeout:g} s: {shown}")


class MirrorMismatch(ProtocolError):
    """The answer to a mirror telegram differs from what was sent (A 5.3)."""

    def __init__(self, address: int, sent: bytes, received: bytes) -> None:
        self.address = address
        self.sent = sent
        self.received = received
        super().__init__(
            f"slave {address}: mirror telegram came back changed: sent "
            f"{sent.hex(' ').upper()}, received {received.hex(' ').upper()}"
        )


class NotInControl(UssError):
    """A command that changes bits of the control word in force (acknowledge, jog, enable),
    or one that would take control with process data nobody set here, was refused: this
    master has sent no control word yet (0000h: no control by the interface) and the drive
    is switched on, or has not answered, so the command would take the drive over with
    OFF1 (047Eh). Nothing was sent."""


class MasterClosed(TransportError):
    """The master was closed (or its transport failed) while the operation waited."""


class ValueDiffers(UssError):
    """The drive answered a write with another value than the one written (C 4.2.1.1: the
    answer to a change job carries the value the drive now holds): it limited or rounded it,
    or changed it by a rule of its own. ``written`` and ``answered``: the values as printed."""

    def __init__(self, label: str, written: str, answered: str) -> None:
        self.label = label
        self.written = written
        self.answered = answered
        super().__init__(
            f"{label}: the drive answered {answered}, not {written}: it holds another value "
            "than the one written (it limits or rounds it): read it, and write a value it takes"
        )
