"""The Modbus TCP face: a Modbus TCP server whose unit ids are the drives' addresses.

The register map is `pyuss.gateway.registers` (pure, tested without sockets); this module
frames the requests (Modbus TCP: the MBAP header with protocol id 0, at most 253 bytes of
PDU) and answers them. It serves function codes 3
(read holding registers), 4 (read input registers), 6 (write single register), 16 (write
multiple registers), 22 (mask write register: the register read, its bits masked, written
back, as FC 6 would write it) and 23 (read/write multiple registers); every other function code is
answered with exception 01 (illegal function), a request of a served function code that is
malformed (wrong length, quantity beyond the protocol's limits, byte count not matching)
with exception 03. A unit id without a drive is answered with exception 0Bh (gateway target
device failed to respond).

The requests of one connection are answered one after the other, in the order they came
(a client may send several before the first answer: each gets its answer). A write is
checked whole before anything is sent (`DriveRegisters.plan_write`): a refused request is
answered with its exception and sends nothing. A frame whose MBAP header cannot be a Modbus
request (protocol id not 0, length beyond 254) leaves nothing to resynchronise on in a TCP
stream: the connection is closed. A connection that completes no request for
``idle_timeout`` seconds is closed, and beyond ``max_connections`` the connection that has
been quiet longest, of the host holding the most, makes room for a new one, so silent peers
cannot lock others out. A stop lets the request being carried out finish and be answered
(`ModbusFace.close`), and starts none after it.

Why a server of its own and not pymodbus's: the gateway must answer every request of a
connection in order, refuse unknown function codes instead of serving the library's own
diagnostics, and bound what a peer can hold; the framing of the six function codes served
is a few lines of `struct`. Clients of other stacks (pymodbus, libmodbus's mbpoll) are what
the tests talk to it with.
"""

from __future__ import annotations

import asyncio
import logging
import struct
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

from pyuss.errors import ConfigError
from pyuss.gateway.options import STOP_WAIT
from pyuss.gateway.registers import DriveRegisters, ModbusException, RegisterError, WordOrder
from pyuss.points.endpoint import Endpoint
from pyuss.points.plant import Plant

__all__ = ["MAX_CONNECTIONS", "SERVED", "ModbusFace"]

log = logging.getLogger("pyuss.gateway.modbus")

SERVED = frozenset({3, 4, 6, 16, 22, 23})
"""The function codes the face serves; any other is answered with exception 01."""

MAX_CONNECTIONS = 32
"""Connections served at once (default); a new one beyond closes the quietest."""

IDLE_TIMEOUT = 60.0
"""Seconds a connection may go without completing a request (default)."""


_HEADER = struct.Struct(">HHHB")  # transaction id, protocol id, length, unit id
_MAX_LENGTH = 254  # unit id + PDU of at most 253 bytes
_MAX_READ = 125
_MAX_WRITE = 123
_MAX_READ_WRITE = 121


class _Malformed(Exception):
    """A request of a served function code whose fields do not fit together (exception 03)."""


@dataclass(eq=False)
class _Connection:
    writer: asyncio.StreamWriter
    task: asyncio.Task[None] | None = None
    last_active: float = 0.0
    busy: bool = False
    peer: object = field(default=None)

    @property
    def host(self) -> object:
        return self.peer[0] if isinstance(self.peer, tuple) else self.peer


def _exception(function: int, code: int) -> bytes:
    return bytes((function | 0x80, code))


def _registers(pdu: bytes, start: int, count: int) -> list[int]:
    """``count`` registers from ``pdu[start:]`` (the byte count before them is checked)."""
    if pdu[start - 1] != 2 * count or len(pdu) != start + 2 * count:
        raise _Malformed
    return list(struct.unpack_from(f">{count}H", pdu, start))


def _quantity(count: int, limit: int) -> None:
    if not 1 <= count <= limit:
        raise _Malformed


