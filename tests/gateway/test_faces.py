"""One suite over every face (Modbus TCP, MQTT, OPC UA): what a client relies on is the same
whichever protocol it speaks. Real clients over real sockets, simulated drives on a virtual
bus behind the gateway."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from typing import Any

import pytest

from gateway.harness import (
    Broker,
    ModbusClient,
    MqttClient,
    OpcuaClient,
    Refused,
    close_to,
    simulated_gateway,
)
from support.waiting import eventually

FACES = ["modbus", "mqtt", "opcua"]


@contextlib.asynccontextmanager
async def face_client(
    face: str, broker: Broker, **options: Any
) -> AsyncIterator[tuple[Any, Any, Any]]:
    kwargs: dict[str, Any] = {
        "modbus": face == "modbus",
        "mqtt": broker.url if face == "mqtt" else None,
        "opcua": face == "opcua",
        **options,
    }
    async with simulated_gateway(**kwargs) as (gateway, engines):
        client_class = {"modbus": ModbusClient, "mqtt": MqttClient, "opcua": OpcuaClient}[face]
        async with client_class(gateway) as client:
            yield gateway, engines, client


@pytest.mark.parametrize("face", FACES)
async def test_a_client_switches_on_and_sets_the_setpoint_and_the_drive_sees_it(
    face: str, broker: Broker
) -> None:
    async with face_client(face, broker) as (_gateway, engines, client):
        await client.switch_on(5)
        await client.set_setpoint(5, 25.0)  # Hz: 50 % of the reference P352 = 50.00 Hz
        drive = engines[5].drive
        # the write returned once a telegram carrying it was answered: the drive has it
        assert drive.value(3) == 2500  # P3 main setpoint, 0.01 Hz
        assert drive.status_word() & 0x0004  # operation enabled
        await eventually(lambda: drive.value(2) > 0)  # the ramp runs towards it
        assert engines[6].drive.value(3) == 0  # the other drive is left alone


@pytest.mark.parametrize("face", FACES)
async def test_a_float_parameter_reads_with_its_unit(face: str, broker: Broker) -> None:
    async with face_client(face, broker) as (_gateway, _engines, client):
        value, unit = await client.read_parameter(5, 107)
        assert close_to(value, 50.0)
        if face != "modbus":  # Modbus carries numbers only; the map documents the units
            assert unit == "Hz"


@pytest.mark.parametrize("face", FACES)
async def test_a_refused_write_comes_back_as_an_error_with_the_drive_number(
    face: str, broker: Broker
) -> None:
    async with face_client(face, broker) as (_gateway, engines, client):
        await client.switch_on(5)
        # P107 may be changed only while the drive does not run: error 17
        with pytest.raises(Refused) as refused:
            await client.write_parameter(5, 107, 60.0)
        assert refused.value.number == 17
        assert engines[5].drive.value(107) == 50.0
        expected = {"modbus": 4, "mqtt": "refused", "opcua": "BadInvalidState"}[face]
        assert refused.value.code == expected


@pytest.mark.parametrize("face", FACES)
async def test_a_write_within_the_limits_is_answered_with_the_drive_value(
    face: str, broker: Broker
) -> None:
    async with face_client(face, broker) as (_gateway, engines, client):
        assert close_to(await client.write_parameter(5, 107, 60.0), 60.0)
        assert engines[5].drive.value(107) == 60.0
        with pytest.raises(Refused) as refused:  # above the maximum of 600 Hz
            await client.write_parameter(5, 107, 1000.0)
        assert engines[5].drive.value(107) == 60.0
        expected = {"modbus": 3, "mqtt": "bad_value", "opcua": "BadOutOfRange"}[face]
        assert refused.value.code == expected


@pytest.mark.parametrize("face", FACES)
async def test_a_read_only_face_refuses_writes_and_leaves_the_drive_alone(
    face: str, broker: Broker
) -> None:
    async with face_client(face, broker, read_only=True) as (_gateway, engines, client):
        value, _ = await client.read_parameter(5, 107)
        assert close_to(value, 50.0)
        with pytest.raises(Refused):
            await client.switch_on(5)
        with pytest.raises(Refused):
            await client.set_setpoint(5, 25.0)
        with pytest.raises(Refused):
            await client.write_parameter(5, 107, 60.0)
        drive = engines[5].drive
        assert drive.value(3) == 0
        assert not drive.status_word() & 0x0004
        assert drive.value(107) == 50.0
