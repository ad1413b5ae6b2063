"""``uss run`` and ``uss status`` against drives simulated as out of the box (``uss simulate
--factory``): a drive whose command or setpoint source is not USS (P0700, P1000 != 5) is not
run - exit code 1, the message naming the parameter, nothing sent to the control word - and
after ``uss write`` of 5 to both the run ramps."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest

from commission.test_docs import uss
from support.processes import simulator

V20 = ["--profile", "sinamics-v20"]


@pytest.fixture
def v20() -> Iterator[list[str]]:
    """A SINAMICS V20 at address 5 with its factory values: P0700 = 1, P1000 = 1."""
    with simulator(*V20, "--address", "5", "--factory") as port:
        yield ["--port", port, *V20]


def run(port: list[str], *more: str) -> tuple[int, str]:
    return uss(["run", "5", "--setpoint", "50", "--duration", "1", *port, *more])


def control_word(port: list[str]) -> str:
    """What r0054, the control word in force, shows."""
    code, out = uss(["read", "5", "54", *port])
    assert code == 0, out
    return out


def test_status_says_what_the_drive_ignores_and_what_to_set(v20: list[str]) -> None:
    code, out = uss(["status", "5", *v20])
    assert code == 0
    assert out.splitlines()[-1] == (
        "sources: the drive ignores the control word: P0700.0 = 1 (operator panel), set "
        "P0700.0 = 5 for USS; the drive ignores the setpoint: P1000.0 = 1 (MOP), set "
        "P1000.0 = 5 for USS"
    )
    code, out = uss(["status", "5", *v20, "--json"])
    sources = json.loads(out)["sources"]
    assert sources["known"] and not sources["follows"]
    assert [(s["parameter"], s["value"], s["uss"], s["follows"]) for s in sources["sources"]] == [
        ("P0700.0", 1, 5, False),
        ("P1000.0", 1, 5, False),
    ]


def test_a_run_is_refused_naming_both_sources_and_nothing_is_sent(v20: list[str]) -> None:
    before = control_word(v20)
    code, out = run(v20)
    assert code == 1
    assert out == (
        "uss run: the drive ignores the control word: P0700.0 = 1 (operator panel), set "
        "P0700.0 = 5 for USS; the drive ignores the setpoint: P1000.0 = 1 (MOP), set "
        "P1000.0 = 5 for USS\n"
    )
    assert control_word(v20) == before


def test_a_run_is_refused_naming_the_setpoint_alone_and_sends_no_control_word(
    v20: list[str],
) -> None:
    assert uss(["write", "5", "P0700.0", "5", *v20])[0] == 0  # commands from USS now
    before = control_word(v20)
    assert "= 0000h " in before  # no control word taken yet
    code, out = run(v20)
    assert (code, out) == (
        1,
        "uss run: the drive ignores the setpoint: P1000.0 = 1 (MOP), set P1000.0 = 5 for USS\n",
    )
    # a drive that takes its commands from USS would show any control word sent: none was
    assert control_word(v20) == before
    code, out = uss(["status", "5", *v20])
    assert out.splitlines()[0] == "drive 5: switch-on inhibited"


def test_after_writing_5_to_both_sources_the_run_ramps(v20: list[str]) -> None:
    assert uss(["write", "5", "P1120.0", "0.5", *v20])[0] == 0  # a short ramp
    assert uss(["write", "5", "P1121.0", "0.5", *v20])[0] == 0
    assert uss(["write", "5", "P0700.0", "5", *v20])[0] == 0
    assert uss(["write", "5", "P1000.0", "5", *v20])[0] == 0
    code, out = run(v20, "--interval", "0.1", "--json")
    samples = [json.loads(line) for line in out.splitlines()]
    assert code == 0, out
    assert max(s["actual_percent"] or 0 for s in samples) > 0
    assert "operation enabled" in {s["state"] for s in samples}
    code, out = uss(["status", "5", *v20])
    assert out.splitlines()[-1] == (
        "sources: the drive follows USS: P0700.0 = 5 (USS/MODBUS 485), P1000.0 = 5 (USS/MODBUS 485)"
    )


def test_a_micromaster_420_is_named_by_its_scalar_parameters() -> None:
    mm420 = ["--profile", "micromaster420"]
    with simulator(*mm420, "--address", "5", "--factory") as port:
        code, out = run(["--port", port, *mm420])
    assert code == 1
    assert "the drive ignores the control word: P0700 = 2 (terminals), set P0700 = 5 for USS" in out
    assert "the drive ignores the setpoint: P1000 = 2 (analog input), set P1000 = 5 for USS" in out


def test_without_factory_the_simulated_drive_is_ready_for_uss() -> None:
    with simulator(*V20, "--address", "5") as port:
        code, out = uss(["read", "5", "P0700.0", "P1000.0", "--port", port, *V20])
    assert (code, out) == (
        0,
        "P0700.0 = 5 [USS/MODBUS 485] (Command source)\n"
        "P1000.0 = 5 [USS/MODBUS 485] (Setpoint source)\n",
    )


def test_factory_is_refused_by_simulators_of_other_protocols() -> None:
    code, out = uss(["simulate", "--profile", "ksvario", "--tcp", "127.0.0.1:0", "--factory"])
    assert code == 2 and "does not take --factory (USS drive options)" in out