async def respond(registers: DriveRegisters, pdu: bytes) -> bytes:
    """The response PDU to the request ``pdu`` of a served function code for one drive."""
    function = pdu[0]
    try:
        if function in (3, 4):
            if len(pdu) != 5:
                raise _Malformed
            address, count = struct.unpack_from(">HH", pdu, 1)
            _quantity(count, _MAX_READ)
            if function == 4:
                values = registers.read_input(address, count)
            else:
                values = await registers.read_holding(address, count)
            return bytes((function, 2 * count)) + struct.pack(f">{count}H", *values)
        if function == 6:
            if len(pdu) != 5:
                raise _Malformed
            address, value = struct.unpack_from(">HH", pdu, 1)
            await registers.write_holding(address, [value])
            return pdu
        if function == 22:
            # mask write: (value AND and_mask) OR (or_mask AND NOT and_mask), Modbus 6.16;
            # a PLC sets or clears single control bits with it
            if len(pdu) != 7:
                raise _Malformed
            address, and_mask, or_mask = struct.unpack_from(">HHH", pdu, 1)
            (value,) = await registers.read_holding(address, 1)  # reads change nothing
            new = (value & and_mask) | (or_mask & ~and_mask & 0xFFFF)
            await registers.carry_out(registers.plan_write(address, [new]))
            return pdu
        if function == 16:
            if len(pdu) < 6:
                raise _Malformed
            address, count = struct.unpack_from(">HH", pdu, 1)
            _quantity(count, _MAX_WRITE)
            await registers.write_holding(address, _registers(pdu, 6, count))
            return struct.pack(">BHH", function, address, count)
        # 23: the write is carried out before the read, as Modbus defines the function
        if len(pdu) < 10:
            raise _Malformed
        read_at, read_count, write_at, write_count = struct.unpack_from(">HHHH", pdu, 1)
        _quantity(read_count, _MAX_READ)
        _quantity(write_count, _MAX_READ_WRITE)
        plan = registers.plan_write(write_at, _registers(pdu, 10, write_count))
        registers.plan_read(read_at, read_count)  # refused before the write goes out
        await registers.carry_out(plan)
        values = await registers.read_holding(read_at, read_count)
        return bytes((function, 2 * read_count)) + struct.pack(f">{read_count}H", *values)
    except _Malformed:
        return _exception(function, ModbusException.ILLEGAL_DATA_VALUE)
    except RegisterError as exc:
        log.info("unit %d: %s", registers.drive.address, exc)
        return _exception(function, exc.code)


