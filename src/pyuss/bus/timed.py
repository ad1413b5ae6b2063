"""Timed sends: a station of the virtual bus hands over a telegram with the moment it is to
start, and the bus puts it on the line then (`Station.write_at`, `BusClientTransport.write_at`
and the send frames of `pyuss.bus.wire`). The master keeps its start pause and the simulator
its response delay that way, to the microsecond and without waiting for the moment."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from pyuss.transport.base import Transport

__all__ = ["TimedWrite", "timed_writer"]

TimedWrite = Callable[[bytes, float], Awaitable[None]]
"""``write_at(data, start)``: send ``data``, its first character not before ``start``."""


def timed_writer(transport: Transport) -> TimedWrite | None:
    """The timed send of ``transport`` if it is a station of a virtual bus, else None."""
    from pyuss.bus.client import BusClientTransport
    from pyuss.bus.core import Station

    if isinstance(transport, Station | BusClientTransport):
        return transport.write_at
    return None
