"""The streaming receiver (A 5.1.2, A 5.2): framing by start pause, LGE and residual time,
classified faults, resynchronisation, fixed lengths, line errors."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.protocol.diagnostics import Diagnostics, ErrorStatus
from pyuss.protocol.receiver import Event, FaultKind, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import AddressMode, Telegram, bcc
from pyuss.protocol.timing import char_time, residual_time_max
from pyuss.transport.base import LineError
from support.paths import load_vectors

from .wire import Wire

VECTORS = load_vectors("uss")["telegrams"]
RAW = [bytes.fromhex(v["hex"]) for v in VECTORS]
GOOD = RAW[0]  # 02 0C 05 ... 55, 14 bytes, address 5
BAUD = 9600
CT = char_time(BAUD)


def frame(data: bytes, adr: int = 5, lge: int | None = None) -> bytes:
    head = bytes((2, len(data) + 2 if lge is None else lge, adr)) + data
    return head + bytes((bcc(head),))


def wire(**kwargs: object) -> Wire:
    return Wire(Receiver(BAUD, **kwargs))  # type: ignore[arg-type]


def kinds(events: list[Event]) -> list[object]:
    return [e.kind if isinstance(e, ReceiveFault) else "ok" for e in events]


def test_every_vector_telegram_is_received() -> None:
    w = wire()
    for raw in RAW:
        events = w.send(raw)
        assert len(events) == 1
        event = events[0]
        assert isinstance(event, Received)
        assert event.raw == raw
        assert event.telegram == Telegram.decode(raw)
        assert event.end == pytest.approx(w.t)
        assert event.start == pytest.approx(w.t - len(raw) * CT)


def test_telegram_byte_by_byte_within_character_gaps() -> None:
    w = wire()
    events = w.send(GOOD[:1]) + w.trickle(GOOD[1:], gap=0.3)
    assert kinds(events) == ["ok"]


@given(st.lists(st.integers(1, 5), min_size=1, max_size=14))
@settings(max_examples=60)
def test_any_back_to_back_chunking_gives_the_telegram(sizes: list[int]) -> None:
    w = wire()
    events, pos = [], 0
    for i, size in enumerate(sizes):
        events += w.send(GOOD[pos : pos + size], gap=3.0 if i == 0 else 0.0)
        pos += size
    events += w.send(GOOD[pos:], gap=0.0) if pos < len(GOOD) else []
    assert kinds(events) == ["ok"]


def test_stx_needs_a_start_pause_before_it() -> None:
    w = wire()
    assert kinds(w.send(GOOD)) == ["ok"]
    # The same telegram right after the first, 1.9 character times later: no start pause.
    assert w.send(GOOD, gap=1.9) == []
    events = w.idle()
    assert kinds(events) == [FaultKind.NO_STX]
    assert events[0].raw == GOOD
    assert "without a start pause" in events[0].detail
    # Two character times of silence are enough.
    assert kinds(w.send(GOOD, gap=2.0)) == ["ok"]


def test_resynchronises_after_garbage_with_a_start_pause() -> None:
    w = wire()
    garbage = b"\x41\x02\x0c\x05\x02\xff\x02"
    assert w.send(garbage) == []  # extent unknown until the line falls idle
    events = w.send(GOOD, gap=2.5)
    assert kinds(events) == [FaultKind.NO_STX, "ok"]
    assert events[0].raw == garbage
    assert events[1].raw == GOOD


def test_first_character_not_stx() -> None:
    w = wire()
    w.send(b"\x41\x42\x43")
    events = w.idle()
    assert kinds(events) == [FaultKind.NO_STX]
    assert events[0].raw == b"ABC"
    assert "41h, not STX" in events[0].detail


def test_bytes_after_a_telegram_are_reported_once_the_line_is_idle() -> None:
    w = wire()
    events = w.send(GOOD + b"\x00\x00")
    assert kinds(events) == ["ok"]
    assert w.rx.busy
    assert w.rx.next_poll() == pytest.approx(w.t + 2 * CT)
    assert w.rx.poll(w.t + 1.9 * CT) == []
    events = w.rx.poll(w.t + 2 * CT)
    assert kinds(events) == [FaultKind.NO_STX]
    assert events[0].raw == b"\x00\x00"
    assert not w.rx.busy
    assert w.rx.next_poll() is None


@pytest.mark.parametrize("lge", [0, 1, 255])
def test_lge_out_of_range(lge: int) -> None:
    w = wire()
    raw = bytes((2, lge, 5, 0, 0))
    w.send(raw)
    events = w.idle()
    assert kinds(events) == [FaultKind.BAD_LGE]
    assert events[0].raw == raw
    assert f"LGE {lge}" in events[0].detail


def test_wrong_bcc_is_reported_at_the_last_byte() -> None:
    w = wire()
    bad = GOOD[:-1] + b"\x00"
    events = w.send(bad)
    assert kinds(events) == [FaultKind.BCC]
    assert events[0].detail == "BCC is 00h, expected 55h"
    assert not w.rx.busy


def test_undefined_adr_is_reported_not_raised() -> None:
    w = wire()
    raw = frame(b"\x00\x00", adr=0x65)
    events = w.send(raw)
    assert kinds(events) == [FaultKind.BAD_ADR]
    assert "undefined" in events[0].detail


def test_bcc_is_checked_before_adr() -> None:
    raw = frame(b"", adr=0xE1)
    events = wire().send(raw[:-1] + bytes((raw[-1] ^ 1,)))
    assert kinds(events) == [FaultKind.BCC]


def test_residual_time_uses_the_exact_deadline_after_lge() -> None:
    # LGE 4: deadline 1.5 x 5 = 7.5 characters after STX; 5 bytes with gaps g end at 5(1+g).
    raw = frame(b"\x01\x02")
    w = wire()
    assert kinds(w.send(raw[:1]) + w.trickle(raw[1:], gap=0.45)) == ["ok"]
    w = wire()
    events = w.send(raw[:1]) + w.trickle(raw[1:], gap=0.55)
    assert events == []
    events = w.idle()
    assert kinds(events) == [FaultKind.RESIDUAL_TIME]
    assert events[0].raw == raw
    assert "residual time" in events[0].detail


@pytest.mark.parametrize(
    ("lge_after", "detail"),
    [
        # LGE just inside the n = 252 deadline: taken, and the exact deadline for n = 10
        # (1.5 x 13 characters = 22.344 ms) replaces it - already past, so the telegram fails.
        (-0.001, "(22.344 ms after STX): 2 of 14 bytes"),
        # LGE just after the n = 252 deadline (1.5 x 255 characters = 438.281 ms): too late.
        (+0.001, "(438.281 ms after STX): 1 of ? bytes"),
    ],
    ids=["lge-in-time", "lge-late"],
)
def test_deadline_on_stx_is_for_252_bytes_and_exact_after_lge(
    lge_after: float, detail: str
) -> None:
    rx = Receiver(BAUD, start_pause=10.0)  # only the residual time can end the telegram
    assert rx.feed(b"\x02", 100.0) == []  # STX complete at 100.0
    lge_time = 100.0 + residual_time_max(BAUD, 252) + lge_after
    assert rx.feed(GOOD[1:2], lge_time) == []
    assert rx.poll(lge_time + 0.001) == []
    events = rx.poll(lge_time + 10.0)
    assert kinds(events) == [FaultKind.RESIDUAL_TIME]
    assert events[0].raw == GOOD[:2]
    assert events[0].detail.endswith(detail)


def test_late_bytes_of_a_telegram_are_part_of_its_fault() -> None:
    rx = Receiver(BAUD, start_pause=10.0)
    rx.feed(GOOD[:2], 100.0)  # STX ended at 100 - CT, deadline 1.5 x 13 characters later
    late = 100.0 - CT + residual_time_max(BAUD, 10) + 0.01
    assert rx.feed(GOOD[2:], late) == []
    events = rx.poll(late + 10.0)
    assert kinds(events) == [FaultKind.RESIDUAL_TIME]
    assert events[0].raw == GOOD


def test_idle_gap_inside_a_telegram_ends_it() -> None:
    w = wire()
    assert w.send(GOOD[:6]) == []
    events = w.send(GOOD, gap=2.0)  # a new telegram after a start pause
    assert kinds(events) == [FaultKind.RESIDUAL_TIME, "ok"]
    assert events[0].raw == GOOD[:6]
    assert "incomplete" in events[0].detail
    assert "6 of 14 bytes" in events[0].detail


def test_fixed_length_per_address() -> None:
    short = frame(b"\x00\x00", adr=5)  # LGE 4
    w = wire(fixed_lengths={5: 12})
    assert kinds(w.send(GOOD)) == ["ok"]
    assert w.send(short) == []
    events = w.idle()
    assert kinds(events) == [FaultKind.BAD_LGE]
    assert "fixed length LGE 12" in events[0].detail
    # Mirror telegrams to that address are held to the same length ...
    w.send(frame(b"\x00\x00", adr=0x45))
    assert kinds(w.idle()) == [FaultKind.BAD_LGE]
    # ... other addresses, broadcasts and special telegrams are framed by their LGE.
    assert kinds(w.send(frame(b"\x00\x00", adr=6))) == ["ok"]
    assert kinds(w.send(frame(b"\x00\x00", adr=0x25))) == ["ok"]
    assert kinds(w.send(frame(b"\x00\x00", adr=0x85))) == ["ok"]


def test_fixed_lengths_can_be_changed_later() -> None:
    w = wire()
    w.rx.fixed_lengths[5] = 4
    w.send(GOOD)
    assert kinds(w.idle()) == [FaultKind.BAD_LGE]


@pytest.mark.parametrize(
    "bad", [{32: 12}, {-1: 12}, {5: 1}, {5: 255}], ids=["addr32", "addr-1", "lge1", "lge255"]
)
def test_bad_fixed_lengths_are_refused(bad: dict[int, int]) -> None:
    with pytest.raises(ConfigError, match="fixed length"):
        Receiver(BAUD, fixed_lengths=bad)


@pytest.mark.parametrize("pause", [0, -1.0, "1"])
def test_bad_start_pause_is_refused(pause: object) -> None:
    with pytest.raises(ConfigError, match="start pause"):
        Receiver(BAUD, start_pause=pause)  # type: ignore[arg-type]


def test_longer_start_pause_for_a_profile() -> None:
    w = wire(start_pause=3 * CT)
    assert kinds(w.send(GOOD)) == ["ok"]
    assert w.send(GOOD, gap=2.5) == []
    assert kinds(w.idle()) == [FaultKind.NO_STX]


@pytest.mark.parametrize(
    ("flag", "kind"),
    [
        (LineError.PARITY, FaultKind.PARITY),
        (LineError.FRAMING, FaultKind.FRAMING),
        (LineError.OVERRUN, FaultKind.OVERRUN),
        (LineError.BREAK, FaultKind.FRAMING),
        (LineError.PARITY | LineError.FRAMING, FaultKind.FRAMING),
    ],
)
def test_line_error_inside_a_telegram(flag: LineError, kind: FaultKind) -> None:
    w = wire()
    events = w.send(GOOD, errors=[(7, flag)])
    assert kinds(events) == [kind]
    assert events[0].raw == GOOD
    assert "byte 7" in events[0].detail
    assert kinds(w.send(GOOD)) == ["ok"]


def test_line_error_on_stx_or_lge_loses_the_framing() -> None:
    w = wire()
    w.send(GOOD, errors=[(0, LineError.PARITY)])
    assert kinds(w.idle()) == [FaultKind.PARITY]
    w.send(GOOD, errors=[(1, LineError.FRAMING)])
    events = w.idle()
    assert kinds(events) == [FaultKind.FRAMING]
    assert events[0].raw == GOOD


def test_incomplete_telegram_with_a_framing_error_reports_the_framing_error() -> None:
    w = wire()
    w.send(GOOD[:6], errors=[(4, LineError.FRAMING)])
    events = w.idle()
    assert kinds(events) == [FaultKind.FRAMING]
    assert "framing error at byte 4" in events[0].detail
    assert "incomplete" in events[0].detail


def test_line_error_flags_outside_the_chunk_or_empty_are_ignored() -> None:
    events = wire().send(GOOD, errors=[(99, LineError.PARITY), (3, LineError.NONE)])
    assert kinds(events) == ["ok"]


def test_long_runs_of_garbage_are_split() -> None:
    w = wire()
    events = w.send(bytes(600)) + w.idle()
    assert [len(e.raw) for e in events] == [256, 256, 88]
    assert set(kinds(events)) == {FaultKind.NO_STX}


def test_empty_chunk_changes_nothing() -> None:
    w = wire()
    assert w.rx.feed(b"", 5.0) == []
    assert not w.rx.busy


def test_reset_drops_a_partial_telegram() -> None:
    w = wire()
    w.send(GOOD[:5])
    w.rx.reset()
    assert not w.rx.busy
    assert kinds(w.send(GOOD, gap=0)) == ["ok"]  # after reset the line counts as idle


def test_line_idle() -> None:
    w = wire()
    w.send(GOOD)
    assert w.rx.last_byte_end == w.t
    assert not w.rx.line_idle(w.t + CT)
    assert w.rx.line_idle(w.t + 2 * CT)


def test_receiver_updates_diagnostics() -> None:
    diag = Diagnostics()
    w = wire(diagnostics=diag)
    w.send(GOOD)
    w.send(GOOD[:-1] + b"\x00")
    w.send(b"\x41")
    w.send(GOOD, errors=[(3, LineError.PARITY)])
    w.send(GOOD)
    w.idle()
    assert (diag.good, diag.discarded, diag.bcc, diag.no_stx, diag.parity) == (2, 3, 1, 1, 1)
    assert diag.status == ErrorStatus.BCC | ErrorStatus.NO_STX | ErrorStatus.PARITY


def test_mirror_telegram_is_received_with_its_mode() -> None:
    raw = next(bytes.fromhex(v["hex"]) for v in VECTORS if v["name"] == "mirror_request")
    (event,) = wire().send(raw)
    assert isinstance(event, Received)
    assert event.telegram.mode is AddressMode.MIRROR
    assert event.telegram.encode() == raw


chunks = st.lists(st.tuples(st.binary(min_size=1, max_size=40), st.floats(0.0, 4.0)), max_size=12)
flags = st.lists(st.tuples(st.integers(0, 39), st.sampled_from(list(LineError))), max_size=3)


@given(chunks, st.lists(flags, max_size=12))
@settings(max_examples=150, deadline=None)
def test_random_bytes_never_raise_and_every_byte_is_accounted(
    parts: list[tuple[bytes, float]], errs: list[list[tuple[int, LineError]]]
) -> None:
    w = wire()
    events = []
    for i, (data, gap) in enumerate(parts):
        events += w.send(data, gap, errs[i] if i < len(errs) else ())
    events += w.idle(10)
    assert not w.rx.busy
    assert b"".join(e.raw for e in events) == b"".join(p[0] for p in parts)
    for event in events:
        assert event.start <= event.end
        if isinstance(event, Received):
            assert bcc(event.raw) == 0
            assert event.telegram.encode() == event.raw


@given(st.binary(max_size=300), st.integers(1, 4), st.sampled_from(RAW))
@settings(max_examples=100, deadline=None)
def test_a_telegram_after_garbage_and_a_start_pause_is_found(
    garbage: bytes, parts: int, raw: bytes
) -> None:
    w = wire()
    events = w.send(garbage, gap=0.5)
    step = -(-len(raw) // parts)
    events += w.send(raw[:step], gap=2.0)
    for pos in range(step, len(raw), step):
        events += w.send(raw[pos : pos + step], gap=0.0)
    assert isinstance(events[-1], Received)
    assert events[-1].raw == raw


segments = st.lists(
    st.tuples(
        st.one_of(
            st.binary(min_size=1, max_size=60),
            st.sampled_from(RAW),
            st.tuples(st.binary(max_size=5), st.sampled_from(RAW)).map(lambda p: p[0] + p[1]),
        ),
        st.floats(0.0, 4.0),
        st.lists(st.integers(1, 10), max_size=10),
    ),
    min_size=1,
    max_size=8,
)


@given(segments)
@settings(max_examples=150, deadline=None)
def test_events_do_not_depend_on_how_the_bytes_are_chunked(
    parts: list[tuple[bytes, float, list[int]]],
) -> None:
    """The same line (segments after idle gaps, bytes back to back inside a segment) gives
    the same events whether each segment comes in one chunk or cut into pieces."""

    def events(cut: bool) -> list[tuple[object, bytes]]:
        w = wire()
        got: list[Event] = []
        for data, gap, sizes in parts:
            pieces, pos = [], 0
            for size in sizes if cut else ():
                if pos < len(data):
                    pieces.append(data[pos : pos + size])
                    pos += size
            if pos < len(data):
                pieces.append(data[pos:])
            got += w.send(pieces[0], gap)
            for piece in pieces[1:]:
                got += w.send(piece, 0.0)
        got += w.idle(10)
        return [(kinds([e])[0], e.raw) for e in got]

    assert events(cut=True) == events(cut=False)


def test_a_telegram_over_its_residual_time_says_when_its_last_byte_came() -> None:
    # A port with coarse timestamps (a start pause of 50 ms): GOOD stalls after 9 bytes beyond
    # its residual time (1.5 x 13 characters after STX, A 6.3), then the next telegram follows
    # in the same run. The fault names the moment GOOD was whole, so a reader can judge.
    rx = Receiver(BAUD, start_pause=0.05)
    t = 10.0
    assert rx.feed(GOOD[:9], t) == []
    late = t + 0.030
    assert rx.feed(GOOD[9:], late) == []
    assert rx.feed(GOOD, late + 0.005) == []
    (fault,) = rx.poll(late + 1.0)
    assert isinstance(fault, ReceiveFault) and fault.kind is FaultKind.RESIDUAL_TIME
    assert fault.raw == GOOD + GOOD
    assert fault.whole_at == pytest.approx(late)
    # One that never becomes whole, and other faults, have no such time.
    rx = Receiver(BAUD, start_pause=0.05)
    rx.feed(GOOD[:9], t)
    rx.feed(GOOD[9:12], t + 0.030)
    (fault,) = rx.poll(t + 1.0)
    assert fault.kind is FaultKind.RESIDUAL_TIME and fault.whole_at is None
    rx = Receiver(BAUD)
    (fault,) = rx.feed(frame(b"\x01\x02")[:-1] + b"\xff", t)
    assert fault.kind is FaultKind.BCC and fault.whole_at is None
