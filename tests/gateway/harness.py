"""What the gateway tests share: a real mosquitto broker on a free loopback port, simulated
drives on a virtual bus behind a `Gateway`, and one client per face with the same small API,
so one suite runs over Modbus, MQTT and OPC UA alike."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import math
import os
import shutil
import socket
import struct
import subprocess
import time
from collections.abc import AsyncIterator, Callable, Sequence
from pathlib import Path
from typing import Any

import pytest

from pyuss.bus import VirtualBus
from pyuss.gateway.config import GatewayConfig, ModbusOptions, MqttOptions, OpcuaOptions
from pyuss.gateway.run import Gateway
from pyuss.master.testing import simulated_drives
from pyuss.points.config import plant_from_flags
from pyuss.points.endpoint import parse_endpoint
from pyuss.protocol.layout import Layout
from pyuss.slave import SlaveEngine
from support.network import free_port
from support.waiting import eventually

BAUD = 38400
LAYOUT = "4,2"


def _root() -> bool:
    """Whether the tests run as root (a POSIX notion: never on Windows)."""
    return hasattr(os, "geteuid") and os.geteuid() == 0


class Broker:
    """A mosquitto broker on 127.0.0.1 that keeps its sessions over a restart."""

    def __init__(self, directory: Path) -> None:
        if shutil.which("mosquitto") is None:
            pytest.skip("mosquitto is not installed (apt-get install mosquitto)")
        self.directory = directory
        self.port = free_port()
        self.process: subprocess.Popen[bytes] | None = None
        config = directory / "mosquitto.conf"
        config.write_text(
            f"listener {self.port} 127.0.0.1\n"
            "allow_anonymous true\n"
            "persistence true\n"
            f"persistence_location {directory}/\n"
            "autosave_interval 1\n" + ("user root\n" if _root() else ""),
            # as root, mosquitto would become user mosquitto, who cannot write the session file
            encoding="utf-8",
        )
        self.config = config

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        self.process = subprocess.Popen(
            ["mosquitto", "-c", str(self.config)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", self.port)):
                return
            time.sleep(0.02)
        raise RuntimeError("mosquitto did not start")

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(10)
            self.process = None


@contextlib.asynccontextmanager
async def simulated_gateway(
    *,
    modbus: bool = False,
    mqtt: str | None = None,
    opcua: bool = False,
    addresses: Sequence[int] = (5, 6),
    bus_name: str = "bus",
    read_only: bool = False,
    users: dict[str, str] | None = None,
    parameters: Sequence[str] = ("107",),
    client_id: str = "pyuss-{bus}",
    mqtt_options: dict[str, Any] | None = None,
    connected: bool = True,
    silent: Sequence[int] = (),
    bus: VirtualBus | None = None,
) -> AsyncIterator[tuple[Gateway, dict[int, SlaveEngine]]]:
    """Simulated drives (generic profile, layout 4,2) on a virtual bus (``bus``, else a new
    one) and a gateway over them and over the drives at the addresses ``silent``, which
    none answers; with ``mqtt`` (``mqtt_options``: more `MqttOptions`), once its MQTT face
    is connected (``connected`` False: at once, a broker that is not there or refuses)."""
    bus = bus or VirtualBus(BAUD)
    drives = [(a, "generic", Layout.parse(LAYOUT)) for a in addresses]
    plant = plant_from_flags(
        port="bus://simulated:1",
        addresses=[*addresses, *silent],
        baud=BAUD,
        profile="generic",  # the simulated drives' family
        layout=LAYOUT,
        name=bus_name,
        parameters=list(parameters),
    )
    config = GatewayConfig(
        plant,
        modbus=ModbusOptions(
            parse_endpoint(f"127.0.0.1:{free_port()}", "modbus"), read_only=read_only
        )
        if modbus
        else None,
        mqtt=MqttOptions(
            parse_endpoint(mqtt, "mqtt"),
            read_only=read_only,
            reconnect=0.2,
            keepalive=5,
            client_id=client_id,
            **(mqtt_options or {}),
        )
        if mqtt
        else None,
        opcua=OpcuaOptions(
            parse_endpoint(f"opc.tcp://127.0.0.1:{free_port()}", "opcua"),
            users=users if users is not None else {"operator": "secret"},
            read_only=read_only,
        )
        if opcua
        else None,
    )
    async with simulated_drives(bus, drives) as engines:
        gateway = Gateway(config, transports={bus_name: bus.attach("gateway")})
        async with gateway:
            answering = [d for d in gateway.plant.drives if d.address not in silent]
            for drive in answering:
                await drive.drive.next_update(timeout=5)
            # the reference (P352) is read in the background; setpoints in Hz need it
            await eventually(lambda: all(d.reference is not None for d in answering))
            if mqtt and connected:  # its states, availability and gateway message are out
                buses = gateway.faces["mqtt"].buses.values()  # type: ignore[attr-defined]
                await eventually(lambda: all(face.connected.is_set() for face in buses))
            yield gateway, engines


class Refused(Exception):
    """A face's error for a refused request: its own code and, where it carries one, the
    drive's error number."""

    def __init__(self, code: object, number: int | None) -> None:
        self.code = code
        self.number = number
        super().__init__(f"{code} (drive error {number})")


