"""Recording the wire as JSON lines, reading it back and replaying it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pyuss.bus import Fault, FaultKind, FaultPlan, Recorder, VirtualBus, load_recording, replay
from pyuss.errors import ConfigError
from pyuss.transport.base import Chunk, LineError
from transport.helpers import byte_ends, flat_errors, joined, read_bytes

REQUEST = bytes.fromhex("02 0C 05 10 34 00 00 00 00 04 7E 00 00 55")
RESPONSE = bytes.fromhex("02 0C 05 10 34 00 00 40 00 02 31 00 00 5C")


async def _exchange(bus: VirtualBus) -> list[Chunk]:
    """Request and response; what a monitor received."""
    async with (
        bus.attach("master") as master,
        bus.attach("slave") as slave,
        bus.attach("monitor", listen_only=True) as monitor,
    ):
        await master.write(REQUEST)
        await read_bytes(slave, len(REQUEST))
        await slave.write(RESPONSE)
        await read_bytes(master, len(RESPONSE))
        return await read_bytes(monitor, 28)


async def test_recording_file_holds_every_character_and_reads_back(tmp_path: Path) -> None:
    path = tmp_path / "wire.jsonl"
    plan = FaultPlan([Fault(FaultKind.PARITY, station="slave", nth=2)])
    bus = VirtualBus(19200, faults=plan, seed=3)
    recorder = Recorder(path).attach(bus)
    seen = await _exchange(bus)
    assert not path.exists()  # written under a temporary name until complete
    recorder.close()
    await bus.close()
    assert path.exists()
    assert list(tmp_path.iterdir()) == [path]
    lines = path.read_text().splitlines()
    header = json.loads(lines[0])
    assert header == {"format": "pyuss-bus-recording", "version": 1, "baud": 19200, "seed": 3}
    assert len(lines) == 1 + 28
    second = json.loads(lines[16])
    assert second["from"] == "slave" and second["byte"] == "0c"
    assert second["flags"] == ["PARITY"] and second["notes"] == ["parity"]
    recording = load_recording(path)
    assert recording.baud == 19200 and recording.seed == 3
    assert [r.byte for r in recording.records] == list(REQUEST + RESPONSE)
    # What the monitor received, as the recording tells it (timestamps relative to the start).
    replayed = recording.chunks()
    assert joined(replayed) == joined(seen)
    assert flat_errors(replayed) == flat_errors(seen)
    assert replayed[-1].timestamp + bus.epoch == pytest.approx(seen[-1].timestamp, abs=1e-6)
    # What the master heard: its own request left out.
    assert joined(recording.chunks("master")) == RESPONSE


async def test_replay_puts_the_same_characters_with_the_same_spacing_on_a_bus() -> None:
    bus = VirtualBus(38400, faults=FaultPlan([Fault(FaultKind.FRAMING, nth=5)]))
    recorder = Recorder().attach(bus)
    seen = await _exchange(bus)
    await bus.close()
    again = VirtualBus(38400)
    async with again.attach("monitor", listen_only=True) as monitor:
        await replay(recorder.recording(), again)
        replayed = await read_bytes(monitor, 28)
    await again.close()
    assert joined(replayed) == joined(seen)
    assert flat_errors(replayed) == [(4, LineError.FRAMING)]
    # Chunking may differ with delivery; the end of each byte is what must agree.
    ours = byte_ends(replayed, 38400)
    theirs = byte_ends(seen, 38400)
    offset = ours[0] - theirs[0]
    assert [t - offset for t in ours] == pytest.approx(theirs, abs=1e-6)


async def test_replay_needs_the_same_baud() -> None:
    bus = VirtualBus(9600)
    recorder = Recorder().attach(bus)
    with pytest.raises(ConfigError, match="9600"):
        await replay(recorder.recording(), VirtualBus(19200))


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ("", "empty file"),
        ('{"format": "other"}\n', "not a bus recording"),
        ('{"format": "pyuss-bus-recording", "version": 9, "baud": 9600}\n', "version 9"),
        (
            '{"format": "pyuss-bus-recording", "version": 1, "baud": 1}\n',
            "1 is not a USS baud rate",
        ),
        (
            '{"format": "pyuss-bus-recording", "version": 1, "baud": 9600}\n'
            '{"t": 0.1, "from": "m", "byte": "zz", "flags": []}\n',
            ":2: bad record",
        ),
        (
            '{"format": "pyuss-bus-recording", "version": 1, "baud": 9600}\n'
            '{"t": 0.1, "from": "m", "byte": "02", "flags": ["LOUD"]}\n',
            "LOUD",
        ),
    ],
)
def test_bad_recording_files_name_file_and_line(tmp_path: Path, content: str, words: str) -> None:
    path = tmp_path / "bad.jsonl"
    path.write_text(content)
    with pytest.raises(ConfigError, match=words):
        load_recording(path)


_HEAD = '{"format": "pyuss-bus-recording", "version": 1, "baud": 19200}\n'
_FIRST = '{"t": 0.001, "start": 0.0004, "from": "m", "byte": "02", "flags": []}\n'


@pytest.mark.parametrize(
    ("record", "words"),
    [
        ('{"t": -Infinity, "start": 0.0011, "from": "m", "byte": "0c"}', "t -inf is not a finite"),
        ('{"t": Infinity, "start": 0.0011, "from": "m", "byte": "0c"}', "t inf is not a finite"),
        ('{"t": NaN, "start": 0.0011, "from": "m", "byte": "0c"}', "t nan is not a finite"),
        ('{"t": 0.0017, "start": NaN, "from": "m", "byte": "0c"}', "start nan is not a finite"),
        ('{"t": 1e300, "start": 0.0011, "from": "m", "byte": "0c"}', r"t 1e\+300 is out of range"),
        ('{"t": "0.0017", "start": 0.0011, "from": "m", "byte": "0c"}', "is not a number"),
        ('{"t": 0.0005, "start": 0.0011, "from": "m", "byte": "0c"}', "start 0.0011 is after t"),
        ('{"t": 0.0009, "start": 0.0003, "from": "m", "byte": "0c"}', "out of time order"),
    ],
)
def test_times_that_are_not_finite_or_out_of_order_are_refused(
    tmp_path: Path, record: str, words: str
) -> None:
    # A byte with such a time vanished from a replay, or ended in an OverflowError.
    path = tmp_path / "wire.jsonl"
    path.write_text(_HEAD + _FIRST + record + "\n")
    with pytest.raises(ConfigError, match=words) as info:
        load_recording(path)
    assert str(info.value).startswith(f"{path}:3: ")


def test_missing_recording_file() -> None:
    with pytest.raises(ConfigError, match="cannot read recording"):
        load_recording("/nonexistent/wire.jsonl")


async def test_discarded_recording_leaves_nothing(tmp_path: Path) -> None:
    bus = VirtualBus(9600)
    recorder = Recorder(tmp_path / "wire.jsonl").attach(bus)
    recorder.discard()
    assert list(tmp_path.iterdir()) == []
