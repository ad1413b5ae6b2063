"""The interface parameters show and set what is in force (C 3.1, C 3.2; Baumueller
communication software manual 2.5), over a line without timing (TCP, and a pty where what
such a line does is meant), for every profile through its ``[interface]`` table."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import pytest

from pyuss.drive import SimulatedDrive, parse_database
from pyuss.errors import ConfigError
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.slave import SlaveEngine, SlaveServer
from pyuss.transport.tcp import TcpServerTransport
from slave.harness import LineSim, engine

LV = Layout(127, 2)
L32 = Layout(3, 2)
OFF1 = (0x047E, 0)


def _refused(pkw: Pkw) -> int | None:
    return pkw.values[0] if pkw.id == 7 else None


@pytest.mark.parametrize(("baud", "code"), [(9600, 6), (19200, 7), (187500, 10)])
def test_p684_shows_the_baud_rate_the_line_runs_at(baud: int, code: int) -> None:
    """C 3.1 codes: 6 = 9600, 7 = 19200, 10 = 187500 baud."""
    with LineSim(engine(5, "generic", "v,2"), baud=baud) as sim, sim.master() as master:
        shown = master.ask(5, LV, Pkw(6, 684, 1), OFF1).pkw
    assert (shown.id, shown.values) == (4, (code,))


@pytest.mark.parametrize("baud", [19200, 38400])
def test_baumueller_182_shows_the_rate_itself(baud: int) -> None:
    """Also a rate beyond what a master may write (150..19200): the drive's own display."""
    with LineSim(engine(5, "baumueller", "3,2"), baud=baud) as sim, sim.master() as master:
        master.ask(5, L32, Pkw(2, 181, values=(4,)), OFF1)  # response-delay mode: direct answers
        shown = master.ask(5, L32, Pkw(1, 182), OFF1).pkw
    assert shown.values == (baud,)


def test_p687_shows_the_failure_time_in_force() -> None:
    with (
        LineSim(engine(5, "generic", "v,2", failure_time=0.3)) as sim,
        sim.master() as master,
    ):
        shown = master.ask(5, LV, Pkw(6, 687, 1), OFF1).pkw
        sim.call(lambda: setattr(sim.engines[0], "failure_time", 0.0))
        off = master.ask(5, LV, Pkw(6, 687, 1), OFF1).pkw
    assert shown.values == (300,)  # ms
    assert off.values == (0,)


def test_nord_p513_shows_the_failure_time_in_its_tenths_of_a_second() -> None:
    drive = SimulatedDrive.from_profile("nord")
    SlaveEngine(5, drive, get_profile("nord"), failure_time=1.5)
    assert drive.value(513) == 15


def test_writing_p687_changes_the_time_the_drive_watches() -> None:
    """Not watched at first; P687.1 = 200 ms written over USS trips the fault once no
    telegram came for that long; 0 written switches the watch off again."""
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        written = master.ask(5, LV, Pkw(7, 687, 1, values=(200,)), OFF1).pkw
        watched = sim.call(lambda: sim.engines[0].failure_time)
        time.sleep(0.5)
        tripped = master.ask(5, LV, Pkw(7, 687, 1, values=(0,)), OFF1)
        master.ask(5, LV, Pkw(0), (0x04FE, 0))  # acknowledge: rising bit 7
        time.sleep(0.5)
        quiet = master.ask(5, LV, Pkw(0), OFF1)
        off = sim.call(lambda: sim.engines[0].failure_time)
    assert (written.id, written.values) == (4, (200,))
    assert watched == 0.2
    assert tripped.pzd[0] & 0x0008  # status bit 3: fault
    assert off == 0.0
    assert not quiet.pzd[0] & 0x0008


def test_a_failure_time_written_through_any_interface_is_in_force() -> None:
    """Any interface: the drive itself (its panel) writes P687.1, the USS engine follows."""
    profile = get_profile("generic")
    drive = SimulatedDrive.from_profile("generic")
    engine_ = SlaveEngine(5, drive, profile, layout=L32)
    drive.write(687, 1500, 1, interface="panel")
    assert engine_.failure_time == 1.5
    engine_.close()
    drive.write(687, 700, 1)
    assert engine_.failure_time == 1.5  # closed: no longer followed


@pytest.mark.parametrize("line", ["tcp", pytest.param("pty", marks=pytest.mark.pty)])
def test_a_pty_or_tcp_line_with_one_drive_follows_its_baud_rate_parameter(line: str) -> None:
    """A pty or a TCP line has no rate of its own: P684.1 = 7 written (RAM) is answered at
    9600 baud, then the simulated line runs at 19200 baud (pacing, start pause, response
    window)."""
    setup = engine(5, "generic", "v,2")
    with LineSim(setup, baud=9600, line=line) as sim, sim.master() as master:
        written = master.ask(5, LV, Pkw(7, 684, 1, values=(7,)), OFF1).pkw
        shown = master.ask(5, LV, Pkw(6, 684, 1), OFF1).pkw
        line = sim.call(lambda: (sim.server.baud, sim.engines[0].baud))
        unknown = master.ask(5, LV, Pkw(7, 684, 1, values=(11,)), OFF1).pkw  # no such code
    assert (written.id, written.values) == (4, (7,))
    assert shown.values == (7,)
    assert line == (19200, 19200)
    assert _refused(unknown) == 2