class ModbusClient:
    name = "modbus"

    def __init__(self, gateway: Gateway) -> None:
        from pymodbus.client import AsyncModbusTcpClient

        face = gateway.modbus[0]
        self.client = AsyncModbusTcpClient(face.endpoint.host, port=face.endpoint.port, timeout=5)

    async def __aenter__(self) -> ModbusClient:
        await self.client.connect()
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.client.close()

    @staticmethod
    def floats(value: float) -> list[int]:
        return list(struct.unpack(">HH", struct.pack(">f", value)))

    async def _check(self, response: Any, address: int) -> Any:
        if response.isError():
            number = None
            box = await self.client.read_holding_registers(206, count=3, device_id=address)
            if not box.isError() and box.registers[0] == 2:
                number = box.registers[2]
            raise Refused(response.exception_code, number)
        return response

    async def switch_on(self, address: int) -> None:
        await self._check(await self.client.write_register(1, 1, device_id=address), address)

    async def set_setpoint(self, address: int, value: float) -> None:
        response = await self.client.write_registers(24, self.floats(value), device_id=address)
        await self._check(response, address)

    async def read_parameter(self, address: int, pnu: int) -> tuple[float, str | None]:
        await self._check(
            await self.client.write_registers(200, [pnu, 0xFFFF, 0, 0, 0, 1], device_id=address),
            address,
        )
        box = await self.client.read_holding_registers(209, count=2, device_id=address)
        value = struct.unpack(">f", struct.pack(">HH", *box.registers))[0]
        return value, None  # Modbus carries numbers; the units are in the register map

    async def write_parameter(self, address: int, pnu: int, value: float) -> float:
        words = [pnu, 0xFFFF, 0, *self.floats(value), 2]
        await self._check(await self.client.write_registers(200, words, device_id=address), address)
        box = await self.client.read_holding_registers(209, count=2, device_id=address)
        result: float = struct.unpack(">f", struct.pack(">HH", *box.registers))[0]
        return result


class MqttClient:
    name = "mqtt"

    def __init__(self, gateway: Gateway, *, bus: str = "bus") -> None:
        import aiomqtt

        options = gateway.config.mqtt
        assert options is not None
        self.bus = bus
        self.client = aiomqtt.Client(options.endpoint.host, options.endpoint.port)
        self.replies: dict[str, dict[str, Any]] = {}
        self.events: dict[str, asyncio.Event] = {}
        self.ids = itertools.count(1)
        self.task: asyncio.Task[None] | None = None

    async def __aenter__(self) -> MqttClient:
        await self.client.__aenter__()
        await self.client.subscribe("uss/+/+/reply", qos=1)
        self.task = asyncio.create_task(self._listen())
        return self

    async def __aexit__(self, *exc: object) -> None:
        assert self.task is not None
        self.task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self.task
        await self.client.__aexit__(None, None, None)

    async def _listen(self) -> None:
        async for message in self.client.messages:
            reply = json.loads(bytes(message.payload))  # type: ignore[arg-type]
            ident = str(reply.get("id"))
            self.replies[ident] = reply
            self.events.setdefault(ident, asyncio.Event()).set()

    async def command(
        self, address: int, name: str, *, bus: str | None = None, **fields: Any
    ) -> dict[str, Any]:
        ident = f"t{next(self.ids)}"
        event = self.events.setdefault(ident, asyncio.Event())
        topic = f"uss/{bus or self.bus}/drive{address}/cmd/{name}"
        await self.client.publish(topic, json.dumps({"id": ident, **fields}), qos=1)
        async with asyncio.timeout(10):
            await event.wait()
        reply = self.replies[ident]
        if not reply["ok"]:
            error = reply["error"]
            raise Refused(error["class"], error.get("number"))
        result: dict[str, Any] = reply["result"]
        return result

    async def switch_on(self, address: int) -> None:
        await self.command(address, "on")

    async def set_setpoint(self, address: int, value: float) -> None:
        await self.command(address, "setpoint", value=value)

    async def read_parameter(self, address: int, pnu: int) -> tuple[float, str | None]:
        result = await self.command(address, "read", pnu=pnu)
        return result["value"], result["unit"]

    async def write_parameter(self, address: int, pnu: int, value: float) -> float:
        result = await self.command(address, "write", pnu=pnu, value=value)
        answered: float = result["value"]
        return answered


