"""Simulated Baumueller drives on a closed RS-232 loop (Baumueller manual 1.4.2), answering BASS.

Topology (Baumueller manual 1.4.2): up to 16 drives in a closed circuit. The PC's TX feeds the first
drive's RX, each drive's TX the next drive's RX, the last drive's TX the PC's RX. Each drive has
a DIP address (Baumueller manual 1: bit 0 = switch 1). The model, as a user would expect it from
that
wiring and from the echo rule of Baumueller manual 1.2:

- Every station passes on every byte it receives, at once and unchanged: what is not addressed
  to it, and also what is (that is the echo the PC sees before the answer).
- After the CR LF of a well-formed request with its own address, the station appends its answer.
  Downstream stations pass the answer on like anything else, so the PC reads the request line
  back, then the answer line. A request to an address nobody has comes back as an echo with no
  answer; a damaged request is passed on damaged and not answered.

A station's data come from an `OperatingData`: a small interface that any drive model can
implement (the USS drive simulator will, so that one drive is reachable over USS and BASS).
`DictOperatingData` is a ready one with the service-interface IDs of Baumueller manual 1.5:

- 170 SV state (read-only): bits 0..3 module state, 1 = RUN (parameters may be written over the
  service interface), 0 = STOP (read only); bits 4..11 the DIP address; bits 12..15 zero.
  The state is RUN exactly while ID 126 bit 0 is 1.
- 171 SV baud rate (read-only): 9600.
- 126 communication source M: bit 0 = write authority of the service interface. While it is 0,
  every BASS write is refused with error 5 (parameter write-protected), 126 included.

Error numbers the station gives (table 1.3, Baumueller manual 1.3): unknown ID 1; write data with
fewer
digits than the element 2, with more 3 (also a read carrying data: 3); read-only element 4;
no write authority 5; below minimum 6; above maximum 7; value outside the element's allowed
set 8; a command other than 003C/003E 9.

The ring is reachable as an in-process `Transport` (`BassRing.port()`), and `BassRing.serve()`
carries its PC side on any transport: a `pyuss.transport.PtyPort` that other programs open like
a serial port, or a `pyuss.transport.TcpServerTransport` on 127.0.0.1.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator, Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

from pyuss._tasks import cancel_and_wait
from pyuss.bass.codec import (
    BAUD,
    BassAnswer,
    BassCommand,
    BassLine,
    BassLineReader,
    BassRequest,
)
from pyuss.bass.errors import BassErrorNumber, BassRefusal
from pyuss.bass.inprocess import InProcessPort
from pyuss.errors import ConfigError, TransportError
from pyuss.transport.base import Transport

log = logging.getLogger("pyuss.bass.ring")

MAX_STATIONS = 16
ID_COMM_SOURCE = 126
ID_SV_STATE = 170
ID_SV_BAUD = 171
SV_STATE_RUN = 0x1
SV_STATE_STOP = 0x0


@runtime_checkable
class OperatingData(Protocol):
    """What a BASS station needs from a drive model.

    Values are bit patterns of the element's width (``digits(ident)`` hex digits: 4 or 8).
    Refuse a job by raising `BassRefusal` with a number of table 1.3. `write` is where a drive
    model learns of a change made over BASS (the place to raise its own notifications).
    """

    @property
    def dip_address(self) -> int:
        """The BASS address set on the DIP switch, 0..255."""
        ...

    def digits(self, ident: int) -> int:
        """Width of element ``ident`` in hex digits; `BassRefusal` 1 when there is none."""
        ...

    def read(self, ident: int) -> int:
        """The element's bit pattern."""
        ...

    def write(self, ident: int, value: int) -> None:
        """Store a bit pattern (the station has checked authority and width already)."""
        ...

    def write_authorized(self) -> bool:
        """True while the service interface may write (ID 126 bit 0, Baumueller manual 1.5)."""
        ...


