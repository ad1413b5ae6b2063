"""What the Modbus face does with requests that must not move a drive, and with peers that
misbehave: refused and partial writes (all or nothing), pipelined requests, function codes
outside the map, garbage and oversize frames, silent peers, a read-only face. Each case
checks what the simulated drive took from the telegrams on the bus, and that a well-behaved
client (pymodbus, or libmodbus's mbpoll) is still served afterwards."""

from __future__ import annotations

import asyncio
import contextlib
import re
import shlex
import shutil
import struct
from collections.abc import AsyncIterator, Sequence

import pytest

from gateway.harness import ModbusClient, simulated_gateway
from pyuss.errors import ConfigError
from pyuss.gateway.modbus import ModbusFace
from pyuss.gateway.run import Gateway
from pyuss.slave import SlaveEngine
from support.paths import ROOT
from support.waiting import eventually

UNIT = 5
RUNNING = 0x047F
STANDSTILL = 0x047E


class Taken:
    """Every control word and main setpoint the simulated drive took from a telegram (the
    drive itself still takes them)."""

    def __init__(self, engine: SlaveEngine) -> None:
        self.words: list[tuple[int, int | None]] = []
        drive = engine.drive
        original = drive.apply_control

        def apply(control_word: int, setpoint: int | None, now: float, *, bits: int = 16) -> bool:
            self.words.append((control_word, setpoint))
            return original(control_word, setpoint, now, bits=bits)

        drive.apply_control = apply  # type: ignore[method-assign]

    def controls(self) -> set[int]:
        return {control for control, _ in self.words}

    def setpoints(self) -> set[int | None]:
        return {setpoint for _, setpoint in self.words}

    async def next_telegrams(self, count: int = 3) -> None:
        """Wait until the drive took ``count`` more telegrams (the master's cycle went on)."""
        seen = len(self.words)
        await eventually(lambda: len(self.words) >= seen + count)


def mbap(transaction: int, unit: int, pdu: bytes) -> bytes:
    return struct.pack(">HHHB", transaction, 0, len(pdu) + 1, unit) + pdu


class Raw:
    """A plain TCP connection speaking hand-built Modbus TCP frames."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader = reader
        self.writer = writer

    async def send(self, data: bytes) -> None:
        self.writer.write(data)
        await self.writer.drain()

    async def answer(self) -> tuple[int, int, bytes]:
        """The next answer: transaction id, unit id, PDU."""
        async with asyncio.timeout(10):
            header = await self.reader.readexactly(7)
            transaction, protocol, length, unit = struct.unpack(">HHHB", header)
            assert protocol == 0
            return transaction, unit, await self.reader.readexactly(length - 1)

    async def closed(self) -> bool:
        """The face closed the connection (nothing more to read)."""
        async with asyncio.timeout(10):
            return await self.reader.read(1) == b""


@contextlib.asynccontextmanager
async def raw(gateway: Gateway) -> AsyncIterator[Raw]:
    face = gateway.modbus[0]
    reader, writer = await asyncio.open_connection(face.endpoint.host, face.endpoint.port)
    try:
        yield Raw(reader, writer)
    finally:
        writer.close()
        with contextlib.suppress(ConnectionError):
            await writer.wait_closed()


async def run_mbpoll(*args: str) -> tuple[int, str]:
    if shutil.which("mbpoll") is None:
        pytest.skip("mbpoll is not installed (apt-get install mbpoll)")
    process = await asyncio.create_subprocess_exec(
        "mbpoll", *args, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT
    )
    async with asyncio.timeout(30):
        out, _ = await process.communicate()
    assert process.returncode is not None
    return process.returncode, out.decode(errors="replace")


async def mbpoll(gateway: Gateway, *args: str) -> tuple[int, str]:
    """Run libmodbus's mbpoll once against the face (PDU addressing from 0, unit 5)."""
    port = str(gateway.modbus[0].endpoint.port)
    return await run_mbpoll("-m", "tcp", "-p", port, "-a", str(UNIT), "-0", "-1", "-o", "5", *args)


async def served(gateway: Gateway) -> None:
    """A well-behaved pymodbus client still reads the drive's status."""
    async with ModbusClient(gateway) as client:
        response = await client.client.read_input_registers(0, count=2, device_id=UNIT)
        assert not response.isError()
        assert response.registers[1] in range(1, 9)