class OpcuaClient:
    name = "opcua"

    def __init__(self, gateway: Gateway, *, user: str | None = "operator") -> None:
        from asyncua import Client

        options = gateway.config.opcua
        assert options is not None
        self.client = Client(f"opc.tcp://127.0.0.1:{options.endpoint.port}", timeout=10)
        if user is not None:
            self.client.set_user(user)
            self.client.set_password(options.users[user])
        self.ns = 0

    async def __aenter__(self) -> OpcuaClient:
        await self.client.connect()
        self.ns = await self.client.get_namespace_index("urn:pyuss:gateway")
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.client.disconnect()

    def node(self, address: int, path: str = "") -> Any:
        from asyncua import ua

        return self.client.get_node(ua.NodeId(f"bus.drive{address}{path}", self.ns))

    async def _call(self, address: int, method: str, *args: Any) -> Any:
        from asyncua import ua

        try:
            return await self.node(address).call_method(ua.QualifiedName(method, self.ns), *args)
        except ua.UaStatusCodeError as exc:
            number = await self.node(address, ".Health.LastErrorNumber").read_value()
            raise Refused(type(exc).__name__, number if number >= 0 else None) from None

    async def switch_on(self, address: int) -> None:
        await self._call(address, "On")

    async def set_setpoint(self, address: int, value: float) -> None:
        from asyncua import ua

        node = self.node(address, ".Setpoint.main")
        try:
            await node.write_value(ua.DataValue(ua.Variant(value, ua.VariantType.Double)))
        except ua.UaStatusCodeError as exc:
            raise Refused(type(exc).__name__, None) from None

    async def read_parameter(self, address: int, pnu: int) -> tuple[float, str | None]:
        from asyncua import ua

        value, unit = await self._call(
            address,
            "ReadParameter",
            ua.Variant(pnu, ua.VariantType.UInt16),
            ua.Variant(-1, ua.VariantType.Int16),
        )
        return value, unit

    async def write_parameter(self, address: int, pnu: int, value: float) -> float:
        from asyncua import ua

        answered = await self._call(
            address,
            "WriteParameter",
            ua.Variant(pnu, ua.VariantType.UInt16),
            ua.Variant(-1, ua.VariantType.Int16),
            ua.Variant(value, ua.VariantType.Double),
        )
        result: float = answered[0] if isinstance(answered, list) else answered
        return result


async def mosquitto_pub(
    broker: Broker, topic: str, payload: bytes | str = b"", *, retain: bool = False
) -> None:
    """Publish with QoS 1 through mosquitto_pub (the payload on its standard input); returns
    once the broker took the message."""
    data = payload.encode() if isinstance(payload, str) else payload
    flags = ["-r"] if retain else []
    process = await asyncio.create_subprocess_exec(
        *("mosquitto_pub", "-h", "127.0.0.1", "-p", str(broker.port), "-q", "1"),
        *("-t", topic, *flags, "-s" if data else "-n"),
        stdin=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    _, error = await process.communicate(data or None)
    assert process.returncode == 0, error


@contextlib.asynccontextmanager
async def subscribed(
    broker: Broker, *topics: str, on: Callable[[str, bytes], object]
) -> AsyncIterator[None]:
    """A client on ``broker`` subscribed to ``topics`` (QoS 1), handing every message to
    ``on(topic, payload)`` until the block ends."""
    import aiomqtt

    async with aiomqtt.Client("127.0.0.1", broker.port) as client:
        for topic in topics:
            await client.subscribe(topic, qos=1)

        async def listen() -> None:
            async for message in client.messages:
                on(message.topic.value, bytes(message.payload))  # type: ignore[arg-type]

        task = asyncio.create_task(listen())
        try:
            yield
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)


def close_to(value: float, expected: float) -> bool:
    return math.isclose(value, expected, rel_tol=1e-6, abs_tol=1e-6)
