"""On a line without timing (a pty, a TCP socket) the simulator keeps a line of its own at the
baud rate (`PacedLine`): a request written at once or paced like a UART is framed by the start
pause and the residual time (A 5.1.2, A 5.2.1.2, A 6.3) and answered the response delay after
its last character ended (A 5.2.1.1), the whole answer written then; what a peer floods the line
with costs the peers after it at most one telegram time.

The model's answer times are asserted exactly (sans-io); over a real pty, with a master in a
process of its own that writes to it as a UART would (termios), that an answer comes and not a
telegram time late."""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path

import pytest

from pyuss.drive import SimulatedDrive
from pyuss.profiles import get_profile
from pyuss.protocol.diagnostics import FaultKind
from pyuss.protocol.layout import Layout
from pyuss.protocol.receiver import Event, Received, ReceiveFault, Receiver
from pyuss.protocol.telegram import MAX_TELEGRAM_BYTES
from pyuss.protocol.timing import residual_time_max
from pyuss.slave import SlaveEngine
from pyuss.slave.server import PacedLine
from slave.harness import LineSim, engine, frame

BAUDS = [300, 1200, 9600, 187500]
READ_P52 = frame(5, "1034 0000 0000 047E 0000")  # C 8.1 example 2: 14 characters
ANSWER_P52 = "020c05103400004000023100005c"  # 14 characters as well
T0 = 1000.0
WRITER = Path(__file__).with_name("uart_writer.py")


def _window(baud: int) -> tuple[float, float]:
    profile = get_profile("generic")
    drive = SimulatedDrive(profile.database(), now=0.0)
    return SlaveEngine(5, drive, profile, layout=Layout(3, 2), now=0.0).response_window(baud)


class Model:
    """The untimed line of `SlaveServer`, sans-io: reads in, the answer's start out."""

    def __init__(self, baud: int) -> None:
        self.line = PacedLine(11 / baud)
        self.receiver = Receiver(baud)
        self.delay = _window(baud)[0]
        self.events: list[Event] = []

    def read(self, data: bytes, arrival: float) -> float | None:
        """Put a read on the line as the server does; the start of the answer to a telegram
        it completes, else None."""
        taken = self.line.take(len(data), arrival, going_on=self.receiver.receiving)
        events = self.receiver.feed(data[:taken], self.line.free, held=self.line.held)
        self.events += events
        for event in events:
            if isinstance(event, Received):
                return self.line.answer(event.end, self.delay)
        return None

    def paced(self, data: bytes, gaps: list[float]) -> tuple[float, float | None]:
        """Write ``data`` one byte at a time, ``gaps[i]`` seconds between byte i and i + 1;
        the end of the last character and the answer's start."""
        at = T0
        answer = self.read(data[:1], at)
        for byte, gap in zip(data[1:], gaps, strict=True):
            at += gap
            answer = self.read(bytes((byte,)), at)
        return at + self.line.char_time, answer


def _uart_gaps(baud: int, low: float, high: float, seed: int = 1) -> list[float]:
    draw = random.Random(seed)
    return [draw.uniform(low, high) * 11 / baud for _ in range(len(READ_P52) - 1)]


@pytest.mark.parametrize("baud", BAUDS)
def test_a_request_written_at_once_is_answered_the_start_pause_after_its_end(baud: int) -> None:
    model = Model(baud)
    tc = 11 / baud
    answer = model.read(READ_P52, T0)
    # its 14 characters end 14 character times after it arrived; the generic profile answers
    # the start pause (2 characters) after that, within A 5.2.1.1's 20 ms (or the start pause)
    assert answer == pytest.approx(T0 + 14 * tc + 2 * tc, abs=1e-12)
    assert answer - (T0 + 14 * tc) <= max(0.020, 2 * tc) + 1e-9


@pytest.mark.parametrize("baud", BAUDS)
def test_a_request_paced_like_a_uart_is_answered_the_start_pause_after_its_end(
    baud: int,
) -> None:
    """Characters 1 to 1.45 character times apart: 13 x 1.45 = 18.85 of the 19.5 character
    times of residual time a 14-character telegram has (1.5 x (10 + 3), A 6.3)."""
    model = Model(baud)
    end, answer = model.paced(READ_P52, _uart_gaps(baud, 1.0, 1.45))
    assert answer == pytest.approx(end + 2 * 11 / baud, abs=1e-12)


@pytest.mark.parametrize("baud", BAUDS)
def test_a_request_slower_than_its_residual_time_is_not_answered(baud: int) -> None:
    """1.6 character times apart: 20.8 character times after STX, beyond the 19.5 of A 6.3."""
    model = Model(baud)
    _, answer = model.paced(READ_P52, [1.6 * 11 / baud] * (len(READ_P52) - 1))
    assert 13 * 1.6 * 11 / baud > residual_time_max(baud, 10)
    assert answer is None
    faults = model.events + model.receiver.poll(T0 + 10_000)
    assert [f.kind for f in faults] == [FaultKind.RESIDUAL_TIME]


@pytest.mark.parametrize("baud", BAUDS)
def test_a_writer_held_up_inside_a_telegram_does_not_end_it(baud: int) -> None:
    """A program writing byte by byte is held up for 10 ms after the sixth character (more
    than a start pause from 9600 baud up): it is no pause of the line. The answer starts the
    start pause after the last character ended as it arrived."""
    model = Model(baud)
    tc = 11 / baud
    gaps = [tc] * (len(READ_P52) - 1)
    gaps[5] += 0.010
    end, answer = model.paced(READ_P52, gaps)
    assert answer == pytest.approx(end + 2 * tc, abs=1e-12)


