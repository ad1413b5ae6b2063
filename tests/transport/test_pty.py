"""PtyPort: a pseudo-terminal another program opens as a serial port."""

from __future__ import annotations

import asyncio
import os
import sys

import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import TransportError
from pyuss.transport.pty import PtyPort
from pyuss.transport.serialport import SerialTransport
from transport.helpers import WAIT, joined, read_bytes

#: Frames a program opens the device with, one after the other: each comes back at least once.
REOPENS = [
    (9600, "E"),
    (9600, "E"),
    (38400, "E"),
    (19200, "N"),
    (9600, "E"),
    (38400, "E"),
    (38400, "E"),
    (19200, "N"),
    (19200, "N"),
    (9600, "E"),
]


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


async def test_writing_while_nobody_reads_fails_after_the_timeout() -> None:
    async with PtyPort(write_timeout=0.2) as pty:
        with pytest.raises(TransportError, match="nobody reads"):
            for _ in range(64):
                await pty.write(bytes(65536))
        assert pty.stats.dropped_out > 0


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


async def exchange(pty: PtyPort, other: serial.Serial, n: int) -> None:
    """Bytes from the program to the owner and back, bytes of 80h and up among them."""
    up = bytes([0x02, 0x80, 0xFF, n, 0xAA])
    other.write(up)
    assert joined(await read_bytes(pty, len(up))) == up
    down = bytes([0x02, 0xFE, 0x81, n, 0x00])
    await pty.write(down)
    assert other.read(len(down)) == down


async def test_a_program_reopens_the_device_as_often_as_it_likes_at_8e1_or_8n1() -> None:
    # The kernel drops the parity bit a program sets on a pty; glibc's tcsetattr then failed
    # (EINVAL) for the next program asking for the very settings the previous one left.
    async with PtyPort() as pty:
        for n, (baud, parity) in enumerate(REOPENS):
            with serial.Serial(pty.device_path, baud, parity=parity, timeout=WAIT) as other:
                await exchange(pty, other, n)
                other.timeout = WAIT / 2  # the open device takes new settings too
                await exchange(pty, other, n)


async def test_a_program_that_opens_and_closes_without_writing_leaves_the_device_ready() -> None:
    async with PtyPort() as pty:

        def open_and_close(baud: int, parity: str) -> None:
            with serial.Serial(pty.device_path, baud, parity=parity, timeout=WAIT):
                pass

        # In a thread, as another program: the owner's event loop runs meanwhile.
        for baud, parity in REOPENS:
            await asyncio.to_thread(open_and_close, baud, parity)
        with serial.Serial(pty.device_path, 9600, parity="E", timeout=WAIT) as other:
            await exchange(pty, other, 0)


_PROGRAM = """
import sys
import serial

for n, (baud, parity) in enumerate([(9600, "E"), (9600, "E"), (38400, "E"), (19200, "N"),
                                    (19200, "N"), (9600, "E")]):
    with serial.Serial(sys.argv[1], baud, parity=parity, timeout=5) as port:
        port.write(bytes([0x02, 0x80, 0xFF, n]))
        back = port.read(4)
        if back != bytes([0xFD, 0x7F, 0x00, 0xFF - n]):
            sys.exit(f"open {n}: {back.hex()} came back")
print("done")
"""


async def test_another_process_reopens_the_device() -> None:
    async with PtyPort() as pty:
        program = await asyncio.create_subprocess_exec(
            sys.executable, "-c", _PROGRAM, pty.device_path, stdout=asyncio.subprocess.PIPE
        )
        received: list[bytes] = []
        for _ in range(6):
            got = joined(await read_bytes(pty, 4))
            received.append(got)
            if len(got) < 4:
                break  # the program failed: its message tells why
            await pty.write(bytes(b ^ 0xFF for b in got))
        out, _ = await asyncio.wait_for(program.communicate(), WAIT)
        assert program.returncode == 0
        assert out == b"done\n"
        assert received == [bytes([0x02, 0x80, 0xFF, n]) for n in range(6)]


async def test_programs_that_mark_line_errors_and_plain_ones_take_turns() -> None:
    # SerialTransport asks the kernel to mark line errors (PARMRK): a data byte FF reaches it
    # doubled, which it undoes. Plain pyserial programs at 8E1 come in between.
    async with PtyPort() as pty:
        for n in range(2):
            async with SerialTransport(pty.device_path) as marking:
                await pty.write(b"\xff\x02\xff")
                assert joined(await read_bytes(marking, 3)) == b"\xff\x02\xff"
                await marking.write(b"\x80\xff")
                assert joined(await read_bytes(pty, 2)) == b"\x80\xff"
            for _ in range(2):
                with serial.Serial(pty.device_path, 9600, parity="E", timeout=WAIT) as other:
                    await exchange(pty, other, n)


_STEPS = st.lists(
    st.tuples(st.sampled_from(["up", "down", "baud", "flush"]), st.binary(min_size=1, max_size=40)),
    max_size=10,
)


@settings(max_examples=30, deadline=None)
@given(_STEPS)
def test_every_byte_passes_whatever_the_program_does_in_between(
    steps: list[tuple[str, bytes]],
) -> None:
    """The master reads in packet mode: a leading byte before every read of data, and control
    bytes of their own for new settings and flushes. None of it may be lost or added."""

    async def replay() -> None:
        async with PtyPort() as pty:
            with serial.Serial(pty.device_path, 9600, timeout=WAIT) as other:
                sent = b""
                for kind, data in steps:
                    if kind == "up":
                        other.write(data)
                        sent += data
                    elif kind == "down":
                        await pty.write(data)
                        assert other.read(len(data)) == data
                    elif kind == "baud":
                        other.baudrate = (9600, 19200, 38400)[data[0] % 3]
                    else:
                        other.reset_input_buffer()
                assert joined(await read_bytes(pty, len(sent))) == sent
                assert pty.stats.bytes_in == len(sent)

    asyncio.run(replay())
