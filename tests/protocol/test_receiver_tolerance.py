"""The receiver on coarse timestamps (``tolerance``): a serial port, a pty or TCP stamps bytes
when the program reads them, up to the tolerance later than they ended on the line. The master
and the monitor share this one mechanism."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.protocol.receiver import Event, FaultKind, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import bcc
from pyuss.protocol.timing import char_time

BAUD = 19200
CT = char_time(BAUD)
START_PAUSE = 2 * CT
TOLERANCE = 0.020


def frame(data: bytes, adr: int = 5) -> bytes:
    head = bytes((2, len(data) + 2, adr)) + data
    return head + bytes((bcc(head),))


REQUEST = frame(bytes(range(1, 11)))  # 14 bytes, as a telegram of layout 3,2
ANSWER = frame(bytes(range(20, 30)))


def kinds(events: list[Event]) -> list[object]:
    return [e.kind if isinstance(e, ReceiveFault) else "ok" for e in events]


def test_an_answer_read_together_with_the_end_of_its_request_keeps_its_start_pause() -> None:
    # The port read the request's last two bytes and the answer's first four in one go: the
    # stamps cannot show the pause between them, so it is not taken as missing.
    chunks = [(REQUEST[:12], 12 * CT), (REQUEST[12:] + ANSWER[:4], 0.0105), (ANSWER[4:], 0.017)]
    for tolerance, expected in ((TOLERANCE, ["ok", "ok"]), (0.0, ["ok", FaultKind.NO_STX])):
        receiver = Receiver(BAUD, tolerance=tolerance)
        events = [e for data, t in chunks for e in receiver.feed(data, t)]
        events += receiver.poll(1.0)
        assert kinds(events) == expected, tolerance
    assert [e.raw for e in events if isinstance(e, Received)] == [REQUEST]


def test_a_late_burst_inside_a_telegram_neither_cuts_it_nor_makes_it_late() -> None:
    # The first 7 bytes came on time, the other 7 were handed over 15 ms later (a USB
    # adapter's latency timer): on the line the telegram was whole and in time.
    late = 7 * CT + 0.015
    chunks = [(REQUEST[:7], 7 * CT), (REQUEST[7:], 7 * CT + late)]
    exact = Receiver(BAUD)
    assert kinds([e for data, t in chunks for e in exact.feed(data, t)] + exact.poll(1.0)) == [
        FaultKind.RESIDUAL_TIME,
        FaultKind.NO_STX,
    ]
    coarse = Receiver(BAUD, tolerance=TOLERANCE)
    events = [e for data, t in chunks for e in coarse.feed(data, t)] + coarse.poll(1.0)
    assert kinds(events) == ["ok"]
    assert events[0].end == pytest.approx(len(REQUEST) * CT)  # back to back, as on the line


def test_a_pause_longer_than_the_tolerance_still_ends_an_incomplete_telegram() -> None:
    receiver = Receiver(BAUD, tolerance=TOLERANCE)
    assert receiver.gap == TOLERANCE
    events = receiver.feed(REQUEST[:7], 7 * CT)
    assert receiver.next_poll() == pytest.approx(7 * CT + TOLERANCE)
    assert receiver.poll(7 * CT + TOLERANCE * 0.9) == []
    events += receiver.poll(7 * CT + TOLERANCE)
    events += receiver.feed(REQUEST[7:], 7 * CT + 0.040)
    events += receiver.poll(1.0)
    assert kinds(events) == [FaultKind.RESIDUAL_TIME, FaultKind.NO_STX]


def test_a_backlog_read_late_follows_back_to_back_and_never_overlaps() -> None:
    # The program read late (its reader stalled): four telegrams came in one read stamped just
    # after the one before, more bytes than the line carries in that time. They are laid out
    # back to back after it, each still a telegram.
    receiver = Receiver(BAUD, tolerance=TOLERANCE)
    backlog = (ANSWER + REQUEST) * 2
    events = receiver.feed(REQUEST, len(REQUEST) * CT)
    events += receiver.feed(backlog, (len(REQUEST) + 1) * CT)
    events += receiver.poll(1.0)
    assert kinds(events) == ["ok"] * 5
    ends = [e.end for e in events]
    assert all(b.start >= a.end - 1e-12 for a, b in itertools.pairwise(events))
    assert ends[-1] == pytest.approx((len(REQUEST) + len(backlog)) * CT)


def test_exact_timestamps_keep_the_start_pause_rule() -> None:
    # Tolerance 0 (the virtual bus): a telegram right after another, without a start pause on
    # the line, is bytes without a start (A 5.1.2).
    receiver = Receiver(BAUD)
    assert (receiver.tolerance, receiver.gap) == (0.0, receiver.start_pause)
    events = receiver.feed(REQUEST + ANSWER, 28 * CT) + receiver.poll(1.0)
    assert kinds(events) == ["ok", FaultKind.NO_STX]


@pytest.mark.parametrize("value", [-0.001, float("inf"), float("nan"), "20", True])
def test_a_bad_tolerance_is_refused(value: object) -> None:
    with pytest.raises(ConfigError, match="tolerance"):
        Receiver(BAUD, tolerance=value)  # type: ignore[arg-type]


@st.composite
def coarse_line(draw: st.DrawFn) -> tuple[list[bytes], list[tuple[bytes, float]], float]:
    """Telegrams on the line with start pauses between them, read by a port in chunks of any
    size, each stamped up to the tolerance after its last byte ended (in order)."""
    tolerance = draw(st.sampled_from([0.0, 0.5 * START_PAUSE, 0.005, TOLERANCE]))
    telegrams = draw(
        st.lists(
            st.binary(min_size=0, max_size=20).map(frame) | st.sampled_from([REQUEST, ANSWER]),
            min_size=1,
            max_size=6,
        )
    )
    ends: list[float] = []  # when each byte ended on the line
    pause_before: list[float] = []
    t = 0.0
    stream = b""
    for telegram in telegrams:
        pause = draw(st.floats(START_PAUSE, 0.03))
        t += pause
        for i, _ in enumerate(telegram):
            t += CT
            ends.append(t)
            pause_before.append(pause if i == 0 else 0.0)
        stream += telegram
    # A read holds the bytes that ended since the one before; its stamp may be late by up to
    # the tolerance for every byte in it, counting the pauses it hides after that byte.
    wanted = set(draw(st.sets(st.integers(1, len(stream) - 1), max_size=len(stream) - 1)))
    chunks: list[tuple[bytes, float]] = []
    last_stamp = a = 0
    hidden = 0.0
    for b in range(1, len(stream) + 1):
        if b < len(stream) and b not in wanted and hidden + pause_before[b] <= tolerance:
            hidden += pause_before[b]
            continue
        delay = draw(st.floats(0.0, tolerance - hidden)) if tolerance > hidden else 0.0
        stamp = max(ends[b - 1] + delay, last_stamp)
        chunks.append((stream[a:b], stamp))
        last_stamp, a, hidden = stamp, b, 0.0
    return telegrams, chunks, tolerance


@settings(max_examples=300, deadline=None)
@given(coarse_line())
def test_every_telegram_comes_through_however_the_port_stamps_within_the_tolerance(
    line: tuple[list[bytes], list[tuple[bytes, float]], float],
) -> None:
    telegrams, chunks, tolerance = line
    receiver = Receiver(BAUD, tolerance=tolerance)
    events = [e for data, stamp in chunks for e in receiver.feed(data, stamp)]
    events += receiver.poll(10.0)
    assert [e.raw if isinstance(e, Received) else e for e in events] == telegrams
