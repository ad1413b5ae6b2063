"""A test helper: a line that stamps chunks the way a transport does (time of the last byte)."""

from __future__ import annotations

from collections.abc import Iterable

from pyuss.protocol.receiver import Event, Receiver
from pyuss.protocol.timing import char_time
from pyuss.transport.base import LineError


class Wire:
    """Feeds a receiver with chunks separated by gaps given in character times."""

    def __init__(self, receiver: Receiver, start: float = 1000.0) -> None:
        self.rx = receiver
        self.ct = char_time(receiver.timing.baud)
        self.t = start

    def send(
        self,
        data: bytes,
        gap: float = 3.0,
        errors: Iterable[tuple[int, LineError]] = (),
    ) -> list[Event]:
        """Idle ``gap`` character times, then ``data`` back to back; returns the events."""
        self.t += (gap + len(data)) * self.ct
        return self.rx.feed(data, self.t, errors)

    def trickle(self, data: bytes, gap: float) -> list[Event]:
        """Each byte separately, ``gap`` character times of silence before each."""
        events: list[Event] = []
        for i in range(len(data)):
            events += self.send(data[i : i + 1], gap)
        return events

    def idle(self, chars: float = 3.0) -> list[Event]:
        """Let ``chars`` character times pass and poll."""
        self.t += chars * self.ct
        return self.rx.poll(self.t)
