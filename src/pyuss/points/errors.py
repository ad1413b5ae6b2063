"""What went wrong with a request from a face, in classes every face maps to its own errors.

A face (Modbus, MQTT, OPC UA, the web page) hands a client's request to the points; what can
go wrong falls into a few classes, and each face has one table from class to its error (a
Modbus exception code, an OPC UA status code, an MQTT reply): `classify` is the one place that
decides the class, so the faces agree. The drive's own error number travels along where there
is one (`error_dict`).

=================  ===============================================================
`Failure`          cause
=================  ===============================================================
``NOT_FOUND``      no such point or register; the drive answered error 0 (no such
                   parameter), 3 (wrong index) or 4 (not an array), C Table 4.3
``BAD_VALUE``      the value was refused before sending (type, limits, not whole),
                   or the drive answered error 2 (limit), 5 (type) or 6 (only reset)
``REFUSED``        the drive refused for another reason: error 1 (not changeable),
                   7, 11 (no operator rights), 12 (keyword), 17 (not in this state),
                   device numbers above 100; or the points refused a command that
                   would take a running drive over with OFF1 (`NotInControl`)
``NO_AUTHORITY``   response 8: another interface holds the write authority
``READ_ONLY``      the face is configured read-only, or the client may only read
``NO_ANSWER``      the drive does not send, or the job got no answer in time
``UNAVAILABLE``    the gateway's bus is closed or its port failed
=================  ===============================================================
"""

from __future__ import annotations

import enum
from typing import Any

from pyuss.errors import ConfigError, DriveRefusal, TransportError, UssError, UssTimeout
from pyuss.master.errors import NotInControl, NoWriteAuthority

__all__ = [
    "Failure",
    "NoWriteAuthority",
    "NotInControl",
    "ReadOnly",
    "UnknownPoint",
    "classify",
    "error_dict",
]


class ReadOnly(UssError, PermissionError):
    """The face or client may not write."""


class UnknownPoint(ConfigError, LookupError):
    """No such drive, point or parameter in the gateway's configuration."""


class Failure(enum.Enum):
    NOT_FOUND = "not_found"
    BAD_VALUE = "bad_value"
    REFUSED = "refused"
    NO_AUTHORITY = "no_authority"
    READ_ONLY = "read_only"
    NO_ANSWER = "no_answer"
    UNAVAILABLE = "unavailable"


_NOT_FOUND_NUMBERS = frozenset({0, 3, 4})
_BAD_VALUE_NUMBERS = frozenset({2, 5, 6})


def classify(exc: BaseException) -> Failure:
    """The class of ``exc`` (see the module docstring); anything unexpected is UNAVAILABLE."""
    if isinstance(exc, DriveRefusal):
        if exc.number in _NOT_FOUND_NUMBERS:
            return Failure.NOT_FOUND
        if exc.number in _BAD_VALUE_NUMBERS:
            return Failure.BAD_VALUE
        return Failure.REFUSED
    if isinstance(exc, NoWriteAuthority):
        return Failure.NO_AUTHORITY
    if isinstance(exc, NotInControl):
        return Failure.REFUSED
    if isinstance(exc, ReadOnly):
        return Failure.READ_ONLY
    if isinstance(exc, UnknownPoint):
        return Failure.NOT_FOUND
    if isinstance(exc, ConfigError | ValueError | TypeError):
        return Failure.BAD_VALUE
    if isinstance(exc, UssTimeout | TimeoutError):
        return Failure.NO_ANSWER
    if isinstance(exc, TransportError):
        return Failure.UNAVAILABLE
    return Failure.UNAVAILABLE


def error_dict(exc: BaseException) -> dict[str, Any]:
    """An error as JSON, in the shape the ``uss`` commands print: ``type``, ``message``,
    ``class`` (a `Failure` value), and ``number`` and ``meaning`` for a refusal (response 7)
    or ``response_id`` 8 for missing write authority."""
    item: dict[str, Any] = {
        "type": type(exc).__name__,
        "message": str(exc) if isinstance(exc, UssError) else f"{type(exc).__name__}: {exc}",
        "class": classify(exc).value,
    }
    if isinstance(exc, DriveRefusal):
        item.update(number=exc.number, meaning=exc.meaning)
        if exc.pnu is not None:
            item["pnu"] = exc.pnu
        if exc.index is not None:
            item["index"] = exc.index
    elif isinstance(exc, NoWriteAuthority):
        item.update(response_id=8, pnu=exc.pnu)
    return item
