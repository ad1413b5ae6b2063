"""pyuss opens a pty whatever another program did to it before.

A pty keeps no parity, and glibc's tcsetattr refuses settings that change only the parity: a
program that opened the device at 9600 8N1 or 8E1 (or a pyuss port that failed half-way, with
``rs485=kernel``) kept pyuss's own 8E1 open from working. These tests run real pyserial clients
(and a client killed while it holds the device) in every order against a real pty.
"""

from __future__ import annotations

import asyncio
import itertools
import os
import sys
from collections.abc import Callable

import pytest
import serial

from pyuss.errors import TransportError
from pyuss.transport.pty import PtyPort
from pyuss.transport.serialport import SerialTransport, is_pty
from pyuss.transport.url import open_transport
from transport.helpers import even_8e1, joined, killed_holder, plain_8n1, read_bytes

pytestmark = [
    pytest.mark.pty,
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux ptys"),
]


def kernel_rs485(path: str) -> None:
    """pyuss's own ``?rs485=kernel`` on a pty: refused (a pty has no RS-485 mode)."""

    async def attempt() -> None:
        port = open_transport(f"{path}?rs485=kernel")
        with pytest.raises(TransportError, match="kernel RS-485 mode"):
            await port.open()

    asyncio.run(attempt())


OTHERS: dict[str, Callable[[str], None]] = {
    "8N1": plain_8n1,
    "8E1": even_8e1,
    "rs485=kernel": kernel_rs485,
    "killed": killed_holder,
}


async def pyuss_exchanges(pty: PtyPort, n: int) -> None:
    """pyuss opens the device at 9600 (8E1, as for a real line) and bytes pass both ways."""
    async with SerialTransport(pty.device_path) as port:
        up = bytes([0x02, 0x80, 0xFF, n])
        await port.write(up)
        assert joined(await read_bytes(pty, len(up))) == up
        down = bytes([0x02, 0xFF, 0x7F, n])
        await pty.write(down)
        assert joined(await read_bytes(port, len(down))) == down


def test_a_pty_is_told_from_other_ports() -> None:
    master, slave = os.openpty()
    try:
        assert is_pty(os.ttyname(slave))
    finally:
        os.close(master)
        os.close(slave)
    assert not is_pty("/dev/null")
    assert not is_pty("loop://")
    assert not is_pty("/dev/does-not-exist-uss")


@pytest.mark.parametrize("order", list(itertools.permutations(OTHERS)), ids="-".join)
async def test_pyuss_opens_the_pty_after_other_programs_in_any_order(
    order: tuple[str, ...],
) -> None:
    async with PtyPort(baud=19200) as pty:
        for n, name in enumerate(order):
            await asyncio.to_thread(OTHERS[name], pty.device_path)
            await pyuss_exchanges(pty, n)
            await pyuss_exchanges(pty, n)  # and again, right after its own open


async def test_pyuss_opens_the_pty_while_another_program_keeps_it_open() -> None:
    async with PtyPort(baud=19200) as pty:
        with serial.Serial(pty.device_path, 9600):
            await pyuss_exchanges(pty, 0)
        with serial.Serial(pty.device_path, 19200, parity="E"):
            await pyuss_exchanges(pty, 1)


async def test_every_baud_rate_opens_after_an_8n1_program() -> None:
    from pyuss.transport.queued import BAUD_RATES

    async with PtyPort() as pty:
        for baud in BAUD_RATES:
            serial.Serial(pty.device_path, baud).close()
            async with SerialTransport(pty.device_path, baud=baud) as port:
                assert port.port.baudrate == baud