async def standing(gateway: Gateway, engines: dict[int, SlaveEngine]) -> Taken:
    """Drive 5 ready and standing still (control word 047Eh taken), watched from now on."""
    async with ModbusClient(gateway) as client:
        response = await client.client.write_register(0, STANDSTILL, device_id=UNIT)
        assert not response.isError()
    taken = Taken(engines[UNIT])
    await taken.next_telegrams()
    assert taken.controls() == {STANDSTILL}
    return taken


def assert_unmoved(gateway: Gateway, engines: dict[int, SlaveEngine], taken: Taken) -> None:
    """Only the standstill control word and no setpoint but 0 reached the drive."""
    assert taken.controls() == {STANDSTILL}
    assert taken.setpoints() <= {0}
    assert engines[UNIT].drive.machine.control == STANDSTILL
    assert not engines[UNIT].drive.status_word() & 0x0004  # not running
    assert gateway.plant.drive("bus", UNIT).snapshot().control_word == STANDSTILL


# -- refused and partial writes --------------------------------------------------------------


async def test_a_stop_lets_the_write_in_flight_go_out_whole_and_answers_it() -> None:
    # SIGTERM between the parts of a write (its process data went out, its command not yet):
    # the drive gets the whole request and the client its answer, never half and silence
    async with simulated_gateway(modbus=True) as (gateway, engines):
        taken = await standing(gateway, engines)
        drive = engines[UNIT].drive
        took = drive.apply_control
        closing: list[asyncio.Task[None]] = []

        def apply(control_word: int, setpoint: int | None, now: float, *, bits: int = 16) -> bool:
            if setpoint == 0x1000 and not closing:  # the first part is on the line: stop now
                closing.append(asyncio.get_running_loop().create_task(gateway.close()))
            return took(control_word, setpoint, now, bits=bits)

        drive.apply_control = apply  # type: ignore[method-assign]
        async with raw(gateway) as peer:
            request = struct.pack(">BHHB3H", 16, 0, 3, 6, STANDSTILL, 1, 0x1000)  # ..., ON
            await peer.send(mbap(7, UNIT, request))
            transaction, unit, pdu = await peer.answer()
            assert (transaction, unit, pdu) == (7, UNIT, struct.pack(">BHH", 16, 0, 3))
            assert closing
            await closing[0]
            assert await peer.closed()
        assert 0x1000 in taken.setpoints()
        assert drive.machine.control & 1  # the ON of the same request went out too


async def test_a_refused_write_of_control_word_and_command_sends_nothing() -> None:
    # control word 047Fh with command 9 (no such command): exception 03, and 047Fh
    # never goes on the line, neither at once nor in the cycles after
    async with simulated_gateway(modbus=True) as (gateway, engines):
        taken = await standing(gateway, engines)
        async with ModbusClient(gateway) as client:
            refused = await client.client.write_registers(0, [RUNNING, 9], device_id=UNIT)
            assert refused.isError() and refused.exception_code == 0x03
            await taken.next_telegrams()
            assert_unmoved(gateway, engines, taken)
            # a valid request of the same client is served
            response = await client.client.write_registers(0, [RUNNING, 1], device_id=UNIT)
            assert not response.isError()
        await eventually(lambda: RUNNING in taken.controls())


async def test_mbpoll_a_refused_write_sends_nothing_and_reads_are_served() -> None:
    async with simulated_gateway(modbus=True) as (gateway, engines):
        taken = await standing(gateway, engines)
        code, out = await mbpoll(gateway, "-r", "0", "-t", "4", "127.0.0.1", "0x047F", "9")
        assert code != 0 and "Illegal data value" in out, out
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)
        code, out = await mbpoll(gateway, "-r", "0", "-c", "2", "-t", "3", "127.0.0.1")
        assert code == 0, out
        assert "[0]: \t" in out and "[1]: \t3" in out  # state 3: ready to switch on
        code, out = await mbpoll(gateway, "-r", "0", "-t", "4:hex", "127.0.0.1")
        assert code == 0 and "0x047E" in out, out


