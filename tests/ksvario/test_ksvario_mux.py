"""Multiplexer modules (KS VARIO interface description 3.4, 3.5): handshake, out-of-range 0,
whole-cache transfers."""

from __future__ import annotations

import pytest

from pyuss.errors import ConfigError
from pyuss.ksvario.mux import (
    CACHE_SIZE,
    FIXED_SIZES,
    CachePair,
    MuxClient,
    MuxIn,
    MuxOut,
    MuxServer,
    decode_fixed,
    encode_fixed,
)


def test_write_is_taken_and_index_mirrored() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=4, write_count=4)
    answer = server.exchange(MuxOut(0, 10, (1, 2, 3, 4)))
    assert answer.index_write == 10
    assert caches.write.read(10, 4) == [1, 2, 3, 4]


def test_index_write_zero_means_data_not_consistent_yet() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=0, write_count=2)
    answer = server.exchange(MuxOut(0, 0, (7, 7)))
    assert answer.index_write == 0
    assert caches.write.read(1, 2) == [0, 0]


def test_read_fills_data_and_mirrors_index() -> None:
    caches = CachePair()
    caches.read.write(100, [11, 12, 13])
    server = MuxServer(caches, read_count=3, write_count=0)
    assert server.exchange(MuxOut(100, 0)) == MuxIn(100, 0, (11, 12, 13))


@pytest.mark.parametrize("index", [1080, 2000, 0xFFFF])
def test_block_outside_1080_is_answered_with_0(index: int) -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=2, write_count=2)
    answer = server.exchange(MuxOut(index, index, (5, 5)))
    assert (answer.index_read, answer.index_write) == (0, 0)
    assert answer.data == (0, 0)
    assert 5 not in caches.write.words


def test_last_block_inside_is_accepted() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=2, write_count=2)
    assert server.exchange(MuxOut(1079, 1079, (5, 6))).index_write == 1079
    assert caches.write.words[-2:] == [5, 6]


def test_data_keep_being_taken_while_the_index_stays() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=0, write_count=1)
    server.exchange(MuxOut(0, 5, (1,)))
    server.exchange(MuxOut(0, 5, (2,)))
    assert caches.write.read(5, 1) == [2]


def drive(client: MuxClient, server: MuxServer, limit: int = 5000) -> int:
    cycles = 0
    while not client.done:
        client.feed(server.exchange(client.request()))
        cycles += 1
        assert cycles < limit
    return cycles


@pytest.mark.parametrize("n", FIXED_SIZES)
def test_whole_cache_read_and_write_with_fixed_multiplexers(n: int) -> None:
    caches = CachePair()
    caches.read.write(1, [(i * 7) & 0xFFFF for i in range(1, CACHE_SIZE + 1)])
    server = MuxServer(caches, read_count=n, write_count=n)
    words = [(i * 13 + 1) & 0xFFFF for i in range(CACHE_SIZE)]
    client = MuxClient(
        read_per=n, write_per=n, read_range=(1, CACHE_SIZE), write_first=1, write_words=words
    )
    drive(client, server)
    assert client.read_words == caches.read.words
    assert caches.write.words == words


def test_non_consistent_master_sends_zero_first() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=0, write_count=4)
    client = MuxClient(
        read_per=0, write_per=4, write_first=20, write_words=range(8), consistent=False
    )
    sent = []
    while not client.done:
        out = client.request()
        sent.append(out.index_write)
        client.feed(server.exchange(out))
    assert sent[:4] == [0, 20, 0, 24]
    assert caches.write.read(20, 8) == list(range(8))


def test_partial_range_overlaps_instead_of_running_past() -> None:
    caches = CachePair()
    server = MuxServer(caches, read_count=0, write_count=4)
    client = MuxClient(read_per=0, write_per=4, write_first=1, write_words=[1, 2, 3, 4, 5, 6])
    drive(client, server)
    assert caches.write.read(1, 7) == [1, 2, 3, 4, 5, 6, 0]


def test_client_refuses_ranges_outside_the_cache() -> None:
    with pytest.raises(ConfigError):
        MuxClient(read_per=4, write_per=4, read_range=(1000, 1100))
    with pytest.raises(ConfigError):
        MuxClient(read_per=4, write_per=4, write_first=1079, write_words=[1, 2, 3, 4])


def test_fixed_module_bytes() -> None:
    raw = encode_fixed(3, 4, [0x1234])
    assert raw == bytes.fromhex("0003 0004 1234")
    assert decode_fixed(raw) == (3, 4, (0x1234,))


def test_master_takes_no_data_under_index_read_0() -> None:
    """3.4.2: Index_Read 0 in IndexIN means the data are not valid yet; the master waits for
    the index it asked for."""
    client = MuxClient(read_per=2, write_per=0, read_range=(7, 8))
    assert client.request().index_read == 7
    client.feed(MuxIn(0, 0, (999, 999)))  # half-updated data, index not confirmed yet
    assert not client.done and client.read_words == []
    client.feed(MuxIn(7, 0, (70, 80)))
    assert client.done and client.read_words == [70, 80]


def test_inconsistent_coupler_answers_a_new_read_index_with_0_first() -> None:
    caches = CachePair()
    caches.read.write(1, [1, 2, 3, 4, 5, 6])
    server = MuxServer(caches, read_count=2, write_count=0, consistent=False)
    assert server.exchange(MuxOut(1, 0)) == MuxIn(0, 0, (1, 2))
    assert server.exchange(MuxOut(1, 0)) == MuxIn(1, 0, (1, 2))
    assert server.exchange(MuxOut(5, 0)).index_read == 0
    assert server.exchange(MuxOut(5, 0)) == MuxIn(5, 0, (5, 6))


@pytest.mark.parametrize("n", FIXED_SIZES)
def test_whole_cache_against_an_inconsistent_coupler(n: int) -> None:
    caches = CachePair()
    caches.read.write(1, [(i * 5) & 0xFFFF for i in range(1, CACHE_SIZE + 1)])
    server = MuxServer(caches, read_count=n, write_count=n, consistent=False)
    client = MuxClient(read_per=n, write_per=n, read_range=(1, CACHE_SIZE))
    drive(client, server)
    assert client.read_words == caches.read.words
