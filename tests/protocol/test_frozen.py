"""The quick construction of the protocol's values (`pyuss.protocol.frozen.builder`): what it
makes is the value the class itself makes - equal, of the same hash, as frozen - and the
values the receiver and the layout make that way are those of the checked constructors."""

from __future__ import annotations

import dataclasses
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.protocol.diagnostics import Counters, ErrorStatus
from pyuss.protocol.frozen import builder
from pyuss.protocol.layout import PKW_VARIABLE, Layout, NetData
from pyuss.protocol.pkw import Pkw, unpacked_pkw
from pyuss.protocol.receiver import Received, Receiver
from pyuss.protocol.telegram import AddressMode, Telegram

WORD = st.integers(0, 0xFFFF)


def test_a_built_value_is_the_class_value() -> None:
    made = builder(Telegram)(5, AddressMode.NORMAL, b"\x01\x02")
    expected = Telegram(5, AddressMode.NORMAL, b"\x01\x02")
    assert type(made) is Telegram
    assert made == expected
    assert hash(made) == hash(expected)
    assert repr(made) == repr(expected)
    with pytest.raises(dataclasses.FrozenInstanceError):
        made.address = 6  # type: ignore[misc]


def test_counters_are_built_field_by_field_in_order() -> None:
    values = (1, 2, 0, ErrorStatus.BCC, *range(5, 17))
    assert builder(Counters)(*values) == Counters(*values)


@settings(max_examples=200)
@given(words=st.lists(WORD, min_size=3, max_size=8))
def test_unpacked_pkw_is_from_words(words: list[int]) -> None:
    made = unpacked_pkw(tuple(words))
    assert made == Pkw.from_words(words)
    assert made.words() == tuple(words)


@settings(max_examples=200)
@given(
    layout=st.sampled_from([Layout(p, z) for p in (0, 3, 4, PKW_VARIABLE) for z in (0, 2, 6)]),
    data=st.data(),
)
def test_unpack_gives_the_checked_values(layout: Layout, data: st.DataObject) -> None:
    count = layout.words if layout.words is not None else layout.pzd + data.draw(st.integers(3, 9))
    words = data.draw(st.lists(WORD, min_size=count, max_size=count))
    net = layout.unpack(struct.pack(f">{count}H", *words))
    pkw_words = count - layout.pzd
    pkw = Pkw.from_words(words[:pkw_words]) if layout.pkw else None
    assert net == NetData(pkw, tuple(words[pkw_words:]))


def test_a_received_telegram_is_the_checked_one() -> None:
    frame = Telegram(7, AddressMode.NORMAL, bytes(range(12))).encode()
    receiver = Receiver(38400)
    [event] = receiver.feed(frame, 1.0)
    assert isinstance(event, Received)
    assert event.telegram == Telegram.decode(frame)
    assert event == Received(Telegram.decode(frame), frame, event.start, 1.0)
