"""open_transport chooses by URL and names what is wrong."""

from __future__ import annotations

import pytest

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
        ("loop://", {"baud": 12345}, "baud rate 12345"),
    ],
)
def test_bad_urls_and_settings(url: str, kwargs: dict[str, object], words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        open_transport(url, **kwargs)  # type: ignore[arg-type]


async def test_opened_by_url_it_works() -> None:
    async with open_transport("loop://", baud=187500) as port:
        await port.write(b"\x02\x02\x00\x00")
        assert joined(await read_bytes(port, 4)) == b"\x02\x02\x00\x00"