@pytest.mark.parametrize(
    ("address", "values", "code"),
    [
        # control word, setpoint raw, then a command out of range
        (0, [RUNNING, 9, 0x2000], 0x03),
        # setpoint 25 Hz (float) and half of the next one
        (24, [*ModbusClient.floats(25.0), 0x4120], 0x03),
        # setpoint, then registers outside what can be written
        (0, [RUNNING, 1, 0x2000, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0], 0x02),
        # a setpoint that does not fit 16 bits (1000 Hz of a 50 Hz reference)
        (24, ModbusClient.floats(1000.0), 0x03),
    ],
)
async def test_a_multi_register_write_is_all_or_nothing(
    address: int, values: Sequence[int], code: int
) -> None:
    async with simulated_gateway(modbus=True) as (gateway, engines):
        taken = await standing(gateway, engines)
        before = gateway.plant.drive("bus", UNIT).snapshot().setpoint_words
        async with ModbusClient(gateway) as client:
            refused = await client.client.write_registers(address, values, device_id=UNIT)
            assert refused.isError() and refused.exception_code == code
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)
        assert gateway.plant.drive("bus", UNIT).snapshot().setpoint_words == before
        await served(gateway)


async def test_a_read_write_request_whose_read_is_refused_writes_nothing() -> None:
    async with simulated_gateway(modbus=True) as (gateway, engines):
        taken = await standing(gateway, engines)
        async with ModbusClient(gateway) as client:
            refused = await client.client.readwrite_registers(
                read_address=210, read_count=2, write_address=0, values=[RUNNING, 1], device_id=5
            )
            assert refused.isError() and refused.exception_code == 0x02
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)


async def test_a_refused_mailbox_request_changes_neither_drive_nor_mailbox() -> None:
    async with simulated_gateway(modbus=True) as (gateway, engines):
        drive = engines[UNIT].drive
        async with ModbusClient(gateway) as client:
            box = await client.client.read_holding_registers(200, count=6, device_id=UNIT)
            # P448 (jog setpoint) = 7.5 Hz as its word 750, in format 9: there is no format 9
            refused = await client.client.write_registers(
                200, [448, 0xFFFF, 9, 0, 750, 2], device_id=UNIT
            )
            assert refused.isError() and refused.exception_code == 0x03
            # P107 = 1000 Hz, beyond its maximum
            refused = await client.client.write_registers(
                200, [107, 0xFFFF, 5, *ModbusClient.floats(1000.0), 2], device_id=UNIT
            )
            assert refused.isError() and refused.exception_code == 0x03
            after = await client.client.read_holding_registers(200, count=6, device_id=UNIT)
            assert after.registers == box.registers
        assert drive.value(448) == 500
        assert drive.value(107) == 50.0


# -- pipelining and function codes -----------------------------------------------------------
async def test_pipelined_requests_are_all_answered_in_order() -> None:
    async with (
        simulated_gateway(modbus=True) as (gateway, engines),
        raw(gateway) as peer,
    ):
        taken = await standing(gateway, engines)
        # five reads of the input registers in one segment
        await peer.send(b"".join(mbap(t, UNIT, struct.pack(">BHH", 4, t, 1)) for t in range(1, 6)))
        answers = [await peer.answer() for _ in range(5)]
        assert [a[0] for a in answers] == [1, 2, 3, 4, 5]
        assert all(unit == UNIT and pdu[:2] == b"\x04\x02" for _, unit, pdu in answers)
        # reads, a refused write and a good read pipelined: each its own answer
        await peer.send(
            mbap(10, UNIT, struct.pack(">BHH", 3, 0, 1))
            + mbap(11, UNIT, struct.pack(">BHHB2H", 16, 0, 2, 4, RUNNING, 9))
            + mbap(12, 9, struct.pack(">BHH", 4, 0, 1))
            + mbap(13, UNIT, struct.pack(">BHH", 4, 1, 1))
        )
        assert await peer.answer() == (10, UNIT, struct.pack(">BBH", 3, 2, STANDSTILL))
        assert await peer.answer() == (11, UNIT, b"\x90\x03")
        assert await peer.answer() == (12, 9, b"\x84\x0b")  # no drive at 9
        assert await peer.answer() == (13, UNIT, struct.pack(">BBH", 4, 2, 3))
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)


