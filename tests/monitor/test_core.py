"""The monitor core on lines with exact, chosen timing: the spec's vectors, timing rules,
framing on real ports, merging two ports, and pairing properties."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.traffic import REQ_52, Wire, answer, request
from pyuss.errors import ConfigError
from pyuss.monitor import Direction, Exchange, LayoutBook, LayoutSource, Monitor, Problem
from pyuss.monitor.render import exchange_line, summary_table
from pyuss.protocol import Layout, Pkw, Receiver, Telegram
from pyuss.protocol.layout import PKW_VARIABLE
from pyuss.protocol.timing import char_time, start_pause
from pyuss.transport.base import LineError
from support.paths import load_vectors

VECTORS = load_vectors("uss")["telegrams"]
BAUD = 19200
TC = char_time(BAUD)


def _layout(vector: dict[str, object]) -> Layout:
    spec = vector["layout"]
    assert isinstance(spec, dict)
    pkw = PKW_VARIABLE if spec["pkw"] == "variable" else int(spec["pkw"])
    return Layout(pkw, int(spec["pzd"]))


_BY_NAME = {v["name"]: v for v in VECTORS}
_ANSWERS = {"mirror_request": "mirror_request", "read_whole_pbe_request": "read_whole_pbe_refused"}
PAIRS = [
    (v, _BY_NAME[_ANSWERS.get(v["name"], v["name"].removesuffix("_request") + "_response")])
    for v in VECTORS
    if v["name"].endswith("_request")
]
EXPECTED_TEXT = {
    "read_word_request": "read P52 -> P52 = 16384 (4000h)",
    "read_whole_pbe_request": "read P52 description[all] -> REFUSED error 103: device-specific",
    "read_pbe_element_request": "read P52 description[7] -> P52 description[7] = 5FFFh",
    "write_array_dword_request": "write P4[2] = 1073741824 (40000000h) -> P4[2] = 1073741824",
    "write_word_pkw4_request": "write P18 = 28672 (7000h) -> P18 = 28672 (7000h)",
    "read_text_request": "read text P7[3] -> text P7[3] = '300 BAUD'",
    "pzd_only_request": "CW 047Fh(ON NO_OFF2",
    "mirror_request": "mirrored",
}


@pytest.mark.parametrize(("req", "ans"), PAIRS, ids=[a["name"] for a, _ in PAIRS])
def test_spec_vectors_pair_and_decode(req: dict[str, str], ans: dict[str, str]) -> None:
    layout = _layout(req)
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(layout)))
    wire.send(bytes.fromhex(req["hex"]), 0.01)
    wire.send(bytes.fromhex(ans["hex"]), 0.005)
    (ex,) = wire.finish()
    assert ex.kind == "exchange" and ex.issues == () and ex.unsure == ""
    assert ex.address == int(req["adr"]) & 0x1F
    assert ex.delay == pytest.approx(0.005)
    assert ex.request is not None and ex.request.raw == bytes.fromhex(req["hex"])
    assert ex.answer is not None and ex.answer.raw == bytes.fromhex(ans["hex"])
    line = exchange_line(ex)
    assert EXPECTED_TEXT[req["name"]] in line
    assert "5.000 ms" in line
    if ex.request_data is not None and ex.request_data.pkw is not None:
        words = [int(w, 16) for w in req["words_hex"]]
        assert ex.request_data.pkw.pke == words[0]
        assert ex.request_data.pkw.index == words[1]


def test_refusal_and_spontaneous_answers_in_words() -> None:
    by_name = {v["name"]: bytes.fromhex(v["hex"]) for v in VECTORS}
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    wire.send(request(5, Pkw(1, 999)), 0.01)
    wire.send(by_name["error_illegal_pnu"], 0.003)
    wire.send(REQ_52, 0.01)
    wire.send(by_name["spontaneous_word"], 0.003)
    first, second = wire.finish()
    assert "REFUSED error 0: illegal parameter number" in exchange_line(first)
    assert "spontaneous P52 = 291 (0123h)" in exchange_line(second)
    assert second.notes == ("spontaneous message (C 4.2.1.2)",)


def test_changed_control_and_status_bits() -> None:
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(0, 2))))
    for control, status in ((0x047E, 0x0231), (0x047F, 0x0237), (0x047F, 0x0237)):
        wire.send(_pzd_only(5, control, 0x2000), 0.01)
        wire.send(_pzd_only(5, status, 0x1FFF), 0.003)
    first, second, third = wire.finish()
    assert "CW 047Eh(NO_OFF2 NO_OFF3" in exchange_line(first)
    assert "CW 047Fh(+ON)" in exchange_line(second)
    assert "SW 0237h(+READY +OPERATION_ENABLED)" in exchange_line(second)
    assert "SP 50.00%" in exchange_line(second) and "AV 49.99%" in exchange_line(second)
    assert "CW 047Fh " in exchange_line(third) and "(+" not in exchange_line(third)


def _pzd_only(address: int, word: int, value: int) -> bytes:
    return Telegram(address, 0, Layout(0, 2).pack(None, (word, value))).encode()


def test_answer_without_start_pause_is_decoded_but_flagged() -> None:
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    wire.send(REQ_52, 0.01)
    wire.send(answer(5, Pkw(1, 52, values=(1,))), 0.5 * TC)  # half a character: no pause
    (ex,) = wire.finish()
    assert ex.kind == "exchange"
    assert [(i.problem, i.where) for i in ex.issues] == [
        (Problem.NO_STX, "answer"),
        (Problem.EARLY_ANSWER, "answer"),
    ]
    assert ex.answer_data is not None and ex.answer_data.pkw == Pkw(1, 52, values=(1,))
    assert "no start pause" in ex.issues[0].text


def test_master_that_does_not_wait_is_told_from_a_wrong_answer() -> None:
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    for address in (3, 4):  # history: control and status words of both addresses
        wire.send(request(address, Pkw(0), 0x047F), 0.01)
        wire.send(answer(address, Pkw(0), 0x0237), 0.003)
    wire.send(request(3, Pkw(0), 0x047F), 0.01)  # slave 3 is silent, the master waits 8 ms
    wire.send(request(4, Pkw(0), 0x047F), 0.008)
    wire.send(answer(4, Pkw(0), 0x0237), 0.003)
    out = wire.finish()
    assert [(ex.kind, ex.address, ex.problems) for ex in out[2:]] == [
        ("request", 3, (Problem.NO_ANSWER,)),
        ("exchange", 4, ()),
    ]
    assert out[2].notes == ("the master sent its next telegram before the response delay limit",)
    # Without that history the same telegram is taken as a wrong answer, and says it guesses.
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    wire.send(request(3, Pkw(0), 0x047F), 0.01)
    wire.send(request(4, Pkw(0), 0x047F), 0.008)
    first = wire.finish()[0]
    assert first.problems == (Problem.WRONG_ADDRESS,) and first.unsure


def test_early_answer_on_four_wires() -> None:
    wire = Wire(Monitor(BAUD, four_wire=True, layouts=LayoutBook(Layout(3, 2))))
    wire.send(REQ_52, 0.01, port=0)
    wire.send(answer(5, Pkw(1, 52)), 0.2 * TC, port=1)
    (ex,) = wire.finish()
    assert ex.problems == (Problem.EARLY_ANSWER,)
    assert "sooner than the start pause" in ex.issues[0].text


def test_response_limit_never_below_the_start_pause() -> None:
    monitor = Monitor(300)
    assert monitor.response_limit == pytest.approx(start_pause(300))  # 73.3 ms > 20 ms
    assert Monitor(19200, response_limit=0.05).response_limit == 0.05


def test_real_port_gap_keeps_bursty_telegrams_whole() -> None:
    # Timestamps of a USB adapter: bytes arrive in bursts, stamped up to ~1 ms late.
    monitor = Monitor(BAUD, gap=0.002, layouts=LayoutBook(Layout(3, 2)))
    t = 10.0
    out: list[Exchange] = []
    for data, stamp in (
        (REQ_52[:5], t + 5 * TC + 0.0009),
        (REQ_52[5:11], t + 11 * TC + 0.0002),
        (REQ_52[11:], t + 14 * TC + 0.0011),
    ):
        out += monitor.feed(data, stamp)
    # The answer 1.5 ms after the request: more than the start pause, less than the gap.
    t2 = t + 14 * TC + 0.0015
    ans = answer(5, Pkw(1, 52, values=(9,)))
    out += monitor.feed(ans, t2 + len(ans) * TC)
    out += monitor.finish()
    (ex,) = out
    assert ex.issues == ()
    assert ex.answer is not None and ex.answer.raw == ans
    # With the spec's start pause the same stamps cut the request apart.
    strict = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    cut: list[Exchange] = []
    for data, stamp in ((REQ_52[:5], t + 5 * TC), (REQ_52[5:], t + 14 * TC + 0.003)):
        cut += strict.feed(data, stamp)
    cut += strict.finish()
    assert Problem.RESIDUAL_TIME in [p for ex in cut for p in ex.problems]


def _feed_in_bursts(
    monitor: Monitor, data: bytes, pauses: dict[int, float], t: float = 50.0
) -> tuple[list[Exchange], float]:
    """Feed ``data`` from ``t`` on, as bursts split where ``pauses`` (byte position: seconds
    of idle line before it) say; the exchanges and the end of the last byte."""
    out: list[Exchange] = []
    for a, b in itertools.pairwise([0, *sorted(pauses), len(data)]):
        t += pauses.get(a, 0.0) + (b - a) * TC
        out += monitor.feed(data[a:b], t)
    return out, t


ANS_2 = answer(5, Pkw(1, 52, values=(2,)))


def _cut_request_then_answer(
    monitor: Monitor, pauses: dict[int, float], delay: float
) -> list[Exchange]:
    """REQ_52 in bursts (`_feed_in_bursts`), ANS_2 ``delay`` seconds later, the end."""
    out, t = _feed_in_bursts(monitor, REQ_52, pauses)
    out += monitor.feed(ANS_2, t + delay + len(ANS_2) * TC)
    return out + monitor.finish()


@pytest.mark.parametrize(
    ("cuts", "pause", "whole"),
    [
        ([5], 0.003, True),  # one late burst: joined again
        ([3, 9], 0.0021, True),  # two of them
        ([5], 0.015, False),  # longer than the residual time allows (A 6.3): a real fault
    ],
)
def test_telegrams_cut_by_port_timestamps_are_joined(
    cuts: list[int], pause: float, whole: bool
) -> None:
    monitor = Monitor(BAUD, gap=0.002, layouts=LayoutBook(Layout(3, 2)))
    pauses = dict.fromkeys(cuts, pause)
    out = _cut_request_then_answer(monitor, pauses, 0.004)
    if whole:
        (ex,) = out
        assert ex.issues == () and ex.request is not None and ex.request.raw == REQ_52
        assert ex.request.start == pytest.approx(50.0)
    else:
        assert [p for ex in out for p in ex.problems][:2] == [
            Problem.RESIDUAL_TIME,
            Problem.NO_STX,
        ]
    # Exact timestamps (the virtual bus) never join: the pause was on the line.
    exact = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    cut, _ = _feed_in_bursts(exact, REQ_52, pauses)
    cut += exact.finish()
    assert Problem.RESIDUAL_TIME in [p for ex in cut for p in ex.problems]


@pytest.mark.parametrize(
    ("pauses", "whole"),
    [
        ({13: 0.004}, True),  # the last byte late
        ({7: 0.0045, 13: 0.0045}, False),  # longer than residual time + resolution (A 6.3)
    ],
)
def test_a_telegram_the_port_stamped_late_runs_into_the_answer(
    pauses: dict[int, float], whole: bool
) -> None:
    # A port that delivers bytes of a telegram late, each burst less than the gap after the
    # last, and the answer right after: the receiver finds the residual time exceeded
    # (A 5.2.1.2) and runs on into the answer. Within the timing resolution (gap less start
    # pause) that is the port's doing; beyond it, a fault on the line.
    monitor = Monitor(BAUD, gap=0.005, layouts=LayoutBook(Layout(3, 2)))
    out = _cut_request_then_answer(monitor, pauses, 0.003)
    ans = ANS_2
    if whole:
        (ex,) = out
        assert ex.kind == "exchange" and ex.issues == ()
        assert ex.request is not None and ex.request.raw == REQ_52
        assert ex.answer is not None and ex.answer.raw == ans
        assert ex.answer_data is not None and ex.answer_data.pkw == Pkw(1, 52, values=(2,))
    else:
        assert out[0].problems[0] is Problem.RESIDUAL_TIME
        assert out[0].request is not None and out[0].request.raw == REQ_52 + ans


def test_gap_shorter_than_the_start_pause_is_refused() -> None:
    with pytest.raises(ConfigError, match="shorter than the start pause"):
        Monitor(BAUD, gap=0.0005)
    with pytest.raises(ConfigError, match="gap must be a positive"):
        Monitor(BAUD, gap=-1)
    with pytest.raises(ConfigError, match="port 2"):
        Monitor(BAUD).feed(b"\x02", 1.0, port=2)


def test_four_wire_ports_are_merged_by_time_whatever_the_arrival_order() -> None:
    monitor = Monitor(BAUD, four_wire=True, layouts=LayoutBook(Layout(3, 2)))
    req_end = 5.0 + 14 * TC
    ans = answer(5, Pkw(1, 52, values=(4,)))
    ans_end = req_end + 0.004 + 14 * TC
    # The answer's port delivers first (its reader ran first), then the request's.
    assert monitor.feed(ans, ans_end, port=1) == []
    assert monitor.feed(REQ_52, req_end, port=0) == []  # the answer may still be before it?
    out = monitor.advance(ans_end + 0.001)
    (ex,) = out
    assert ex.kind == "exchange" and ex.delay == pytest.approx(0.004)
    assert ex.request is not None and ex.request.direction is Direction.REQUEST


def test_open_telegram_holds_off_no_answer() -> None:
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    assert monitor.feed(REQ_52, 1.0) == []
    ans = answer(5, Pkw(1, 52))
    # The answer starts 19 ms after the request, in time; its last bytes come later.
    first_end = 1.0 + 0.019 + 4 * TC
    assert monitor.feed(ans[:4], first_end) == []
    now = first_end + 0.5 * TC
    assert now > 1.0 + 0.020
    assert monitor.advance(now) == []  # past 20 ms, but a telegram is open
    out = monitor.feed(ans[4:], first_end + 10 * TC)
    (ex,) = out
    assert ex.issues == () and ex.delay == pytest.approx(0.019)


def test_advance_reports_no_answer_after_the_late_limit() -> None:
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)), late_limit=0.1)
    monitor.feed(REQ_52, 1.0)
    assert monitor.advance(1.09) == []
    (ex,) = monitor.advance(1.11)
    assert ex.problems == (Problem.NO_ANSWER,)


def test_receiver_events_of_the_caller() -> None:
    rx = Receiver(BAUD)
    events = rx.feed(REQ_52, 2.0) + rx.feed(answer(5, Pkw(0)), 2.01) + rx.poll(3.0)
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    out = monitor.add_events(events) + monitor.finish()
    assert [ex.kind for ex in out] == ["exchange"]


def test_layout_book_parse() -> None:
    book = LayoutBook.parse(["3,2", "7=v,0", "1+2=4,1"])
    assert book.given(5) == Layout(3, 2)
    assert book.given(7) == Layout(PKW_VARIABLE, 0)
    assert book.given(2) == Layout(4, 1)
    assert book.fixed_lengths()[5] == 12 and 7 not in book.fixed_lengths()
    for bad, words in (
        (["3,2", "4,2"], "given twice"),
        (["40=3,2"], "not a slave address"),
        (["x=3,2"], "not a slave address"),
        (["1=3,2", "1=4,2"], "twice"),
        (["3,3,3"], "bad layout"),
    ):
        with pytest.raises(ConfigError, match=words):
            LayoutBook.parse(bad)


@pytest.mark.parametrize(
    ("names", "layout"),
    [
        (["read_word", "read_pbe_element", "error_illegal_pnu"], Layout(3, 2)),
        (["write_array_dword", "write_word_pkw4"], Layout(4, 0)),
        (["read_text"], Layout(PKW_VARIABLE, 0)),
        (["pzd_only"], Layout(0, 2)),
    ],
)
def test_layout_inference_on_the_vectors(names: list[str], layout: Layout) -> None:
    by_name = {v["name"]: bytes.fromhex(v["hex"]) for v in VECTORS}
    wire = Wire(Monitor(BAUD))
    for name in names:
        reply = by_name.get(f"{name}_response", by_name.get(name))
        job = by_name.get(f"{name}_request", REQ_52)
        assert reply is not None
        wire.send(job, 0.01)
        wire.send(reply, 0.003)
    out = wire.finish()
    assert out[-1].layout == layout
    # Several exchanges give clear evidence; a single one only when no other layout fits.
    assert out[-1].layout_source is LayoutSource.INFERRED


def test_an_address_with_little_evidence_borrows_the_bus_layout() -> None:
    wire = Wire(Monitor(BAUD))
    for pnu in (52, 53):
        wire.send(request(5, Pkw(1, pnu)), 0.01)
        wire.send(answer(5, Pkw(1, pnu, values=(1,))), 0.003)
    # Address 6 answers an array read with an unfitting ID: on its own, 0,5 would win.
    wire.send(request(6, Pkw(6, 4, 2)), 0.01)
    wire.send(answer(6, Pkw(1, 4, values=(1,))), 0.003)
    *_, six = wire.finish()
    assert six.address == 6
    assert (six.layout, six.layout_source) == (Layout(3, 2), LayoutSource.GUESSED)
    assert "3,2?" in exchange_line(six)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(0, 31),
            st.integers(0, 2047),
            st.sampled_from(["answer", "none", "late", "glitch"]),
            st.floats(2.2, 15.0),
        ),
        min_size=1,
        max_size=12,
    )
)
def test_two_wire_pairing_property(
    script: list[tuple[int, int, str, float]],
) -> None:
    """Requests and answers with chosen gaps: each in-time answer pairs with its request, also
    after a stray character on the line (a driver switching on), each silent slave is
    reported as not answering, each late one as late."""
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    expected: list[tuple[int | None, str, float]] = []
    for address, pnu, what, delay_tc in script:
        wire.send(request(address, Pkw(1, pnu), 0x047E + (address & 1)), 0.08)
        reply = answer(address, Pkw(1, pnu, values=(pnu ^ 0x5555,)))
        expected.append((address, what, delay_tc))
        if what == "answer":
            wire.send(reply, delay_tc * TC)
        elif what == "late":
            wire.send(reply, 0.035)
        elif what == "glitch":
            wire.send(b"\xff", delay_tc * TC)
            wire.send(reply, 3 * TC)
            expected.append((None, "noise", 0.0))
    out = wire.finish()
    assert [(ex.address, ex.kind) for ex in out] == [
        (address, {"none": "request", "noise": "noise"}.get(what, "exchange"))
        for address, what, _ in expected
    ]
    for ex, (_, what, delay_tc) in zip(out, expected, strict=True):
        if what == "answer":
            assert ex.issues == ()
            assert ex.delay == pytest.approx(delay_tc * TC)
        elif what == "none":
            assert ex.problems == (Problem.NO_ANSWER,)
        elif what == "late":
            assert ex.problems == (Problem.LATE_ANSWER,)
            assert ex.unsure
        elif what == "glitch":
            assert ex.issues == () and ex.unsure == ""
            assert ex.delay == pytest.approx((delay_tc + 4) * TC)  # FF, 3 idle characters
        else:
            assert ex.problems == (Problem.NO_STX,)


def test_stray_character_before_an_answer_on_four_wires() -> None:
    wire = Wire(Monitor(BAUD, four_wire=True, layouts=LayoutBook(Layout(3, 2))))
    wire.send(REQ_52, 0.01, port=0)
    wire.send(b"\x00", 0.002, port=1)
    wire.send(answer(5, Pkw(1, 52, values=(7,))), 3 * TC, port=1)
    wire.send(request(5, Pkw(1, 53)), 0.01, port=0)
    wire.send(b"\x00", 0.002, port=1)  # this time nothing follows: the answer, damaged
    out = wire.finish()
    assert [(ex.kind, ex.problems) for ex in out] == [
        ("exchange", ()),
        ("noise", (Problem.NO_STX,)),
        ("exchange", (Problem.NO_STX,)),
    ]
    assert out[0].answer_data is not None and out[0].answer_data.pkw == Pkw(1, 52, values=(7,))
    assert out[1].request is not None and out[1].request.port == 1


def test_per_minute_rates_fall_when_the_line_goes_quiet() -> None:
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    assert monitor.now is None
    wire = Wire(monitor)
    for pnu in range(5):
        wire.send(request(5, Pkw(1, pnu)), 0.01)
        wire.send(answer(5, Pkw(1, pnu, values=(1,))), 0.003)
    assert monitor.now == pytest.approx(wire.t)
    row = monitor.summary.rows(monitor.now)[0]
    assert row["counters"]["good_per_minute"] == 10  # A 5.2.3 parameter 5
    monitor.advance(wire.t + 61)  # a minute of silence: the live runner says time passed
    assert monitor.now == pytest.approx(wire.t + 61)
    row = monitor.summary.rows(monitor.now)[0]
    assert row["counters"]["good_per_minute"] == 0 and row["counters"]["good"] == 10


def test_line_errors_a_port_flags_are_receive_faults() -> None:
    # A 5.2.2: characters the port flagged (overrun, parity, framing) make the telegram a
    # fault of that kind; A 5.2.3 counts them and latches the status bits 1, 2 and 0.
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    t = 10.0
    out: list[Exchange] = []
    for error in (LineError.OVERRUN, LineError.PARITY, LineError.FRAMING):
        t += 0.05 + len(REQ_52) * TC
        out += monitor.feed(REQ_52, t, [(6, error)])
    out += monitor.finish()
    assert [ex.problems for ex in out] == [
        (Problem.OVERRUN,),
        (Problem.PARITY,),
        (Problem.FRAMING,),
    ]
    for ex in out:  # damaged, and still shown as far as the bytes go
        assert ex.kind == "request" and ex.request_data is not None
        assert ex.request_data.pkw == Pkw(1, 52, values=(0,))
    for stats in (monitor.summary.line, monitor.summary.addresses[5]):
        counters = stats.diagnostics.snapshot(t)
        assert (counters.overrun, counters.parity, counters.framing) == (1, 1, 1)
        assert counters.error_status == 0x07
        assert counters.discarded == 3 and counters.timeout == 0  # damaged: no answer due


def test_response_time_statistics_and_error_rate() -> None:
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    wire = Wire(monitor)
    for ms in range(2, 21):  # response delays 2..20 ms (A 5.2.1.1)
        wire.send(request(5, Pkw(1, ms)), 0.03)
        wire.send(answer(5, Pkw(1, ms, values=(ms,))), ms / 1000)
    wire.send(request(5, Pkw(1, 99)), 0.03)
    bad = bytearray(answer(5, Pkw(1, 99, values=(1,))))
    bad[-1] ^= 0x01
    wire.send(bytes(bad), 0.005)
    out = wire.finish()
    assert len(out) == 20 and out[-1].problems == (Problem.BCC,)
    stats = monitor.summary.addresses[5]
    times = stats.delays.as_dict()
    assert times == {
        "count": 20,
        "min_ms": 2.0,
        "mean_ms": pytest.approx((sum(range(2, 21)) + 5) / 20, abs=1e-3),
        "p95_ms": 19.0,  # nearest rank: the 19th of the 20 sorted (5 ms twice)
        "max_ms": 20.0,
    }
    assert stats.error_rate == pytest.approx(1 / 40)  # one discarded frame of 40
    row = summary_table(monitor.summary, wire.t).splitlines()[1]
    assert row.split()[8] == "2.5" and row.endswith("2.00/10.70/19.00/20.00")


def test_noise_then_the_master_repeating_its_request() -> None:
    # A garbled answer, and the master repeats the request at once: the noise was the answer.
    wire = Wire(Monitor(BAUD, layouts=LayoutBook(Layout(3, 2))))
    wire.send(REQ_52, 0.01)
    wire.send(b"\xff\xfe\xfd", 0.002)
    wire.send(REQ_52, 0.005)
    wire.send(answer(5, Pkw(1, 52, values=(1,))), 0.002)
    out = wire.finish()
    assert [(ex.kind, ex.problems) for ex in out] == [
        ("exchange", (Problem.NO_STX,)),
        ("exchange", ()),
    ]
    assert out[0].answer is not None and out[0].answer.raw == b"\xff\xfe\xfd"
    assert out[1].answer_data is not None and out[1].answer_data.pkw == Pkw(1, 52, values=(1,))


def test_a_late_telegram_in_a_run_of_telegrams_keeps_the_run() -> None:
    # A port with coarse timestamps (gap 15 ms) on a busy machine: the request stalls after 9
    # bytes for longer than its residual time, and answer, next request and its answer all
    # follow within the gap, so the receiver sees one run. The request was whole within its
    # residual time plus the resolution: each telegram is cut out and paired, none is lost.
    monitor = Monitor(BAUD, gap=0.015, layouts=LayoutBook(Layout(3, 2)))
    out, t = _feed_in_bursts(monitor, REQ_52, {9: 0.008})
    second = request(5, Pkw(1, 53))
    for data, pause in ((ANS_2, 0.004), (second, 0.010), (answer(5, Pkw(1, 53)), 0.004)):
        t += pause + len(data) * TC
        out += monitor.feed(data, t)
    out += monitor.finish()
    assert [ex.kind for ex in out] == ["exchange", "exchange"]
    assert [ex.request.raw for ex in out if ex.request] == [REQ_52, second]
    assert out[0].answer is not None and out[0].answer.raw == ANS_2


ANS_52_1 = answer(5, Pkw(1, 52, values=(1,)))


@given(
    cut=st.integers(1, len(REQ_52) + len(ANS_52_1) - 1),
    pause=st.floats(0.0, 0.01),
    late=st.floats(0.0, 0.015),
)
@settings(max_examples=200, deadline=None)
def test_response_delays_on_ports_that_stamp_when_read_are_never_negative(
    cut: int, pause: float, late: float
) -> None:
    """On a pty or a USB adapter (stamps up to the tolerance late) the reads may cut the line
    anywhere: a response delay is never negative, and where the stamps cannot show the pause
    (the answer read together with the end of its request) it is unknown and says why."""
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)), tolerance=0.02)
    line = REQ_52 + ANS_52_1
    ends = [100.0 + (i + 1) * TC + (pause if i >= len(REQ_52) else 0.0) for i in range(len(line))]
    out = monitor.feed(line[:cut], ends[cut - 1] + late)
    out += monitor.feed(line[cut:], max(ends[-1], ends[cut - 1] + late))
    out += monitor.finish()
    (ex,) = out
    assert ex.kind == "exchange"
    line_text = exchange_line(ex)
    assert "-0.000 ms" not in line_text
    if ex.delay is None:
        assert ex.notes[0].startswith("delay unknown: the port delivered the answer together")
        assert "delay unknown" in line_text
        assert monitor.summary.addresses[5].delays.as_dict()["count"] == 0
    else:
        assert ex.delay > 0


def test_an_answer_read_with_its_request_has_an_unknown_delay() -> None:
    monitor = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)), tolerance=0.02)
    out = monitor.feed(REQ_52 + ANS_52_1, 100.0)  # one read: the pause is not seen
    (ex,) = out + monitor.finish()
    assert ex.delay is None and not ex.issues
    assert "resolution 20.000 ms" in ex.notes[0]
    # on exact timestamps (the virtual bus) the same bytes are an answer without a pause
    exact = Monitor(BAUD, layouts=LayoutBook(Layout(3, 2)))
    (ex,) = exact.feed(REQ_52 + ANS_52_1, 100.0) + exact.finish()
    assert ex.delay == 0.0 and Problem.EARLY_ANSWER in ex.problems


def test_four_wire_stamps_that_put_the_answer_first_give_no_delay() -> None:
    """Each port of a 4-wire line stamps its bytes when it reads them: a request read late can
    seem to end after its answer began. That is no delay and no early answer."""
    monitor = Monitor(BAUD, four_wire=True, layouts=LayoutBook(Layout(3, 2)), tolerance=0.02)
    out = monitor.feed(REQ_52, 100.0 + 0.012, port=0)  # read 12 ms late
    out += monitor.feed(ANS_52_1, 100.0 + 0.013, port=1)  # its first byte seems earlier
    (ex,) = out + monitor.finish()
    assert ex.kind == "exchange" and ex.delay is None and not ex.issues
    assert ex.notes[0].startswith("delay unknown: the answer's stamps put its start")
