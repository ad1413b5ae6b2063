"""SerialTransport over pyserial URLs and real pseudo-terminals."""

from __future__ import annotations

import asyncio
import logging

import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError, TransportError
from pyuss.transport.base import LineError
from pyuss.transport.pty import PtyPort
from pyuss.transport.queued import BAUD_RATES, EchoError
from pyuss.transport.serialport import MARKED, MarkDecoder, RS485Mode, SerialTransport
from pyuss.transport.tcp import TcpServerTransport
from pyuss.transport.url import open_transport
from transport.helpers import WAIT, Rfc2217Server, joined, read_bytes


async def test_loop_url_reads_back_what_was_written() -> None:
    async with SerialTransport("loop://", baud=19200) as port:
        await port.write(b"\x02\x06\x01\x00\x00\x00\x00\x05")
        chunks = await read_bytes(port, 8)
        assert joined(chunks) == b"\x02\x06\x01\x00\x00\x00\x00\x05"
        stamps = [c.timestamp for c in chunks]
        assert stamps == sorted(stamps)
        assert all(c.timestamp <= port.clock() for c in chunks)


async def test_socket_url_carries_bytes_both_ways() -> None:
    server = TcpServerTransport()
    await server.open()
    async with SerialTransport(f"socket://127.0.0.1:{server.port}", baud=19200) as port:
        assert await server.wait_peer(WAIT)
        await port.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(server, 4)) == b"\x02\x02\x00\x00"
        await server.write(bytes(range(256)))
        assert joined(await read_bytes(port, 256)) == bytes(range(256))
        await server.close()  # the converter goes away: the loss is reported
        with pytest.raises(TransportError, match="lost"):
            await port.read(WAIT)


@pytest.mark.filterwarnings("ignore::DeprecationWarning:serial.rfc2217")
async def test_rfc2217_url_sets_the_remote_port_to_8e1_and_the_baud() -> None:
    remote = serial.serial_for_url("loop://", baudrate=9600, parity="N", timeout=0.05)
    server = Rfc2217Server(remote)
    host, tcp_port = server.address
    try:
        async with SerialTransport(f"rfc2217://{host}:{tcp_port}", baud=19200) as port:
            # The remote port loops back what it is sent.
            await port.write(b"\x02\x04\x00\xff\x11\xe8")
            assert joined(await read_bytes(port, 6)) == b"\x02\x04\x00\xff\x11\xe8"
            assert (remote.baudrate, remote.bytesize, remote.parity, remote.stopbits) == (
                19200,
                8,
                "E",
                1,
            )
    finally:
        server.close()
        remote.close()


async def test_default_frame_is_8e1() -> None:
    transport = SerialTransport("loop://")
    assert transport.port.bytesize == 8
    assert transport.port.parity == "E"
    assert transport.port.stopbits == 1
    assert transport.baud == 9600


@pytest.mark.pty
async def test_every_baud_rate_of_b_2_4_sets_up_a_terminal() -> None:
    # 76800, 93750 and 187500 are no standard termios rates: pyserial sets them as custom ones.
    async with PtyPort() as pty:
        for baud in BAUD_RATES:
            async with SerialTransport(pty.device_path, baud=baud) as port:
                assert port.port.baudrate == baud
                await port.write(b"\x02")
                assert joined(await read_bytes(pty, 1)) == b"\x02"


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"baud": 1234}, "1234 is not a USS baud rate"),
        ({"baud": "9600"}, "'9600' is not a USS baud rate"),
        ({"parity": "X"}, "parity 'X'"),
        ({"stopbits": 3}, "stop bits 3"),
        ({"rs485": "both"}, "RS-485 mode 'both'"),
    ],
)
def test_bad_settings_name_what_is_wrong(kwargs: dict[str, object], words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        SerialTransport("loop://", **kwargs)  # type: ignore[arg-type]


def test_unknown_url_scheme_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="nosuch://x"):
        SerialTransport("nosuch://x")


async def test_missing_device_fails_to_open_with_its_name() -> None:
    transport = SerialTransport("/dev/does-not-exist-uss")
    with pytest.raises(TransportError, match="/dev/does-not-exist-uss"):
        await transport.open()