class ModbusFace:
    """A Modbus TCP server for the drives of ``buses`` (default: every bus of the plant;
    their addresses must differ, since the unit id is the address)."""

    def __init__(
        self,
        plant: Plant,
        endpoint: Endpoint,
        *,
        buses: Sequence[str] | None = None,
        word_order: WordOrder = WordOrder.BIG,
        read_only: bool = False,
        max_connections: int = MAX_CONNECTIONS,
        idle_timeout: float = IDLE_TIMEOUT,
    ) -> None:
        if max_connections < 1:
            raise ConfigError(f"modbus {endpoint}: max_connections must be 1 or more")
        if not idle_timeout > 0:
            raise ConfigError(f"modbus {endpoint}: idle_timeout must be more than 0 s")
        self.plant = plant
        self.endpoint = endpoint
        self.read_only = read_only
        self.max_connections = max_connections
        self.idle_timeout = idle_timeout
        units: dict[int, DriveRegisters] = {}
        owner: dict[int, str] = {}
        for name in buses if buses is not None else list(plant.buses):
            bus = plant.bus(name)
            for address, drive in bus.drives.items():
                if address in units:
                    raise ConfigError(
                        f"modbus {endpoint}: unit id {address} is a drive of bus {owner[address]} "
                        f"and of bus {name}: give each bus its own Modbus address "
                        '(modbus = "HOST:PORT" in its [[bus]] table)'
                    )
                units[address] = DriveRegisters(drive, word_order=word_order, read_only=read_only)
                owner[address] = name
        self.units = units
        self.connections: set[_Connection] = set()
        self._server: asyncio.Server | None = None
        self._closing = False

    async def start(self) -> None:
        try:
            self._server = await asyncio.start_server(
                self._accept, self.endpoint.host, self.endpoint.port
            )
        except OSError as exc:
            raise ConfigError(f"modbus {self.endpoint}: cannot listen there ({exc})") from None
        log.info(
            "Modbus TCP on %s:%d, units %s",
            self.endpoint.host,
            self.endpoint.port,
            sorted(self.units),
        )

    async def close(self) -> None:
        """Stop taking connections and requests; a request being carried out finishes (up to
        `STOP_WAIT` seconds) and is answered, so no write is cut between its parts and no
        client is left without the answer to one that went out; then close every
        connection."""
        server, self._server = self._server, None
        if server is None:
            return
        server.close()
        self._closing = True
        busy = [c.task for c in self.connections if c.busy and c.task is not None]
        if busy:
            # each returns once its answer is written (`_serve`)
            await asyncio.wait(busy, timeout=STOP_WAIT)
        tasks = [c.task for c in self.connections if c.task is not None]
        for connection in list(self.connections):
            self._drop(connection)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await server.wait_closed()

    # -- connections --------------------------------------------------------------------------
    def _drop(self, connection: _Connection) -> None:
        self.connections.discard(connection)
        connection.writer.close()

    def _make_room(self) -> bool:
        """If the face is full, close the connection quiet longest (never one being
        answered) of the peer host holding the most connections, so that one host opening
        connections closes its own first; False if every connection is being answered."""
        if len(self.connections) < self.max_connections:
            return True
        quiet = [c for c in self.connections if not c.busy]
        if not quiet:
            return False
        held = Counter(c.host for c in self.connections)
        oldest = min(quiet, key=lambda c: (-held[c.host], c.last_active))
        log.info(
            "Modbus: %d connections, closing the quietest of %s (%s)",
            len(self.connections),
            oldest.host,
            oldest.peer,
        )
        self._drop(oldest)  # its reader sees the end and its task ends
        return True

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        loop = asyncio.get_running_loop()
        connection = _Connection(
            writer, asyncio.current_task(), loop.time(), peer=writer.get_extra_info("peername")
        )
        if not self._make_room():
            writer.close()
            return
        self.connections.add(connection)
        try:
            await self._serve(reader, connection)
        except (ConnectionError, asyncio.IncompleteReadError, TimeoutError) as exc:
            log.debug("Modbus connection %s: %s", connection.peer, exc or type(exc).__name__)
        except asyncio.CancelledError:
            # the face closes (`close`): the connection's task ends here, as asyncio's
            # server expects of the tasks it made (it asks them for their exception)
            log.debug("Modbus connection %s: closed with the face", connection.peer)
        finally:
            self._drop(connection)

    async def _serve(self, reader: asyncio.StreamReader, connection: _Connection) -> None:
        """Answer the requests of one connection in order until it closes, goes quiet for
        ``idle_timeout`` or sends a frame that is no Modbus request."""
        loop = asyncio.get_running_loop()
        writer = connection.writer
        while True:
            async with asyncio.timeout(self.idle_timeout):
                header = await reader.readexactly(_HEADER.size)
                transaction, protocol, length, unit = _HEADER.unpack(header)
                if protocol != 0 or not 2 <= length <= _MAX_LENGTH:
                    log.info(
                        "Modbus connection %s: protocol id %d, length %d is no Modbus "
                        "request: closing it",
                        connection.peer,
                        protocol,
                        length,
                    )
                    return
                pdu = await reader.readexactly(length - 1)
            if self._closing:
                return  # the face closes: no request starts now
            connection.busy = True
            try:
                response = await self._answer(unit, pdu)
            finally:
                connection.busy = False
                connection.last_active = loop.time()
            writer.write(_HEADER.pack(transaction, 0, len(response) + 1, unit) + response)
            if self._closing:
                return  # answered; the face closes (`close`)
            async with asyncio.timeout(self.idle_timeout):
                await writer.drain()

    async def _answer(self, unit: int, pdu: bytes) -> bytes:
        function = pdu[0]
        if function not in SERVED:
            return _exception(function & 0x7F, ModbusException.ILLEGAL_FUNCTION)
        registers = self.units.get(unit)
        if registers is None:
            return _exception(function, ModbusException.GATEWAY_TARGET_NO_RESPONSE)
        try:
            return await respond(registers, pdu)
        except Exception:
            log.exception("unit %d: function %d failed", unit, function)
            return _exception(function, ModbusException.SERVER_DEVICE_FAILURE)
