"""BASS line codec (Baumueller manual 1.1, 1.2, 1.3; reading 12) against the shared vectors and
properties."""

from __future__ import annotations

import itertools
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bass.codec import (
    BassAnswer,
    BassCommand,
    BassFault,
    BassLine,
    BassLineReader,
    BassRequest,
    BassStatus,
    checksum,
    decode_answer,
    decode_line,
    decode_request,
    decode_text,
    decode_value,
    encode_text,
    encode_value,
    parse_line,
)
from pyuss.bass.errors import (
    BassErrorNumber,
    BassRefusal,
    BassTelegramError,
    FaultKind,
    error_meaning,
)
from pyuss.errors import DriveRefusal, TelegramError, UssError
from support.paths import load_vectors


def _wire(line: str) -> bytes:
    """The vectors write CR LF as the escapes \\r\\n."""
    return line.replace("\\r", "\r").replace("\\n", "\n").encode("ascii")


VECTORS: Any = load_vectors("bass")


@pytest.mark.parametrize("vector", VECTORS["lines"], ids=lambda v: v["body"])
def test_vector_checksum_and_line(vector: Any) -> None:
    body = vector["body"].encode("ascii")
    assert checksum(body) == int(vector["checksum"], 16)
    line = decode_request(_wire(vector["line"]))
    assert line.encode() == _wire(vector["line"])


def test_vector_write_id2_75_percent() -> None:
    line = _wire(VECTORS["lines"][0]["line"])
    assert BassRequest.write(0, 2, 7500).encode() == line
    request = decode_request(line)
    assert request.command == BassCommand.WRITE_ELEMENT
    assert request.is_write
    assert (request.address, request.ident, decode_value(request.data)) == (0, 2, 7500)


def test_vector_read_id51() -> None:
    line = _wire(VECTORS["lines"][1]["line"])
    assert BassRequest.read(0, 51).encode() == line
    request = decode_request(line)
    assert (request.command, request.ident, request.data) == (BassCommand.READ_ELEMENT, 51, "")
    assert not request.is_write


def test_checksum_folds_carries_back() -> None:
    example = VECTORS["carry_example"]
    body = bytes([0xFF, 0xFF, 0x36])
    assert sum(body) == int(example["sum"], 16)
    assert checksum(body) == int(example["checksum"], 16)
    # a fold can carry again: FFh + FFh... must end inside a byte
    assert checksum(bytes([0xFF] * 257)) <= 0xFF


@given(st.binary(max_size=600))
@settings(max_examples=200)
def test_checksum_is_end_around_sum(body: bytes) -> None:
    value = checksum(body)
    assert 0 <= value <= 0xFF
    assert value % 255 == sum(body) % 255
    assert (value == 0) == (sum(body) == 0)


def test_answer_of_document_example_2() -> None:
    """Baumueller manual 1.2: the drive answers the read of ID 51 with 1D3E = 7486 (74.86 %)."""
    answer = BassAnswer.value(0, 51, 0x1D3E)
    line = answer.encode()
    assert line.startswith(b"#0000000033" + b"1D3E")
    decoded = decode_answer(line)
    assert decoded.status == BassStatus.OK
    assert decoded.to_int() == 7486


@pytest.mark.parametrize("number", list(range(10)))
def test_status_bit_2_carries_each_error_number(number: int) -> None:
    answer = decode_answer(BassAnswer.refusal(7, 126, number).encode())
    assert answer.status & 0x0004
    assert answer.is_error
    assert answer.error_number == number
    with pytest.raises(BassRefusal) as info:
        answer.to_int()
    assert info.value.number == number
    assert info.value.meaning == BassErrorNumber(number).meaning
    assert info.value.address == 7 and info.value.ident == 126


def test_error_table_meanings() -> None:
    assert [e.value for e in BassErrorNumber] == list(range(10))
    assert error_meaning(1) == "element not available"
    assert error_meaning(5) == "parameter is write-protected"
    assert error_meaning(9) == "access to the parameter not valid"
    assert "not in table 1.3" in error_meaning(42)


def test_refusal_belongs_to_the_one_error_tree() -> None:
    refusal = BassRefusal(5, ident=2, address=3)
    assert isinstance(refusal, DriveRefusal) and isinstance(refusal, UssError)
    assert refusal.code is BassErrorNumber.WRITE_PROTECTED
    assert str(refusal) == "drive 3 refused ID 2: error 5: parameter is write-protected"
    assert BassRefusal(42).code is None
    assert issubclass(BassTelegramError, TelegramError)