async def test_read_before_open_and_after_close_raise() -> None:
    transport = SerialTransport("loop://")
    with pytest.raises(TransportError, match="not open"):
        await transport.read(0.01)
    await transport.open()
    await transport.close()
    await transport.close()  # idempotent
    with pytest.raises(TransportError, match="closed"):
        await transport.read(0.01)
    with pytest.raises(TransportError, match="not open"):
        await transport.write(b"x")


async def test_read_times_out_with_none() -> None:
    async with SerialTransport("loop://") as port:
        assert await port.read(0.05) is None


async def test_flush_input_discards_what_was_not_read() -> None:
    async with SerialTransport("loop://") as port:
        await port.write(b"stale")
        await read_until_buffered(port)
        port.flush_input()
        assert await port.read(0.1) is None
        await port.write(b"new")
        assert joined(await read_bytes(port, 3)) == b"new"


async def read_until_buffered(port: SerialTransport) -> None:
    for _ in range(100):
        if port.stats.bytes_in:
            return
        await asyncio.sleep(0.02)


async def test_echo_is_verified_and_removed() -> None:
    # loop:// returns every byte written, as a 2-wire adapter returns its own telegram.
    async with SerialTransport("loop://", echo=True) as port:
        await port.write(b"\x02\x03\x05\x00\x04")
        assert await port.read(0.3) is None
        assert port.stats.echo_bytes == 5
        assert port.stats.echo_errors == 0


@pytest.mark.pty
async def test_pty_serial_both_ways() -> None:
    async with PtyPort(baud=19200) as pty, SerialTransport(pty.device_path, baud=19200) as port:
        await port.write(b"\x02\x04\x00\x11\x22\x35")
        assert joined(await read_bytes(pty, 6)) == b"\x02\x04\x00\x11\x22\x35"
        await pty.write(bytes(range(256)))
        assert joined(await read_bytes(port, 256)) == bytes(range(256))


@pytest.mark.pty
async def test_pty_byte_ff_survives_error_marking() -> None:
    # The port marks line errors (PARMRK), so the kernel doubles every FF: it must read as one.
    async with PtyPort() as pty, SerialTransport(pty.device_path) as port:
        await pty.write(b"\xff\x02\xff\xff\x00\xff")
        chunks = await read_bytes(port, 6)
        assert joined(chunks) == b"\xff\x02\xff\xff\x00\xff"
        assert all(c.errors == () for c in chunks)


@pytest.mark.pty
async def test_echo_that_differs_is_reported() -> None:
    async with PtyPort() as pty, SerialTransport(pty.device_path, echo=True) as port:
        await port.write(b"\x02\x03\x05")
        assert joined(await read_bytes(pty, 3)) == b"\x02\x03\x05"
        await pty.write(b"\x02\x03\x07")  # the echo as a collision would garble it
        with pytest.raises(EchoError) as info:
            await port.read(WAIT)
        assert info.value.sent == b"\x02\x03\x05"
        assert info.value.received == b"\x02\x03\x07"
        assert port.stats.echo_errors == 1
        # Afterwards the port reads normally again.
        await pty.write(b"\x02")
        assert joined(await read_bytes(port, 1)) == b"\x02"


@pytest.mark.pty
async def test_missing_echo_is_reported() -> None:
    async with (
        PtyPort() as pty,
        SerialTransport(pty.device_path, echo=True, echo_timeout=0.05) as port,
    ):
        await port.write(b"\x02\x03")
        with pytest.raises(EchoError, match="missing"):
            await port.read(WAIT)


@pytest.mark.pty
async def test_lost_port_is_reported_to_the_reader() -> None:
    pty = PtyPort()
    await pty.open()
    async with SerialTransport(pty.device_path) as port:
        await pty.write(b"last")
        assert joined(await read_bytes(port, 4)) == b"last"
        await pty.close()
        with pytest.raises(TransportError, match="lost"):
            await port.read(WAIT)


@pytest.mark.pty
@pytest.mark.parametrize(
    ("mode", "words"), [("kernel", "kernel RS-485 mode"), ("rts", "RTS direction control")]
)
async def test_direction_control_a_port_cannot_do_fails_to_open(mode: str, words: str) -> None:
    # A pty has neither the kernel's RS-485 mode nor modem lines.
    async with PtyPort() as pty:
        port = SerialTransport(pty.device_path, rs485=mode)
        with pytest.raises(TransportError, match=words):
            await port.open()
        assert not port.is_open


