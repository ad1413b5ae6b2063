"""Timed sends: a station of the virtual bus hands over a telegram with the moment it is to
start, and the bus puts it on the line then (`Station.write_at`, `BusClientTransport.write_at`
and the send frames of `pyuss.bus.wire`). The master keeps its start pause and the simulator
its response delay that way, to the microsecond and without waiting for the moment.

The checks here look at the bus's modules only where they are loaded already (a transport
cannot be a station of a module nobody imported), so a program on a serial port or a
``bus://`` client never loads the bus itself for them.
"""

from __future__ import annotations

import sys
from collections.abc import Awaitable
from typing import Protocol

from pyuss.transport.base import Transport

__all__ = ["TimedWrite", "is_station", "timed_writer"]


class TimedWrite(Protocol):
    """``write_at(data, start, hold_until=None)``: send ``data``, its first character not
    before ``start``; ``hold_until``: its answer is still taken if its first character is
    handed over by then (the bus may then hand a station in another process the answer
    whole, `pyuss.bus.core.Station.hold_answer`)."""

    def __call__(
        self, data: bytes, start: float, hold_until: float | None = None
    ) -> Awaitable[None]: ...


def is_station(transport: Transport) -> bool:
    """Whether ``transport`` is a station of a virtual bus (in-process or ``bus://``), whose
    chunk timestamps are the characters' true end times on the line."""
    for module, name in (("pyuss.bus.core", "Station"), ("pyuss.bus.client", "BusClientTransport")):
        loaded = sys.modules.get(module)
        if loaded is not None and isinstance(transport, getattr(loaded, name)):
            return True
    return False


def timed_writer(transport: Transport) -> TimedWrite | None:
    """The timed send of ``transport`` if it is a station of a virtual bus, else None."""
    if not is_station(transport):
        return None
    write_at: TimedWrite = transport.write_at  # type: ignore[attr-defined]
    return write_at
