"""Simulated coupler and in-process master: the four worked examples of KS VARIO interface
description 4.5 end to
end, the three views, caches per selection, multiplexers over the image, A.7, fail-safe."""

from __future__ import annotations

import math
import struct
from typing import Any

import pytest

from pyuss.errors import ConfigError, UssTimeout
from pyuss.ksvario.address import Address, View
from pyuss.ksvario.channel import ByteOrder, DataFormat, DisplayWord, Result
from pyuss.ksvario.coupler import CacheSelection, Coupler, ForceKind
from pyuss.ksvario.errors import ChannelResultError
from pyuss.ksvario.master import CyclicLink, KsVarioMaster, LocalLink
from pyuss.ksvario.modules import Configuration
from pyuss.ksvario.userprm import FailSafe, UserParameters
from support.paths import load_vectors

VECTORS = load_vectors("ksvario")


def make(modules: str = "A.1,A.4", **kw: object) -> tuple[Coupler, KsVarioMaster]:
    coupler = Coupler(**kw)  # type: ignore[arg-type]
    conf = Configuration(modules.split(","))
    coupler.configure(conf)
    return coupler, KsVarioMaster(LocalLink(coupler), conf, byte_order=coupler.user.byte_order)


async def test_example_1_read_pb1_fixpoint1() -> None:
    coupler, master = make()
    coupler.set(Address.channel(1, 0x96), 123.4)
    assert await master.read(0x4496) == [1234]
    assert master.status.word == DisplayWord.DONE_OK


async def test_example_2_read_four_reals_of_channel_2() -> None:
    coupler, master = make()
    for k, v in enumerate((10.5, 950.0, 42.25, -7.0)):
        coupler.set(Address.channel(2, 0x69 + k), v)
    assert await master.read(0x8CD2, 4) == [10.5, 950.0, 42.25, -7.0]


async def test_example_3_write_td1_of_channel_30_integer() -> None:
    coupler, master = make()
    await master.write(0x3E9A, [45])
    assert coupler.get(Address.channel(30, 0x9A)) == 45.0


async def test_example_4_write_three_reals_at_fd09() -> None:
    coupler, master = make()
    await master.write(0xFD09, [1.5, 99.0, 0.25])
    assert [coupler.get(Address.channel(30, d)) for d in (0x84, 0x85, 0x86)] == [1.5, 99.0, 0.25]


@pytest.mark.parametrize("order", list(ByteOrder))
async def test_intel_order_from_user_parameters(order: ByteOrder) -> None:
    coupler, master = make(user=UserParameters(byte_order=order))
    coupler.set(Address.channel(2, 0x69), 3.25)
    assert await master.read(0x8CD2) == [3.25]


async def test_three_views_of_one_datum() -> None:
    _coupler, master = make()
    await master.write(Address.channel(5, 0x10, View.FLOAT), [12.34])
    assert await master.read(Address.channel(5, 0x10, View.INTEGER)) == [12]
    assert await master.read(Address.channel(5, 0x10, View.FIXPOINT1)) == [123]
    await master.write(Address.channel(5, 0x10, View.FIXPOINT1), [-55])
    [value] = await master.read(Address.channel(5, 0x10, View.FLOAT))
    assert math.isclose(float(value), -5.5)
    # a float address read with the integer format is turned into the integer view (4.1)
    assert await master.read(Address.channel(5, 0x10, View.FLOAT), fmt=DataFormat.INTEGER) == [-6]


async def test_char_and_compact_char() -> None:
    _coupler, master = make()
    await master.write(0x0010, [b"KS V", b"ARIO"], fmt=DataFormat.COMPACT_CHAR)
    assert await master.read(0x0010, 8, fmt=DataFormat.CHAR) == [ord(c) for c in "KS VARIO"]
    assert await master.read(0x0010, 2, fmt=DataFormat.COMPACT_CHAR) == [b"KS V", b"ARIO"]


async def test_results_reach_the_user() -> None:
    coupler, master = make(channels=4)
    with pytest.raises(ChannelResultError) as err:
        await master.read(Address.channel(30, 1))
    assert err.value.result == Result.BAD_ADDRESS
    coupler.set_limits(Address.channel(1, 0x96), 0.1, 999.9)
    with pytest.raises(ChannelResultError) as err:
        await master.write(Address.channel(1, 0x96, View.FLOAT), [5000.0])
    assert err.value.result == Result.INVALID_VALUE
    with pytest.raises(ChannelResultError) as err:
        await master.read(0x0400, 200)
    assert err.value.result == Result.BUFFER_OVERFLOW
    assert master.status.result == 4


