"""Recorded traffic of the virtual bus, with seeded faults, decoded by the monitor: every field
of clean exchanges and every error class (A 5.2.2, A 5.2.1.1, A 3, A 5.3)."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from monitor.traffic import (
    REQ_52,
    Line,
    Slave,
    answer,
    decode,
    echo_job,
    request,
    run_line,
)
from pyuss.bus import Fault, FaultKind, FaultPlan
from pyuss.monitor import Direction, Exchange, LayoutBook, LayoutSource, Problem, exchange_line
from pyuss.protocol import AddressMode, Layout, Pkw, Telegram, bcc
from pyuss.protocol.layout import PKW_VARIABLE
from pyuss.protocol.timing import char_time

BAUD = 38400
TC = char_time(BAUD)
GIVEN = LayoutBook(Layout(3, 2))


def _problems(exchanges: Sequence[Exchange]) -> list[list[tuple[str, str]]]:
    return [[(i.problem.value, i.where) for i in ex.issues] for ex in exchanges]


async def _line(requests: Sequence[bytes], slaves: Sequence[Slave], **kw: object) -> Line:
    return await run_line(requests, slaves, baud=BAUD, **kw)  # type: ignore[arg-type]


async def test_clean_exchanges_every_field() -> None:
    jobs = [REQ_52, request(5, Pkw(2, 18, values=(0x7000,))), request(5, Pkw(0), 0x047F, 0x2000)]
    line = await _line(jobs, [Slave(5)])
    exchanges, monitor = decode(line, layouts=LayoutBook(Layout(3, 2)))
    assert [ex.kind for ex in exchanges] == ["exchange"] * 3
    assert _problems(exchanges) == [[], [], []]
    for ex, raw in zip(exchanges, jobs, strict=True):
        assert ex.address == 5
        assert ex.request is not None and ex.answer is not None
        assert ex.request.raw == raw
        assert ex.request.direction is Direction.REQUEST and ex.request.guessed
        assert ex.answer.direction is Direction.RESPONSE and ex.answer.guessed
        assert ex.layout == Layout(3, 2) and ex.layout_source is LayoutSource.GIVEN
        assert ex.unsure == ""
        assert ex.delay is not None
        # A 5.2.1.1: after at least a start pause, within 20 ms (the slave waits 2 ms).
        assert 2 * TC <= ex.delay <= 0.020
        assert ex.request.end - ex.request.start == pytest.approx(14 * TC, abs=1e-9)
    first, second, third = exchanges
    assert first.request_data is not None and first.answer_data is not None
    assert first.request_data.pkw == Pkw(1, 52, values=(0,))
    assert first.request_data.pzd == (0x047E, 0)
    assert first.answer_data.pkw == Pkw(1, 52, values=(1234,))
    assert first.answer_data.pzd == (0x0231, 0x1000)
    assert first.control_before is None and first.status_before is None
    assert second.request_data is not None and second.request_data.pkw == Pkw(
        2, 18, values=(0x7000,)
    )
    assert second.control_before == 0x047E and second.status_before == 0x0231
    assert third.request_data is not None and third.request_data.pzd == (0x047F, 0x2000)
    assert third.answer_data is not None and third.answer_data.pkw == Pkw(0, values=(0,))
    summary = monitor.summary.addresses[5]
    assert (summary.requests, summary.answers, summary.no_answer) == (3, 3, 0)
    assert summary.diagnostics.good == 6 and summary.diagnostics.discarded == 0
    assert summary.delays.count == 3


async def test_layouts_are_inferred_and_say_when_guessing() -> None:
    jobs = [REQ_52, request(5, Pkw(1, 53)), request(5, Pkw(0), 0x047F)]
    line = await _line(jobs, [Slave(5)])
    exchanges, _ = decode(line)
    assert [ex.layout for ex in exchanges] == [Layout(3, 2)] * 3
    # One exchange is not enough evidence: a guess; then the evidence is clear.
    assert [ex.layout_source for ex in exchanges] == [
        LayoutSource.GUESSED,
        LayoutSource.INFERRED,
        LayoutSource.INFERRED,
    ]
    assert exchanges[1].request_data is not None
    assert exchanges[1].request_data.pkw == Pkw(1, 53, values=(0,))


FAULT_CASES = [
    # (fault, expected problems of the exchanges)
    (Fault(FaultKind.FLIP, station="slave", nth=19), [[], [("parity", "answer")]]),
    (Fault(FaultKind.FLIP, station="slave", nth=20, bits=2), [[], [("bcc", "answer")]]),
    (Fault(FaultKind.FRAMING, station="slave", nth=28), [[], [("framing", "answer")]]),
    # A damaged request: the slave must not answer it (A 5.2.2), so no "no answer".
    (Fault(FaultKind.PARITY, station="master", nth=17), [[], [("parity", "request")], []]),
    # A dropped character: the telegram never completes (A 5.2.1.2).
    (Fault(FaultKind.DROP, station="master", nth=20), [[], [("residual_time", "request")], []]),
    # A gap of 3 characters inside a telegram looks like a start pause (A 5.1.2): the first
    # part is incomplete, the rest starts without STX.
    (
        Fault(FaultKind.STRETCH, station="master", nth=19, gap=3),
        [[], [("residual_time", "request")], [("no_stx", "request")], []],
    ),
    # An inserted character after ADR: LGE counts wrong, so the BCC fails, and one byte is left.
    (
        Fault(FaultKind.INSERT, station="master", nth=17, byte=0x00),
        [[], [("bcc", "request")], [("no_stx", "request")], []],
    ),
]


@pytest.mark.parametrize(("fault", "expected"), FAULT_CASES, ids=lambda v: getattr(v, "kind", ""))
async def test_receive_faults_are_classified(
    fault: Fault, expected: list[list[tuple[str, str]]]
) -> None:
    jobs = [REQ_52, request(5, Pkw(1, 53)), request(5, Pkw(1, 54))]
    line = await _line(jobs, [Slave(5)], faults=FaultPlan([fault]), seed=7)
    exchanges, monitor = decode(line, layouts=GIVEN)
    got = _problems(exchanges)
    assert got[: len(expected)] == expected
    assert all(not p for p in got[len(expected) :])
    damaged = next(ex for ex in exchanges if ex.issues)
    kind = damaged.issues[0].problem.fault
    assert kind is not None
    counters = monitor.summary.line.diagnostics.snapshot(0)
    assert counters.discarded >= 1
    assert counters.error_status & kind.status
    assert not any(Problem.NO_ANSWER in ex.problems for ex in exchanges)


async def test_same_document_same_faults() -> None:
    plan = FaultPlan([Fault(FaultKind.FLIP, probability=0.02)])
    jobs = [request(5, Pkw(1, n)) for n in range(30, 40)]
    a = await _line(jobs, [Slave(5)], faults=plan, seed=3)
    b = await _line(jobs, [Slave(5)], faults=plan, seed=3)
    ea, _ = decode(a, layouts=GIVEN)
    eb, _ = decode(b, layouts=GIVEN)
    assert _problems(ea) == _problems(eb)
    assert any(_problems(ea))


async def test_no_answer_and_deaf_slave() -> None:
    def silent_for_99(tg: Telegram) -> bytes | None:
        job = Layout(3, 2).unpack(tg.data).pkw
        return None if job is not None and job.pnu == 99 else echo_job()(tg)

    jobs = [REQ_52, request(5, Pkw(1, 99)), request(5, Pkw(1, 53), 0x047F)]
    line = await _line(jobs, [Slave(5, silent_for_99)])
    exchanges, monitor = decode(line, layouts=GIVEN)
    assert [ex.kind for ex in exchanges] == ["exchange", "request", "exchange"]
    assert _problems(exchanges) == [[], [("no_answer", "exchange")], []]
    assert "did not answer within 20.000 ms" in exchanges[1].issues[0].text
    stats = monitor.summary.addresses[5]
    assert stats.no_answer == 1 and stats.diagnostics.timeout == 1
    assert stats.diagnostics.status & 0x80  # A 5.2.3 bit 7: response delay exceeded

    deaf = FaultPlan([Fault(FaultKind.DEAF, station="slave", at=0, duration=3600)])
    line = await _line(jobs[:2], [Slave(5)], faults=deaf)
    exchanges, _ = decode(line, layouts=GIVEN)
    assert _problems(exchanges) == [[("no_answer", "exchange")]] * 2


async def test_late_answer_on_two_wires_is_a_guess() -> None:
    late = FaultPlan([Fault(FaultKind.DELAY, station="slave", nth=2, seconds=0.03)])
    jobs = [REQ_52, request(5, Pkw(1, 53)), request(5, Pkw(1, 54))]
    line = await _line(jobs, [Slave(5)], faults=late)
    exchanges, monitor = decode(line, layouts=GIVEN)
    assert [ex.kind for ex in exchanges] == ["exchange"] * 3
    assert _problems(exchanges) == [[], [("late_answer", "answer")], []]
    assert exchanges[1].delay is not None and exchanges[1].delay > 0.030
    assert "late answer" in exchanges[1].unsure
    assert monitor.summary.addresses[5].late == 1


async def test_answer_from_the_wrong_address() -> None:
    def as_six(tg: Telegram) -> bytes:
        return answer(6, Pkw(1, 52, values=(7,)))

    line = await _line([REQ_52], [Slave(5, as_six)])
    (ex,) = decode(line, layouts=GIVEN)[0]
    assert _problems([ex]) == [[("wrong_address", "answer")]]
    assert ex.answer is not None and ex.answer.address == 6 and ex.address == 5
    assert "taken as a wrong answer" in ex.unsure


async def test_bad_lengths_addresses_and_starts() -> None:
    long_job = Telegram(5, AddressMode.NORMAL, Layout(4, 2).pack(Pkw(1, 52), (0x047E, 0)))
    frame = bytes.fromhex("02 0C 65 10 34 00 00 00 00 04 7E 00 00")  # ADR bits 011: undefined
    bad_adr = frame + bytes([bcc(frame)])
    jobs = [REQ_52, long_job.encode(), bad_adr, b"\xff\x00\x13", request(5, Pkw(1, 53))]

    def fixed_only(tg: Telegram) -> bytes | None:
        return echo_job()(tg) if len(tg.data) == 10 else None

    line = await _line(jobs, [Slave(5, fixed_only)])
    exchanges, monitor = decode(line, layouts=GIVEN)
    assert [ex.kind for ex in exchanges] == ["exchange", "request", "noise", "noise", "exchange"]
    assert _problems(exchanges) == [
        [],
        [("bad_lge", "request")],
        [("bad_adr", "request")],
        [("no_stx", "request")],
        [],
    ]
    assert "3 bytes: FF 00 13  !! no_stx: first character after the start pause is FFh" in (
        exchange_line(exchanges[3])
    )
    # The telegram with the wrong length is still decoded as far as its bytes go.
    assert exchanges[1].request is not None and exchanges[1].request.address == 5
    counters = monitor.summary.line.diagnostics
    assert (counters.bad_lge, counters.no_stx, counters.discarded) == (1, 1, 3)


async def test_mirror_and_broadcast() -> None:
    mirror = bytes.fromhex("02 0C 47 10 01 00 00 00 00 04 7E 12 34 04")  # vector mirror_request
    broadcast = bytes.fromhex("02 0E 20 00 05 00 00 00 00 00 00 00 00 20 00 09")
    line = await _line([mirror, broadcast, REQ_52], [Slave(7), Slave(5)])
    exchanges, _ = decode(line, layouts=LayoutBook(Layout(3, 2), {0: Layout(4, 2)}))
    assert [ex.kind for ex in exchanges] == ["exchange", "request", "exchange"]
    assert _problems(exchanges) == [[], [], []]
    assert exchanges[0].answer is not None and exchanges[0].answer.raw == mirror
    assert exchanges[1].mode is AddressMode.BROADCAST and exchanges[1].answer is None


async def test_mirror_answer_that_differs() -> None:
    mirror = bytes.fromhex("02 0C 47 10 01 00 00 00 00 04 7E 12 34 04")

    def other(tg: Telegram) -> bytes:
        return Telegram(7, AddressMode.MIRROR, tg.data[:-1] + b"\x35").encode()

    line = await _line([mirror], [Slave(7, other, mirror=False)])
    (ex,) = decode(line, layouts=GIVEN)[0]
    assert _problems([ex]) == [[("mirror", "answer")]]


async def test_four_wire_direction_by_port() -> None:
    jobs = [REQ_52, request(5, Pkw(1, 99)), request(5, Pkw(1, 53))]

    def silent_for_99(tg: Telegram) -> bytes | None:
        job = Layout(3, 2).unpack(tg.data).pkw
        return None if job is not None and job.pnu == 99 else echo_job()(tg)

    line = await _line(jobs, [Slave(5, silent_for_99)], four_wire=True)
    exchanges, _ = decode(line, layouts=GIVEN)
    assert [ex.kind for ex in exchanges] == ["exchange", "request", "exchange"]
    assert _problems(exchanges) == [[], [("no_answer", "exchange")], []]
    for ex in (exchanges[0], exchanges[2]):
        assert ex.request is not None and ex.answer is not None
        assert (ex.request.port, ex.answer.port) == (0, 1)
        assert not ex.request.guessed and not ex.answer.guessed
        assert ex.unsure == ""


async def test_four_wire_late_wrong_and_unexpected_answers() -> None:
    broadcast = bytes.fromhex("02 0E 20 00 05 00 00 00 00 00 00 00 00 20 00 09")

    def reply(tg: Telegram) -> bytes | None:
        if tg.mode.is_broadcast:
            return answer(5, Pkw(0))
        job = Layout(3, 2).unpack(tg.data).pkw
        assert job is not None
        return answer(9 if job.pnu == 60 else 5, Pkw(1, job.pnu, values=(1,)))

    late = FaultPlan([Fault(FaultKind.DELAY, station="slave", nth=1, seconds=0.03)])
    jobs = [REQ_52, request(5, Pkw(1, 60)), broadcast, request(5, Pkw(1, 61))]
    line = await _line(
        jobs,
        [Slave(5, reply, broadcasts=True)],
        four_wire=True,
        faults_rx=late,
    )
    exchanges, monitor = decode(line, layouts=LayoutBook(Layout(3, 2), {0: Layout(4, 2)}))
    assert [ex.kind for ex in exchanges] == [
        "exchange",
        "exchange",
        "request",
        "answer",
        "exchange",
    ]
    assert _problems(exchanges) == [
        [("late_answer", "answer")],
        [("wrong_address", "answer")],
        [],
        [("unexpected", "answer")],
        [],
    ]
    assert all(ex.unsure == "" for ex in exchanges)
    assert "after a broadcast" in exchanges[3].issues[0].text
    assert monitor.summary.line.unexpected == 1


@pytest.mark.parametrize("pause", [0, 3], ids=["glued", "pause"])
async def test_a_stray_character_before_the_answer_does_not_shift_the_pairing(
    pause: int,
) -> None:
    # A slave's driver switching on can put a character on an RS-485 line before the answer;
    # glued to the answer (no start pause) or apart from it (a stretched gap).
    def glitch(tg: Telegram) -> bytes | None:
        data = echo_job()(tg)
        return None if data is None else b"\xff" + data

    jobs = [REQ_52, request(5, Pkw(1, 53)), request(5, Pkw(1, 54), 0x047F)]
    plan = FaultPlan(
        [Fault(FaultKind.STRETCH, station="slave", gap=pause, nth=2 + 15 * n) for n in range(3)]
        if pause
        else []
    )
    line = await _line(jobs, [Slave(5, glitch)], faults=plan)
    exchanges, monitor = decode(line)
    assert [ex.kind for ex in exchanges] == ["exchange", "noise"] * 3
    for ex, pnu in zip(exchanges[::2], (52, 53, 54), strict=True):
        assert ex.request_data is not None and ex.answer_data is not None
        assert ex.request_data.pkw == Pkw(1, pnu, values=(0,))
        assert ex.answer_data.pkw == Pkw(1, pnu, values=(1234,))
        assert ex.answer_data.pzd == (0x0231, 0x1000)
        assert ex.unsure == "" and ex.notes == ()
        # Glued, the master's receiver sees no start pause before STX (A 5.1.2).
        assert _problems([ex]) == [[] if pause else [("no_stx", "answer")]]
    for noise in exchanges[1::2]:
        assert noise.request is not None and noise.request.raw == b"\xff"
        assert noise.problems == (Problem.NO_STX,)
    # Control and status words are followed through (a damaged answer's status is not).
    assert exchanges[4].control_before == 0x047E
    assert exchanges[4].status_before == (0x0231 if pause else None)
    assert monitor.summary.addresses[5].no_answer == 0
    assert [ex.layout for ex in exchanges[::2]] == [Layout(3, 2)] * 3


async def test_noise_alone_within_the_response_delay_is_the_damaged_answer() -> None:
    def garbled(tg: Telegram) -> bytes | None:
        return b"\xff\xfe\xfd"

    line = await _line([REQ_52, request(5, Pkw(1, 53))], [Slave(5, garbled)])
    exchanges, monitor = decode(line, layouts=GIVEN)
    assert [ex.kind for ex in exchanges] == ["exchange", "exchange"]
    assert _problems(exchanges) == [[("no_stx", "answer")]] * 2
    assert exchanges[1].request is not None
    assert exchanges[1].request.raw == request(5, Pkw(1, 53))
    assert exchanges[1].answer is not None and exchanges[1].answer.raw == b"\xff\xfe\xfd"
    assert monitor.summary.addresses[5].no_answer == 0


async def test_answer_to_a_broadcast_on_two_wires() -> None:
    broadcast = bytes.fromhex("02 0E 20 00 05 00 00 00 00 00 00 00 00 20 00 09")

    def reply(tg: Telegram) -> bytes | None:
        if tg.mode.is_broadcast:
            return answer(5, Pkw(0), 0x0231)  # a fault: no slave answers a broadcast (A 3)
        return echo_job(0x0231)(tg)

    jobs = [REQ_52, broadcast, request(5, Pkw(1, 53)), broadcast, request(5, Pkw(1, 54))]
    line = await _line(jobs, [Slave(5, reply, broadcasts=True)])
    exchanges, monitor = decode(line, layouts=LayoutBook(Layout(3, 2), {0: Layout(4, 2)}))
    assert [(ex.kind, ex.address) for ex in exchanges] == [
        ("exchange", 5),
        ("request", 0),
        ("answer", 5),
        ("exchange", 5),
        ("request", 0),
        ("answer", 5),
        ("exchange", 5),
    ]
    unexpected = [("unexpected", "answer")]
    assert _problems(exchanges) == [[], [], unexpected, [], [], unexpected, []]
    assert "after a broadcast" in exchanges[2].issues[0].text
    assert "taken as an answer" in exchanges[2].unsure
    assert exchanges[3].request_data is not None
    assert exchanges[3].request_data.pkw == Pkw(1, 53, values=(0,))
    assert monitor.summary.line.unexpected == 2
    assert monitor.summary.addresses[5].no_answer == 0


async def test_net_data_that_do_not_fit_the_layout() -> None:
    # Address 5 is given the variable layout with 2 PZD (PKE, IND, a PWE and 2 PZD at least,
    # C 4.1.2); address 6 is inferred. A telegram of 4 words cannot be read with the first,
    # one of 7 bytes with no layout at all (net data are words, A 4).
    short = Telegram(5, AddressMode.NORMAL, bytes(8)).encode()
    odd = Telegram(6, AddressMode.NORMAL, bytes(7)).encode()
    line = await _line([REQ_52, short, odd], [Slave(5, lambda tg: None)])
    layouts = LayoutBook(None, {5: Layout(PKW_VARIABLE, 2)})
    exchanges, _ = decode(line, layouts=layouts)
    assert [(ex.address, ex.problems) for ex in exchanges] == [
        (5, (Problem.NO_ANSWER,)),
        (5, (Problem.NO_ANSWER, Problem.LAYOUT)),
        (6, (Problem.NO_ANSWER, Problem.LAYOUT)),
    ]
    assert "4 net data words do not fit layout v,2" in exchanges[1].issues[1].text
    assert exchanges[2].issues[1].text == "7 net bytes are not whole words (A 4)"
    # What cannot be decoded is shown as bytes, and the problem is highlighted.
    text = exchange_line(exchanges[1])
    assert "adr 5     v,2    data 00 00 00 00 00 00 00 00  !! no_answer" in text
    assert "; layout: 4 net data words" in text
