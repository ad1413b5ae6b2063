"""Telegram frame (A 4): every telegram of the shared vectors, BCC, ADR and the error cases."""

from __future__ import annotations

import functools
import operator
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import TelegramError
from pyuss.protocol.telegram import (
    MAX_NET_BYTES,
    STX,
    AddressError,
    AddressMode,
    BccError,
    LengthError,
    StxError,
    Telegram,
    adr_byte,
    bcc,
    parse_adr,
)
from support.paths import load_vectors

VECTORS = load_vectors("uss")
TELEGRAMS = VECTORS["telegrams"]


def _words_to_bytes(words_hex: list[str]) -> bytes:
    return b"".join(int(w, 16).to_bytes(2, "big") for w in words_hex)


@pytest.mark.parametrize("vec", TELEGRAMS, ids=[v["name"] for v in TELEGRAMS])
def test_vector_encodes_to_its_exact_bytes(vec: dict[str, Any]) -> None:
    address, mode = parse_adr(vec["adr"])
    telegram = Telegram(address, mode, _words_to_bytes(vec["words_hex"]))
    raw = telegram.encode()
    assert raw == bytes.fromhex(vec["hex"])
    assert telegram.lge == vec["lge"]
    assert len(raw) == vec["total_bytes"]
    assert telegram.adr == vec["adr"]


@pytest.mark.parametrize("vec", TELEGRAMS, ids=[v["name"] for v in TELEGRAMS])
def test_vector_decodes_from_its_exact_bytes(vec: dict[str, Any]) -> None:
    telegram = Telegram.decode(bytes.fromhex(vec["hex"]))
    assert telegram.adr == vec["adr"]
    assert telegram.lge == vec["lge"]
    assert telegram.data == _words_to_bytes(vec["words_hex"])


def test_vector_address_modes() -> None:
    by_name = {v["name"]: Telegram.decode(bytes.fromhex(v["hex"])) for v in TELEGRAMS}
    assert by_name["mirror_request"].mode is AddressMode.MIRROR
    assert by_name["mirror_request"].address == 7
    assert by_name["broadcast_setpoint"].mode is AddressMode.BROADCAST
    assert not by_name["broadcast_setpoint"].expects_answer
    assert by_name["special_telegram"].mode is AddressMode.SPECIAL
    assert by_name["special_telegram"].address == 3
    assert by_name["read_word_request"].mode is AddressMode.NORMAL


@pytest.mark.parametrize("vec", VECTORS["bcc"])
def test_bcc_running_values(vec: dict[str, Any]) -> None:
    data = bytes.fromhex(vec["bytes"])
    running = [bcc(data[: i + 1]) for i in range(len(data))]
    assert running == [int(x, 16) for x in vec["running"]]


@given(st.binary(max_size=300), st.integers(0, 255))
@settings(max_examples=200)
def test_bcc_is_the_xor_of_all_bytes(data: bytes, initial: int) -> None:
    assert bcc(data, initial) == functools.reduce(operator.xor, data, initial)


def test_every_adr_byte_is_parsed_or_refused() -> None:
    defined = {0b000, 0b010, 0b001, 0b100, 0b101}
    for byte in range(256):
        if byte >> 5 in defined:
            address, mode = parse_adr(byte)
            assert address == byte & 0x1F
            assert adr_byte(address, mode) == byte
        else:
            with pytest.raises(AddressError, match="undefined"):
                parse_adr(byte)


@pytest.mark.parametrize("mode", [0x60, 0xC0, 0xE0])
def test_undefined_mode_is_refused_when_encoding(mode: int) -> None:
    with pytest.raises(AddressError, match="undefined"):
        adr_byte(1, mode)
    with pytest.raises(AddressError):
        Telegram(1, mode, b"")  # type: ignore[arg-type]


@pytest.mark.parametrize("mode", [0x10, 0x61, 0x100, -1, "x", True])
def test_a_mode_that_is_no_adr_type_is_refused(mode: object) -> None:
    with pytest.raises(AddressError, match=r"ADR bits 5\.\.7 in place"):
        adr_byte(1, mode)  # type: ignore[arg-type]


@pytest.mark.parametrize("address", [-1, 32, 255])
def test_address_out_of_range_is_refused(address: int) -> None:
    with pytest.raises(AddressError, match=r"0\.\.31"):
        adr_byte(address)
    with pytest.raises(AddressError, match=r"0\.\.31"):
        Telegram(address, AddressMode.NORMAL, b"")


def test_net_data_limit() -> None:
    Telegram(0, AddressMode.NORMAL, bytes(MAX_NET_BYTES))
    with pytest.raises(LengthError, match="253 net bytes"):
        Telegram(0, AddressMode.NORMAL, bytes(MAX_NET_BYTES + 1))


def test_shortest_and_longest_telegram() -> None:
    short = Telegram(3, AddressMode.NORMAL, b"").encode()
    assert short == bytes([STX, 2, 3, STX ^ 2 ^ 3])
    long = Telegram(3, AddressMode.NORMAL, bytes(range(252))).encode()
    assert len(long) == 256
    assert long[1] == 254
    assert Telegram.decode(long).data == bytes(range(252))


def test_bytearray_data_is_stored_as_bytes() -> None:
    telegram = Telegram(1, AddressMode.NORMAL, bytearray(b"\x01\x02"))  # type: ignore[arg-type]
    assert type(telegram.data) is bytes


GOOD = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")


@pytest.mark.parametrize(
    ("raw", "error", "text"),
    [
        (b"", LengthError, "too short"),
        (GOOD[:3], LengthError, "too short"),
        (b"\x03" + GOOD[1:], StxError, "not STX"),
        (bytes([2, 1, 5, 6]), LengthError, "LGE 1 is out of range"),
        (bytes([2, 255]) + bytes(255), LengthError, "LGE 255 is out of range"),
        (GOOD[:-1], LengthError, "announces 14 bytes, got 13"),
        (GOOD + b"\x00", LengthError, "announces 14 bytes, got 15"),
        (GOOD[:-1] + b"\x56", BccError, "BCC is 56h, expected 55h"),
    ],
)
def test_decode_names_what_is_wrong(raw: bytes, error: type[Exception], text: str) -> None:
    with pytest.raises(error, match=text):
        Telegram.decode(raw)


def test_bcc_error_carries_both_values() -> None:
    with pytest.raises(BccError) as info:
        Telegram.decode(GOOD[:-1] + b"\x00")
    assert (info.value.expected, info.value.received) == (0x55, 0x00)


def test_decode_without_bcc_check_accepts_a_wrong_bcc() -> None:
    assert Telegram.decode(GOOD[:-1] + b"\x00", check_bcc=False).address == 5


def test_decode_reports_undefined_adr() -> None:
    frame = bytes([STX, 2, 0x65])
    with pytest.raises(AddressError, match="65h"):
        Telegram.decode(frame + bytes([bcc(frame)]))


modes = st.sampled_from(list(AddressMode))


@given(st.integers(0, 31), modes, st.binary(max_size=MAX_NET_BYTES))
@settings(max_examples=150)
def test_round_trip(address: int, mode: AddressMode, data: bytes) -> None:
    telegram = Telegram(address, mode, data)
    raw = telegram.encode()
    assert len(raw) == telegram.lge + 2
    assert bcc(raw) == 0
    assert Telegram.decode(raw) == telegram


@given(st.binary(max_size=260))
@settings(max_examples=300)
def test_decode_of_any_bytes_raises_only_telegram_errors(raw: bytes) -> None:
    try:
        telegram = Telegram.decode(raw)
    except TelegramError:
        return
    assert telegram.encode() == raw
