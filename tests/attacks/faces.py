"""One adapter per face with the same methods, so one suite of attacks runs over the Modbus,
MQTT and OPC UA faces of the gateway and the web page's API alike (as one test suite runs over
every backend of a library). Each adapter talks to its face with a real client (pymodbus and
raw Modbus TCP frames, aiomqtt and mosquitto_pub, asyncua, aiohttp) and names the simulated
drive its requests reach (`engine`), so a case can watch what that drive takes.

Every request a face refuses raises `Refused` with that face's own error: the Modbus exception
code (or ``"closed"`` where the face closes the connection), the MQTT reply's error class, the
OPC UA status code's name, the HTTP status. A notion a face does not have (nesting in Modbus
registers, retained OPC UA writes) raises `Meaningless` with the reason; the case is skipped
with it."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import math
import struct
from collections.abc import AsyncIterator, Callable
from typing import Any, ClassVar

import aiohttp

from gateway.harness import (
    Broker,
    ModbusClient,
    MqttClient,
    OpcuaClient,
    Refused,
    mosquitto_pub,
    simulated_gateway,
)
from pyuss.gateway.run import Gateway
from pyuss.slave import SlaveEngine
from pyuss.web.backend import Backend
from pyuss.web.bodies import MAX_JSON
from pyuss.web.server import WebServer
from support.waiting import eventually
from support.web import serve

KINDS = ("oversize", "nested", "wrong_type", "huge", "nan", "inf")
"""Malformed input every adapter is asked to send (`Face.malformed`)."""
NOTIONS = ("retained", "stale", "replayed")
"""Requests that must never act however well-formed they are (`Face.outdated`)."""
COMMANDS = ("on", "off1", "off2", "off3", "acknowledge")


class Meaningless(Exception):
    """The case has no meaning on this face; the message says why."""


class Face:
    """What every adapter offers (the methods raise `Refused` for a refused request)."""

    name = ""
    address = 5
    engine: SlaveEngine

    async def command(self, name: str) -> None:
        raise NotImplementedError

    async def set_setpoint(self, value: float) -> None:
        """The main setpoint in Hz (the simulated drives' reference is 50 Hz)."""
        raise NotImplementedError

    async def write_parameter(self, pnu: int, value: float) -> float:
        """Write a number; the value the drive answered with."""
        raise NotImplementedError

    async def read_parameter(self, pnu: int) -> float:
        raise NotImplementedError

    async def malformed(self, kind: str) -> None:
        """Send input of ``kind`` (one of `KINDS`) that the face must refuse whole."""
        raise NotImplementedError

    meaningless: ClassVar[dict[str, str]] = {}
    errors: ClassVar[frozenset[object]] = frozenset()
    """The face's errors for a request it refuses as bad (`Refused.code`)."""
    """Why a notion of `NOTIONS` has no meaning on the face."""

    async def outdated(self, notion: str) -> None:
        """Send a request that is ``notion`` (one of `NOTIONS`): it must not act."""
        raise Meaningless(self.meaningless[notion])

    def read_only(self) -> contextlib.AbstractAsyncContextManager[Face]:
        """The same face, read-only, over a drive of its own (or the same drive)."""
        raise NotImplementedError

    async def served(self) -> None:
        """A new, well-behaved client reads P107 (50 Hz unless a case changed it)."""
        raise NotImplementedError


class ClientFace(Face):
    """A gateway face through the harness's client of it (`gateway.harness`)."""

    client: ModbusClient | MqttClient | OpcuaClient

    async def __aenter__(self) -> Any:
        await self.client.__aenter__()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.client.__aexit__(*exc)

    async def set_setpoint(self, value: float) -> None:
        await self.client.set_setpoint(self.address, value)

    async def write_parameter(self, pnu: int, value: float) -> float:
        return await self.client.write_parameter(self.address, pnu, value)

    async def read_parameter(self, pnu: int) -> float:
        value, _ = await self.client.read_parameter(self.address, pnu)
        return value


# -- Modbus TCP ------------------------------------------------------------------------------
MODBUS_COMMANDS = {name: number for number, name in enumerate(COMMANDS, 1)}
"""Holding register 1: 1 ON, 2 OFF1, 3 OFF2, 4 OFF3, 5 acknowledge (docs/gateway.md)."""


def mbap(unit: int, pdu: bytes, transaction: int = 1) -> bytes:
    return struct.pack(">HHHB", transaction, 0, len(pdu) + 1, unit) + pdu


def fc16(address: int, *words: int) -> bytes:
    return struct.pack(f">BHHB{len(words)}H", 16, address, len(words), 2 * len(words), *words)


class ModbusFace(ClientFace):
    name = "modbus"
    errors = frozenset({3, "closed"})  # illegal data value; no request: the connection closed
    meaningless: ClassVar[dict[str, str]] = {
        "retained": "Modbus TCP keeps no request for later: nothing is retained",
        "stale": "a Modbus request carries no age: it is answered on its connection or not",
        "replayed": "a Modbus request carries no token to replay: each is checked whole anew",
    }

    def __init__(self, gateway: Gateway, engines: dict[int, SlaveEngine]) -> None:
        self.gateway = gateway
        self.engine = engines[self.address]
        self.client = ModbusClient(gateway)

    async def command(self, name: str) -> None:
        number = MODBUS_COMMANDS.get(name, 9)  # a name outside the map: a number outside it
        response = await self.client.client.write_register(1, number, device_id=self.address)
        await self.client._check(response, self.address)

    async def exchange(self, frame: bytes) -> bytes | None:
        """Send ``frame`` on a connection of its own: the answer's PDU, None if closed."""
        face = self.gateway.modbus[0]
        reader, writer = await asyncio.open_connection(face.endpoint.host, face.endpoint.port)
        try:
            writer.write(frame)
            await writer.drain()
            async with asyncio.timeout(10):
                try:
                    header = await reader.readexactly(7)
                except asyncio.IncompleteReadError:
                    return None
                (length,) = struct.unpack(">H", header[4:6])
                return await reader.readexactly(length - 1)
        finally:
            writer.close()
            with contextlib.suppress(ConnectionError):
                await writer.wait_closed()

    async def malformed(self, kind: str) -> None:
        floats = ModbusClient.floats
        frames = {
            # a length beyond any PDU: nothing to find the next request by
            "oversize": struct.pack(">HHHB", 1, 0, 0xFFFF, self.address) + b"\x10" * 300,
            # half of the float setpoint (registers 24..25)
            "wrong_type": mbap(self.address, struct.pack(">BHH", 6, 24, 0x41C8)),
            "huge": mbap(self.address, fc16(24, *floats(1e30))),
            "nan": mbap(self.address, fc16(24, *floats(math.nan))),
            "inf": mbap(self.address, fc16(24, *floats(math.inf))),
        }
        if kind not in frames:
            raise Meaningless("Modbus carries flat registers: nothing in a request nests")
        pdu = await self.exchange(frames[kind])
        if pdu is None:
            raise Refused("closed", None)
        if pdu[0] & 0x80:
            raise Refused(pdu[1], None)

    @contextlib.asynccontextmanager
    async def read_only(self) -> AsyncIterator[Face]:
        async with (
            simulated_gateway(modbus=True, addresses=(5,), read_only=True) as (gateway, engines),
            ModbusFace(gateway, engines) as face,
        ):
            yield face

    async def served(self) -> None:
        async with ModbusClient(self.gateway) as client:
            value, _ = await client.read_parameter(self.address, 107)
            assert value == 50.0


# -- MQTT ------------------------------------------------------------------------------------
class Replies(MqttClient):
    """The harness's MQTT client that also keeps the replies to payloads without an id."""

    def __init__(self, gateway: Gateway, *, bus: str = "bus") -> None:
        super().__init__(gateway, bus=bus)
        self.anonymous: list[dict[str, Any]] = []
        # ids of its own: every client on the broker sees every drive's replies
        self.ids = (f"-{bus}-attack-{n}" for n in itertools.count(1))  # type: ignore[assignment]

    async def _listen(self) -> None:
        async for message in self.client.messages:
            reply = json.loads(bytes(message.payload))  # type: ignore[arg-type]
            if reply.get("id") is None:
                self.anonymous.append(reply)
                continue
            ident = str(reply["id"])
            self.replies[ident] = reply
            self.events.setdefault(ident, asyncio.Event()).set()


MQTT_MALFORMED: dict[str, tuple[str, bytes]] = {
    "oversize": ("cmd/read", b"[" * 200_000),
    "nested": ("cmd/read", b"[" * 4000),
    "wrong_type": ("cmd/setpoint", b'{"value": true}'),
    "huge": ("cmd/setpoint", b"0x" + b"F" * 20),
    "nan": ("cmd/setpoint", b'{"value": NaN}'),
    "inf": ("cmd/setpoint", b'{"value": 1e999}'),
}


class MqttFace(ClientFace):
    name = "mqtt"
    errors = frozenset({"bad_value"})
    meaningless: ClassVar[dict[str, str]] = {
        "stale": "an MQTT command carries no age (commands queued while the gateway was away"
        " are tests/gateway/test_mqtt_attacks.py's)",
        "replayed": "an MQTT command carries no token to replay: each is checked whole anew",
    }

    def __init__(
        self, gateway: Gateway, engines: dict[int, SlaveEngine], broker: Broker, bus: str = "bus"
    ) -> None:
        self.gateway = gateway
        self.broker = broker
        self.bus = bus
        self.engine = engines[self.address]
        self.client = Replies(gateway, bus=bus)
        self.sent = 0

    async def command(self, name: str) -> None:
        if name not in COMMANDS:  # refused by its topic, before the payload's id is read
            await self._raw(f"cmd/{name}", b"")
        await self.client.command(self.address, name)

    async def write_parameter(self, pnu: int, value: float) -> float:
        if not math.isfinite(value):  # no JSON number: refused before the payload's id is read
            await self._raw("cmd/write", json.dumps({"pnu": pnu, "value": value}).encode())
        return await super().write_parameter(pnu, value)

    async def _raw(self, topic: str, payload: bytes, *, retain: bool = False) -> None:
        """Publish ``payload`` (without an id) to the drive's ``topic`` through mosquitto_pub
        and wait for its reply; replies come in the order the face refuses, so only the
        reply of a lone request is the refusal of that request."""
        self.sent += 1
        count = self.sent
        full = f"uss/{self.bus}/drive{self.address}/{topic}"
        await mosquitto_pub(self.broker, full, payload, retain=retain)
        await eventually(lambda: len(self.client.anonymous) >= count, timeout=30)
        reply = self.client.anonymous[count - 1]
        if not reply["ok"]:
            raise Refused(reply["error"]["class"], reply["error"].get("number"))

    async def malformed(self, kind: str) -> None:
        await self._raw(*MQTT_MALFORMED[kind])

    async def outdated(self, notion: str) -> None:
        if notion != "retained":
            await super().outdated(notion)
        # published retained while the face is connected (it sees the retain flag)
        await self._raw("cmd/setpoint", b'{"value": 25}', retain=True)

    @contextlib.asynccontextmanager
    async def read_only(self) -> AsyncIterator[Face]:
        # a bus of its own on the same broker (its own topics and client id)
        async with (
            simulated_gateway(
                mqtt=self.broker.url, addresses=(5,), read_only=True, bus_name="ro"
            ) as (gateway, engines),
            MqttFace(gateway, engines, self.broker, bus="ro") as face,
        ):
            yield face

    async def served(self) -> None:
        async with MqttClient(self.gateway, bus=self.bus) as client:
            value, unit = await client.read_parameter(self.address, 107)
            assert (value, unit) == (50.0, "Hz")


# -- OPC UA ----------------------------------------------------------------------------------
class OpcuaFace(ClientFace):
    name = "opcua"
    errors = frozenset(
        {"BadTypeMismatch", "BadOutOfRange", "BadInvalidArgument", "BadNodeIdInvalid"}
    )
    meaningless: ClassVar[dict[str, str]] = {
        "retained": "OPC UA keeps no write for later: nothing is retained",
        "replayed": "an OPC UA write carries no token to replay: each is checked whole anew",
    }

    def __init__(self, gateway: Gateway, engines: dict[int, SlaveEngine]) -> None:
        self.gateway = gateway
        self.engine = engines[self.address]
        self.client = OpcuaClient(gateway)

    async def command(self, name: str) -> None:
        from asyncua import ua

        method = name[0].upper() + name[1:]
        request = ua.CallMethodRequest(
            ObjectId=self.client.node(self.address).nodeid,
            MethodId=self.client.node(self.address, f".{method}").nodeid,
            InputArguments=[],
        )
        (result,) = await self.client.client.uaclient.call([request])
        if not result.StatusCode.is_good():
            raise Refused(result.StatusCode.name, None)

    async def write(self, variant: Any, status: int = 0) -> None:
        """One Write of ``variant`` (with ``status``) to the main setpoint's value."""
        from asyncua import ua

        item = ua.WriteValue(
            NodeId=self.client.node(self.address, ".Setpoint.main").nodeid,
            AttributeId=ua.AttributeIds.Value,
            Value=ua.DataValue(variant, StatusCode=ua.StatusCode(status)),
        )
        (code,) = await self.client.client.uaclient.write(ua.WriteParameters(NodesToWrite=[item]))
        if not code.is_good():
            raise Refused(code.name, None)

    async def malformed(self, kind: str) -> None:
        from asyncua import ua

        double = ua.VariantType.Double
        variants: dict[str, Callable[[], Any]] = {
            "oversize": lambda: ua.Variant("9" * 100_000, ua.VariantType.String),
            "nested": lambda: ua.Variant([[[25.0]]], double, Dimensions=[1, 1, 1]),
            "wrong_type": lambda: ua.Variant("25", ua.VariantType.String),
            "huge": lambda: ua.Variant(1e300, double),
            "nan": lambda: ua.Variant(math.nan, double),
            "inf": lambda: ua.Variant(math.inf, double),
        }
        await self.write(variants[kind]())

    async def outdated(self, notion: str) -> None:
        from asyncua import ua

        if notion != "stale":
            await super().outdated(notion)
        # a value its writer marks bad (no communication) is no request to act on
        variant = ua.Variant(25.0, ua.VariantType.Double)
        await self.write(variant, status=ua.StatusCodes.BadNoCommunication)

    @contextlib.asynccontextmanager
    async def read_only(self) -> AsyncIterator[Face]:
        async with (
            simulated_gateway(opcua=True, addresses=(5,), read_only=True) as (gateway, engines),
            OpcuaFace(gateway, engines) as face,
        ):
            yield face

    async def served(self) -> None:
        async with OpcuaClient(self.gateway, user=None) as client:
            assert await client.read_parameter(self.address, 107) == (50.0, "Hz")


# -- the web page's HTTP API -----------------------------------------------------------------
WRITE = {"X-Pyuss": "1", "Content-Type": "application/json"}
WEB_MALFORMED: dict[str, str] = {
    "oversize": json.dumps({"name": "on", "value": "x" * MAX_JSON}),
    "nested": "[" * 60_000,
    "wrong_type": json.dumps({"name": "setpoint", "value": True}),
    "huge": '{"name": "setpoint", "value": {"value": 1' + "0" * 400 + ', "unit": "Hz"}}',
    "nan": '{"name": "setpoint", "value": NaN}',
    "inf": '{"name": "setpoint", "value": 1e999}',
}


class WebFace(Face):
    name = "web"
    errors = frozenset({400})
    meaningless: ClassVar[dict[str, str]] = {
        "retained": "HTTP keeps no request for later: nothing is retained"
    }
    address = 1  # the demo's generic drive

    def __init__(self, backend: Backend, server: WebServer) -> None:
        self.backend = backend
        self.server = server
        self.engine = backend.engines[self.address]
        self.http = aiohttp.ClientSession()
        self.stale_server: WebServer | None = None

    async def __aenter__(self) -> WebFace:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.http.close()
        if self.stale_server is not None:
            await self.stale_server.close()

    def url(self, path: str, server: WebServer | None = None) -> str:
        port = (server or self.server).port
        return f"http://127.0.0.1:{port}/api/drive/{self.address}{path}"

    async def post(self, url: str, body: Any) -> Any:
        data = body if isinstance(body, str) else json.dumps(body)
        async with self.http.post(url, data=data, headers=WRITE) as reply:
            answer = await reply.json()
            if reply.status != 200:
                assert len(answer["error"]) < 300  # one line, not the request echoed back
                raise Refused(reply.status, None)
            return answer

    async def command(self, name: str) -> None:
        await self.post(self.url("/command"), {"name": name})

    async def set_setpoint(self, value: float) -> None:
        setpoint = {"name": "setpoint", "value": {"value": value, "unit": "Hz"}}
        await self.post(self.url("/command"), setpoint)

    async def write_parameter(self, pnu: int, value: float) -> float:
        answer = await self.post(self.url("/params/write"), {"id": str(pnu), "value": value})
        return float(answer["input"].split()[0])

    async def read_parameter(self, pnu: int) -> float:
        (answer,) = await self.post(self.url("/params/read"), {"ids": [str(pnu)]})
        if "error" in answer:
            raise Refused(answer["error"], None)
        return float(answer["input"].split()[0])

    async def malformed(self, kind: str) -> None:
        await self.post(self.url("/command"), WEB_MALFORMED[kind])

    async def outdated(self, notion: str) -> None:
        zero = {"name": "setpoint", "value": 0}  # a yes that, used, sends what is sent
        if notion == "replayed":
            check = await self.post(self.url("/command"), {**zero, "check": True})
            await self.post(self.url("/command"), {**zero, "confirm": check["confirm"]})
            await self.post(self.url("/command"), {**zero, "confirm": check["confirm"]})
        elif notion == "stale":
            if self.stale_server is None:
                self.stale_server = await serve(self.backend, confirm_age=0.0)
            url = self.url("/command", self.stale_server)
            check = await self.post(url, {"name": "on", "check": True})
            await self.post(url, {"name": "on", "confirm": check["confirm"]})
        else:
            await super().outdated(notion)

    @contextlib.asynccontextmanager
    async def read_only(self) -> AsyncIterator[Face]:
        server = await serve(self.backend, read_only=True)
        try:
            async with WebFace(self.backend, server) as face:
                yield face
        finally:
            await server.close()

    async def served(self) -> None:
        async with aiohttp.ClientSession() as http:
            ids = {"ids": ["107"]}
            async with http.post(self.url("/params/read"), json=ids, headers=WRITE) as reply:
                assert reply.status == 200
                (answer,) = await reply.json()
                assert float(answer["input"].split()[0]) == 50.0
