"""``uss run``: what it says when the drive does not stop in time, and its JSON lines (the same
keys on every line, wall-clock ISO 8601 times, failures as one more line)."""

from __future__ import annotations

import datetime
import json
from collections.abc import Iterator

import pytest

from pyuss.cli.main import main
from pyuss.protocol.layout import Layout
from support.buses import SimulatorThread

KEYS = {
    "time",
    "address",
    "setpoint",
    "state",
    "status",
    "status_hex",
    "actual",
    "unit",
    "actual_percent",
    "actual_raw",
    "control",
    "error",
}


@pytest.fixture
def slow_to_stop() -> Iterator[list[str]]:
    """A drive that ramps up in 0.1 s and down in 60 s; yields the port options."""
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:

        def ramps(s: SimulatorThread) -> None:
            s.engines[5].drive.write(462, 1)
            s.engines[5].drive.write(464, 600)

        sim.call(ramps)
        yield ["--port", sim.paths[0], "--baud", str(sim.baud), "--layout", "3,2"]


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["run", "5", "--setpoint", "50", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_drive_that_answers_but_does_not_stop_in_time_is_named_as_such(
    slow_to_stop: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["--duration", "0.5", "--stop-timeout", "0.5", *slow_to_stop]
    code, _, err = _run(capsys, *argv)
    assert code == 1, err
    assert "no answer" not in err
    assert "slave 5: did not reach the stopped state after OFF1" in err
    assert "within 0.5 s: it reports status word" in err and "operation enabled" in err


def test_json_lines_have_the_same_keys_and_wall_clock_times(
    slow_to_stop: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    before = datetime.datetime.now(datetime.UTC)
    argv = ["--duration", "0.5", "--stop-timeout", "0.5", "--interval", "0.1", *slow_to_stop]
    code, out, err = _run(capsys, *argv, "--json")
    after = datetime.datetime.now(datetime.UTC)
    assert code == 1 and not err
    lines = [json.loads(line) for line in out.splitlines()]
    assert len(lines) >= 3
    assert all(set(line) == KEYS for line in lines)
    for line in lines:
        moment = datetime.datetime.fromisoformat(line["time"])
        assert moment.tzinfo is not None  # ISO 8601 with the UTC offset
        assert before - datetime.timedelta(seconds=1) <= moment <= after
    failures = [line for line in lines if line["error"] is not None]
    assert len(failures) == 1
    error = failures[0]["error"]
    assert error["type"] == "StatusTimeout" and error["exit_code"] == 1
    assert "did not reach the stopped state" in error["message"]
    assert failures[0]["state"] == "operation enabled"


def test_json_bad_input_is_a_line_of_the_stream_too(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, "--port", "/dev/null", "--duration", "-1", "--json")
    assert code == 2 and not err
    (line,) = [json.loads(text) for text in out.splitlines()]
    assert set(line) == KEYS and line["status"] is None
    assert line["error"]["type"] == "ConfigError" and line["error"]["exit_code"] == 2
    code, out, err = _run(capsys, "--port", "/dev/nonexistent-uss-port", "--json")
    assert code == 1 and not err
    (line,) = [json.loads(text) for text in out.splitlines()]
    assert set(line) == KEYS and "cannot open" in line["error"]["message"]