@pytest.mark.parametrize("baud", [9600, 187500])
def test_between_telegrams_a_pause_counts_as_it_came(baud: int) -> None:
    """Two requests 3 ms apart (more than a start pause at these rates): both are telegrams;
    a hold-up is only taken out inside a telegram."""
    model = Model(baud)
    assert model.read(READ_P52, T0) is not None
    second = T0 + 14 * 11 / baud + 0.003
    assert model.read(READ_P52, second) == pytest.approx(second + 16 * 11 / baud, abs=1e-12)
    assert all(isinstance(e, Received) for e in model.events)


@pytest.mark.parametrize("stray", [b"\x55", b"\x02", b"\x00"], ids=lambda b: b.hex())
@pytest.mark.parametrize("baud", BAUDS)
def test_a_stray_character_before_a_paced_request_costs_it_nothing(baud: int, stray: bytes) -> None:
    """One stray character, 6 character times of silence (a start pause and more, A 5.1.2,
    but less than a hold-up may last), then a request paced like a UART: it is answered the
    start pause after its end, and the stray character is a fault of its own."""
    model = Model(baud)
    tc = 11 / baud
    assert model.read(stray, T0) is None
    start = T0 + 7 * tc
    answer = None
    for i, byte in enumerate(READ_P52):
        answer = model.read(bytes((byte,)), start + i * tc) or answer
    assert answer == pytest.approx(start + 16 * tc, abs=1e-9)
    assert [type(e) for e in model.events] == [ReceiveFault, Received]
    assert model.events[0].raw == stray


@pytest.mark.parametrize("baud", BAUDS)
def test_a_flood_costs_later_peers_at_most_one_telegram_time(baud: int) -> None:
    """100 KiB written at once and more behind it: one telegram's worth (256 characters) is
    taken, the rest dropped; a request that comes one telegram time and a start pause later
    is answered as on an idle line."""
    model = Model(baud)
    tc = 11 / baud
    assert model.line.take(100 * 1024, T0) == MAX_TELEGRAM_BYTES
    assert model.line.take(4096, T0 + tc / 2) == 0
    model.line = PacedLine(tc)
    assert model.read(bytes(100 * 1024), T0) is None
    assert model.line.free == pytest.approx(T0 + MAX_TELEGRAM_BYTES * tc)
    later = T0 + (MAX_TELEGRAM_BYTES + 2) * tc
    assert model.read(READ_P52, later) == pytest.approx(later + 16 * tc, abs=1e-12)


def _exchange(path: str, baud: int, low: float, high: float, seed: int) -> dict[str, object]:
    args = (path, str(baud), READ_P52.hex(), str(low), str(high), str(seed))
    done = subprocess.run(
        [sys.executable, str(WRITER), *args],
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    )
    result: dict[str, object] = json.loads(done.stdout)
    return result


@pytest.mark.pty
@pytest.mark.parametrize(("low", "high"), [(0, 0), (1.0, 1.45)], ids=["at once", "paced"])
@pytest.mark.parametrize("baud", BAUDS)
def test_over_a_pty_the_answer_comes_within_the_response_delay(
    baud: int, low: float, high: float
) -> None:
    """A master in a process of its own writes the request at once or paced like a UART; the
    whole answer comes when it starts (A 5.2.1.1: 20 ms, or the start pause where that is
    longer), not when its last character would have ended on a wire - a telegram time later,
    513 ms at 300 baud, where a master has long given up. The bound has slack for a loaded
    machine: half a telegram time, at least 50 ms. A paced writer that the machine holds up
    for longer than a hold-up may last (20 ms) ends its own telegram by the rules: it may
    try three times."""
    tc = 11 / baud
    latest = _window(baud)[1] + max(7 * tc, 0.050)
    with LineSim(engine(5, "generic", "3,2"), baud=baud, line="pty") as sim:
        for seed in range(3):
            got = _exchange(sim.path, baud, low, high, seed)
            if got["answer"] or not high:
                break
    assert got["answer"] == ANSWER_P52
    assert isinstance(got["first"], float) and isinstance(got["end"], float)
    assert got["first"] - got["end"] < latest


SERIAL_WRITER = Path(__file__).with_name("serial_writer.py")


@pytest.mark.pty
@pytest.mark.parametrize("stray", [b"\x55", b"\x02"], ids=lambda b: b.hex())
@pytest.mark.parametrize("baud", [9600, 19200])
def test_over_a_pty_a_stray_character_before_a_paced_request_costs_it_nothing(
    baud: int, stray: bytes
) -> None:
    """A master in a process of its own, on pyserial, writes a stray character, keeps 6
    character times of silence and writes the request one character at a time: the answer
    comes. A machine too loaded to read the stray character before the request comes hands
    both over in one read, where no pause can be seen: it may try three times."""
    pytest.importorskip("serial")
    args = [str(SERIAL_WRITER), "", str(baud), stray.hex(), "6", READ_P52.hex()]
    with LineSim(engine(5, "generic", "3,2"), baud=baud, line="pty") as sim:
        args[1] = sim.path
        for _ in range(3):
            done = subprocess.run(
                [sys.executable, *args], capture_output=True, text=True, timeout=30, check=True
            )
            answer = json.loads(done.stdout)["answer"]
            if answer:
                break
    assert answer == ANSWER_P52
