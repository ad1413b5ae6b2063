"""open_transport chooses by URL and names what is wrong."""

from __future__ import annotations

import pytest

from pyuss.cli.main import main
from pyuss.errors import ConfigError
from pyuss.transport.reconnect import ReconnectingTransport
from pyuss.transport.serialport import RS485Mode, SerialTransport
from pyuss.transport.tcp import TcpServerTransport, TcpTransport
from pyuss.transport.url import open_transport
from transport.helpers import joined, read_bytes


def test_choice_by_url() -> None:
    tcp = open_transport("tcp://127.0.0.1:4001", baud=19200)
    assert isinstance(tcp, TcpTransport)
    assert (tcp.host, tcp.port, tcp.baud) == ("127.0.0.1", 4001, 19200)
    server = open_transport("tcp-listen://127.0.0.1:0")
    assert isinstance(server, TcpServerTransport)
    for url in ("loop://", "socket://127.0.0.1:4001", "rfc2217://127.0.0.1:4001", "/dev/ttyS9"):
        serial = open_transport(url, rs485="rts", echo=True)
        assert isinstance(serial, SerialTransport)
        assert serial.rs485 is RS485Mode.RTS and serial.echo
    assert isinstance(open_transport("loop://", reconnect=True), ReconnectingTransport)


def test_line_options_in_the_query() -> None:
    port = open_transport("loop://?rs485=rts&echo=1&reconnect=1")
    assert isinstance(port, ReconnectingTransport)
    inner = port.inner
    assert isinstance(inner, SerialTransport)
    assert (inner.url, inner.rs485, inner.echo) == ("loop://", RS485Mode.RTS, True)
    # pyserial's own options stay in the URL it gets.
    serial = open_transport("socket://127.0.0.1:4001?logging=debug&echo=yes")
    assert isinstance(serial, SerialTransport)
    assert serial.url == "socket://127.0.0.1:4001?logging=debug" and serial.echo
    device = open_transport("/dev/ttyS9?rs485=kernel", rs485="rts")
    assert isinstance(device, SerialTransport)
    assert (device.url, device.rs485, device.echo) == ("/dev/ttyS9", RS485Mode.KERNEL, False)
    tcp = open_transport("tcp://127.0.0.1:4001?echo=1")
    assert isinstance(tcp, TcpTransport) and tcp.echo
    # Low-latency mode is asked for unless the URL (or the caller) keeps it off.
    assert isinstance(usb := open_transport("/dev/ttyUSB0"), SerialTransport) and usb.low_latency
    slow = open_transport("/dev/ttyUSB0?low_latency=0&rs485=rts")
    assert isinstance(slow, SerialTransport)
    assert (slow.url, slow.low_latency, slow.rs485) == ("/dev/ttyUSB0", False, RS485Mode.RTS)
    kept = open_transport("/dev/ttyUSB0", low_latency=False)
    assert isinstance(kept, SerialTransport) and not kept.low_latency
    asked = open_transport("/dev/ttyUSB0?low_latency=yes", low_latency=False)
    assert isinstance(asked, SerialTransport) and asked.low_latency
    assert isinstance(open_transport("tcp://127.0.0.1:4001?reconnect=on"), ReconnectingTransport)
    assert isinstance(open_transport("bus://127.0.0.1:4001?reconnect=1"), ReconnectingTransport)


async def test_echo_asked_for_in_the_url_is_removed() -> None:
    async with open_transport("loop://?echo=1", baud=38400) as port:
        await port.write(b"\x02\x02\x00\x00")
        assert await port.read(0.3) is None
        assert isinstance(port, SerialTransport) and port.stats.echo_bytes == 4


def test_a_command_on_an_echoing_line_does_not_take_its_own_request_for_the_answer(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # loop:// returns every byte: without echo=1 the request would read as the answer.
    assert main(["read", "--port", "loop://?echo=1", "--timeout", "0.3", "5", "1"]) == 1
    assert "does not send" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("url", "words"),
    [
        ("socket://nohost", "expected socket://HOST:PORT"),
        ("rfc2217://", "expected rfc2217://HOST:PORT"),
        ("loop://?rs485=both", "RS-485 mode 'both'"),
        ("tcp://[::1", "expected tcp://HOST:PORT, with an IPv6 address as [::1]"),
        ("bus://[::1:5", "expected bus://HOST:PORT, with an IPv6 address as [::1]"),
        ("socket://[::1", "expected socket://HOST:PORT, with an IPv6 address as [::1]"),
        ("rfc2217://[::1", "expected rfc2217://HOST:PORT, with an IPv6 address as [::1]"),
    ],
)
def test_a_command_given_a_bad_port_url_says_so_with_exit_2(
    url: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["read", "--port", url, "5", "1"]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("url", "kwargs", "words"),
    [
        ("", {}, "non-empty"),
        ("tcp://127.0.0.1", {}, "HOST:PORT"),
        ("tcp://127.0.0.1:http", {}, "port is not a number"),
        ("tcp://127.0.0.1:0", {}, "TCP port"),
        ("tcp://127.0.0.1:4001?x=1", {}, "unknown option 'x'"),
        ("tcp://127.0.0.1:4001/path", {}, "unexpected path"),
        ("nosuch://x", {}, "nosuch"),
        ("loop://", {"baud": 12345}, "12345 is not a USS baud rate"),
        ("loop://?rs485=both", {}, "RS-485 mode 'both'"),
        ("loop://?echo=maybe", {}, "echo='maybe'"),
        ("loop://?echo=1&echo=0", {}, "'echo' given more than once"),
        ("/dev/ttyUSB0?low_latency=fast", {}, "low_latency='fast'"),
        ("tcp://127.0.0.1:4001?low_latency=0", {}, "unknown option 'low_latency'"),
        ("socket://127.0.0.1", {}, "expected socket://HOST:PORT"),
        ("socket://127.0.0.1:x", {}, "expected socket://HOST:PORT"),
        ("rfc2217://:4001", {}, "expected rfc2217://HOST:PORT"),
        ("tcp://127.0.0.1:4001?rs485=rts", {}, "unknown option 'rs485'"),
        ("tcp-listen://127.0.0.1:0?echo=1", {}, "unknown option 'echo'"),
        ("bus://127.0.0.1:4001?reconnect=x", {}, "reconnect='x'"),
        ("tcp-listen://[", {}, "IPv6 address as"),
        ("bus://127.0.0.1:4001?name=%00", {}, "printable"),
    ],
)
def test_bad_urls_and_settings(url: str, kwargs: dict[str, object], words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        open_transport(url, **kwargs)  # type: ignore[arg-type]


async def test_opened_by_url_it_works() -> None:
    async with open_transport("loop://", baud=187500) as port:
        await port.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(port, 4)) == b"\x02\x02\x00\x00"