async def test_timeout_without_a_coupler_answer() -> None:
    class Dead:
        async def exchange(self, outputs: bytes) -> bytes:
            return bytes(8)

    now = [0.0]

    def clock() -> float:
        now[0] += 0.5
        return now[0]

    master = KsVarioMaster(Dead(), Configuration(["A.1"]), timeout=2.0, clock=clock)
    with pytest.raises(UssTimeout):
        await master.read(0x4496)
    assert master.status.flags & DisplayWord.TIMEOUT


def test_selection_lays_out_the_caches() -> None:
    sel = CacheSelection(free_read=((1, 5), (2, 6)), per_channel_read=(1, 2), channels=3)
    entries = sel.read_entries()
    assert [(a.channel_number, a.datum) for a in entries] == [
        (1, 5),
        (2, 6),
        (1, 1),
        (1, 2),
        (2, 1),
        (2, 2),
        (3, 1),
        (3, 2),
    ]
    assert len(CacheSelection(per_channel_read=tuple(range(32))).read_entries()) == 960
    with pytest.raises(ConfigError):
        CacheSelection(free_read=((1, 1),) * 121)
    with pytest.raises(ConfigError, match="32 data per channel"):
        CacheSelection(per_channel_write=tuple(range(33)))
    full = CacheSelection(free_read=((1, 1),) * 120, per_channel_read=tuple(range(32)))
    assert len(full.read_entries()) == 1080


async def test_whole_cache_through_variable_multiplexer() -> None:
    sel = CacheSelection(
        free_read=tuple((1, d) for d in range(120)),
        per_channel_read=tuple(range(200, 232)),
        free_write=tuple((2, d) for d in range(120)),
        per_channel_write=tuple(range(300, 332)),
    )
    coupler, master = make("A.1,A.2,B.5,B.5,B.10,B.10", selection=sel)
    for i, a in enumerate(sel.read_entries()):
        coupler.set(a, (i % 3000) / 10)
    words = await master.read_cache(1, 1080)
    assert words == [i % 3000 for i in range(1080)]
    new = [(7 * i) % 30000 for i in range(1080)]
    await master.write_cache(1, new)
    for i, a in enumerate(sel.write_entries()):
        assert coupler.view_word(a) == new[i]


async def test_whole_cache_through_fixed_multiplexer() -> None:
    sel = CacheSelection(
        free_read=tuple((1, d) for d in range(300, 420)),
        free_write=tuple((2, d) for d in range(300, 420)),
        per_channel_read=tuple(range(32)),
        per_channel_write=tuple(range(32, 64)),
    )
    coupler, master = make("A.6", selection=sel)
    for i, a in enumerate(sel.read_entries()):
        coupler.set(a, i / 10)
    assert await master.read_cache(1, 1080) == list(range(1080))
    await master.write_cache(1, list(range(1080, 0, -1)))
    assert [coupler.view_word(a) for a in sel.write_entries()] == list(range(1080, 0, -1))


async def test_direct_io_modules_map_to_the_caches_in_order() -> None:
    sel = CacheSelection(free_read=((1, 0x01), (2, 0x01)), free_write=((1, 0x10), (2, 0x10)))
    coupler, master = make("B.1,B.1,B.7", selection=sel)
    coupler.set(Address.channel(1, 0x01), 20.5)
    coupler.set(Address.channel(2, 0x01), -1.0)
    master.outputs[:] = bytes.fromhex("0064 00C8")  # 10.0 and 20.0 in FixPoint1
    inputs = await master.cycle()
    assert inputs == bytes.fromhex("00CD FFF6")
    assert coupler.get(Address.channel(1, 0x10)) == 10.0
    assert coupler.get(Address.channel(2, 0x10)) == 20.0


