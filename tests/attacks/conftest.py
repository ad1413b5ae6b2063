"""Fixtures of the attack suite: one face at a time, shared by every case of the module (a
gateway or page server with its simulated drives; the cases leave the drives as they found
them)."""

from __future__ import annotations

import shutil
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest
import pytest_asyncio

from attacks.faces import Face, ModbusFace, MqttFace, OpcuaFace, WebFace
from gateway.harness import Broker, simulated_gateway
from pyuss.web.backend import Backend
from support.web import serve

FACES = ("modbus", "mqtt", "opcua", "web")


@pytest.fixture(scope="module")
def module_broker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Broker]:
    """A real mosquitto for the module's MQTT cases."""
    if shutil.which("mosquitto_pub") is None:
        pytest.skip("mosquitto_pub is not installed (apt-get install mosquitto-clients)")
    server = Broker(Path(tmp_path_factory.mktemp("mosquitto")))
    server.start()
    try:
        yield server
    finally:
        server.stop()


@pytest_asyncio.fixture(scope="module", loop_scope="module", params=FACES)
async def face(request: pytest.FixtureRequest) -> AsyncIterator[Face]:
    """The face under attack, connected, over simulated drives."""
    name: str = request.param
    if name == "web":
        backend = Backend(demo=True)
        await backend.start()
        server = await serve(backend)
        try:
            async with WebFace(backend, server) as web:
                yield web
        finally:
            await server.close()
            await backend.close()
    elif name == "mqtt":
        broker: Broker = request.getfixturevalue("module_broker")
        async with (
            simulated_gateway(mqtt=broker.url) as (gateway, engines),
            MqttFace(gateway, engines, broker) as mqtt,
        ):
            yield mqtt
    elif name == "opcua":
        async with (
            simulated_gateway(opcua=True) as (gateway, engines),
            OpcuaFace(gateway, engines) as opcua,
        ):
            yield opcua
    else:
        async with (
            simulated_gateway(modbus=True) as (gateway, engines),
            ModbusFace(gateway, engines) as modbus,
        ):
            yield modbus
