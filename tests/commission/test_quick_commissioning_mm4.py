"""A quick commissioning of a MICROMASTER 440 and 420 as their Operating Instructions order it
(issue 10/06, chapter 3, the quick commissioning: P0010 = 1, the motor data from the rating
plate P0304..P0311, the command and setpoint sources P0700/P1000, the frequency limits and
ramps, P3900 to end), then a run, all through `uss` commands against a `uss simulate`
process on TCP.

What the simulator does of the rules it follows: motor data (marked C) are refused with error
17 outside commissioning; in commissioning r0002 shows 0 and the drive does not switch on;
P3900 = 3 calculates the pole pairs r0313 from P0310 and P0311 and sets P0010 back to 0. What
it does not do: P3900 = 1 and 2 do not reset the other parameters as a real drive does, and
the quick commissioning parameters the parameter files leave out (P0205, P0300, P0320, P1300's
vector modes, P1500, P1910, P1960 on the MICROMASTER 440) are not part of the sequence."""

from __future__ import annotations

import io
import json
from contextlib import redirect_stderr, redirect_stdout

import pytest

from pyuss.cli.main import main
from support.processes import simulator

BAUD = "38400"
ADDRESS = "3"


def uss(argv: list[str]) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue() + err.getvalue()


# (family, the index of the data set commissioned; None: the family's motor data are scalars)
FAMILIES = [("micromaster440", 0), ("micromaster420", None)]


def at(pnu: int, index: int | None) -> str:
    return str(pnu) if index is None else f"{pnu}.{index}"


@pytest.mark.parametrize(("family", "ds"), FAMILIES)
def test_quick_commissioning_then_a_run(family: str, ds: int | None) -> None:
    with simulator("--profile", family, "--address", ADDRESS, "--baud", BAUD) as url:
        line = ["--port", url, "--baud", BAUD, "--profile", family]

        def write(pnu: int, value: str, index: int | None = None) -> str:
            code, out = uss(["write", ADDRESS, at(pnu, index), value, *line])
            assert code == 0, out
            return out.strip()

        def read(*names: str) -> dict[str, float]:
            code, out = uss(["read", ADDRESS, *names, *line, "--json"])
            assert code == 0, out
            return {at(p["pnu"], p["index"]): p["value"] for p in json.loads(out)["parameters"]}

        # Motor data are C: refused before the quick commissioning starts, nothing changed.
        code, out = uss(["write", ADDRESS, at(304, ds), "400", *line])
        assert code == 1 and "error 17" in out and "set P0010 = 1 first" in out
        assert read(at(304, ds))[at(304, ds)] == 230

        assert write(10, "1") == "P0010 = 1 [quick commiss.] (Commissioning)"
        assert read("2")["2"] == 0  # r0002: commissioning
        write(100, "0")  # P0100: Europe, kW, 50 Hz
        assert write(304, "400", ds).startswith(f"P0304{'' if ds is None else '.0'} = 400 V")
        write(305, "1.9", ds)
        write(307, "0.75", ds)
        write(310, "50", ds)
        write(311, "1395", ds)
        write(700, "5", ds)  # commands from USS on the COM link
        write(1000, "5", ds)  # setpoint from USS on the COM link
        write(1080, "0", ds)
        write(1082, "50", ds)
        write(1120, "0.5", ds)
        write(1121, "0.5", ds)

        # In commissioning the drive does not switch on.
        run = ["run", ADDRESS, "--setpoint", "25 Hz", "--interval", "0.1", *line, "--json"]
        code, out = uss([*run, "--duration", "1"])
        states = {json.loads(sample)["state"] for sample in out.splitlines()}
        assert code == 0 and "operation enabled" not in states, states

        assert write(3900, "3") == "P3900 = 3 [end, motor data] (End quick comm.)"
        got = read("10", at(313, ds), "2")
        assert got == {"10": 0, at(313, ds): 2, "2": 1}  # round(60 x 50 / 1395) = 2

        # Out of commissioning the motor data are C again: refused.
        code, out = uss(["write", ADDRESS, at(304, ds), "230", *line])
        assert code == 1 and "error 17" in out
        assert read(at(304, ds))[at(304, ds)] == 400

        code, out = uss([*run, "--duration", "1.5"])
        samples = [json.loads(sample) for sample in out.splitlines()]
        assert code == 0 and "operation enabled" in {s["state"] for s in samples}, out
        top = max(s["actual"] for s in samples)
        assert abs(top - 25.0) < 50 / 0x4000, top  # 25 of P2000 = 50 Hz, to one PZD step