async def test_values_are_taken_only_when_they_change() -> None:
    sel = CacheSelection(free_write=((1, 0x10),))
    coupler, master = make("B.6", selection=sel)
    master.outputs[:] = bytes.fromhex("0064")
    await master.cycle()
    coupler.set(Address.channel(1, 0x10), 77.0)  # changed locally (front panel)
    await master.cycle()
    assert coupler.get(Address.channel(1, 0x10)) == 77.0  # same bus value: not taken again
    master.outputs[:] = bytes.fromhex("0065")
    await master.cycle()
    assert coupler.get(Address.channel(1, 0x10)) == 10.1


async def test_a7_gates_output_transfer() -> None:
    sel = CacheSelection(free_write=((1, 0x10),))
    coupler, master = make("A.7,B.6", selection=sel)
    master.outputs[:] = bytes.fromhex("00 0064")
    await master.cycle()
    assert coupler.get(Address.channel(1, 0x10)) == 0.0
    master.outputs[:] = bytes.fromhex("01 0064")  # 0 -> 1 edge
    await master.cycle()
    assert coupler.get(Address.channel(1, 0x10)) == 10.0


@pytest.mark.parametrize("fail_safe", list(FailSafe))
def test_fail_safe(fail_safe: FailSafe) -> None:
    coupler = Coupler(user=UserParameters(fail_safe=fail_safe))
    ain, din, out = Address.channel(1, 1), Address.channel(1, 2), Address.channel(1, 3)
    for a, kind in (
        (ain, ForceKind.ANALOG_INPUT),
        (din, ForceKind.DIGITAL_INPUT),
        (out, ForceKind.OUTPUT),
    ):
        coupler.force(a, kind)
        coupler.set(a, 5.0)
    coupler.bus_failure()
    assert coupler.device_diagnosis().inputs  # forced analogue input is FAIL in both modes
    expect = 0.0 if fail_safe is FailSafe.ZERO else 5.0
    assert coupler.get(din) == expect and coupler.get(out) == expect


class Recorder:
    """A link that keeps every (output image, input image) pair of the bus cycles."""

    def __init__(self, link: CyclicLink) -> None:
        self.link = link
        self.cycles: list[tuple[bytes, bytes]] = []

    async def exchange(self, outputs: bytes) -> bytes:
        inputs = await self.link.exchange(outputs)
        self.cycles.append((outputs, inputs))
        return inputs


def _pattern(text: str, data: bytes) -> bool:
    return all(p.lower() == "xx" or int(p, 16) == data[i] for i, p in enumerate(text.split()))


#: The four worked examples of KS VARIO interface description 4.5: datum, channel, values the
#: coupler holds or gets.
EXAMPLES: dict[str, dict[str, Any]] = {
    "4.5.1": {"channel": 1, "datum": 0x96, "held": [123.4], "read": [1234]},
    "4.5.2": {"channel": 2, "datum": 0x69, "held": [10.5, 950.0, 42.25, -7.0]},
    "4.5.3": {"channel": 30, "datum": 0x9A, "write": [45]},
    "4.5.4": {"channel": 30, "datum": 0x84, "write": [1.5, 99.0, 0.25]},
}


@pytest.mark.parametrize("vec", VECTORS["start_telegrams"], ids=lambda v: v["section"])
async def test_worked_example_end_to_end(vec: dict[str, str]) -> None:
    """KS VARIO interface description 4.5.1 - 4.5.4 on the cyclic image of a simulated coupler
    (module A.1): the
    start telegram of the vector and its answer, data telegrams with Count 1..n mirrored for
    flow control, the end telegram with result 0, and the data where the example puts them."""
    ex = EXAMPLES[vec["section"]]
    coupler = Coupler()
    conf = Configuration(["A.1"])
    coupler.configure(conf)
    link = Recorder(LocalLink(coupler))
    master = KsVarioMaster(link, conf)
    master_start = bytes.fromhex(vec["master"])
    address = (master_start[3] << 8) | master_start[4]
    for k, value in enumerate(ex.get("held", [])):
        coupler.set(Address.channel(ex["channel"], ex["datum"] + k), value)
    written = ex.get("write")
    if written is None:
        values = await master.read(address, master_start[2])
    else:
        await master.write(address, written)
    telegrams = []  # each distinct (request, answer) pair once, in order
    for pair in link.cycles:
        if not telegrams or telegrams[-1] != pair:
            telegrams.append(pair)
    start, *data, end = telegrams
    assert start[0] == master_start
    assert _pattern(vec["device"], start[1])
    n = len(written) if written is not None else master_start[2]
    assert [(r[0], r[1], a[0], a[1]) for r, a in data] == [
        (0x68, k, 0x68, k) for k in range(1, n + 1)
    ]
    assert end[0] == bytes.fromhex("16 00 00 00 00 00 00 00")
    assert end[1][0] == 0x16 and end[1][2] == 0  # result 0
    is_real = master_start[1] in (1, 3)
    if written is None:
        held = [struct.unpack(">f", struct.pack(">f", v))[0] for v in ex["held"]]
        assert values == ex.get("read", held)
        carried = [a[4:8] for _, a in data]
    else:
        stored = [coupler.get(Address.channel(ex["channel"], ex["datum"] + k)) for k in range(n)]
        assert stored == [float(v) for v in written]
        carried = [r[4:8] for r, _ in data]
    expect = values if written is None else written
    for field, value in zip(carried, expect, strict=True):
        if is_real:
            assert field == struct.pack(">f", value)
        else:
            assert field == bytes(2) + struct.pack(">h", value)


