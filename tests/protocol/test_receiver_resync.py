"""Resynchronisation on the start pause (A 5.1.2: a telegram begins with an STX after a start
pause of at least 2 character times): a stray character before a telegram costs that telegram
nothing when a start pause lies between them, also where the times fed cannot show the pause
- coarse stamps within the receiver's tolerance, or a feeder that took a writer's hold-up out
(``held``, the simulator's untimed line). Given times, no clock."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.protocol.receiver import Event, FaultKind, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import bcc
from pyuss.protocol.timing import char_time

BAUD = 9600
CT = char_time(BAUD)
T0 = 500.0


def frame(data: bytes, adr: int = 5) -> bytes:
    head = bytes((2, len(data) + 2, adr)) + data
    return head + bytes((bcc(head),))


TELEGRAM = frame(bytes(range(1, 11)))  # 14 characters
STRAYS = [b"\x55", b"\x02", b"\x00", b"\xff"]


def kinds(events: list[Event]) -> list[object]:
    return [e.kind if isinstance(e, ReceiveFault) else "ok" for e in events]


def paced(rx: Receiver, data: bytes, start: float, **first: float) -> list[Event]:
    """``data`` one character at a time, back to back from ``start`` (the end of the first);
    ``first`` goes to the feed of the first character."""
    events: list[Event] = []
    for i, byte in enumerate(data):
        events += rx.feed(bytes((byte,)), start + i * CT, **(first if i == 0 else {}))
    return events


def whole(rx: Receiver, events: list[Event], until: float) -> list[Event]:
    return events + rx.poll(until)


@pytest.mark.parametrize("stray", STRAYS, ids=lambda b: b.hex())
def test_exact_times_a_stray_character_then_a_start_pause_then_a_telegram(stray: bytes) -> None:
    rx = Receiver(BAUD)
    events = rx.feed(stray, T0)
    events += paced(rx, TELEGRAM, T0 + 7 * CT)  # 6 character times of silence between
    events = whole(rx, events, T0 + 100 * CT)
    assert kinds(events)[-1] == "ok"
    assert len(events) == 2 and events[0].raw == stray
    assert isinstance(events[1], Received) and events[1].raw == TELEGRAM


@pytest.mark.parametrize("stray", STRAYS, ids=lambda b: b.hex())
def test_a_pause_the_feeder_took_out_is_a_start_pause_after_all(stray: bytes) -> None:
    """The feeder shows the telegram back to back with the stray character and says it took
    6 character times out (``held``): the receiver starts again at the STX after it."""
    rx = Receiver(BAUD)
    events = rx.feed(stray, T0)
    events += paced(rx, TELEGRAM, T0 + CT, held=6 * CT)
    events = whole(rx, events, T0 + 100 * CT)
    assert isinstance(events[-1], Received) and events[-1].raw == TELEGRAM
    assert b"".join(e.raw for e in events) == stray + TELEGRAM  # every byte in one event
    assert isinstance(events[0], ReceiveFault) and events[0].raw == stray
    assert events[-1].start == pytest.approx(T0)  # on the times fed
    assert events[-1].end == pytest.approx(T0 + 14 * CT)


@pytest.mark.parametrize("stray", STRAYS, ids=lambda b: b.hex())
def test_coarse_stamps_hide_the_pause_and_the_telegram_still_comes(stray: bytes) -> None:
    """Within a 20 ms tolerance a read 6 character times after the stray one is taken as back
    to back; when what it started fails, the STX after that pause begins the telegram."""
    rx = Receiver(BAUD, tolerance=0.020)
    events = rx.feed(stray, T0)
    events += rx.feed(TELEGRAM, T0 + 20 * CT)  # 6 character times, then 14 characters
    events = whole(rx, events, T0 + 200 * CT)
    assert isinstance(events[-1], Received) and events[-1].raw == TELEGRAM
    assert b"".join(e.raw for e in events) == stray + TELEGRAM


def test_a_stray_stx_before_the_telegram_is_reported_as_cut_short() -> None:
    rx = Receiver(BAUD)
    events = rx.feed(b"\x02", T0)
    events += paced(rx, TELEGRAM, T0 + CT, held=6 * CT)
    assert kinds(events) == [FaultKind.RESIDUAL_TIME, "ok"]
    assert isinstance(events[0], ReceiveFault) and "pause" in events[0].detail


def test_without_a_pause_nothing_is_resynchronised() -> None:
    """The STX of a telegram right after a stray STX, with no pause before it, begins no
    telegram (A 5.1.2): the receiver does not hunt for STX in what it has."""
    rx = Receiver(BAUD)
    events = rx.feed(b"\x02", T0)
    events += paced(rx, TELEGRAM, T0 + CT)
    events = whole(rx, events, T0 + 100 * CT)
    assert "ok" not in kinds(events)
    assert b"".join(e.raw for e in events) == b"\x02" + TELEGRAM


def test_a_pause_shorter_than_a_start_pause_is_no_new_start() -> None:
    rx = Receiver(BAUD)
    events = rx.feed(b"\x02", T0)
    events += paced(rx, TELEGRAM, T0 + CT, held=1.5 * CT)
    events = whole(rx, events, T0 + 100 * CT)
    assert "ok" not in kinds(events)


def test_a_telegram_held_up_inside_is_not_cut_by_the_resynchronisation() -> None:
    """A writer held up inside a good telegram (``held`` before a byte that is STX by chance)
    still gets its telegram: the mark is used only when the telegram fails."""
    data = frame(bytes((1, 2, 2, 4, 5, 6, 7, 8, 9, 10)))
    rx = Receiver(BAUD)
    events = rx.feed(data[:5], T0)
    assert data[5] == 2
    events += rx.feed(data[5:], T0 + (len(data) - 5) * CT, held=8 * CT)
    assert kinds(events) == ["ok"]


_chunk = st.tuples(
    st.binary(min_size=1, max_size=20).map(lambda b: b.replace(b"\x03", b"\x02")),
    st.floats(0, 30),  # idle character times before it
    st.sampled_from([0.0, 0.0, 1.0, 2.0, 6.0, 30.0]),  # character times the feeder held
)


@given(st.lists(_chunk, min_size=1, max_size=12), st.sampled_from([0.0, 0.020]))
@settings(max_examples=300, deadline=None)
def test_every_byte_ends_in_one_event_in_order_however_pauses_hide(
    chunks: list[tuple[bytes, float, float]], tolerance: float
) -> None:
    rx = Receiver(BAUD, tolerance=tolerance)
    t = T0
    events: list[Event] = []
    fed = b""
    for data, idle, held in chunks:
        t += (idle + len(data)) * CT
        events += rx.feed(data, t, held=held * CT)
        fed += data
        events += rx.poll(t)
    events += rx.poll(t + 1000 * CT)
    assert b"".join(e.raw for e in events) == fed
    assert not rx.busy


@given(st.binary(min_size=1, max_size=3), st.sampled_from([0.0, 0.020]))
@settings(max_examples=100, deadline=None)
def test_any_stray_bytes_before_a_hidden_pause_cost_the_telegram_nothing(
    stray: bytes, tolerance: float
) -> None:
    rx = Receiver(BAUD, tolerance=tolerance)
    events = rx.feed(stray, T0)
    events += paced(rx, TELEGRAM, T0 + CT, held=6 * CT)
    events = whole(rx, events, T0 + 1000 * CT)
    assert isinstance(events[-1], Received) and events[-1].raw == TELEGRAM