# -- mask write (function 22): one control bit set by a PLC ----------------------------------


async def test_a_mask_write_sets_one_control_bit_and_keeps_the_others() -> None:
    # 047Eh with bit 0 set (AND FFFEh, OR 0001h): 047Fh, the drive switched on
    async with simulated_gateway(modbus=True, addresses=(5,)) as (gateway, engines):
        taken = await standing(gateway, engines)
        async with ModbusClient(gateway) as client:
            response = await client.client.mask_write_register(
                address=0, and_mask=0xFFFE, or_mask=0x0001, device_id=UNIT
            )
            assert not response.isError()
            await eventually(lambda: engines[UNIT].drive.machine.control == RUNNING)
            holding = await client.client.read_holding_registers(0, count=1, device_id=UNIT)
            assert holding.registers == [RUNNING]
            # and clear it again (AND FFFEh, OR 0000h): OFF1
            response = await client.client.mask_write_register(
                address=0, and_mask=0xFFFE, or_mask=0x0000, device_id=UNIT
            )
            assert not response.isError()
            await eventually(lambda: engines[UNIT].drive.machine.control == STANDSTILL)
        assert taken.controls() == {STANDSTILL, RUNNING}


@pytest.mark.parametrize(
    ("pdu", "code"),
    [
        (struct.pack(">BHHH", 22, 190, 0xFFFE, 1), 0x02),  # no register to write there
        (struct.pack(">BHHH", 22, 24, 0x0000, 0x4000), 0x03),  # half a float setpoint
        (struct.pack(">BHH", 22, 0, 0xFFFE), 0x03),  # too short
        (struct.pack(">BHHHB", 22, 0, 0xFFFE, 1, 0), 0x03),  # too long
    ],
    ids=["not-writable", "half-a-float", "short", "long"],
)
async def test_a_refused_mask_write_sends_nothing(pdu: bytes, code: int) -> None:
    async with (
        simulated_gateway(modbus=True, addresses=(5,)) as (gateway, engines),
        raw(gateway) as peer,
    ):
        taken = await standing(gateway, engines)
        await peer.send(mbap(3, UNIT, pdu))
        assert await peer.answer() == (3, UNIT, bytes([22 | 0x80, code]))
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)
        await served(gateway)


@pytest.mark.parametrize("function", [1, 2, 5, 7, 8, 11, 12, 15, 17, 20, 21, 24, 43, 65, 100])
async def test_function_codes_outside_the_map_are_illegal_functions(function: int) -> None:
    async with (
        simulated_gateway(modbus=True, addresses=(5,)) as (gateway, engines),
        raw(gateway) as peer,
    ):
        taken = await standing(gateway, engines)
        body = {8: b"\x00\x00\x12\x34"}.get(function, b"")
        await peer.send(mbap(1, UNIT, bytes([function]) + body) + mbap(2, 9, bytes([function])))
        assert await peer.answer() == (1, UNIT, bytes([function | 0x80, 0x01]))
        assert await peer.answer() == (2, 9, bytes([function | 0x80, 0x01]))
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)
        await served(gateway)


# -- garbage, oversize frames and silent peers -----------------------------------------------
@pytest.mark.parametrize(
    "frame",
    [
        struct.pack(">HHHB", 1, 0x1234, 6, UNIT) + b"\x06\x00\x00\x04\x7f",  # protocol id not 0
        struct.pack(">HHHB", 1, 0, 0xFFFF, UNIT) + b"\x10" * 300,  # longer than any request
        struct.pack(">HHHB", 1, 0, 1, UNIT),  # no function code
        b"GET / HTTP/1.1\r\nHost: modbus\r\n\r\n",
    ],
    ids=["protocol-id", "oversize", "no-function", "http"],
)
async def test_a_frame_that_is_no_modbus_request_closes_that_connection_alone(
    frame: bytes,
) -> None:
    async with (
        simulated_gateway(modbus=True, addresses=(5,)) as (gateway, engines),
        ModbusClient(gateway) as client,
    ):
        taken = await standing(gateway, engines)
        async with raw(gateway) as peer:
            await peer.send(frame)
            assert await peer.closed()
        response = await client.client.read_input_registers(1, count=1, device_id=UNIT)
        assert response.registers == [3]
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)


