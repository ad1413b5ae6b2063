"""`Gateway`: a plant and its faces, started and stopped together.

The faces are built first (each checks that its library is installed, `pyuss.gateway.extras`,
and its configuration), so bad configuration fails before any port opens. `start` starts the
faces and then the buses - the OPC UA server's start takes the event loop for a moment, which
would otherwise delay the first telegrams -, `close` stops the faces first (MQTT says
``offline``) and then the buses.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from types import TracebackType
from typing import Any, Protocol

from pyuss.gateway.config import GatewayConfig
from pyuss.gateway.extras import require
from pyuss.points.model import resolve
from pyuss.points.plant import Plant
from pyuss.transport.base import Transport

__all__ = ["Gateway"]

log = logging.getLogger("pyuss.gateway")


class Face(Protocol):
    async def start(self) -> None: ...

    async def close(self) -> None: ...


class Gateway:
    """The plant of ``config`` with the faces it names. ``transports``: a `Transport` per bus
    name instead of its port URL (tests)."""

    def __init__(
        self, config: GatewayConfig, *, transports: Mapping[str, Transport] | None = None
    ) -> None:
        self.config = config
        for face, options in (
            ("modbus", config.modbus),
            ("mqtt", config.mqtt),
            ("opcua", config.opcua),
        ):
            if options is not None:
                require(face)
        self.plant = Plant(resolve(config.plant), transports=transports)
        self.faces: dict[str, Face] = {}
        self.modbus: list[Any] = []
        if config.modbus is not None:
            from pyuss.gateway.modbus import ModbusFace

            options = config.modbus
            shared = [b for b in self.plant.buses if b not in options.bus_endpoints]
            if shared:
                shared_face = ModbusFace(
                    self.plant,
                    options.endpoint,
                    buses=shared,
                    word_order=options.word_order,
                    read_only=options.read_only,
                )
                self.faces["modbus"] = shared_face
                self.modbus.append(shared_face)
            for bus, endpoint in options.bus_endpoints.items():
                own = ModbusFace(
                    self.plant,
                    endpoint,
                    buses=[bus],
                    word_order=options.word_order,
                    read_only=options.read_only,
                )
                self.faces[f"modbus {bus}"] = own
                self.modbus.append(own)
        if config.mqtt is not None:
            from pyuss.gateway.mqtt import MqttFace

            self.faces["mqtt"] = MqttFace(self.plant, config.mqtt)
        if config.opcua is not None:
            from pyuss.gateway.opcua import OpcuaFace

            self.faces["opcua"] = OpcuaFace(self.plant, config.opcua)
        self._started: list[Face] = []

    async def start(self) -> None:
        try:
            for face in self.faces.values():
                await face.start()
                self._started.append(face)
            await self.plant.start()
        except BaseException:
            await self.close()
            raise

    async def close(self) -> None:
        started, self._started = self._started, []
        for face in reversed(started):
            try:
                await face.close()
            except Exception:
                log.exception("closing a face failed")
        await self.plant.close()

    async def __aenter__(self) -> Gateway:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()