def test_error_status_without_number_is_malformed() -> None:
    answer = BassAnswer(1, BassStatus.SERVICE_CHANNEL_ERROR, 2)
    with pytest.raises(BassTelegramError):
        answer.raise_for_status()


def test_other_status_bits_are_not_errors() -> None:
    assert not BassAnswer(1, 0xFFFB, 2, "0001").is_error
    assert BassAnswer(1, 0xFFFB, 2, "0001").to_int() == 1


def test_values_are_words_or_double_words() -> None:
    assert encode_value(7500) == "1D4C"
    assert encode_value(-1) == "FFFF"
    assert encode_value(0x10000) == "00010000"
    assert encode_value(-0x8001) == "FFFF7FFF"
    assert decode_value("FFFF", signed=True) == -1
    assert decode_value("FFFF") == 0xFFFF
    assert decode_value("FFFF7FFF", signed=True) == -0x8001
    for bad in (0x1_0000_0000, -0x8000_0001):
        with pytest.raises(BassTelegramError):
            encode_value(bad)
    with pytest.raises(BassTelegramError):
        encode_value(0x10000, 4)
    with pytest.raises(BassTelegramError):
        decode_value("")


@given(st.integers(-0x8000_0000, 0xFFFF_FFFF))
@settings(max_examples=200)
def test_value_round_trip(value: int) -> None:
    digits = encode_value(value)
    assert len(digits) in (4, 8)
    assert decode_value(digits, signed=value < 0) == value


@given(st.text(alphabet=st.characters(max_codepoint=0xFF), max_size=80))
@settings(max_examples=100)
def test_text_round_trip_with_two_length_words(text: str) -> None:
    data = encode_text(text)
    assert data[:4] == data[4:8] == f"{len(text):04X}"
    line = BassAnswer(3, 0, 9, data).encode()
    assert decode_answer(line).to_text() == text


def test_text_length_words_must_agree() -> None:
    good = encode_text("SV")
    assert decode_text(good) == "SV"
    for bad in ("0002000353560", "00020003" + "5356", "00030003" + "5356", "0002"):
        with pytest.raises(BassTelegramError) as info:
            decode_text(bad)
        assert info.value.fault is FaultKind.BAD_TEXT
    with pytest.raises(BassTelegramError):
        encode_text("€")


def test_encoder_rejects_fields_that_do_not_fit() -> None:
    for request in (
        BassRequest(256, 0x3C, 1),
        BassRequest(-1, 0x3C, 1),
        BassRequest(1, 0x10000, 1),
        BassRequest(1, 0x3C, 0x10000),
        BassRequest(1, 0x3E, 1, "1d4c"),
        BassRequest(1, 0x3E, 1, "12 4"),
    ):
        with pytest.raises(BassTelegramError):
            request.encode()


def test_lower_case_hex_is_accepted() -> None:
    body = b"0a003c00ff"
    line = b"#" + body + f"{checksum(body):02x}".encode() + b"\r\n"
    request = decode_request(line)
    assert (request.address, request.command, request.ident) == (10, 0x3C, 255)


@pytest.mark.parametrize(
    ("raw", "kind"),
    [
        (b"00003C0033FD\r\n", FaultKind.MISSING_BOF),
        (b"#00003C0033FD", FaultKind.MISSING_EOF),
        (b"#00003C0033FD\n", FaultKind.MISSING_EOF),
        (b"#00003C0033FD\r\r\n", FaultKind.BAD_HEX),
        (b"#00003C0033FE\r\n", FaultKind.BAD_CHECKSUM),
        (b"#00003C0G33FD\r\n", FaultKind.BAD_HEX),
        (b"#00003C00FD\r\n", FaultKind.TOO_SHORT),
    ],
)
def test_decode_names_the_fault(raw: bytes, kind: FaultKind) -> None:
    item = parse_line(raw)
    assert isinstance(item, BassFault) and item.kind is kind
    with pytest.raises(BassTelegramError) as info:
        decode_line(raw)
    assert info.value.fault is kind


addresses = st.integers(0, 0xFF)
words = st.integers(0, 0xFFFF)
data_fields = st.text(alphabet="0123456789ABCDEF", max_size=40)


@given(addresses, words, words, data_fields)
@settings(max_examples=200)
def test_request_and_answer_round_trip(address: int, word: int, ident: int, data: str) -> None:
    request = BassRequest(address, word, ident, data)
    assert decode_request(request.encode()) == request
    answer = BassAnswer(address, word, ident, data)
    assert decode_answer(answer.encode()) == answer


