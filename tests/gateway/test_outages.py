"""``uss gateway`` through lost lines, as a user runs it: the gateway and ``uss simulate --tcp``
in processes of their own, the simulator killed and started again. The gateway reopens the
line each time without a restart, its Modbus and OPC UA faces say offline while the line is
down (real clients: pymodbus, asyncua), the log says each outage once when it begins and once
when it ends, the drive commanded before an outage is not commanded again after it; with
``reconnect=0`` in the port URL a lost line stops the gateway with exit code 1 and one line
saying why."""

from __future__ import annotations

import asyncio
import struct
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from support.network import free_port
from support.processes import first_line, stop_uss
from support.waiting import eventually

USS = [sys.executable, "-m", "pyuss.cli.main"]
BAUD = "38400"
ONLINE_BITS = 0b1000001
"""Input register 2: bit 0 offline, bit 6 the bus offline (docs/gateway.md)."""
PATH_UNAVAILABLE = 0x0A


def _simulator(port: int) -> subprocess.Popen[str]:
    """``uss simulate`` of drive 5 (generic, 4,2) on a TCP line at ``port``."""
    process = subprocess.Popen(
        [*USS, "simulate", "--address", "5", "--layout", "4,2", "--baud", BAUD,
         "--tcp", f"127.0.0.1:{port}"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    assert first_line(process, "tcp://") == f"tcp://127.0.0.1:{port}"
    return process


def _kill(process: subprocess.Popen[str]) -> None:
    """Kill a simulator as a crash or a pulled plug would end it: nothing said goodbye."""
    process.kill()
    process.wait(30)
    assert process.stdout is not None
    process.stdout.close()


@contextmanager
def _gateway(url: str, log: Path, *faces: str) -> Iterator[subprocess.Popen[str]]:
    """``uss gateway`` of drive 5 on ``url`` with ``faces``; its log lines into ``log``."""
    with log.open("w", encoding="utf-8") as stderr:
        process = subprocess.Popen(
            [*USS, "gateway", "--port", url, "--baud", BAUD, "--profile", "generic",
             "--layout", "4,2", "--address", "5", *faces],
            stdout=subprocess.PIPE, stderr=stderr, text=True,
        )  # fmt: skip
        try:
            first_line(process, "ready")
            yield process
        finally:
            if process.poll() is None:
                process.kill()
                process.wait(30)


def _pyuss_lines(log: Path) -> list[str]:
    """The gateway's log lines of pyuss at WARNING or above (libraries aside)."""
    return [
        line
        for line in log.read_text(encoding="utf-8").splitlines()
        if " pyuss." in line and (" WARNING " in line or " ERROR " in line)
    ]


class _Modbus:
    def __init__(self, port: int) -> None:
        from pymodbus.client import AsyncModbusTcpClient

        self.client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=5)

    async def health(self) -> int:
        response = await self.client.read_input_registers(2, count=1, device_id=5)
        assert not response.isError(), response
        value: int = response.registers[0]
        return value

    async def write(self, address: int, words: list[int]) -> Any:
        return await self.client.write_registers(address, words, device_id=5)

    async def read_holding(self, address: int) -> int:
        response = await self.client.read_holding_registers(address, count=1, device_id=5)
        assert not response.isError(), response
        value: int = response.registers[0]
        return value

    async def read_input(self, address: int) -> int:
        response = await self.client.read_input_registers(address, count=1, device_id=5)
        assert not response.isError(), response
        value: int = response.registers[0]
        return value


async def _until(check: Any, what: str, timeout: float = 45.0) -> None:
    """`eventually` for an async ``check``."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not await check():
        assert loop.time() < end, f"{what} not reached within {timeout} s"
        await asyncio.sleep(0.05)


async def test_the_gateway_rides_out_three_simulator_restarts_and_says_so_once_each(
    tmp_path: Path,
) -> None:
    from asyncua import Client, ua

    line = free_port()
    modbus_port, opcua_port = free_port(), free_port()
    log = tmp_path / "gateway.log"
    simulator = await asyncio.to_thread(_simulator, line)
    faces = ("--modbus", f"127.0.0.1:{modbus_port}", "--opcua", f"opc.tcp://127.0.0.1:{opcua_port}")
    try:
        with _gateway(f"tcp://127.0.0.1:{line}", log, *faces) as gateway:
            modbus = _Modbus(modbus_port)
            await modbus.client.connect()
            opcua = Client(f"opc.tcp://127.0.0.1:{opcua_port}", timeout=10)
            await opcua.connect()
            try:
                ns = await opcua.get_namespace_index("urn:pyuss:gateway")
                status_word = opcua.get_node(ua.NodeId("bus.drive5.StatusWord", ns))
                online_node = opcua.get_node(ua.NodeId("bus.drive5.Health.Online", ns))

                async def status() -> str:
                    value = await status_word.read_data_value(raise_on_bad_status=False)
                    name: str = value.StatusCode.name
                    return name

                for outage in range(3):
                    # (an outage ends once the line stayed up a second: one killed sooner
                    # would be the same outage, a line that comes and goes)
                    await _log_says(log, "link back", outage)
                    await _until(
                        lambda: _is(modbus.health(), lambda h: h & ONLINE_BITS == 0), "online"
                    )
                    await _until(lambda: _is(status(), lambda s: s == "Good"), "Good")
                    assert await online_node.read_value() is True
                    if outage == 2:  # run the drive: 25 Hz (a 50 Hz reference) and ON
                        await _until(
                            lambda: _is(modbus.health(), lambda h: h & 16), "the reference"
                        )
                        hz = list(struct.unpack(">HH", struct.pack(">f", 25.0)))
                        assert not (await modbus.write(24, hz)).isError()
                        assert not (await modbus.write(1, [1])).isError()
                        await _until(lambda: _is(modbus.read_input(1), lambda s: s == 5), "on")
                    _kill(simulator)
                    await _until(
                        lambda: _is(modbus.health(), lambda h: h & ONLINE_BITS == ONLINE_BITS),
                        "offline on Modbus",
                    )
                    await _until(
                        lambda: _is(status(), lambda s: s == "BadNoCommunication"),
                        "offline on OPC UA",
                    )
                    assert await online_node.read_value() is False
                    refused = await modbus.write(0, [0x047F])  # nothing can go out now
                    assert refused.isError() and refused.exception_code == PATH_UNAVAILABLE
                    simulator = await asyncio.to_thread(_simulator, line)
                await _until(lambda: _is(modbus.health(), lambda h: h & ONLINE_BITS == 0), "back")
                # the drive ran when the line went; the simulator started again has it
                # standing: the gateway gave it back (0000h) and commands nothing
                assert await modbus.read_holding(0) == 0
                await asyncio.sleep(0.5)  # (telegrams go on)
                assert await modbus.read_input(1) != 5  # not operation enabled
                await _log_says(log, "link back", 3)
            finally:
                modbus.client.close()
                await opcua.disconnect()
            assert await asyncio.to_thread(stop_uss, gateway) == 0
    finally:
        _kill(simulator)
    lines = _pyuss_lines(log)
    lost = [x for x in lines if "link lost" in x]
    back = [x for x in lines if "link back after" in x]
    given = [x for x in lines if "given back" in x]
    assert (len(lost), len(back), len(given)) == (3, 3, 1), lines
    assert "drive5" in given[0]
    # nothing else, but where a loaded machine made answers late in a row: the drive's own
    # outage, one line when it begins and one when it ends
    others = [x for x in lines if x not in lost + back + given]
    assert all("bus/drive5 offline: " in x or "bus/drive5 online again" in x for x in others)
    assert len(others) % 2 == 0 and len(others) <= 4, lines


async def _log_says(log: Path, words: str, times: int) -> None:
    """Wait until the gateway's log has ``times`` pyuss lines with ``words``."""
    await eventually(
        lambda: sum(words in x for x in _pyuss_lines(log)) >= times,
        timeout=30,
        what=f"{times} lines with {words!r} in the log",
    )


async def _is(value: Any, test: Any) -> bool:
    return bool(test(await value))


async def test_with_reconnect_off_a_lost_line_stops_the_gateway_with_one_line(
    tmp_path: Path,
) -> None:
    line = free_port()
    log = tmp_path / "gateway.log"
    simulator = await asyncio.to_thread(_simulator, line)
    modbus_port = free_port()
    url = f"tcp://127.0.0.1:{line}?reconnect=0"
    try:
        with _gateway(url, log, "--modbus", f"127.0.0.1:{modbus_port}") as gateway:
            modbus = _Modbus(modbus_port)
            await modbus.client.connect()
            try:
                await _until(lambda: _is(modbus.health(), lambda h: h & ONLINE_BITS == 0), "online")
            finally:
                modbus.client.close()
            _kill(simulator)
            # the gateway notices the lost line at its next read, a telegram's time: 15 s
            # bounds a loaded machine (docs/gateway.md, "Availability")
            assert await asyncio.to_thread(gateway.wait, 15) == 1
    finally:
        if simulator.poll() is None:
            _kill(simulator)
    lines = _pyuss_lines(log)
    assert len(lines) == 1, lines
    assert " ERROR " in lines[0] and "the line is lost and not reopened" in lines[0]
    assert str(line) in lines[0]
