"""A face of another package, as small as a face can be, for the registry's tests: its
options, the reader of its ``[dummy]`` table, its ``--dummy`` flag and `SPEC`, the entry the
gateway registers (``dummy = "gateway.dummyface:SPEC"`` in the ``pyuss.faces`` entry points).

Started, it listens on ``listen`` and answers each connection with one line - its greeting,
the plant's buses with their drive addresses and ``read-only`` or ``writable`` - then closes."""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyuss.errors import ConfigError
from pyuss.gateway.faces import FaceSpec, Flag
from pyuss.points.config import PlantConfig, Where
from pyuss.points.plant import Plant


@dataclass(frozen=True, slots=True)
class DummyOptions:
    host: str = "127.0.0.1"
    port: int = 0
    greeting: str = "hello"
    read_only: bool = False


def _listen(text: str, options: DummyOptions) -> DummyOptions:
    host, _, port = text.rpartition(":")
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ConfigError(f"{text!r}: expected HOST:PORT")
    return DummyOptions(host or "127.0.0.1", int(port), options.greeting, options.read_only)


def read(table: Mapping[str, Any], where: Where, plant: PlantConfig, base: Path | None) -> Any:
    table = where.table(table, ("listen", "greeting", "read_only"))
    options = DummyOptions(
        greeting=where.key("greeting").text(table.get("greeting", "hello")),
        read_only=where.key("read_only").flag(table.get("read_only", False)),
    )
    try:
        return _listen(where.key("listen").text(table.get("listen", ":0")), options)
    except ConfigError as exc:
        raise where.key("listen").error(str(exc)) from None


class DummyFace:
    def __init__(self, plant: Plant, options: DummyOptions) -> None:
        self.plant = plant
        self.options = options
        self.server: asyncio.Server | None = None

    @property
    def endpoint(self) -> str:
        port = self.options.port
        if self.server is not None:
            port = self.server.sockets[0].getsockname()[1]
        return f"dummy://{self.options.host}:{port}"

    async def start(self) -> None:
        self.server = await asyncio.start_server(self._answer, self.options.host, self.options.port)

    async def _answer(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        buses = " ".join(
            f"{name}=" + ",".join(str(drive.address) for drive in bus.model.drives)
            for name, bus in self.plant.buses.items()
        )
        access = "read-only" if self.options.read_only else "writable"
        writer.write(f"{self.options.greeting} {buses} {access}\n".encode())
        await writer.drain()
        writer.close()

    async def close(self) -> None:
        if self.server is not None:
            self.server.close()
            await self.server.wait_closed()


SPEC = FaceSpec(
    name="dummy",
    module=__name__,
    cls="DummyFace",
    read=read,
    flag=Flag(
        "HOST:PORT", "serve the dummy face here", lambda o, text: _listen(text, o or DummyOptions())
    ),
    endpoint=lambda face: str(face.endpoint),
)