@dataclass(frozen=True, slots=True)
class Element:
    """One element of `DictOperatingData`."""

    value: int = 0
    digits: int = 4
    signed: bool = False
    writable: bool = True
    minimum: int | None = None
    maximum: int | None = None
    allowed: frozenset[int] | None = None

    def __post_init__(self) -> None:
        if self.digits not in (4, 8):
            raise ConfigError(f"element width must be 4 or 8 hex digits, not {self.digits}")
        self.pattern(self.value)

    def pattern(self, value: int) -> int:
        """``value`` as the bit pattern the wire carries."""
        limit = 1 << 4 * self.digits
        low = -(limit // 2) if self.signed else 0
        high = limit // 2 - 1 if self.signed else limit - 1
        if not low <= value <= high:
            raise ConfigError(f"value {value} does not fit a {self.digits}-digit element")
        return value % limit

    def from_pattern(self, pattern: int) -> int:
        limit = 1 << 4 * self.digits
        return pattern - limit if self.signed and pattern >= limit // 2 else pattern


ChangeListener = Callable[[int, int, int], None]
"""Called as ``listener(ident, old_value, new_value)`` after a write changed an element."""


class DictOperatingData:
    """Operating data held in a dict, with the service-interface IDs of Baumueller manual 1.5.

    ``elements`` adds drive elements (for example ID 2, speed setpoint, and ID 51, actual speed,
    of the Baumueller manual's examples). `on_change` registers a listener for writes.
    """

    def __init__(
        self,
        address: int,
        elements: Mapping[int, Element] | None = None,
        *,
        write_authority: bool = True,
        baud: int = BAUD,
    ) -> None:
        if not 0 <= address <= 0xFF:
            raise ConfigError(f"DIP address {address} is outside 0..255")
        self._address = address
        self._baud = baud
        self.elements: dict[int, Element] = {
            ID_COMM_SOURCE: Element(1 if write_authority else 0, minimum=0, maximum=0xFFFF)
        }
        for ident, element in (elements or {}).items():
            if ident in (ID_SV_STATE, ID_SV_BAUD):
                raise ConfigError(f"ID {ident} is the service interface's own, not settable")
            self.elements[ident] = element
        self._listeners: list[ChangeListener] = []

    @property
    def dip_address(self) -> int:
        return self._address

    def on_change(self, listener: ChangeListener) -> Callable[[], None]:
        """Call ``listener(ident, old, new)`` after each change; returns an unsubscribe function."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener)

    def set_write_authority(self, enabled: bool) -> None:
        """Set ID 126 bit 0 from the drive side (panel or USS), not over BASS."""
        old = self.elements[ID_COMM_SOURCE]
        self.elements[ID_COMM_SOURCE] = replace(old, value=(old.value & ~1) | int(enabled))

    def write_authorized(self) -> bool:
        return bool(self.elements[ID_COMM_SOURCE].value & 1)

    def sv_state(self) -> int:
        """ID 170: module state in bits 0..3, DIP address in bits 4..11 (Baumueller manual 1.5)."""
        state = SV_STATE_RUN if self.write_authorized() else SV_STATE_STOP
        return state | (self._address << 4)

    def value(self, ident: int) -> int:
        """The element's value as a number (signed elements negative where they are)."""
        if ident == ID_SV_STATE:
            return self.sv_state()
        if ident == ID_SV_BAUD:
            return self._baud
        return self._element(ident).value

    def _element(self, ident: int) -> Element:
        try:
            return self.elements[ident]
        except KeyError:
            raise BassRefusal(BassErrorNumber.ELEMENT_NOT_AVAILABLE, ident=ident) from None

    def digits(self, ident: int) -> int:
        if ident in (ID_SV_STATE, ID_SV_BAUD):
            return 4
        return self._element(ident).digits

    def read(self, ident: int) -> int:
        if ident in (ID_SV_STATE, ID_SV_BAUD):
            return self.value(ident)
        element = self._element(ident)
        return element.pattern(element.value)

    def write(self, ident: int, value: int) -> None:
        if ident in (ID_SV_STATE, ID_SV_BAUD):
            raise BassRefusal(BassErrorNumber.DATA_NOT_CHANGEABLE, ident=ident)
        element = self._element(ident)
        if not element.writable:
            raise BassRefusal(BassErrorNumber.DATA_NOT_CHANGEABLE, ident=ident)
        new = element.from_pattern(value)
        if element.minimum is not None and new < element.minimum:
            raise BassRefusal(BassErrorNumber.BELOW_MINIMUM, ident=ident)
        if element.maximum is not None and new > element.maximum:
            raise BassRefusal(BassErrorNumber.ABOVE_MAXIMUM, ident=ident)
        if element.allowed is not None and new not in element.allowed:
            raise BassRefusal(BassErrorNumber.DATA_NOT_VALID, ident=ident)
        old = element.value
        self.elements[ident] = replace(element, value=new)
        if new != old:
            for listener in list(self._listeners):
                listener(ident, old, new)


def demo_elements() -> dict[int, Element]:
    """The elements of the Baumueller manual's examples: ID 2 speed setpoint and ID 51 actual speed.

    Both in 0.01 % (1D4Ch = 7500 = 75 %, Baumueller manual 1.1), signed, setpoint limited to +-100
    %.
    """
    return {
        2: Element(0, signed=True, minimum=-10000, maximum=10000),
        51: Element(0, signed=True, writable=False),
    }


class BassStation:
    """One drive on the ring: passes every byte on, answers requests to its DIP address."""

    def __init__(self, data: OperatingData) -> None:
        address = data.dip_address
        if not 0 <= address <= 0xFF:
            raise ConfigError(f"DIP address {address} is outside 0..255")
        self.data = data
        self.address = address
        self._reader = BassLineReader()
        self.answered = 0
        """Requests this station answered (refusals included)."""

    def receive(self, data: bytes) -> bytes:
        """Bytes arriving at RX; returns what leaves at TX (the same bytes plus any answer)."""
        out = bytearray()
        # A request completes only at its LF: answer right after it, before later bytes.
        for segment in data.splitlines(keepends=True):
            out += segment
            for item in self._reader.feed(segment):
                if isinstance(item, BassLine) and item.address == self.address:
                    out += self.answer(item.as_request()).encode()
        return bytes(out)

    def answer(self, request: BassRequest) -> BassAnswer:
        """The answer to a request addressed to this station (table 1.3 for refusals)."""
        self.answered += 1
        try:
            return self._serve(request)
        except BassRefusal as refusal:
            return BassAnswer.refusal(self.address, request.ident, refusal.number)

    def _serve(self, request: BassRequest) -> BassAnswer:
        ident, data = request.ident, self.data
        if request.command == BassCommand.READ_ELEMENT:
            digits = data.digits(ident)
            if request.data:
                raise BassRefusal(BassErrorNumber.DATA_TOO_LONG, ident=ident)
        elif request.command == BassCommand.WRITE_ELEMENT:
            digits = data.digits(ident)
            if not data.write_authorized():
                raise BassRefusal(BassErrorNumber.WRITE_PROTECTED, ident=ident)
            if len(request.data) < digits:
                raise BassRefusal(BassErrorNumber.DATA_TOO_SHORT, ident=ident)
            if len(request.data) > digits:
                raise BassRefusal(BassErrorNumber.DATA_TOO_LONG, ident=ident)
            data.write(ident, int(request.data, 16))
        else:
            raise BassRefusal(BassErrorNumber.ACCESS_NOT_VALID, ident=ident)
        return BassAnswer.value(self.address, ident, data.read(ident), digits)


class BassRing:
    """Up to 16 stations on a closed RS-232 loop (Baumueller manual 1.4.2), in the order of the
    wiring.

    `inject` is the PC's TX: it returns what reaches the PC's RX. One PC at a time: the ring
    is a single loop and the stations' line state is shared by whatever feeds it.
    """

    def __init__(self, stations: Sequence[BassStation | OperatingData], *, baud: int = BAUD):
        built = [s if isinstance(s, BassStation) else BassStation(s) for s in stations]
        if not 1 <= len(built) <= MAX_STATIONS:
            raise ConfigError(f"a ring has 1 to {MAX_STATIONS} drives, not {len(built)}")
        seen: set[int] = set()
        for station in built:
            if station.address in seen:
                raise ConfigError(f"DIP address {station.address} is set on two drives")
            seen.add(station.address)
        self.stations: tuple[BassStation, ...] = tuple(built)
        self.baud = baud

    @classmethod
    def with_addresses(
        cls, addresses: Iterable[int], *, elements: Mapping[int, Element] | None = None
    ) -> BassRing:
        """A ring of `DictOperatingData` drives with these DIP addresses (wiring order)."""
        return cls([DictOperatingData(a, elements) for a in addresses])

    def station(self, address: int) -> BassStation:
        for station in self.stations:
            if station.address == address:
                return station
        raise ConfigError(f"no drive with DIP address {address} on the ring")

    def inject(self, data: bytes) -> bytes:
        """Send ``data`` round the loop from the PC's TX; return what arrives at the PC's RX."""
        for station in self.stations:
            data = station.receive(data)
        return data

    def port(self) -> InProcessPort:
        """A `Transport` end for a master in this process (the PC's serial port)."""
        port = InProcessPort(baud=self.baud, name="bass-ring")
        port.on_write = lambda data: port.deliver(self.inject(data))
        return port

    @contextlib.asynccontextmanager
    async def serving(self, transport: Transport) -> AsyncIterator[None]:
        """Open ``transport`` and run `serve` on it while the block runs; at its end the
        service stops first (even in the middle of a write), then the transport is closed."""
        async with transport:
            task = asyncio.create_task(self.serve(transport))
            try:
                yield
            finally:
                await cancel_and_wait(task)

    async def serve(self, transport: Transport) -> None:
        """Carry the ring's PC side on an open ``transport`` until it is closed.

        For example a `pyuss.transport.PtyPort` (other programs open its device like a serial
        port) or a `pyuss.transport.TcpServerTransport` (several TCP clients on the PC side;
        an idle one gives way to a new one).

        What the PC does not take (a pty nobody reads, its buffer full) is lost, as on an
        RS-232 line whose receiver does not read: the ring goes on serving the next requests.
        """
        while True:
            try:
                chunk = await transport.read(None)
            except TransportError as exc:
                log.info("the ring stops serving: %s", exc)
                return
            if chunk is None:
                continue
            out = self.inject(chunk.data)
            if not out:
                continue
            try:
                await transport.write(out)
            except TransportError as exc:  # a lost line ends the service at the next read
                log.warning("the ring's output is lost: %s", exc)