async def test_kernel_mode_asks_for_rts_high_while_sending() -> None:
    port = SerialTransport("loop://", rs485="kernel")
    assert port.port.rs485_mode is None  # set when the port opens
    async with port:
        settings = port.port.rs485_mode
        assert settings is not None
        assert (settings.rts_level_for_tx, settings.rts_level_for_rx) == (True, False)


async def test_rts_mode_raises_rts_around_each_write(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="pySerial.loop")
    baud = 2400
    async with SerialTransport("loop://?logging=info", baud=baud, rs485=RS485Mode.RTS) as port:
        caplog.clear()
        await port.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(port, 4)) == b"\x02\x02\x00\x00"
    rts = [r for r in caplog.records if "_update_rts_state" in r.getMessage()]
    assert [r.getMessage() for r in rts[:2]] == [
        "_update_rts_state(True) -> state of CTS",
        "_update_rts_state(False) -> state of CTS",
    ]
    # RTS stays up at least while the 4 characters are on the line (A 6.1: 11 bits each), even
    # though loop:// takes the bytes at once: the hold comes from the character time.
    assert rts[1].created - rts[0].created >= 4 * 11 / baud


def _mark(data: bytes, bad: set[int]) -> bytes:
    out = bytearray()
    for i, b in enumerate(data):
        if i in bad:
            out += bytes((0xFF, 0x00, b))
        elif b == 0xFF:
            out += b"\xff\xff"
        else:
            out.append(b)
    return bytes(out)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_mark_decoder_undoes_kernel_marking_across_any_split(data: st.DataObject) -> None:
    payload = data.draw(st.binary(max_size=40))
    bad = data.draw(st.sets(st.integers(0, max(0, len(payload) - 1)))) if payload else set()
    raw = _mark(payload, bad)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(raw)), max_size=4)))
    decoder = MarkDecoder()
    out = bytearray()
    errors: list[tuple[int, LineError]] = []
    last = 0
    for cut in [*cuts, len(raw)]:
        piece, errs = decoder.feed(raw[last:cut])
        errors += [(pos + len(out), flag) for pos, flag in errs]
        out += piece
        last = cut
    assert bytes(out) == payload
    assert errors == [(i, MARKED) for i in sorted(bad)]


def _uart_with_serial_info() -> str | None:
    """A real serial port here whose driver offers TIOCGSERIAL (an 8250 UART), or None (also
    where there are no terminal settings: not a POSIX system)."""
    import os

    try:
        import fcntl
        import termios
    except ImportError:
        return None

    for path in ("/dev/ttyS0", "/dev/ttyS1"):
        try:
            fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            continue
        try:
            fcntl.ioctl(fd, termios.TIOCGSERIAL, bytes(1024))
        except OSError:
            continue
        finally:
            os.close(fd)
        return path
    return None


def _low_latency_flag(path: str) -> bool:
    import fcntl
    import os
    import struct
    import termios

    from pyuss.system._posix import ASYNC_LOW_LATENCY

    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        info = fcntl.ioctl(fd, termios.TIOCGSERIAL, bytes(1024))
    finally:
        os.close(fd)
    return bool(struct.unpack_from("i", info, 16)[0] & ASYNC_LOW_LATENCY)


UART = _uart_with_serial_info()


@pytest.mark.skipif(UART is None, reason="needs a serial port whose driver offers TIOCGSERIAL")
async def test_a_driver_that_offers_low_latency_mode_gets_asked_for_it() -> None:
    # As setserial does: ASYNC_LOW_LATENCY through TIOCSSERIAL while the port is open; the
    # driver's setting as it was once the port closes. low_latency=0 keeps it off.
    assert UART is not None
    before = _low_latency_flag(UART)
    async with open_transport(UART) as port:
        assert isinstance(port, SerialTransport)
        assert port.low_latency_mode is True
        assert _low_latency_flag(UART)
    assert _low_latency_flag(UART) == before
    async with open_transport(f"{UART}?low_latency=0") as port:
        assert isinstance(port, SerialTransport)
        assert port.low_latency_mode is False
        assert not _low_latency_flag(UART)
    assert _low_latency_flag(UART) == before


@pytest.mark.pty
async def test_a_pty_offers_no_low_latency_mode_and_opens_all_the_same() -> None:
    async with PtyPort() as pty, SerialTransport(pty.device_path) as port:
        assert port.low_latency_mode is None
        await pty.write(b"\x02\x02")
        assert joined(await read_bytes(port, 2)) == b"\x02\x02"
