"""Parameter channel (KS VARIO interface description 4): telegrams of the vectors, both sides,
formats, results."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.ksvario.address import Address
from pyuss.ksvario.channel import (
    ByteOrder,
    ChannelClient,
    ChannelServer,
    DataFormat,
    DisplayWord,
    Result,
    StartRequest,
    TelegramId,
    Value,
    decode_value,
    encode_value,
    end_result,
)
from support.paths import load_vectors

VECTORS = load_vectors("ksvario")


def _hex(text: str) -> bytes:
    return bytes.fromhex(text)


def _matches(pattern: str, data: bytes) -> bool:
    parts = pattern.split()
    return all(p.lower() == "xx" or int(p, 16) == data[i] for i, p in enumerate(parts))


class Store:
    """A stand-in device for the server: data by (area, datum), integers and reals."""

    def __init__(self) -> None:
        self.data: dict[tuple[int, int], float] = {}
        self.writes: list[tuple[int, list[Value]]] = []

    def read_values(self, address: Address, fmt: DataFormat, count: int) -> list[Value] | Result:
        if address.datum + count > 512:
            return Result.BAD_ADDRESS
        out: list[Value] = []
        for d in range(address.datum, address.datum + count):
            v = self.data.get((address.area, d), 0.0)
            out.append(v if fmt.is_real else int(v))
        return out

    def write_values(self, address: Address, fmt: DataFormat, values: Sequence[Value]) -> Result:
        if any(isinstance(v, float) and math.isnan(v) for v in values):
            return Result.INVALID_VALUE
        for k, v in enumerate(values):
            assert not isinstance(v, bytes)
            self.data[(address.area, address.datum + k)] = float(v)
        self.writes.append((address.encode(), list(values)))
        return Result.OK


def run(
    client: ChannelClient, server: ChannelServer, limit: int = 100
) -> list[tuple[bytes, bytes]]:
    trace = []
    t = 0.0
    for _ in range(limit):
        req = client.request()
        resp = server.exchange(req, t)
        trace.append((req, resp))
        client.feed(resp, t)
        t += 0.01
        if client.status.done:
            return trace
    raise AssertionError("job did not finish")


@pytest.mark.parametrize("vec", VECTORS["start_telegrams"], ids=lambda v: v["section"])
def test_start_telegram_vectors(vec: dict[str, str]) -> None:
    master = _hex(vec["master"])
    start = StartRequest.decode(master)
    assert start.encode() == master
    store = Store()
    server = ChannelServer(store)
    answer = server.exchange(master, 0.0)
    assert _matches(vec["device"], answer), answer.hex(" ")


def test_ids_of_the_vectors() -> None:
    ids = VECTORS["ids"]
    assert int(ids["start"], 16) == TelegramId.START
    assert int(ids["data"], 16) == TelegramId.DATA
    assert int(ids["end"], 16) == TelegramId.END
    assert {int(k): v for k, v in VECTORS["results"].items()} == {
        r.value: r.meaning for r in Result
    }


def test_read_sequence_example_1_bytes() -> None:
    """4.5.1: read 1 integer at 4496h; the coupler mirrors Count and sends the value."""
    store = Store()
    store.data[(2, 0x96)] = 123
    client = ChannelClient()
    client.start_read(DataFormat.INTEGER, 0x4496, 1, 0.0)
    trace = run(client, ChannelServer(store))
    reqs = [r for r, _ in trace]
    assert reqs[0] == _hex("10 00 01 44 96 00 00 00")
    assert _hex("68 01 00 00 00 00 00 00") in reqs
    assert reqs[-1] == _hex("16 00 00 00 00 00 00 00")
    data_answer = next(a for _, a in trace if a[0] == 0x68)
    assert data_answer == _hex("68 01 00 00 00 00 00 7B")
    assert client.values == [123]
    assert client.result == 0
    assert client.status.word == DisplayWord.DONE_OK


def test_write_sequence_mirrors_count_and_ends_with_result() -> None:
    """4.3 / 4.5.4: write 3 reals; Count 1..3 is echoed; the end telegram carries result 0."""
    store = Store()
    client = ChannelClient()
    client.start_write(DataFormat.REAL, 0xFD09, [1.5, 2.5, -3.0], 0.0)
    trace = run(client, ChannelServer(store))
    assert trace[0][0] == _hex("10 01 00 FD 09 00 03 00")
    counts = [(r[1], a[1]) for r, a in trace if r[0] == 0x68 and a[0] == 0x68]
    assert sorted(set(counts)) == [(1, 1), (2, 2), (3, 3)]
    assert trace[-1][1][0] == 0x16
    assert store.writes == [(0xFD09, [1.5, 2.5, -3.0])]
    assert store.data[(31, 0x84)] == 1.5 and store.data[(31, 0x86)] == -3.0
    assert client.status.ok and client.status.flags & DisplayWord.WRITE


def test_repeated_image_is_one_telegram() -> None:
    store = Store()
    server = ChannelServer(store)
    start = StartRequest(DataFormat.INTEGER, 0x0400, 0, 0, 2).encode()
    server.exchange(start, 0)
    val = encode_value(DataFormat.INTEGER, 7, ByteOrder.MOTOROLA)
    for _ in range(3):  # the same data telegram seen in three bus cycles
        server.exchange(bytes((0x68, 1, 0, 0)) + val, 0)
    server.exchange(bytes((0x68, 2, 0, 0)) + val, 0)
    assert end_result(server.exchange(bytes((0x16,)) + bytes(7), 0)) == 0
    assert store.writes == [(0x0400, [7, 7])]


def test_end_before_all_values_is_invalid_value_and_writes_nothing() -> None:
    store = Store()
    server = ChannelServer(store)
    server.exchange(StartRequest(DataFormat.INTEGER, 0x0400, 0, 0, 2).encode(), 0)
    server.exchange(bytes((0x68, 1, 0, 0, 0, 0, 0, 1)), 0)
    assert end_result(server.exchange(bytes((0x16,)) + bytes(7), 0)) == Result.INVALID_VALUE
    assert store.writes == []


@pytest.mark.parametrize(
    ("start", "result"),
    [
        (StartRequest(DataFormat.INTEGER, 0x0400, 0, 1, 1), Result.INVALID_VALUE),  # both counts
        (StartRequest(DataFormat.INTEGER, 0x0400, 0, 0, 0), Result.INVALID_VALUE),  # nothing
        (StartRequest(DataFormat.INTEGER, 0x0400, 200, 0, 0), Result.BUFFER_OVERFLOW),
        (StartRequest(DataFormat.INTEGER, 0x05FF, 2, 0, 0), Result.BAD_ADDRESS),  # past area end
        (StartRequest(DataFormat.REAL, 0x0400, 0, 0, 1), Result.INVALID_VALUE),  # wrong count kind
    ],
)
def test_refused_starts_end_with_the_result(start: StartRequest, result: Result) -> None:
    server = ChannelServer(Store(), max_block=128)
    answer = server.exchange(start.encode(), 0)
    assert (answer[0] == 0x10 and answer[6] == 0 and answer[7] == 0) or start.is_write
    assert end_result(server.exchange(bytes((0x16,)) + bytes(7), 0)) == result


def test_client_reports_bad_address_through_display_word() -> None:
    client = ChannelClient()
    client.start_read(DataFormat.INTEGER, 0x05FF, 2, 0.0)
    run(client, ChannelServer(Store()))
    assert client.result == Result.BAD_ADDRESS
    assert client.status.flags & DisplayWord.DONE_ERROR
    assert client.status.result == 2
    assert "bad address" in client.status.describe()


def test_client_times_out_without_answers() -> None:
    client = ChannelClient(timeout=1.0)
    client.start_read(DataFormat.INTEGER, 0x0400, 1, 0.0)
    client.feed(bytes(8), 0.5)
    assert client.status.running
    client.feed(bytes(8), 1.5)
    assert client.status.flags & DisplayWord.TIMEOUT
    assert client.result is None


def test_server_drops_a_stale_job() -> None:
    store = Store()
    server = ChannelServer(store, timeout=2.0)
    server.exchange(StartRequest(DataFormat.INTEGER, 0x0400, 0, 0, 1).encode(), 0.0)
    server.exchange(bytes((0x68, 1, 0, 0, 0, 0, 0, 9)), 0.5)
    # the master vanished for longer than the timeout; a late end finds no job
    assert end_result(server.exchange(bytes((0x16,)) + bytes(7), 5.0)) == Result.INVALID_VALUE
    assert store.writes == []


@pytest.mark.parametrize("order", list(ByteOrder))
def test_byte_orders(order: ByteOrder) -> None:
    real = encode_value(DataFormat.REAL, 1.0, order)
    integer = encode_value(DataFormat.INTEGER, 0x1234, order)
    if order is ByteOrder.MOTOROLA:
        assert real == bytes.fromhex("3F800000") and integer == bytes.fromhex("00001234")
    else:
        assert real == bytes.fromhex("0000803F") and integer == bytes.fromhex("00003412")


def test_char_formats() -> None:
    assert encode_value(DataFormat.CHAR, ord("A"), ByteOrder.INTEL) == b"\x00A\x00\x00"
    assert encode_value(DataFormat.COMPACT_CHAR, b"AB", ByteOrder.INTEL) == b"AB\x00\x00"
    assert decode_value(DataFormat.COMPACT_CHAR, b"KS V", ByteOrder.MOTOROLA) == b"KS V"
    with pytest.raises(ConfigError):
        encode_value(DataFormat.CHAR, 300, ByteOrder.MOTOROLA)
    with pytest.raises(ConfigError):
        encode_value(DataFormat.COMPACT_CHAR, b"too long", ByteOrder.MOTOROLA)


@settings(max_examples=100)
@given(
    st.sampled_from(list(DataFormat)),
    st.sampled_from(list(ByteOrder)),
    st.data(),
)
def test_value_codec_round_trip(fmt: DataFormat, order: ByteOrder, data: st.DataObject) -> None:
    value: Value
    if fmt.is_real:
        value = data.draw(st.floats(width=32, allow_nan=False))
    elif fmt is DataFormat.INTEGER:
        value = data.draw(st.integers(-0x8000, 0x7FFF))
    elif fmt is DataFormat.CHAR:
        value = data.draw(st.integers(0, 255))
    else:
        value = data.draw(st.binary(min_size=4, max_size=4))
    assert decode_value(fmt, encode_value(fmt, value, order), order) == value


@settings(max_examples=30)
@given(
    st.lists(st.integers(-0x8000, 0x7FFF), min_size=1, max_size=20),
    st.sampled_from(list(ByteOrder)),
)
def test_any_integer_block_written_is_read_back(values: list[int], order: ByteOrder) -> None:
    store = Store()
    server = ChannelServer(store, byte_order=order)
    w = ChannelClient(byte_order=order)
    w.start_write(DataFormat.INTEGER, 0x0600, values, 0.0)
    run(w, server, 200)
    r = ChannelClient(byte_order=order)
    r.start_read(DataFormat.INTEGER, 0x0600, len(values), 0.0)
    run(r, server, 200)
    assert r.values == values


def test_client_refuses_bad_jobs() -> None:
    client = ChannelClient()
    with pytest.raises(ConfigError):
        client.start_read(DataFormat.INTEGER, 0x400, 0, 0.0)
    with pytest.raises(ConfigError):
        client.start_write(DataFormat.INTEGER, 0x400, [70000], 0.0)
    client.start_read(DataFormat.INTEGER, 0x400, 1, 0.0)
    with pytest.raises(ConfigError, match="still running"):
        client.start_read(DataFormat.INTEGER, 0x400, 1, 0.0)


def test_real_format_3_is_a_real_job() -> None:
    """ID1 = 3 is the second real format (4.1): Cnt.Real counts it, values are 4-byte floats."""
    start = StartRequest(DataFormat.REAL3, 0x8CD2, 0, 2, 0)
    assert start.encode() == _hex("10 03 00 8C D2 00 02 00")
    store = Store()
    server = ChannelServer(store)
    w = ChannelClient()
    w.start_write(DataFormat.REAL3, 0x8CD2, [2.5, -1.25], 0.0)
    trace = run(w, server)
    assert trace[0][0] == start.encode()
    assert trace[1][0] == _hex("68 01 00 00 40 20 00 00")  # 2.5, Motorola
    r = ChannelClient()
    r.start_read(DataFormat.REAL3, 0x8CD2, 2, 0.0)
    trace = run(r, server)
    assert trace[0][1][6:8] == bytes((2, 0))  # the counts come back as Cnt.Real
    assert r.values == [2.5, -1.25]


def test_count_echo_is_the_flow_control() -> None:
    """4.3/4.4: the next data telegram goes out only once the coupler mirrored the Count of the
    last one. With answers that arrive one bus cycle late (the master sees each answer again in
    the next cycle), a stale echo of Count k-1 must not count as the answer to Count k."""
    store = Store()
    for k, v in enumerate((11, 22, 33)):
        store.data[(2, k)] = v
    server = ChannelServer(store)
    client = ChannelClient()
    client.start_read(DataFormat.INTEGER, 0x0400, 3, 0.0)
    late = bytes(8)
    sent: list[bytes] = []
    for cycle in range(100):
        req = client.request()
        sent.append(req)
        answer = server.exchange(req, cycle * 0.01)
        client.feed(late, cycle * 0.01)
        late = answer
        if client.status.done:
            break
    assert client.values == [11, 22, 33]
    data_counts = [r[1] for r in sent if r[0] == TelegramId.DATA]
    assert sorted(set(data_counts)) == [1, 2, 3]
    assert data_counts == sorted(data_counts)


def test_display_word_follows_the_job() -> None:
    """ANZW (8.1): running and waiting for the acknowledgement, then waiting for the end
    telegram, then done; the write bit while a write runs; bit 4 after a reset."""
    server = ChannelServer(Store())
    client = ChannelClient()
    client.start_write(DataFormat.INTEGER, 0x0400, [1, 2], 0.0)
    seen = []
    for cycle in range(20):
        seen.append(client.status.word)
        client.feed(server.exchange(client.request(), cycle), cycle)
        if client.status.done:
            break
    running = DisplayWord.RUNNING | DisplayWord.WRITE
    assert seen[0] == running | DisplayWord.WAIT_ACK
    assert running | DisplayWord.WAIT_END in seen
    assert client.status.word == DisplayWord.DONE_OK | DisplayWord.WRITE
    assert client.status.describe() == "ANZW 0022h: done_ok, write; result 0 (OK)"
    client.start_read(DataFormat.INTEGER, 0x0400, 1, 0.0)
    client.reset()
    assert client.status.word == DisplayWord.RESET and not client.busy
    assert client.request() == _hex("16 00 00 00 00 00 00 00")


def test_unknown_data_format_is_a_wrong_service() -> None:
    """ANZW bit 14 (8.1): a job with a data format the channel does not know ends at once."""
    client = ChannelClient()
    with pytest.raises(ConfigError, match="service wrong"):
        client.start_read(7, 0x0400, 1, 0.0)  # type: ignore[arg-type]
    assert client.status.word == DisplayWord.WRONG_SERVICE | DisplayWord.DONE_ERROR
    assert client.status.done and not client.status.ok and not client.busy
    assert "wrong_service" in client.status.describe()
    client.start_read(DataFormat.INTEGER, 0x0400, 1, 0.0)  # the channel is free again
    with pytest.raises(ConfigError, match="service wrong"):
        client.start_write(9, 0x0400, [1], 0.0)  # type: ignore[arg-type]
    assert client.status.running  # a running job keeps its display word
