"""Net data layout (C 3.1, C 4.1, C 7; reading 5, 6): validation, parsing, word placement,
round trips for every layout."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError, TelegramError
from pyuss.protocol.layout import MAX_WORDS, PKW_VARIABLE, Layout, NetData
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram

ALL_LAYOUTS = [Layout(pkw, pzd) for pkw in (0, 3, 4, PKW_VARIABLE) for pzd in range(17)]


@pytest.mark.parametrize(
    ("text", "layout"),
    [
        ("3,2", Layout(3, 2)),
        ("v,2", Layout(PKW_VARIABLE, 2)),
        ("4,0", Layout(4, 0)),
        (" 0 , 16 ", Layout(0, 16)),
        ("var,0", Layout(PKW_VARIABLE, 0)),
        ("127,4", Layout(PKW_VARIABLE, 4)),
        ("V,1", Layout(PKW_VARIABLE, 1)),
    ],
)
def test_parse(text: str, layout: Layout) -> None:
    assert Layout.parse(text) == layout


@pytest.mark.parametrize("text", ["3", "3,2,1", "x,2", "2,2", "3,17", "3,-1", "", "3;2", "3,a"])
def test_parse_refuses_with_a_clear_message(text: str) -> None:
    with pytest.raises(ConfigError, match=r"layout|PKW|PZD"):
        Layout.parse(text)


@pytest.mark.parametrize(("pkw", "pzd"), [(1, 2), (5, 0), (128, 0), (3, 17), (3, -1), (True, 1)])
def test_invalid_layouts(pkw: int, pzd: int) -> None:
    with pytest.raises(ConfigError):
        Layout(pkw, pzd)


def test_str_and_properties() -> None:
    assert str(Layout(3, 2)) == "3,2"
    assert str(Layout(PKW_VARIABLE, 2)) == "v,2"
    assert Layout(3, 2).lge == 12
    assert Layout(3, 2).words == 5
    assert Layout(PKW_VARIABLE, 2).lge is None
    assert Layout(PKW_VARIABLE, 16).max_pwe == 108  # C 4.1.2
    assert Layout(PKW_VARIABLE, 0).max_pwe == 124  # C 4.1.2
    assert Layout(4, 2).max_pwe == 2
    assert Layout(0, 2).max_pwe == 0


def test_word_placement() -> None:
    job = Pkw(2, 18, values=(0x7000,))
    assert Layout(3, 0).pack(job, []) == bytes.fromhex("2012 0000 7000")
    assert Layout(4, 0).pack(job, []) == bytes.fromhex("2012 0000 0000 7000")  # PWE2
    assert Layout(PKW_VARIABLE, 0).pack(job, []) == bytes.fromhex("2012 0000 7000")  # PWE1
    dword = Pkw(3, 18, values=(0x1234, 0x5678))
    assert Layout(4, 0).pack(dword, []) == bytes.fromhex("3012 0000 1234 5678")
    assert Layout(PKW_VARIABLE, 0).pack(dword, []) == bytes.fromhex("3012 0000 1234 5678")


def test_empty_pwe_is_filled_to_the_minimum() -> None:
    assert Layout(3, 0).pack(Pkw(1, 5), []) == bytes.fromhex("1005 0000 0000")
    assert Layout(4, 0).pack(Pkw(1, 5), []) == bytes.fromhex("1005 0000 0000 0000")
    assert Layout(PKW_VARIABLE, 0).pack(Pkw(1, 5), []) == bytes.fromhex("1005 0000 0000")


def test_no_pkw_given_sends_no_job() -> None:
    assert Layout(3, 1).pack(None, [0x047E]) == bytes.fromhex("0000 0000 0000 047E")


def test_what_does_not_fit_is_refused_when_packing() -> None:
    with pytest.raises(ConfigError, match="PKW 3 holds one word"):
        Layout(3, 2).pack(Pkw(3, 1, values=(1, 2)), [0, 0])
    with pytest.raises(ConfigError, match="PKW 4 holds two words"):
        Layout(4, 2).pack(Pkw(15, 1, values=(1, 2, 3)), [0, 0])
    with pytest.raises(ConfigError, match="at most 108"):
        Layout(PKW_VARIABLE, 16).pack(Pkw(15, 1, values=(0,) * 109), [0] * 16)
    with pytest.raises(ConfigError, match="no PKW area"):
        Layout(0, 2).pack(Pkw(1, 1), [0, 0])
    with pytest.raises(ConfigError, match="carries 2 PZD words, got 1"):
        Layout(0, 2).pack(None, [0])
    with pytest.raises(ConfigError, match="PZD2 must be a 16-bit word"):
        Layout(0, 2).pack(None, [0, 0x10000])


def test_variable_layout_takes_the_longest_pkw_area() -> None:
    data = Layout(PKW_VARIABLE, 16).pack(Pkw(15, 1, values=(0,) * 108), [0] * 16)
    assert len(data) == 2 * MAX_WORDS
    assert Layout(PKW_VARIABLE, 16).unpack(data).pkw == Pkw(15, 1, values=(0,) * 108)


def test_what_does_not_fit_is_refused_when_unpacking() -> None:
    with pytest.raises(TelegramError, match="not whole words"):
        Layout(3, 2).unpack(bytes(9))
    with pytest.raises(TelegramError, match="it needs 5"):
        Layout(3, 2).unpack(bytes(12))
    with pytest.raises(TelegramError, match=r"needs 5\.\.126"):
        Layout(PKW_VARIABLE, 2).unpack(bytes(8))  # PKE and IND without PWE


def test_unpack_zero_pkw() -> None:
    assert Layout(0, 2).unpack(bytes.fromhex("047F2000")) == NetData(None, (0x047F, 0x2000))
    assert Layout(0, 0).unpack(b"") == NetData(None, ())


def _word_count(layout: Layout) -> st.SearchStrategy[int]:
    if layout.variable:
        return st.integers(layout.pzd + 3, MAX_WORDS)
    return st.just(layout.pkw + layout.pzd)


@st.composite
def net_bytes(draw: st.DrawFn) -> tuple[Layout, bytes]:
    layout = draw(st.sampled_from(ALL_LAYOUTS))
    count = draw(_word_count(layout))
    return layout, draw(st.binary(min_size=2 * count, max_size=2 * count))


@given(net_bytes())
@settings(max_examples=300)
def test_bytes_round_trip_for_every_layout(case: tuple[Layout, bytes]) -> None:
    layout, data = case
    net = layout.unpack(data)
    assert len(net.pzd) == layout.pzd
    assert (net.pkw is None) == (layout.pkw == 0)
    assert layout.pack(net.pkw, net.pzd) == data
    assert layout.unpack(layout.pack(net.pkw, net.pzd)) == net


@st.composite
def jobs(draw: st.DrawFn) -> tuple[Layout, Pkw | None, list[int]]:
    layout = draw(st.sampled_from(ALL_LAYOUTS))
    pzd = draw(st.lists(st.integers(0, 0xFFFF), min_size=layout.pzd, max_size=layout.pzd))
    if layout.pkw == 0:
        return layout, None, pzd
    n = draw(st.integers(0, min(layout.max_pwe, 8) if layout.variable else layout.max_pwe))
    values = tuple(draw(st.lists(st.integers(0, 0xFFFF), min_size=n, max_size=n)))
    pkw = Pkw(
        draw(st.integers(0, 15)),
        draw(st.integers(0, 2047)),
        draw(st.integers(0, 0xFFFF)),
        draw(st.booleans()),
        values,
    )
    return layout, pkw, pzd


@given(jobs(), st.integers(0, 31))
@settings(max_examples=300)
def test_jobs_round_trip_through_a_telegram_for_every_layout(
    case: tuple[Layout, Pkw | None, list[int]], address: int
) -> None:
    layout, pkw, pzd = case
    raw = Telegram(address, AddressMode.NORMAL, layout.pack(pkw, pzd)).encode()
    net = layout.unpack(Telegram.decode(raw).data)
    assert net.pzd == tuple(pzd)
    if pkw is None:
        assert net.pkw is None
        return
    assert net.pkw is not None
    assert (net.pkw.id, net.pkw.pnu, net.pkw.index, net.pkw.spm_toggle) == (
        pkw.id,
        pkw.pnu,
        pkw.index,
        pkw.spm_toggle,
    )
    if len(pkw.values) == 1:
        assert net.pkw.word() == pkw.values[0]  # wherever the layout placed it
    elif len(pkw.values) == 2 or pkw.values:
        assert net.pkw.values == pkw.values
    else:
        assert set(net.pkw.values) == {0}