@pytest.mark.parametrize(
    "pdu",
    [
        struct.pack(">BHHB3H", 16, 0, 2, 6, RUNNING, 1, 0x2000),  # 3 values for a count of 2
        struct.pack(">BHHB", 16, 0, 2, 4) + struct.pack(">H", RUNNING),  # values cut short
        struct.pack(">BHH", 16, 0, 0),  # no byte count
        struct.pack(">BHHHHB2H", 23, 0, 126, 0, 2, 4, RUNNING, 1),  # reads more than 125
        struct.pack(">BHHH", 6, 0, RUNNING, 1),  # a byte too many
        struct.pack(">BHH", 3, 0, 126),  # more than 125 registers
        struct.pack(">BHH", 4, 0, 0),  # no register
        struct.pack(">BHHHHB2H", 23, 0, 1, 0, 2, 4, RUNNING, 1)[:-1],  # cut short
    ],
    ids=[
        "fc16-extra",
        "fc16-short",
        "fc16-no-count",
        "fc23-read-126",
        "fc6-long",
        "fc3-126",
        "fc4-none",
        "fc23-short",
    ],
)
async def test_a_malformed_request_is_refused_and_the_connection_served_on(pdu: bytes) -> None:
    async with (
        simulated_gateway(modbus=True, addresses=(5,)) as (gateway, engines),
        raw(gateway) as peer,
    ):
        taken = await standing(gateway, engines)
        await peer.send(mbap(7, UNIT, pdu) + mbap(8, UNIT, struct.pack(">BHH", 4, 1, 1)))
        assert await peer.answer() == (7, UNIT, bytes([pdu[0] | 0x80, 0x03]))
        assert await peer.answer() == (8, UNIT, struct.pack(">BBH", 4, 2, 3))
        await taken.next_telegrams()
        assert_unmoved(gateway, engines, taken)


async def test_silent_peers_do_not_lock_out_a_client() -> None:
    async with simulated_gateway(modbus=True, addresses=(5,)) as (gateway, _):
        face = gateway.modbus[0]
        silent = []
        # a client of another host, connected before the flood, keeps its connection
        reader, writer = await asyncio.open_connection(
            face.endpoint.host, face.endpoint.port, local_addr=("127.0.0.2", 0)
        )
        other = Raw(reader, writer)
        try:
            for _ in range(3 * face.max_connections):
                silent.append(await asyncio.open_connection(face.endpoint.host, face.endpoint.port))
            # a peer that sent half a request and stopped is as quiet as one that sent nothing
            silent[-1][1].write(struct.pack(">HHHB", 1, 0, 6, UNIT) + b"\x04")
            await served(gateway)
            assert len(face.connections) <= face.max_connections
            # the oldest of the flooding host were closed to make room
            assert await Raw(*silent[0]).closed()
            await other.send(mbap(1, UNIT, struct.pack(">BHH", 4, 1, 1)))
            assert await other.answer() == (1, UNIT, struct.pack(">BBH", 4, 2, 2))
        finally:
            other.writer.close()
            for _, flooding in silent:
                flooding.close()


async def test_a_connection_quiet_for_the_idle_timeout_is_closed() -> None:
    async with simulated_gateway(modbus=True, addresses=(5,)) as (gateway, _):
        face = gateway.modbus[0]
        face.idle_timeout = 0.3
        async with raw(gateway) as peer:
            await peer.send(struct.pack(">HHHB", 1, 0, 6, UNIT) + b"\x04\x00")  # half a request
            assert await peer.closed()
        await eventually(lambda: not face.connections)
        await served(gateway)


async def test_limits_of_no_connection_or_no_time_are_refused() -> None:
    async with simulated_gateway(modbus=True, addresses=(5,)) as (gateway, _):
        endpoint = gateway.modbus[0].endpoint
        with pytest.raises(ConfigError, match="max_connections must be 1 or more"):
            ModbusFace(gateway.plant, endpoint, max_connections=0)
        with pytest.raises(ConfigError, match="idle_timeout must be more than 0 s"):
            ModbusFace(gateway.plant, endpoint, idle_timeout=0)


