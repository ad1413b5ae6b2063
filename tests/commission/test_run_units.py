"""``uss run`` with setpoints in the reference's unit and with jog, against a simulated
MICROMASTER 4 (reference P2000 = 50 Hz) on TCP."""

from __future__ import annotations

import json

from commission.test_backup import mm4, opts  # noqa: F401  (the fixture)
from commission.test_docs import uss
from support.typed import Simulator


def test_a_setpoint_in_hz_goes_through_the_reference_parameter(mm4: Simulator) -> None:  # noqa: F811
    assert uss(["write", "3", "1120", "0.5", *opts(mm4)])[0] == 0  # short ramps
    assert uss(["write", "3", "1121", "0.5", *opts(mm4)])[0] == 0
    run = ["run", "3", "--duration", "1.5", "--interval", "0.1", *opts(mm4), "--json"]
    code, out = uss([*run, "--setpoint", "25 Hz"])
    samples = [json.loads(line) for line in out.splitlines()]
    assert code == 0 and {s["setpoint"] for s in samples} == {50.0}  # 25 of 50 Hz
    top = max(s["actual"] for s in samples)
    assert abs(top - 25.0) < 50 / 0x4000 and samples[0]["unit"] == "Hz"  # to one PZD step
    code, out = uss([*run, "--setpoint", "1500 rpm"])
    assert code == 2 and "the reference parameter is in Hz" in out


def test_jog_runs_at_the_drives_jog_setpoint(mm4: Simulator) -> None:  # noqa: F811
    assert uss(["write", "3", "1060", "0.2", *opts(mm4)])[0] == 0  # jog ramp 0.2 s
    code, out = uss(
        ["run", "3", "--jog", "1", "--duration", "1.5", "--interval", "0.1", *opts(mm4), "--json"]
    )
    samples = [json.loads(line) for line in out.splitlines()]
    assert code == 0
    # a MICROMASTER 4 jogs from standstill: jog 1 (bit 8) with ON/OFF1 = 0, never ON
    controls = {s["control"] for s in samples} - {None}
    assert 0x057E in controls and not any(c & 1 for c in controls), controls
    top = max(s["actual"] for s in samples)
    assert abs(top - 5.0) < 50 / 0x4000  # P1058 jog frequency right: 5 Hz, to one PZD step
    assert samples[-1]["state"] != "operation enabled"


def test_a_setpoint_that_is_no_number_is_named_so_before_the_port_opens() -> None:
    gone = ["--port", "/dev/no-such-port", "--profile", "micromaster4", "--duration", "1"]
    for text in ("50 %%", "1_0", "25 -Hz", "\u0665\u0660", "garbage"):
        code, out = uss(["run", "3", "--setpoint", text, *gone])
        assert (code, out) == (
            2,
            f"uss run: --setpoint {text!r}: setpoint {text!r} is not a number\n",
        ), out
