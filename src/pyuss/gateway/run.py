"""`Gateway`: a plant and its faces, started and stopped together.

The faces configured are built first, in the order of the registry (`pyuss.gateway.faces`;
each checks that its library is installed, `pyuss.gateway.extras`, and its configuration),
and two faces listening on one port are refused (`pyuss.gateway.config.check_listening`), so
bad configuration fails before any port opens. `start` starts the
faces and then the buses - the OPC UA server's start takes the event loop for a moment, which
would otherwise delay the first telegrams -, `close` stops the faces first (MQTT says
``offline``) and then the buses.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from types import TracebackType
from typing import Any

from pyuss.gateway.config import GatewayConfig, check_listening
from pyuss.gateway.extras import require
from pyuss.gateway.faces import Face, FaceSpec, faces
from pyuss.points.model import resolve
from pyuss.points.plant import Plant
from pyuss.transport.base import Transport

__all__ = ["Gateway"]

log = logging.getLogger("pyuss.gateway")


class Gateway:
    """The plant of ``config`` with the faces it names. ``transports``: a `Transport` per bus
    name instead of its port URL (tests)."""

    def __init__(
        self, config: GatewayConfig, *, transports: Mapping[str, Transport] | None = None
    ) -> None:
        self.config = config
        configured = [
            (spec, options)
            for spec in faces().values()
            if (options := config.face(spec.name)) is not None
        ]
        for spec, _options in configured:
            require(spec.name)
        check_listening(config)
        self.plant = Plant(resolve(config.plant), transports=transports)
        self.faces: dict[str, Face] = {}
        """Every face started, by the name it is printed under (``modbus line1``: a bus's
        own Modbus server)."""
        self._specs: dict[str, FaceSpec] = {}
        for spec, options in configured:
            for name, face in spec.instances(self.plant, options):
                self.faces[name] = face
                self._specs[name] = spec
        self._started: list[Face] = []

    def faces_of(self, face: str) -> list[Any]:
        """The faces started for the registry's face ``face`` (Modbus: one server per address)."""
        return [f for name, f in self.faces.items() if self._specs[name].name == face]

    @property
    def modbus(self) -> list[Any]:
        """The Modbus servers: the shared one first, then those of buses with their own."""
        return self.faces_of("modbus")

    def endpoints(self) -> list[tuple[str, str]]:
        """Each face's name and where it listens or connects, as ``uss gateway`` prints them."""
        return [(name, self._specs[name].endpoint(face)) for name, face in self.faces.items()]

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
