"""HOST:PORT is read by one parser everywhere (`pyuss.transport.address`)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.transport.address import HostPort, parse_host_port


@pytest.mark.parametrize(
    ("text", "host", "port"),
    [
        ("10.0.0.5:4001", "10.0.0.5", 4001),
        (" plc.local:502 ", "plc.local", 502),
        ("[::1]:8420", "::1", 8420),
        (":4001", "127.0.0.1", 4001),
        ("4001", "127.0.0.1", 4001),
        ("localhost:0", "localhost", 0),
    ],
)
def test_the_forms_a_user_writes(text: str, host: str, port: int) -> None:
    assert parse_host_port(text, "--tcp") == HostPort(host, port)


def test_defaults_are_the_callers() -> None:
    assert parse_host_port("broker", "x", default_port=1883) == HostPort("broker", 1883)
    assert parse_host_port("[fe80::1]", "x", default_port=4840) == HostPort("fe80::1", 4840)
    with pytest.raises(ConfigError, match=r"^'tcp://:4001': expected tcp://HOST:PORT$"):
        parse_host_port(":4001", "'tcp://:4001'", form="tcp://HOST:PORT", default_host=None)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("", "--tcp '': expected HOST:PORT"),
        ("localhost", "--tcp 'localhost': expected HOST:PORT"),
        ("host:http", "the port is not a number 0..65535"),
        ("host:65536", "the port is not a number 0..65535"),
        ("host:\u00b2", "the port is not a number 0..65535"),
        ("host:-1", "the port is not a number 0..65535"),
        ("::1:502", "write an IPv6 address in brackets"),
        ("[::1", "with an IPv6 address as [::1]"),
        ("[::1]502", "with an IPv6 address as [::1]"),
        ("[]:502", "with an IPv6 address as [::1]"),
    ],
)
def test_bad_addresses_say_what_is_wrong(text: str, words: str) -> None:
    with pytest.raises(ConfigError, match=r"^--tcp ") as caught:
        parse_host_port(text, f"--tcp {text!r}")
    assert words in str(caught.value)


@settings(deadline=None)
@given(
    st.one_of(
        st.from_regex(r"[a-z][a-z0-9.-]{0,20}", fullmatch=True),
        st.ip_addresses().map(str),
    ),
    st.integers(min_value=0, max_value=65535),
)
def test_what_is_written_reads_back(host: str, port: int) -> None:
    where = HostPort(host, port)
    assert parse_host_port(str(where), "x") == where


@settings(deadline=None)
@given(st.text(max_size=30))
def test_any_text_is_read_or_refused_with_a_config_error(text: str) -> None:
    try:
        where = parse_host_port(text, "x")
    except ConfigError:
        return
    assert 0 <= where.port <= 65535 and where.host
