"""The Modbus TCP face: a pymodbus server whose unit ids are the drives' addresses.

The register map is `pyuss.gateway.registers` (pure, tested without sockets); this module is
the thin server around it. pymodbus frames the requests and calls the data store for every
read and write; the store here is asynchronous, so a write waits until the drive answered the
telegram or parameter job carrying it, and a refusal is answered with the exception code of
`pyuss.gateway.registers.EXCEPTIONS`. A unit id without a drive is answered with exception
0Bh (gateway target device failed to respond).

Why pymodbus: it is the maintained Modbus stack for Python and brings framing, function codes
and the TCP server; the gateway only supplies the data store. Its data store classes change
between minor releases, so the supported range is narrow (`pyuss.gateway.extras`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.server import ModbusTcpServer

from pyuss.errors import ConfigError
from pyuss.gateway.registers import DriveRegisters, ModbusException, RegisterError, WordOrder
from pyuss.points.endpoint import Endpoint
from pyuss.points.plant import Plant

__all__ = ["ModbusFace"]

log = logging.getLogger("pyuss.gateway.modbus")

_INPUT = frozenset({4})
_HOLDING_READ = frozenset({3, 6, 16, 22, 23})
_HOLDING_WRITE = frozenset({6, 16, 23, 22})


class _Store(ModbusServerContext):
    """The data store pymodbus calls: one `DriveRegisters` per unit id."""

    def __init__(self, units: dict[int, DriveRegisters]) -> None:
        # The base class builds a simulated device; this store has none of its own.
        self.units = units
        self.simdevices = []
        self.old_simulator = True

    def device_ids(self) -> list[int]:
        return sorted(self.units)

    async def async_getValues(
        self, device_id: int, func_code: int, address: int, count: int = 1
    ) -> list[int] | list[bool] | ExcCodes:
        unit = self.units.get(device_id)
        if unit is None:
            return ExcCodes(int(ModbusException.GATEWAY_TARGET_NO_RESPONSE))
        try:
            if func_code in _INPUT:
                return unit.read_input(address, count)
            if func_code in _HOLDING_READ:
                return await unit.read_holding(address, count)
        except RegisterError as exc:
            log.info("unit %d: %s", device_id, exc)
            return ExcCodes(int(exc.code))
        return ExcCodes(int(ModbusException.ILLEGAL_FUNCTION))

    async def async_setValues(
        self,
        device_id: int,
        func_code: int,
        address: int,
        values: Sequence[int] | Sequence[bool],
    ) -> ExcCodes | None:
        unit = self.units.get(device_id)
        if unit is None:
            return ExcCodes(int(ModbusException.GATEWAY_TARGET_NO_RESPONSE))
        if func_code not in _HOLDING_WRITE:
            return ExcCodes(int(ModbusException.ILLEGAL_FUNCTION))
        try:
            await unit.write_holding(address, [int(v) for v in values])
        except RegisterError as exc:
            log.info("unit %d: %s", device_id, exc)
            return ExcCodes(int(exc.code))
        return None


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
    ) -> None:
        self.plant = plant
        self.endpoint = endpoint
        self.read_only = read_only
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
        self._server: ModbusTcpServer | None = None

    async def start(self) -> None:
        self._server = ModbusTcpServer(
            _Store(self.units), address=(self.endpoint.host, self.endpoint.port)
        )
        try:
            await self._server.serve_forever(background=True)
        except RuntimeError as exc:
            self._server = None
            raise ConfigError(f"modbus {self.endpoint}: cannot listen there ({exc})") from None
        log.info(
            "Modbus TCP on %s:%d, units %s",
            self.endpoint.host,
            self.endpoint.port,
            sorted(self.units),
        )

    async def close(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            await server.shutdown()  # type: ignore[no-untyped-call]