def _two_drives(store: str | None = None) -> Callable[[float], list[SlaveEngine]]:
    """Drives 5 and 6 on one line: they share its rate, which therefore stays."""

    def make(now: float) -> list[SlaveEngine]:
        profile = get_profile("generic")
        return [
            SlaveEngine(
                address,
                SimulatedDrive(profile.database(), store=store and store.format(address=address)),
                profile,
                layout=LV,
                now=now,
            )
            for address in (5, 6)
        ]

    return make


def test_where_the_line_keeps_its_rate_a_change_is_stored_for_the_next_start(
    tmp_path: Path,
) -> None:
    """Two drives on one line: a RAM write (request 7) and an EEPROM write into a drive
    without a store would change nothing and are refused (error 1); an EEPROM write into a
    drive with a store is stored and is the rate of the next start."""
    with LineSim(_two_drives(), baud=9600) as sim, sim.master() as master:
        ram = master.ask(5, LV, Pkw(7, 684, 1, values=(7,)), OFF1).pkw
        eeprom = master.ask(5, LV, Pkw(12, 684, 1, values=(7,)), OFF1).pkw
        same = master.ask(5, LV, Pkw(7, 684, 1, values=(6,)), OFF1).pkw  # the rate in force
        other = master.ask(5, LV, Pkw(7, 684, 2, values=(7,)), OFF1).pkw  # the SCB: not ours
        shown = master.ask(5, LV, Pkw(6, 684, 1), OFF1).pkw
    assert _refused(ram) == 1
    assert _refused(eeprom) == 1
    assert (same.id, other.id) == (4, 4)
    assert shown.values == (6,)

    store = str(tmp_path / "drive{address}.store")
    with LineSim(_two_drives(store), baud=9600) as sim, sim.master() as master:
        stored = master.ask(5, LV, Pkw(12, 684, 1, values=(7,)), OFF1).pkw
        running = sim.call(lambda: sim.server.baud)
    assert (stored.id, stored.values) == (4, (7,))
    assert running == 9600  # until the next start
    restarted = SimulatedDrive.from_profile("generic", store=tmp_path / "drive5.store")
    assert restarted.value(684, 1) == 7


async def test_a_drive_refuses_a_line_it_has_no_code_for() -> None:
    """C 3.1 has no code for 115200 baud: a generic drive does not run at it."""
    profile = get_profile("generic")
    drive = SimulatedDrive(profile.database())
    line = TcpServerTransport("127.0.0.1", 0, baud=115200)
    with pytest.raises(ConfigError, match=r"does not run at 115200 baud \(P684\.1: 300, 600"):
        SlaveServer(line, SlaveEngine(5, drive, profile, layout=L32))


@pytest.mark.parametrize(
    ("profile", "seconds", "message"),
    [
        ("generic", 7.0, r"takes 0\.\.6\.5 s \(P687\.1\)"),
        ("generic", 0.0005, r"steps of 0\.001 s"),
        ("nord", 0.25, r"steps of 0\.1 s \(P513\)"),
    ],
)
def test_a_failure_time_the_drive_cannot_have_is_refused(
    profile: str, seconds: float, message: str
) -> None:
    drive = SimulatedDrive.from_profile(profile)
    with pytest.raises(ConfigError, match=message):
        SlaveEngine(5, drive, get_profile(profile), failure_time=seconds)


OWN_FILE = """
[profile]
name = "own"
index_base = 0

[interface]
baud = [10, 1]
failure_time = 14

[[parameter]]
pnu = 10
name = "Baud rate"
type = "uint16"
array = 2
default = 1
texts = { 0 = "4.8 kBaud", 1 = "9.6 kBaud", 2 = "19.2 kBaud", 3 = "auto" }

[[parameter]]
pnu = 14
name = "Telegram timeout"
type = "uint16"
unit = "s"
scaling = 0.1
"""


def test_any_parameter_file_configures_the_interface_through_its_interface_table() -> None:
    """The same mechanism for every profile: codes from the value texts (here index 0 based,
    in kBaud), the failure time in the parameter's unit and scaling."""
    db = parse_database(OWN_FILE)
    drive = SimulatedDrive(db)
    engine_ = SlaveEngine(5, drive, get_profile("generic"), layout=L32, failure_time=2.5)
    engine_.set_line_baud(19200)
    assert drive.value(10, 1) == 2
    assert drive.value(14) == 25
    assert engine_.interface_parameters.rates() == (4800, 9600, 19200)
    with pytest.raises(ConfigError, match=r"does not run at 38400 baud \(P10\.1: 4800, 9600"):
        engine_.set_line_baud(38400)


def test_a_baud_parameter_that_names_no_rate_is_refused_with_the_file() -> None:
    bad = OWN_FILE.replace(
        'texts = { 0 = "4.8 kBaud", 1 = "9.6 kBaud", 2 = "19.2 kBaud", 3 = "auto" }', ""
    )
    with pytest.raises(ConfigError, match=r"\[interface\].*baud.*P10 holds no baud rate"):
        parse_database(bad)
