"""The engine without I/O: any input is answered by the rules or ignored, never with an error."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pyuss.drive import SimulatedDrive
from pyuss.errors import ConfigError
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import JobLatency, SlaveEngine

CASES = [
    ("generic", Layout(127, 2)),
    ("baumueller", Layout(4, 3)),
    ("micromaster4", Layout(3, 2)),
    ("6se21", Layout(3, 2)),
    ("nord", Layout(127, 4)),
]


def _engine(profile: str, layout: Layout) -> SlaveEngine:
    prof = get_profile(profile)
    return SlaveEngine(5, SimulatedDrive(prof.database()), prof, layout=layout)


ENGINES = {name: _engine(name, layout) for name, layout in CASES}


def _numbers(profile: str) -> list[int]:
    """PKE parameter bits worth trying: the file's parameters, the slave's diagnostic
    parameters and one that does not exist."""
    prof = get_profile(profile)
    numbers = {p.pnu for p in prof.database()} | {999}
    numbers |= set(range(prof.diagnostic_pnu, prof.diagnostic_pnu + 18))
    return sorted({n % 2048 for n in numbers})


NUMBERS = {name: _numbers(name) for name, _ in CASES}


@pytest.mark.parametrize(("profile", "layout"), CASES)
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_any_job_gets_an_answer_of_the_layout(
    profile: str, layout: Layout, data: st.DataObject
) -> None:
    engine = ENGINES[profile]
    words = layout.max_pwe if layout.variable else layout.pkw - 2
    count = data.draw(st.integers(1, min(words, 12))) if layout.variable else words
    pkw = Pkw(
        data.draw(st.integers(0, 15)),
        data.draw(st.sampled_from(NUMBERS[profile])),
        data.draw(st.one_of(st.integers(0, 0xFFFF), st.sampled_from([0, 1, 2, 255, 0x8001]))),
        data.draw(st.booleans()),
        tuple(data.draw(st.lists(st.integers(0, 0xFFFF), min_size=count, max_size=count))),
    )
    pzd = data.draw(st.lists(st.integers(0, 0xFFFF), min_size=layout.pzd, max_size=layout.pzd))
    telegram = Telegram(5, AddressMode.NORMAL, layout.pack(pkw, pzd))
    answer = engine.handle(telegram, data.draw(st.floats(0, 1e6)))
    assert answer is not None
    net = layout.unpack(answer.data)
    assert len(net.pzd) == layout.pzd
    assert net.pkw is not None


@settings(max_examples=300, deadline=None)
@given(raw=st.binary(max_size=40), adr=st.integers(0, 255))
def test_random_bytes_are_ignored_or_answered_never_raised(raw: bytes, adr: int) -> None:
    engine = ENGINES["generic"]
    head = bytes((0x02, len(raw) + 2, adr)) + raw
    checksum = 0
    for byte in head:
        checksum ^= byte
    for frame in (head + bytes((checksum,)), raw):
        answer = engine.handle_bytes(frame, 0.0)
        if answer is not None:
            assert adr in (5, 0x45)  # only normal and mirror telegrams to address 5


def test_bad_settings_are_refused() -> None:
    profile = get_profile("generic")
    drive = SimulatedDrive(profile.database())
    with pytest.raises(ConfigError, match=r"0\.\.31"):
        SlaveEngine(32, drive, profile)
    with pytest.raises(ConfigError, match="failure time"):
        SlaveEngine(5, drive, profile, failure_time=-1)
    with pytest.raises(ConfigError, match="job latency"):
        JobLatency(cycles=-1)
    with pytest.raises(ConfigError, match="collide with P51"):
        SlaveEngine(5, drive, profile, diagnostic_pnu=40)
    with pytest.raises(ConfigError, match="do not fit"):
        SlaveEngine(5, drive, profile, diagnostic_pnu=2040)


def test_a_repeated_request_is_answered_with_the_values_of_now() -> None:
    # the engine keeps the last request and answer: the same bytes again must still be
    # answered from the drive as it is now, not from the kept answer
    prof = get_profile("generic")
    layout = Layout(3, 2)
    engine = SlaveEngine(5, SimulatedDrive(prof.database()), prof, layout=layout)
    engine.handle(Telegram(5, AddressMode.NORMAL, layout.pack(None, (0x047E, 0))), 0.0)
    data = layout.pack(Pkw(1, 2), (0x047F, 0x2000))  # read P2, the actual frequency
    seen = []
    for t in (0.0, 0.0, 1.0, 1.0, 2.0, 30.0, 30.0):
        answer = engine.handle(Telegram.decode(Telegram(5, AddressMode.NORMAL, data).encode()), t)
        assert answer is not None
        net = layout.unpack(answer.data)
        assert net.pkw == Pkw(1, 2, 0, False, (engine.drive.value(2),))
        assert net.pzd == (engine.drive.status_word(), engine.drive.actual_value())
        seen.append(net.pkw.values[0])
    assert seen == [0, 0, 500, 500, 1000, 2500, 2500]  # 10 s ramp to 25.00 Hz
    # a value changed by another interface while the process data stay the same
    read = Telegram(5, AddressMode.NORMAL, layout.pack(Pkw(1, 18), (0x047F, 0x2000)))
    for value in (7, 7, 9):
        engine.drive.write(18, value)
        answer = engine.handle(read, 31.0)
        assert answer is not None
        assert layout.unpack(answer.data).pkw == Pkw(1, 18, 0, False, (value,))