# -- a read-only face ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "pdu",
    [
        struct.pack(">BHH", 6, 0, RUNNING),
        struct.pack(">BHH", 6, 1, 1),  # ON
        struct.pack(">BHHB2H", 16, 0, 2, 4, RUNNING, 1),
        struct.pack(">BHHB2H", 16, 24, 2, 4, *ModbusClient.floats(25.0)),
        struct.pack(">BHHB2H", 16, 100, 2, 4, *ModbusClient.floats(60.0)),  # P107
        struct.pack(">BHHB6H", 16, 200, 6, 12, 107, 0xFFFF, 5, *ModbusClient.floats(60.0), 2),
        struct.pack(">BHHHHB2H", 23, 0, 1, 0, 2, 4, RUNNING, 1),
        struct.pack(">BHHH", 22, 0, 0xFFFE, 1),  # mask write: ON
    ],
    ids=["control", "command", "fc16-control", "setpoint", "parameter", "mailbox", "fc23", "fc22"],
)
async def test_a_read_only_face_refuses_every_write_and_sends_nothing(pdu: bytes) -> None:
    async with (
        simulated_gateway(modbus=True, addresses=(5,), read_only=True) as (gateway, engines),
        raw(gateway) as peer,
    ):
        taken = Taken(engines[UNIT])
        await taken.next_telegrams()
        before = taken.controls()
        await peer.send(mbap(1, UNIT, pdu))
        assert await peer.answer() == (1, UNIT, bytes([pdu[0] | 0x80, 0x01]))
        await taken.next_telegrams()
        assert taken.controls() == before
        assert taken.setpoints() <= {0}
        assert engines[UNIT].drive.value(107) == 50.0
        await served(gateway)


async def test_mbpoll_on_a_read_only_face_is_refused_and_reads() -> None:
    async with simulated_gateway(modbus=True, addresses=(5,), read_only=True) as (gateway, engines):
        taken = Taken(engines[UNIT])
        await taken.next_telegrams()
        before = taken.controls()
        code, out = await mbpoll(gateway, "-r", "0", "-t", "4", "127.0.0.1", "0x047F", "1")
        assert code != 0 and "Illegal function" in out, out
        code, out = await mbpoll(gateway, "-r", "1", "-t", "4", "127.0.0.1", "1")
        assert code != 0 and "Illegal function" in out, out
        await taken.next_telegrams()
        assert taken.controls() == before
        code, out = await mbpoll(gateway, "-r", "1", "-t", "3", "127.0.0.1")
        assert code == 0 and "[1]: \t2" in out, out  # switch-on inhibited


async def test_the_mbpoll_line_of_the_docs_reads_status_and_state() -> None:
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    (line,) = re.findall(r"^`(mbpoll [^`]+)`$", text, re.M)
    async with simulated_gateway(modbus=True) as (gateway, _):
        port = str(gateway.modbus[0].endpoint.port)
        code, out = await run_mbpoll(*shlex.split(line.replace("5020", port))[1:])
    assert code == 0, out
    assert "[1]: \t2" in out  # switch-on inhibited


async def test_the_float_lines_of_the_docs_write_and_read_a_setpoint_high_word_first() -> None:
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    block = text.split("<!-- run by tests/gateway/test_modbus_attacks.py -->\n```sh\n")[1]
    write, read = block.split("```")[0].strip().splitlines()
    async with simulated_gateway(modbus=True) as (gateway, engines):
        port = str(gateway.modbus[0].endpoint.port)
        taken = Taken(engines[UNIT])
        code, out = await run_mbpoll(*shlex.split(write.replace("5020", port))[1:])
        assert code == 0, out
        # 25 Hz of the simulated drive's 50 Hz reference: 2000h sent
        await eventually(lambda: 0x2000 in taken.setpoints())
        code, out = await run_mbpoll(*shlex.split(read.replace("5020", port))[1:])
        assert code == 0 and "[24]: \t25" in out, out
        # low word first, as mbpoll reads without -B: not the setpoint
        code, out = await run_mbpoll(
            *shlex.split(read.replace("5020", port).replace(" -B", ""))[1:]
        )
        assert code == 0 and "[24]: \t25" not in out, out
