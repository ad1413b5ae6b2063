"""The Modbus register map: 32-bit values in two registers with either word order (pure), and
the map over simulated drives with a real pymodbus client."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gateway.harness import ModbusClient, simulated_gateway
from pyuss.gateway.registers import (
    EXCEPTIONS,
    DriveRegisters,
    ModbusException,
    RegisterError,
    WordOrder,
    from_registers,
    to_registers,
)
from pyuss.points.errors import Failure
from support.limits import limit_writes
from support.waiting import eventually


@given(st.integers(min_value=-(1 << 31), max_value=(1 << 31) - 1), st.sampled_from(WordOrder))
def test_integers_fill_two_registers_either_way_round(value: int, order: WordOrder) -> None:
    words = to_registers(value, "int", order)
    assert all(0 <= w <= 0xFFFF for w in words)
    assert from_registers(words, "int", order) == value


@given(st.floats(width=32, allow_nan=False), st.sampled_from(WordOrder))
def test_floats_fill_two_registers_either_way_round(value: float, order: WordOrder) -> None:
    assert from_registers(to_registers(value, "float", order), "float", order) == value


def test_big_word_order_puts_the_high_word_first_as_uss_does() -> None:
    assert to_registers(0x12345678, "int", WordOrder.BIG) == (0x1234, 0x5678)
    assert to_registers(0x12345678, "int", WordOrder.LITTLE) == (0x5678, 0x1234)
    assert to_registers(50.0, "float", WordOrder.BIG) == (0x4248, 0x0000)


def test_every_failure_has_a_documented_exception() -> None:
    assert set(EXCEPTIONS) == set(Failure)
    assert EXCEPTIONS[Failure.REFUSED] is ModbusException.SERVER_DEVICE_FAILURE


async def test_the_map_without_sockets_reads_status_and_refuses_half_a_float() -> None:
    async with simulated_gateway() as (gateway, _):
        registers = DriveRegisters(gateway.plant.drive("bus", 5))
        image = registers.read_input(0, 60)
        assert image[0] == 0x0240  # switch-on inhibited, control requested
        assert image[1] == 2  # state code: switch-on inhibited
        assert from_registers(registers.read_input(24, 2), "float", WordOrder.BIG) == 0.0
        with pytest.raises(RegisterError) as error:
            await registers.write_holding(24, [0x41C8])  # half of 25.0
        assert error.value.code is ModbusException.ILLEGAL_DATA_VALUE
        with pytest.raises(RegisterError) as error:
            registers.read_input(190, 20)
        assert error.value.code is ModbusException.ILLEGAL_DATA_ADDRESS


async def test_a_modbus_client_reads_status_actual_value_and_health() -> None:
    async with (
        simulated_gateway(modbus=True) as (gateway, engines),
        ModbusClient(gateway) as client,
    ):
        await client.set_setpoint(5, 10.0)
        await client.switch_on(5)

        async def actual() -> float:
            response = await client.client.read_input_registers(24, count=2, device_id=5)
            value: float = struct.unpack(">f", struct.pack(">HH", *response.registers))[0]
            return value

        values: list[float] = []

        async def sample() -> bool:
            values.append(await actual())
            return values[-1] > 0

        for _ in range(500):
            if await sample():
                break
        assert values[-1] > 0
        status = await client.client.read_input_registers(0, count=4, device_id=5)
        assert status.registers[0] & 0x0004  # operation enabled
        assert status.registers[1] == 5
        assert status.registers[2] & 1 == 0  # the drive sends
        holding = await client.client.read_holding_registers(0, count=3, device_id=5)
        assert holding.registers[0] == 0x047F
        assert holding.registers[2] == round(0.2 * 0x4000)  # 10 Hz of 50 Hz: 20 % of 4000h
        missing = await client.client.read_input_registers(0, count=1, device_id=9)
        assert missing.isError() and missing.exception_code == 0x0B
        await eventually(lambda: engines[5].drive.value(3) == 1000)


async def test_the_mailbox_reads_and_writes_any_parameter_in_one_request() -> None:
    async with (
        simulated_gateway(modbus=True) as (gateway, engines),
        ModbusClient(gateway) as client,
    ):
        # function 23: write the job and read its result in one transaction
        response = await client.client.readwrite_registers(
            read_address=206,
            read_count=5,
            write_address=200,
            values=[18, 0xFFFF, 2, 0, 0x1234, 2],  # P18 = 1234h as signed 16
            device_id=5,
        )
        assert response.registers[:3] == [1, 0, 0]  # done, no refusal
        assert engines[5].drive.value(18) == 0x1234
        refused = await client.client.write_registers(200, [999, 0xFFFF, 1, 0, 1, 2], device_id=5)
        assert refused.isError() and refused.exception_code == 0x02  # error 0: no such PNU
        box = await client.client.read_holding_registers(206, count=3, device_id=5)
        assert box.registers == [2, 7, 0]  # refused, response 7, error number 0
        health = await client.client.read_input_registers(5, count=3, device_id=5)
        assert health.registers == [7, 0, 999]


async def test_the_mailbox_carries_the_drives_word_or_the_value_times_a_stated_factor() -> None:
    # P448 (jog setpoint 1) is a signed word of 0.01 Hz: 7.5 Hz is the word 750
    async with (
        simulated_gateway(modbus=True) as (gateway, engines),
        ModbusClient(gateway) as client,
    ):

        async def job(fmt: int, value: tuple[int, int], command: int) -> list[int]:
            response = await client.client.readwrite_registers(
                read_address=206,
                read_count=5,
                write_address=200,
                values=[448, 0xFFFF, fmt, *value, command],
                device_id=5,
            )
            assert not response.isError(), response
            assert response.registers[0] == 1  # done
            return list(response.registers[3:])

        assert await job(2, (0, 750), 2) == [0, 750]  # the drive's word, signed 16
        assert engines[5].drive.value(448) == 750
        assert await job(5, (0, 0), 1) == ModbusClient.floats(7.5)  # float, in Hz
        assert await job(0, (0, 0), 1) == ModbusClient.floats(7.5)  # scaled: a float
        assert await job(6, (0, 0), 1) == [0, 75]  # Hz x 10
        assert await job(7, (0, 0), 1) == [0, 750]  # Hz x 100
        assert await job(8, (0, 0), 1) == [0, 7500]  # Hz x 1000
        assert await job(6, (0xFFFF, 0xFFEC), 2) == [0xFFFF, 0xFFEC]  # -2.0 Hz as -20
        assert engines[5].drive.value(448) == -200
        assert await job(2, (0, 0), 1) == [0xFFFF, 0xFF38]  # the word -200, sign-extended
        assert await job(1, (0, 0), 1) == [0, 0xFF38]  # the word as it is on the line
        # a float parameter's word is its IEEE 754 double word: no 16-bit format
        refused = await client.client.write_registers(200, [107, 0xFFFF, 1, 0, 1, 1], device_id=5)
        assert refused.isError() and refused.exception_code == 0x03
        box = await client.client.readwrite_registers(
            read_address=209,
            read_count=2,
            write_address=200,
            values=[107, 0xFFFF, 3, 0, 0, 1],
            device_id=5,
        )
        assert box.registers == ModbusClient.floats(50.0)


async def test_a_request_with_a_part_that_would_take_a_drive_over_is_refused_whole() -> None:
    # raw setpoint word and acknowledge in one request to a drive that has not answered yet
    # (whether it runs is not known): the acknowledge would take control with OFF1, so the
    # whole request is refused before its setpoint went out (it was sent first, then the
    # acknowledge was refused)
    from pyuss.bus import VirtualBus
    from pyuss.points import Plant
    from pyuss.points.model import line_model
    from pyuss.protocol.layout import Layout

    bus = VirtualBus(38400)
    model = line_model("line", [(1, "generic", Layout(3, 2))], baud=38400)
    try:
        async with Plant(model, transports={"line": bus.attach("gateway")}) as plant:
            points = plant.drive("line", 1)
            registers = DriveRegisters(points)
            before = (points.drive.control, points.drive.setpoints)
            with pytest.raises(RegisterError, match="acknowledge refused") as error:
                await registers.write_holding(1, [5, 0x2000])
            assert error.value.code is ModbusException.SERVER_DEVICE_FAILURE
            assert (points.drive.control, points.drive.setpoints) == before
    finally:
        await bus.close()


async def test_a_mailbox_write_the_drive_answers_with_another_value_says_so() -> None:
    # A drive limits or rounds a value: the write is done, but the drive holds another value
    # than the one written, and the mailbox's status says so (4), not "done" (1).
    async with (
        simulated_gateway(modbus=True) as (gateway, engines),
        ModbusClient(gateway) as client,
    ):
        limit_writes(engines[5].drive, 18, 1000)
        statuses = []
        for value in (5000, 700):
            response = await client.client.readwrite_registers(
                read_address=206,
                read_count=5,
                write_address=200,
                values=[18, 0xFFFF, 2, 0, value, 2],  # P18 as a signed 16-bit word
                device_id=5,
            )
            statuses.append((response.registers[0], response.registers[4]))
    assert statuses == [(4, 1000), (1, 700)]
