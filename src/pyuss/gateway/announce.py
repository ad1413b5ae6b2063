"""The gateway message of a bus: what a program reading the topics needs to know of a
gateway before it sends a command, published retained with QoS 1 on ``uss/BUS/gateway`` at
every connection of the bus's MQTT client (schema ``gateway.json``)::

    {"v": 1, "bus": "line1", "version": "1.2.0", "read_only": false, "keepalive": 30,
     "drives": [{"name": "conveyor", "address": 5, "profile": "generic", "layout": "4,2",
                 "unit": "Hz", "setpoints": [{"key": "main", "pzd": 2, "dword": false}],
                 "actual": [{"key": "main", "pzd": 2, "dword": false}]}],
     "time": "2026-11-27T02:00:00.000Z"}

``read_only`` is the MQTT face's: a read-only gateway takes reads only. ``keepalive`` is the
MQTT keep-alive of its client, in seconds: the broker publishes the gateway's last will
(``uss/BUS/availability`` ``offline``) within one and a half keep-alives of losing it. The
drives' process values (PZD word, 32 bits or 16) are what a reader needs to check a setpoint
the way the gateway will (`pyuss.points.checks.checked_setpoint`); the reference (100 %)
comes with each state."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from pyuss import __version__
from pyuss.gateway.topics import CONTRACT_VERSION
from pyuss.points.config import ProcessConfig
from pyuss.points.model import DriveModel
from pyuss.points.state import iso, now
from pyuss.profiles import UNKNOWN_KIND

__all__ = ["gateway_payload", "gateway_topic"]


def gateway_topic(prefix: str, bus: str) -> str:
    """``uss/BUS/gateway``."""
    return f"{prefix}/{bus}/gateway"


def _points(items: Sequence[ProcessConfig]) -> list[dict[str, Any]]:
    return [{"key": item.key, "pzd": item.pzd, "dword": item.dword} for item in items]


def gateway_payload(
    bus: str, drives: Sequence[DriveModel], *, read_only: bool, keepalive: int
) -> bytes:
    """The gateway message of bus ``bus`` (schema ``gateway.json``)."""
    data = {
        "v": CONTRACT_VERSION,
        "bus": bus,
        "version": __version__,
        "read_only": read_only,
        "keepalive": keepalive,
        "drives": [
            {
                "name": drive.name,
                "address": drive.address,
                "profile": drive.profile or UNKNOWN_KIND,
                "layout": str(drive.layout),
                "unit": drive.unit,
                "setpoints": _points(drive.setpoints),
                "actual": _points(drive.actual),
            }
            for drive in drives
        ],
        "time": iso(now()),
    }
    return json.dumps(data, separators=(",", ":")).encode()
