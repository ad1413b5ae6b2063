"""``uss write`` when the answer to the write never comes: it says the outcome is unknown, and
``--verify`` reads the value back to tell whether the drive took it.

The simulated drive sits on a virtual bus served on raw TCP (another thread); the line goes bad
the moment the master's write telegram is on it: either the master hears nothing for a while
(the drive takes the write, its answers are lost) or the drive does (it never gets it)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from pyuss.bus.core import WireChar
from pyuss.cli.main import main
from pyuss.protocol.layout import Layout
from support.buses import SimulatorThread
from support.limits import limit_writes

GAP = 1.5  # character times: a longer idle gap starts a new telegram


def _on_write_telegram(sim: SimulatorThread, act: Callable[[float], None]) -> None:
    """Call ``act`` (on the bus's loop) once, when the PKE of the master's first "write word"
    telegram to address 5 goes over the line (its fourth character), with that character's
    end: what is done takes effect from there on the line's time."""
    state = {"position": 0, "end": 0.0, "address": -1, "done": False}

    def watch(char: WireChar) -> None:
        if state["done"] or char.sender.startswith("drive"):
            return
        assert sim.bus is not None
        if char.start - float(state["end"]) > GAP * sim.bus.char_time:
            state["position"] = 0
        state["end"] = char.end
        position = int(state["position"])
        state["position"] = position + 1
        if position == 2:
            state["address"] = char.byte
        elif position == 3 and state["address"] == 5 and char.byte >> 4 == 2:
            state["done"] = True
            act(char.end)

    sim.call(lambda s: s.bus.on_char.append(watch))


def _uss(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _port(sim: SimulatorThread) -> list[str]:
    return ["--port", sim.paths[0], "--baud", str(sim.baud), "--layout", "3,2"]


def test_a_lost_answer_is_an_unknown_outcome_and_verify_finds_it_applied(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        _on_write_telegram(sim, lambda at: sim.bus.make_deaf(sim.station(), 0.5, start=at))  # type: ignore[union-attr]
        code, out, err = _uss(capsys, "write", "5", "18", "0x7000", "--timeout", "0.3", *_port(sim))
        assert code == 1 and not out
        assert "may have carried it out" in err and "--verify" in err
        assert len(err.splitlines()) == 1
        assert sim.call(lambda s: s.engines[5].drive.value(18)) == 0x7000  # it did

    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        _on_write_telegram(sim, lambda at: sim.bus.make_deaf(sim.station(), 0.5, start=at))  # type: ignore[union-attr]
        argv = ["write", "5", "18", "0x7000", "--verify", "--timeout", "0.4", *_port(sim)]
        code, out, err = _uss(capsys, *argv)
        assert code == 0, err
        assert out.startswith("P18 = 28672")
        assert out.strip().endswith("(its answer was lost; read back: the drive holds it)")


def test_verify_tells_a_write_the_drive_never_got(capsys: pytest.CaptureFixture[str]) -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        _on_write_telegram(sim, lambda at: sim.bus.make_deaf("drive5", 0.5, start=at))  # type: ignore[union-attr]
        argv = ["write", "5", "18", "0x7000", "--verify", "--timeout", "0.4", *_port(sim), "--json"]
        code, out, err = _uss(capsys, *argv)
        assert code == 1 and not err
        data = json.loads(out)
        assert (data["address"], data["pnu"]) == (5, 18)
        error = data["error"]
        assert error["type"] == "JobTimeout" and error["exit_code"] == 1
        assert error["outcome"] == "not_applied" and error["may_have_applied"] is False
        assert "did not carry it out" in error["message"]
        assert sim.call(lambda s: s.engines[5].drive.value(18)) == 0


def test_json_says_how_the_value_is_known(capsys: pytest.CaptureFixture[str]) -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        code, out, _ = _uss(capsys, "write", "5", "18", "5", *_port(sim), "--json")
        assert code == 0
        data = json.loads(out)
        assert (data["address"], data["pnu"], data["value"]) == (5, 18, 5)
        assert data["outcome"] == "answered"
        _on_write_telegram(sim, lambda at: sim.bus.make_deaf(sim.station(), 0.5, start=at))  # type: ignore[union-attr]
        argv = ["write", "5", "18", "7", "--timeout", "0.3", *_port(sim), "--json"]
        code, out, _ = _uss(capsys, *argv)
        error = json.loads(out)["error"]
        assert code == 1 and error["outcome"] == "unknown" and error["may_have_applied"] is True
        assert error["sent"] >= 1 and error["timeout"] == 0.3


def _limits_p18(sim: SimulatorThread, highest: int) -> None:
    """The drive holds at most ``highest`` in P18 and answers a write with what it holds, as
    drives that limit or round a value do."""

    def patch(s: SimulatorThread) -> None:
        limit_writes(s.engines[5].drive, 18, highest)

    sim.call(patch)


def test_a_write_answered_with_another_value_is_not_done(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        _limits_p18(sim, 1000)
        code, out, err = _uss(
            capsys, "write", "5", "18", "5000", *_port(sim), "--profile", "generic"
        )
        assert code == 1, out
        assert out.strip() == "P18 = 1000 (Fixed setpoint)"  # what the drive holds
        assert err.startswith("uss write: P18 (Fixed setpoint): the drive answered 1000, not")
        assert "5000" in err and len(err.splitlines()) == 1
        code, out, err = _uss(capsys, "write", "5", "18", "5000", "--raw", *_port(sim), "--json")
        assert code == 1 and not err
        data = json.loads(out)
        assert data["raw"] == [1000] and data["written"] == [5000]
        assert data["error"]["type"] == "ValueDiffers" and data["error"]["exit_code"] == 1
        code, out, _ = _uss(capsys, "write", "5", "18", "700", *_port(sim))
        assert (code, out.strip()) == (0, "P18 = 700 (02BCh)")


def test_a_restore_answered_with_another_value_says_so(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        port = [*_port(sim), "--profile", "generic"]
        assert _uss(capsys, "write", "5", "18", "5000", *port)[0] == 0
        backup = str(tmp_path / "b.json")
        assert _uss(capsys, "backup", "5", "-o", backup, *port)[0] == 1  # 32 bits: not in PKW 3
        assert _uss(capsys, "write", "5", "18", "0", *port)[0] == 0
        _limits_p18(sim, 1000)
        code, out, err = _uss(capsys, "restore", "5", backup, "--yes", *port)
        assert code == 1, out + err
        assert "P18 (Fixed setpoint): the drive answered 1000, not 5000: it holds another" in out
        assert "refused" not in out
        assert out.strip().endswith("drive 5: 0 of 1 written, 1 answered with another value")
        code, out, _ = _uss(capsys, "diff", "5", backup, *port)
        assert code == 1 and "P18 (Fixed setpoint): 1000 -> 5000" in out


def test_verify_of_a_drive_that_limits_the_value_does_not_say_it_did_nothing(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the answer to "P18 = 5000" is lost; the drive took the write and holds 1000: reading
    # back shows another value, which is no proof that the write was not carried out
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        _limits_p18(sim, 1000)
        _on_write_telegram(sim, lambda at: sim.bus.make_deaf(sim.station(), 0.5, start=at))  # type: ignore[union-attr]
        argv = ["write", "5", "18", "5000", "--verify", "--timeout", "0.4", *_port(sim)]
        code, out, err = _uss(capsys, *argv)
        assert code == 1 and not out
        assert "reading it back shows 1000 (3E8h): the drive does not hold the value" in err
        assert "or it holds a value of its own (it limits or rounds)" in err
        assert sim.call(lambda s: s.engines[5].drive.value(18)) == 1000
