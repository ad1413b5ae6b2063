"""``--json`` on every command: one error object (type, message, exit code and details), the
same whether the command failed, was given bad input or refused its arguments; wall-clock
ISO 8601 times."""

from __future__ import annotations

import argparse
import datetime
import json
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from cli.test_run_output import KEYS as RUN_KEYS
from monitor.test_cli import EXCHANGE_KEYS
from pyuss.cli.main import build_parser, main
from pyuss.protocol.layout import Layout
from support.buses import SimulatorThread

ERROR_KEYS = {"type", "message", "exit_code"}


def _json_commands() -> list[str]:
    """Every command and sub-action that takes ``--json``, as words (``bass read``)."""
    found: list[str] = []

    def walk(parser: argparse.ArgumentParser, words: list[str]) -> None:
        if any("--json" in action.option_strings for action in parser._actions):
            found.append(" ".join(words))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, [*words, name])

    walk(build_parser(), [])
    return found


COMMANDS = _json_commands()
STREAMS = {"run": RUN_KEYS, "monitor": EXCHANGE_KEYS}


def _uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exit:
        code = int(exit.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def _error(out: str) -> dict[str, object]:
    (line,) = out.splitlines()
    error = json.loads(line)["error"]
    assert isinstance(error, dict) and set(error) >= ERROR_KEYS
    return error


def test_the_commands_with_json_are_the_ones_this_file_covers() -> None:
    assert set(COMMANDS) == {
        *("scan", "read", "write", "describe", "mirror", "run", "monitor", "decode"),
        *("params", "backup", "diff", "restore", "status", "ack", "log"),
        *("bass read", "bass write"),
    }


@pytest.mark.parametrize("command", COMMANDS)
def test_arguments_the_parser_refuses_are_a_json_error_too(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _uss(capsys, *command.split(), "--no-such-option", "--json")
    assert code == 2 and not err
    error = _error(out)
    if command in STREAMS:  # a line of the stream: its keys, and the error
        assert set(json.loads(out)) == STREAMS[command]
    assert error["type"] == "UsageError" and error["exit_code"] == 2
    assert str(error["message"]).startswith(f"uss {command}: ")
    code, _, err = _uss(capsys, *command.split(), "--no-such-option")
    assert code == 2 and err.startswith("usage: ")  # without --json: argparse's usage lines


@pytest.mark.parametrize(
    "command",
    [
        *("scan --address 5", "read 5 52", "write 5 18 1", "describe 5 52", "mirror 5"),
        *("params 5", "backup 5 -o b.toml", "status 5", "ack 5", "log 5 status -o l.csv"),
    ],
)
def test_a_port_that_cannot_be_opened(
    command: str,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = [*command.split(), "--port", "/dev/nonexistent-uss-port"]
    code, out, err = _uss(capsys, *argv, "--json")
    assert code == 1 and not err
    error = _error(out)
    assert error["type"] == "TransportError" and error["exit_code"] == 1
    assert "cannot open" in str(error["message"])


@pytest.mark.parametrize("command", ["diff 5 none.toml", "restore 5 none.toml --yes"])
def test_a_file_that_cannot_be_read(
    command: str,
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = [*command.split(), "--port", "/dev/nonexistent-uss-port", "--json"]
    code, out, err = _uss(capsys, *argv)
    assert code == 2 and not err
    error = _error(out)
    assert error["type"] == "ConfigError" and "none.toml" in str(error["message"])


@pytest.fixture(scope="module")
def sim() -> Iterator[list[str]]:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as simulator:
        yield ["--port", simulator.paths[0], "--baud", str(simulator.baud), "--layout", "3,2"]


def test_read_puts_the_error_object_into_the_parameter_it_concerns(
    sim: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _uss(capsys, "read", "5", "52", "999", *sim, "--json")
    assert code == 1 and not err
    data = json.loads(out)
    good, bad = data["parameters"]
    assert (good["pnu"], good["index"], good["value"], good.get("error")) == (
        52,
        None,
        0x4000,
        None,
    )
    assert bad["error"] == {
        "type": "DriveRefusal",
        "message": "drive refused the job (P999): error 0: illegal parameter number"
        "; check the parameter number and the drive's profile: this drive has no such parameter",
        "exit_code": 1,
        "number": 0,
        "meaning": "illegal parameter number",
    }
    code, out, _ = _uss(capsys, "read", "5", "5x", *sim, "--json")
    assert code == 2 and _error(out)["type"] == "ConfigError" and "5x" in _error(out)["message"]


def test_describe_mirror_and_scan_failures(
    sim: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = _uss(capsys, "describe", "5", "52", "--element", "255", *sim, "--json")
    data = json.loads(out)
    assert code == 1 and (data["address"], data["pnu"]) == (5, 52)
    assert data["error"]["type"] == "DriveRefusal" and data["error"]["number"] == 103
    code, out, _ = _uss(capsys, "mirror", "9", *sim, "--json")
    (attempt,) = json.loads(out)["tries"]
    assert code == 1 and attempt["ok"] is False
    assert attempt["error"]["type"] == "NotSending" and attempt["error"]["address"] == 9
    code, out, _ = _uss(capsys, "mirror", "5", "--data", "zz", *sim, "--json")
    assert code == 2 and _error(out) == {
        "type": "ConfigError",
        "message": "--data 'zz' is not hex",
        "exit_code": 2,
    }
    code, out, _ = _uss(capsys, "scan", *sim[:2], "--address", "30-40", "--json")
    assert code == 2 and "0..31" in str(_error(out)["message"])


def test_a_timeout_says_what_is_known_of_the_job(
    sim: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = _uss(capsys, "write", "9", "18", "1", *sim, "--timeout", "0.3", "--json")
    error = json.loads(out)["error"]
    assert code == 1 and error["type"] == "JobTimeout"
    assert error["outcome"] == "not_sent" and error["may_have_applied"] is False
    assert error["sent"] == 0 and error["timeout"] == 0.3 and error["elapsed"] >= 0.3


# -- uss monitor ------------------------------------------------------------------------------


def test_monitor_errors_are_lines_of_its_stream(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _uss(capsys, "monitor", "--read", str(tmp_path / "none.pcapng"), "--json")
    assert code == 2 and not err
    (line,) = [json.loads(text) for text in out.splitlines()]
    assert set(line) == EXCHANGE_KEYS
    assert (
        line["error"]["type"] == "ConfigError" and "cannot read capture" in line["error"]["message"]
    )
    datetime.datetime.fromisoformat(line["time"])


@pytest.mark.posix("time.tzset")
def test_monitor_times_are_wall_clock(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from monitor.test_cli import _capture

    monkeypatch.setenv("TZ", "UTC")
    time.tzset()
    try:
        path = tmp_path / "line.pcapng"
        _capture(path)  # frames 100 s after the Unix epoch
        assert main(["monitor", "--read", str(path), "--json"]) == 0
        lines = [json.loads(text) for text in capsys.readouterr().out.splitlines()]
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()
    assert [line["time"] for line in lines] == [
        "1970-01-01T00:01:40.010000+00:00",
        "1970-01-01T00:01:40.040042+00:00",
        "1970-01-01T00:01:40.070083+00:00",
    ]
    assert lines[0]["t"] == 0.0 and lines[1]["t"] == pytest.approx(0.030042, abs=1e-6)
    assert all(line["error"] is None for line in lines)
