"""The Siemens families' commissioning through `uss` commands against a `uss simulate` process
on TCP, in the order their manuals give it: the quick commissioning (P0010 = 1, the motor data
from the rating plate P0304..P0311, P3900 = 1 to end it), the command and setpoint sources
P0700/P1000 = 5 (USS on RS-485), a run; the telegram off time P2014 with its fault and the
acknowledgement; the factory reset (P0010 = 30, P0970 = 1). The MICROMASTER 420 and 440 go
through their Operating Instructions' own sequence in test_quick_commissioning_mm4.py.

The family's facts come from its parameter file: which parameters are C (quick commissioning
only), the fault number the telegram off time trips (``[faults] telegram_failure``), what a
factory reset keeps (``[commissioning] keep_on_reset``: SINAMICS V20 P2010, P2021, P2023,
Operating Instructions 07/2012, 6.2)."""

from __future__ import annotations

import json
import time

import pytest

from commission.test_quick_commissioning_mm4 import at, uss
from pyuss.profiles import get_profile
from support.processes import simulator

BAUD = "38400"
ADDRESS = "3"
SIEMENS = ["micromaster420", "micromaster440", "sinamics-g110", "sinamics-g120", "sinamics-v20"]
FAULT_BIT = 1 << 3  # status word 1 bit 3: fault active


def _data_set(family: str, pnu: int) -> int | None:
    """Index 0 where the family's parameter is an array (the data set in force), else None."""
    return None if get_profile(family).database().parameter(pnu).array is None else 0


class Session:
    """`uss` commands to the simulated drive at `ADDRESS`."""

    def __init__(self, url: str, family: str) -> None:
        self.family = family
        self.line = ["--port", url, "--baud", BAUD, "--profile", family]

    def name(self, pnu: int) -> str:
        return at(pnu, _data_set(self.family, pnu))

    def write(self, pnu: int, value: str) -> str:
        code, out = uss(["write", ADDRESS, self.name(pnu), value, *self.line])
        assert code == 0, out
        return out.strip()

    def refused(self, pnu: int, value: str) -> str:
        code, out = uss(["write", ADDRESS, self.name(pnu), value, *self.line])
        assert code == 1, out
        return out

    def read(self, *pnus: int) -> list[float]:
        code, out = uss(["read", ADDRESS, *(self.name(p) for p in pnus), *self.line, "--json"])
        assert code == 0, out
        return [p["value"] for p in json.loads(out)["parameters"]]

    def run(self, seconds: float, *, exit_code: int = 0) -> list[dict[str, object]]:
        argv = ["run", ADDRESS, "--setpoint", "25 Hz", "--interval", "0.1", *self.line]
        code, out = uss([*argv, "--json", "--duration", str(seconds)])
        assert code == exit_code, out
        return [json.loads(sample) for sample in out.splitlines()]


def states(samples: list[dict[str, object]]) -> set[object]:
    return {s["state"] for s in samples}


@pytest.fixture
def session(request: pytest.FixtureRequest) -> object:
    family = request.param
    with simulator("--profile", family, "--address", ADDRESS, "--baud", BAUD) as url:
        yield Session(url, family)


@pytest.mark.parametrize(
    "session", ["sinamics-g110", "sinamics-g120", "sinamics-v20"], indirect=True
)
def test_quick_commissioning_as_the_manual_orders_it(session: Session) -> None:
    s = session
    (voltage,) = s.read(304)
    # Motor data are C: refused with error 17 outside quick commissioning, nothing changed.
    out = s.refused(304, "380")
    assert "error 17" in out and "set P0010 = 1 first" in out
    assert s.read(304) == [voltage]

    s.write(10, "1")
    assert s.read(2) == [0]  # r0002: commissioning
    for pnu, value in ((304, "380"), (305, "1.9"), (307, "0.75"), (310, "50"), (311, "1395")):
        s.write(pnu, value)
    assert s.read(304, 311) == [380, 1395]
    assert "operation enabled" not in states(s.run(0.6))  # P0010 = 1: the drive stays off

    assert s.write(3900, "1").startswith("P3900 = 1")
    assert s.read(10, 313) == [0, 2]  # back to ready; pole pairs round(60 x 50 / 1395)
    assert "error 17" in s.refused(304, "400")  # C again

    s.write(700, "5")  # commands from USS on RS-485
    s.write(1000, "5")  # setpoint from USS on RS-485
    s.write(1120, "0.5")
    s.write(1121, "0.5")
    samples = s.run(1.5)
    assert "operation enabled" in states(samples), samples
    top = max(float(str(x["actual"])) for x in samples)
    assert abs(top - 25.0) < 0.01, top


@pytest.mark.parametrize("session", SIEMENS, indirect=True)
def test_the_telegram_off_time_trips_the_familys_fault_until_acknowledged(
    session: Session,
) -> None:
    s = session
    code = get_profile(s.family).database().faults["telegram_failure"]
    assert code == 72  # F0072 on every Siemens family's file: USS on the RS-485 interface
    s.write(2014, "300")  # ms
    time.sleep(0.6)  # the master keeps quiet for longer
    fault, status = s.read(947, 52)
    assert fault == code
    assert int(status) & FAULT_BIT
    samples = s.run(0.4, exit_code=1)  # uss run stops at the fault the drive reports
    assert states(samples) == {"fault"} and "DriveFault" in json.dumps(samples)
    s.write(2014, "0")  # no more monitoring
    done, out = uss(["ack", ADDRESS, *s.line])
    assert done == 0 and "acknowledged" in out, out
    fault, status = s.read(947, 52)
    assert fault == 0 and not int(status) & FAULT_BIT
    assert "operation enabled" in states(s.run(1.0))  # ready again


@pytest.mark.parametrize("session", SIEMENS, indirect=True)
def test_a_factory_reset_restores_what_the_manual_says_it_restores(session: Session) -> None:
    s = session
    db = get_profile(s.family).database()
    assert db.commissioning is not None
    kept = set(db.commissioning.keep_on_reset)
    (ramp,) = s.read(1120)
    s.write(1120, "5")
    changed = {1120: 5.0}
    if 2021 in db:  # V20: the Modbus address survives the reset
        s.write(2021, "7")
        changed[2021] = 7
    code, out = uss(["write", ADDRESS, "P2010.1", "7", *s.line])  # RS-232 / BOP link rate
    assert code == 0, out
    s.write(10, "30")
    s.write(970, "1")
    assert s.read(10, 970) == [0, 0]
    assert s.read(1120) == [ramp]
    if 2021 in changed:
        assert s.read(2021) == [7]
    code, out = uss(["read", ADDRESS, "P2010.1", *s.line, "--json"])
    rate = json.loads(out)["parameters"][0]["value"]
    assert rate == (7 if 2010 in kept else db.parameter(2010).default[1])
    assert (2010 in kept and 2021 in kept and 2023 in kept) == (s.family == "sinamics-v20")