async def test_real3_and_char_write_through_the_coupler() -> None:
    """ID1 3 reads reals like ID1 1 (4.1); a char write (ID1 2) lands as character codes."""
    coupler, master = make()
    coupler.set(Address.channel(1, 0x96), 2.5)
    assert await master.read(0x4496, fmt=DataFormat.REAL3) == [2.5]
    await master.write(0x0020, [ord("K"), ord("S")], fmt=DataFormat.CHAR)
    assert await master.read(0x0020, 1, fmt=DataFormat.COMPACT_CHAR) == [b"KS\x00\x00"]


@pytest.mark.parametrize("key", ["A.3", "A.4", "A.5"])
async def test_whole_cache_through_each_fixed_multiplexer(key: str) -> None:
    """A.3, A.4, A.5 carry 1, 4, 8 data per message (3.5); A.6 has its own test above."""
    sel = CacheSelection(
        free_read=tuple((1, d) for d in range(120)),
        free_write=tuple((2, d) for d in range(120)),
        per_channel_read=tuple(range(200, 232)),
        per_channel_write=tuple(range(300, 332)),
    )
    coupler, master = make(f"A.1,{key}", selection=sel)
    for i, a in enumerate(sel.read_entries()):
        coupler.set(a, i / 10)
    assert await master.read_cache(1, 1080) == list(range(1080))
    await master.write_cache(1, [3 * i for i in range(1080)])
    assert [coupler.view_word(a) for a in sel.write_entries()] == [3 * i for i in range(1080)]


async def test_coupler_that_shows_index_0_first() -> None:
    """3.4.2: a coupler that cannot send data and Index_Read consistently answers a new index
    with 0 first; the master takes the data only under the index it asked for."""
    sel = CacheSelection(per_channel_read=tuple(range(32)), channels=30)
    coupler, master = make("A.1,A.2,B.5,B.5", selection=sel, consistent_mux=False)
    for i, a in enumerate(sel.read_entries()):
        coupler.set(a, i / 10)
    link = Recorder(master.link)
    master.link = link
    assert await master.read_cache(1, 960) == list(range(960))
    index_in = [int.from_bytes(inp[8:10], "big") for _, inp in link.cycles]
    assert 0 in index_in and index_in[-1] != 0


async def test_forced_input_is_written_from_the_bus() -> None:
    """2.3: a physical input is read-only to the bus until it is forced; then the parameter
    channel and the write cache both write it."""
    sel = CacheSelection(free_write=((1, 0x01),))
    coupler, master = make("A.1,B.6", selection=sel)
    x1 = Address.channel(1, 0x01)
    coupler.set_limits(x1, writable=False)
    with pytest.raises(ChannelResultError) as err:
        await master.write(x1.as_view(View.FLOAT), [55.5])
    assert err.value.result == Result.INVALID_VALUE
    coupler.force(x1, ForceKind.ANALOG_INPUT)
    await master.write(x1.as_view(View.FLOAT), [55.5])
    assert coupler.get(x1) == 55.5
    master.outputs[8:10] = bytes.fromhex("00C8")  # 20.0 in FixPoint1 through B.6
    await master.cycle()
    assert coupler.get(x1) == 20.0