@given(addresses, words, words, data_fields, st.integers(0, 200), st.integers(0, 0xFF))
@settings(max_examples=200)
def test_any_single_byte_change_is_caught(
    address: int, word: int, ident: int, data: str, where: int, new: int
) -> None:
    line = bytearray(BassRequest(address, word, ident, data).encode())
    pos = 1 + where % (len(line) - 3)  # inside the body or checksum
    if line[pos] == new or chr(new) in "abcdef" or chr(line[pos]) in "abcdef":
        return
    if chr(new).upper() == chr(line[pos]).upper():
        return
    line[pos] = new
    assert isinstance(parse_line(bytes(line)), BassFault)


def _feed_all(reader: BassLineReader, chunks: list[bytes]) -> list[BassLine | BassFault]:
    out: list[BassLine | BassFault] = []
    for chunk in chunks:
        out += reader.feed(chunk)
    return out


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in itertools.pairwise(points)]


line_bits = st.sampled_from(
    [
        BassRequest.read(0, 51).encode(),
        BassRequest.write(0, 2, 7500).encode(),
        BassAnswer.refusal(3, 126, 5).encode(),
        b"#00003C0033FE\r\n",
        b"#",
        b"\r\n",
        b"\n",
        b"\r",
        b"zz",
        b"#0G",
        b"1234",
        b"\x00\xff",
    ]
)


@given(st.lists(line_bits | st.binary(max_size=30), max_size=20), st.lists(st.integers(0, 999)))
@settings(max_examples=200)
def test_reader_is_lossless_and_split_independent(parts: list[bytes], cuts: list[int]) -> None:
    stream = b"".join(parts)
    whole = BassLineReader(max_line=64)
    items = whole.feed(stream)
    split = BassLineReader(max_line=64)
    assert _feed_all(split, _split(stream, cuts)) == items
    assert split.pending == whole.pending
    assert b"".join(item.raw for item in items) + whole.pending == stream
    for item in items:
        if isinstance(item, BassLine):
            assert decode_line(item.raw) == item
    rest = whole.flush()
    assert whole.pending == b""
    assert all(isinstance(i, BassFault) for i in rest)


@given(st.binary(max_size=2000))
@settings(max_examples=100)
def test_reader_never_raises_on_garbage(garbage: bytes) -> None:
    reader = BassLineReader(max_line=100)
    items = reader.feed(garbage) + reader.flush()
    assert b"".join(item.raw for item in items) == garbage
    assert all(len(item.raw) <= 101 for item in items)


def test_reader_reports_each_kind_of_fault_and_resynchronises() -> None:
    good = BassRequest.read(0, 51).encode()
    reader = BassLineReader(max_line=40)
    stream = (
        b"noise\r\n"  # no '#'
        + b"#00003C0033"  # cut off by the next '#'
        + b"#00003C0033FE\r\n"  # bad checksum
        + b"#00Z03C0033FD\r\n"  # bad hex
        + b"#00003C0033FD\n"  # LF without CR
        + b"#"
        + b"0" * 60
        + b"\r\n"  # overlong
        + good
    )
    items = reader.feed(stream)
    kinds = [i.kind if isinstance(i, BassFault) else "line" for i in items]
    assert kinds == [
        FaultKind.MISSING_BOF,
        FaultKind.MISSING_EOF,
        FaultKind.BAD_CHECKSUM,
        FaultKind.BAD_HEX,
        FaultKind.MISSING_EOF,
        FaultKind.OVERLONG,
        FaultKind.OVERLONG,
        "line",
    ]
    last = items[-1]
    assert isinstance(last, BassLine) and last.raw == good
    assert reader.feed(b"#00003C") == []
    assert reader.pending == b"#00003C"
    (unfinished,) = reader.flush()
    assert isinstance(unfinished, BassFault) and unfinished.kind is FaultKind.MISSING_EOF


def test_an_overlong_line_is_named_in_one_short_message() -> None:
    first, *rest = BassLineReader(max_line=100).feed(b"#" + b"0" * 2000 + b"\r\n")
    assert isinstance(first, BassFault) and rest
    assert all(isinstance(i, BassFault) and i.kind is FaultKind.OVERLONG for i in rest)
    message = str(first.to_error())
    assert message.startswith("line too long: over 100 bytes in b'#000")
    assert message.endswith("0'... (101 bytes)")
    assert len(message) < 120
    assert str(BassFault(FaultKind.BAD_CHECKSUM, b"#00\r\n").to_error()).endswith("in b'#00\\r\\n'")
