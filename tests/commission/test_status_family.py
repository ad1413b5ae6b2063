"""`uss status` speaks the family's language: its status bits 11..15 and its fault texts."""

from __future__ import annotations

import json

import pytest

from pyuss.cli.main import main
from pyuss.commission.status import look
from pyuss.profiles import get_profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from support.buses import SimulatorThread, simulated_bus


async def test_status_names_the_familys_bits_and_fault() -> None:
    layout = Layout(PKW_VARIABLE, 2)
    async with simulated_bus([(3, "sinamics-v20", layout)], profile="sinamics-v20") as env:
        env.engines[3].drive.raise_fault(72)  # the telegram off time ran out: F0072
        drive = env.master.drive(3, layout=layout)
        seen = await look(drive, timeout=2.0)
    meanings = {bit: text for bit, _, text in seen.bits()}
    assert meanings[11] == "motor current limit warning (0 = active)"
    assert meanings[14] == "motor turns right"
    assert "device-specific" not in meanings.values()
    assert meanings[3] == "fault"  # the specification's bits keep their words
    text = get_profile("sinamics-v20").faults[72]
    assert "setpoint fault" in text
    faults = [line for line in seen.lines() if line.startswith("r0947.0")]
    assert faults == [f"r0947.0 (Fault numbers) = 72 ({text})"], seen.lines()
    shown = {p["label"]: p["fault_text"] for p in seen.to_dict()["parameters"]}
    assert shown["r0947.0"] == text and shown["r2110.0"] is None  # no warning


@pytest.mark.parametrize("profile", ["micromaster440", "sinamics-v20"])
def test_only_the_fault_number_parameter_gets_a_fault_text(
    profile: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """r0002 (drive state) = 1 is "ready to run", not fault 1 (overcurrent): `uss status` puts
    fault texts beside the fault number parameter (r0947) only."""
    with SimulatorThread([(3, profile, None)]) as sim:
        argv = ["status", "3", "--port", sim.paths[0], "--baud", str(sim.baud)]
        argv += ["--profile", profile]
        assert main(argv) == 0
        text, _ = capsys.readouterr()
        assert main([*argv, "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
    state = [line for line in text.splitlines() if line.startswith("r0002 ")]
    assert state == ["r0002 (Drive state) = 1 [ready to run]"], text
    assert get_profile(profile).faults[1] == "overcurrent"  # the text it must not get
    shown = {p["label"]: p for p in data["parameters"]}
    assert shown["r0002"]["value"] == 1 and shown["r0002"]["fault_text"] is None
    assert shown["r0947.0"]["value"] == 0 and shown["r0947.0"]["fault_text"] is None


def test_a_reference_the_drive_refuses_leaves_the_rest_of_the_look(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A MICROMASTER 4 looked at as a SINAMICS V20 (whose reference P2000 is an array): the
    drive refuses P2000.0, and the look shows the status word, the actual value in percent
    and what went wrong, with the likely cause, instead of ending on the refusal."""
    with SimulatorThread([(3, "micromaster4", None)]) as sim:
        argv = ["status", "3", "--port", sim.paths[0], "--baud", str(sim.baud)]
        assert main([*argv, "--profile", "sinamics-v20"]) == 0
        text = capsys.readouterr().out.splitlines()
    assert text[:2] == [
        "drive 3: switch-on inhibited",
        "status word 0240h  switch-on inhibited, control requested",
    ], text
    assert "actual value (PZD2) 0.00 %" in text
    assert (
        "the reference parameter P2000.0 (100 % of the actual value) could not be read: error "
        "4: parameter is not an array; is --profile sinamics-v20 this drive's family?"
    ) in text


@pytest.mark.parametrize(
    ("fault", "shown"),
    [
        (72, "r0947.0 (Fault numbers) = 72 (USS/MODBUS setpoint fault (telegram off time))"),
        (70, "r0947.0 (Fault numbers) = 70"),  # a MICROMASTER fault the V20 does not have
    ],
)
def test_uss_status_names_the_v20s_fault(
    fault: int, shown: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`uss status` of a simulated V20 that tripped names the fault in r0947 with the V20's
    own text (F0072: no setpoint from USS/MODBUS within the telegram off time), and gives a
    number the V20's file drops (F0070, the MICROMASTER's fieldbus fault) no borrowed text."""
    with SimulatorThread([(3, "sinamics-v20", None)]) as sim:
        sim.call(lambda s: s.engines[3].drive.raise_fault(fault))
        argv = ["status", "3", "--port", sim.paths[0], "--baud", str(sim.baud)]
        assert main([*argv, "--profile", "sinamics-v20"]) == 0
        text = capsys.readouterr().out.splitlines()
    assert text[0] == "drive 3: fault", text
    assert [line for line in text if line.startswith("r0947.0")] == [shown], text
