"""What a command of the MQTT face does to its drive, and the refusals the face answers with
(`pyuss.gateway.mqtt`, one drive's commands carried out in order by its worker:
`pyuss.gateway.mqtt_drive`).

A command acts through the drive model (`pyuss.points.drive`): ``run`` ON is ``on``, OFF is
``off1``; a setpoint is read by the drive model (text too); a control word is a whole number;
``read`` and ``write`` answer with the parameter as read back, rounded to its resolution
(`pyuss.gateway.payloads.reading_dict`). A read-only face refuses every command but
``read``. A refusal carries the keys of `pyuss.points.errors.error_dict`, and every refusal is
one log line (`log_refused`).
"""

from __future__ import annotations

import logging
from typing import Any

from pyuss.errors import ConfigError, UssError
from pyuss.gateway.payloads import reading_dict, reply_payload, state_dict
from pyuss.gateway.topics import Command, number, show, switch_value
from pyuss.points.drive import DrivePoints
from pyuss.points.errors import ReadOnly, UnknownPoint, error_dict
from pyuss.points.state import DriveState

__all__ = ["carry_out", "log_refused", "lost_link", "refusal", "stopping"]

log = logging.getLogger("pyuss.gateway.mqtt")


def refusal(kind: str, message: str, failure: str = "refused") -> dict[str, Any]:
    """An error of a reply that no exception stands for (same keys as `error_dict`)."""
    return {"type": kind, "message": message, "class": failure}


def lost_link() -> dict[str, Any]:
    """The refusal of a command that waited for its drive when the broker was lost."""
    return refusal(
        "Disconnected",
        "the connection to the MQTT broker was lost before it was carried out: not carried out",
        "unavailable",
    )


def stopping() -> dict[str, Any]:
    """The refusal of a command that comes or waits while the gateway stops."""
    return refusal("Stopping", "the gateway is stopping: not carried out", "unavailable")


def log_refused(bus: str, what: str, message: str) -> None:
    """The one log line of a refused command."""
    log.warning(
        "%s: refused %s: %s", bus, what, message if len(message) < 300 else show(message, 300)
    )


async def carry_out(
    drive: DrivePoints, command: Command, *, read_only: bool, bus: str
) -> dict[str, Any]:
    """Carry ``command`` out on ``drive`` and make its reply: a refusal (one log line) for
    what the drive model or the drive refuses (a write to a ``read_only`` face too), an
    error reply for any other failure; nothing a command does ends the drive's task."""
    try:
        if command.writes and read_only:
            raise ReadOnly("this MQTT face is read-only: only read commands are taken")
        result = await _run(drive, command)
    except (UssError, ValueError) as exc:
        error = error_dict(exc)
        log_refused(drive.model.bus, f"{command.name} for {command.drive}", error["message"])
        return reply_payload(command, error=error)
    except Exception as exc:  # one command's failure ends nothing
        log.error(
            "%s: %s for %s failed: %s",
            bus,
            command.name,
            command.drive,
            show(exc, 200),
        )
        return reply_payload(command, error=error_dict(exc))
    return reply_payload(command, result=result)


async def _run(drive: DrivePoints, command: Command) -> dict[str, Any]:
    """What ``command`` does to ``drive``: its result."""
    name = command.name
    state: DriveState
    if name in ("on", "off1", "off2", "off3", "acknowledge"):
        state = await drive.command(name)
    elif name == "run":
        state = await drive.command("on" if switch_value(command.value) else "off1")
    elif name in ("setpoint", "setpoint_percent"):
        unit = "percent" if name == "setpoint_percent" else "value"
        # the drive model reads the number (text too): one reading of a setpoint
        state = await drive.set_setpoint(command.value, command.key, unit=unit)
    elif name == "control_word":
        word = number(command.value, name)
        if not isinstance(word, int):
            raise ConfigError(f"control word must be a whole number, not {show(word)}")
        state = await drive.set_control_word(word)
    elif name == "read":
        assert command.pnu is not None
        return reading_dict(await drive.read_parameter(command.pnu, command.index))
    elif name == "write":
        assert command.pnu is not None
        value = number(command.value, f"write P{command.pnu}")
        reading = await drive.write_parameter(
            command.pnu, value, command.index, eeprom=command.eeprom
        )
        return reading_dict(reading)
    else:  # pragma: no cover - parse_command knows the names
        raise UnknownPoint(f"unknown command {name!r}")
    return {
        "status_word": state.status_word,
        "state": state.state,
        "control_word": state.control_word,
        "setpoint": state_dict(state)["setpoint"],
    }
