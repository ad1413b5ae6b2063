"""What every ``uss`` command prints with ``--json``: one shape for errors, wall-clock times.

Errors. A failure is the object

    {"type": "DriveRefusal", "message": "...", "exit_code": 1, ...details}

under the key ``"error"``: ``type`` is the class of the error (`pyuss.errors` tree;
``UsageError`` for arguments the command line parser refuses), ``message`` the line the
command prints on stderr without ``--json``, ``exit_code`` what the failure makes the command
exit with (1 failed, 2 bad input). Details by type: ``number`` and ``meaning`` for a refusal
(USS response 7, a BASS error number), ``response_id`` 8 for missing parameter change rights,
``address`` where a drive is named, and for a `JobTimeout` ``outcome`` (``not_sent``,
``unknown``, ``not_applied``), ``may_have_applied``, ``sent``, ``elapsed`` and ``timeout``
(seconds). A command that fails as a whole prints ``{"error": {...}}`` (with the keys of its
result it knows by then); a failure of one item of a result (a parameter of ``uss read``, a
try of ``uss mirror``) sits in that item as ``"error"``.

Times. Points in time are ISO 8601 wall-clock times with the UTC offset
(``2025-01-31T14:05:09.123456+01:00``). pyuss stamps bytes with ``time.monotonic()``;
`wall_clock` turns such a stamp into the wall-clock time it stands for. Durations stay numbers
of seconds (or of milliseconds where the key says ``_ms``).

Streams. Commands that print one JSON object per line (``uss run``, ``uss monitor``) print the
same keys on every line; a failure during the stream is one more line with those keys and
``"error"`` set (``null`` on the other lines).
"""

from __future__ import annotations

import datetime
import json
import time
from typing import Any

from pyuss.errors import DriveRefusal
from pyuss.system import clock

__all__ = [
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_USAGE",
    "error_object",
    "failure",
    "iso_time",
    "print_error",
    "print_json",
    "usage_error",
    "wall_clock",
]

EXIT_OK = 0
EXIT_FAILED = 1
"""The operation failed: no answer, refused by the drive, a port that failed."""
EXIT_USAGE = 2
"""Bad input: arguments, values, a request the layout cannot carry."""
EXIT_INTERRUPTED = 130


def wall_clock(monotonic: float | None = None) -> str:
    """The ISO 8601 wall-clock time (local, with UTC offset, microseconds) of the
    line's clock stamp ``monotonic`` (`pyuss.system.clock`; now when None)."""
    now = time.time()
    return iso_time(now if monotonic is None else now - (clock() - monotonic))


def iso_time(unix: float) -> str:
    """Unix time ``unix`` (seconds) as an ISO 8601 wall-clock time, as `wall_clock`."""
    moment = datetime.datetime.fromtimestamp(unix, tz=datetime.UTC).astimezone()
    return moment.isoformat(timespec="microseconds")


def error_object(exc: BaseException, exit_code: int = 1) -> dict[str, Any]:
    """``exc`` as the JSON error object (module docstring)."""
    from pyuss.master.errors import JobTimeout, NotSending, NoWriteAuthority

    item: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc), "exit_code": exit_code}
    if isinstance(exc, DriveRefusal):
        item.update(number=exc.number, meaning=exc.meaning)
    elif isinstance(exc, NoWriteAuthority):
        item.update(address=exc.address, response_id=8)
    elif isinstance(exc, JobTimeout):
        item.update(
            address=exc.address,
            outcome=exc.outcome.value,
            may_have_applied=exc.may_have_applied,
            sent=exc.sent,
            elapsed=None if exc.elapsed is None else round(exc.elapsed, 6),
            timeout=exc.timeout,
        )
    elif isinstance(exc, NotSending):
        item.update(address=exc.address)
    return item


def print_json(data: Any) -> None:
    """One JSON document on one line of stdout, flushed."""
    print(json.dumps(data, default=str), flush=True)


def print_error(exc: BaseException, exit_code: int = 1, **result: Any) -> None:
    """Print ``{**result, "error": error_object(exc)}``."""
    print_json({**result, "error": error_object(exc, exit_code)})


def failure(command: str | None, error: dict[str, Any]) -> dict[str, Any]:
    """The document a failure of ``command`` prints: a line of its stream for the commands
    that print one (their module's ``json_error_line``), else ``{"error": error}``."""
    if command:
        import importlib

        try:
            module = importlib.import_module(f"pyuss.cli.{command}")
        except ImportError:  # pragma: no cover - every command has its module
            module = None
        line = getattr(module, "json_error_line", None)
        if line is not None:
            document: dict[str, Any] = line(error)
            return document
    return {"error": error}


def usage_error(message: str) -> dict[str, Any]:
    """The error object of arguments the command line parser refused (exit code 2)."""
    return {"type": "UsageError", "message": message, "exit_code": 2}
