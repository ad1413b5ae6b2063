"""PtyPort: a pseudo-terminal another program opens as a serial port (POSIX systems)."""

from __future__ import annotations

import asyncio
import os

import pytest
import serial

from pyuss.errors import TransportError
from pyuss.transport.pty import PtyPort
from transport.helpers import joined, read_bytes


@pytest.mark.pty
async def test_device_path_is_a_terminal_other_programs_open() -> None:
    async with PtyPort() as pty:
        assert os.path.exists(pty.device_path)
        with serial.Serial(pty.device_path, 9600, parity="E", timeout=5) as other:
            other.write(b"\x02\x03")
            assert joined(await read_bytes(pty, 2)) == b"\x02\x03"
            await pty.write(b"\x02\x04")
            assert other.read(2) == b"\x02\x04"
        # The device may be opened again after a program closed it.
        with serial.Serial(pty.device_path, 9600, timeout=5) as again:
            again.write(b"x")
            assert joined(await read_bytes(pty, 1)) == b"x"


async def test_device_path_needs_an_open_port() -> None:
    pty = PtyPort()
    with pytest.raises(TransportError, match="not open"):
        _ = pty.device_path


@pytest.mark.pty
async def test_writing_while_nobody_reads_fails_after_the_timeout() -> None:
    async with PtyPort(write_timeout=0.2) as pty:
        with pytest.raises(TransportError, match="nobody reads"):
            for _ in range(64):
                await pty.write(bytes(65536))
        assert pty.stats.dropped_out > 0


@pytest.mark.pty
async def test_closing_while_a_write_waits_for_room_ends_the_write_with_a_transport_error() -> None:
    pty = PtyPort(write_timeout=30.0)
    await pty.open()
    writing = asyncio.create_task(pty.write(bytes(1 << 20)))  # more than the kernel buffers
    while pty.stats.bytes_out == 0:
        await asyncio.sleep(0.01)
    await pty.close()
    with pytest.raises(TransportError, match="closed while writing"):
        await writing
    assert pty.stats.dropped_out > 0
