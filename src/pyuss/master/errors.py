"""Errors of the master, all under `pyuss.errors.UssError`.

- `NoWriteAuthority`: the drive answered a change job with response ID 8, "keine
  PKW-Bedienhoheit" (C Table 4.2): another interface holds the right to change parameters.
  Response 8 carries no error number, so it is its own class rather than a `DriveRefusal`
  with an invented number; it derives from `PermissionError` as well, which is what it is.
  Catch ``(DriveRefusal, NoWriteAuthority)`` for "the drive said no".
- `JobTimeout`: a parameter job got no answer belonging to it within its time (C 4.2.1.1).
- `NotSending`: the slave did not answer within its response delay ("Teilnehmer x sendet
  nicht", A 5.2.1.1): raised by operations that need one exchange (mirror, process data).
- `MirrorMismatch`: a mirror telegram came back changed (A 5.3).
- `MasterClosed`: the master was closed while the operation waited.
"""

from __future__ import annotations

from pyuss.errors import ProtocolError, TransportError, UssError, UssTimeout

__all__ = ["JobTimeout", "MasterClosed", "MirrorMismatch", "NoWriteAuthority", "NotSending"]


class NoWriteAuthority(UssError, PermissionError):
    """Response ID 8: the interface has no right to change parameters (C Table 4.2).

    Reading still works; every change and EEPROM job is refused this way (C 4.2.1.1).
    """

    def __init__(self, *, address: int, pnu: int, index: int | None = None) -> None:
        self.address = address
        self.pnu = pnu
        self.index = index
        where = f"P{pnu}" + ("" if index is None else f".{index}")
        super().__init__(
            f"slave {address}: no parameter change rights for {where} (response ID 8: another "
            "interface holds the parameter write authority)"
        )


class JobTimeout(UssTimeout):
    """A parameter job got no answer belonging to it in time (C 4.2.1.1)."""

    def __init__(self, message: str, *, address: int, pnu: int | None, sent: int) -> None:
        self.address = address
        self.pnu = pnu
        self.sent = sent
        super().__init__(message)


class NotSending(UssTimeout):
    """ "Slave x does not send": no answer within the response delay (A 5.2.1.1)."""

    def __init__(self, address: int, detail: str = "") -> None:
        self.address = address
        extra = f": {detail}" if detail else ""
        super().__init__(f"slave {address} does not send{extra}")


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


class MasterClosed(TransportError):
    """The master was closed (or its transport failed) while the operation waited."""
