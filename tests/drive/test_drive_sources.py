"""The command and setpoint sources (``[sources]``: Siemens P0700, P1000): a simulated SINAMICS
or MICROMASTER follows the control word and the setpoint of USS only while they hold 5, starts
ready for USS by default and with its factory values with ``factory=True``."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.drive.database import ParamRef
from pyuss.drive.loader import load_profile, parse_database
from pyuss.drive.simulated import SimulatedDrive
from pyuss.drive.states import DriveState
from pyuss.errors import ConfigError

OFF1, ON = 0x047E, 0x047F
HALF = 0x2000  # 50 %

# the four families and the factory values of P0700 / P1000 their files hold
FAMILIES = {
    "sinamics-v20": (1, 1),
    "micromaster420": (2, 2),
    "micromaster440": (2, 2),
    "sinamics-g120": (2, 2),
}


def _ref(drive: SimulatedDrive, kind: str) -> ParamRef:
    source = drive.db.sources.get(kind)
    assert source is not None
    return source.ref


def _set(drive: SimulatedDrive, kind: str, value: int) -> None:
    ref = _ref(drive, kind)
    drive.write(ref.pnu, value, ref.index, interface="uss")


def _switch_on(drive: SimulatedDrive, setpoint: int = HALF, now: float = 0.0) -> None:
    drive.exchange([OFF1, setpoint], now)
    drive.exchange([ON, setpoint], now)


@pytest.mark.parametrize("profile", FAMILIES)
def test_every_family_names_p0700_and_p1000_with_uss_5(profile: str) -> None:
    sources = load_profile(profile).sources
    assert sources.command is not None and sources.setpoint is not None
    assert (sources.command.ref.pnu, sources.command.uss) == (700, 5)
    assert (sources.setpoint.ref.pnu, sources.setpoint.uss) == (1000, 5)


@pytest.mark.parametrize(("profile", "factory"), FAMILIES.items())
def test_a_factory_drive_ignores_the_control_word_of_uss(
    profile: str, factory: tuple[int, int]
) -> None:
    drive = SimulatedDrive.from_profile(profile, factory=True)
    command, setpoint = (_ref(drive, k) for k in ("command", "setpoint"))
    assert (drive.ref_value(command), drive.ref_value(setpoint)) == factory
    before = drive.status_word()
    _switch_on(drive)
    reply = drive.exchange([ON, HALF], 10.0)
    assert drive.state is DriveState.SWITCH_ON_INHIBIT and not drive.running
    assert drive.machine.control == 0  # the word in force stays as it was
    assert reply == (before, 0)  # answered as before: status word, actual value 0
    assert not drive.follows_uss("command") and not drive.follows_uss("setpoint")


@pytest.mark.parametrize("profile", FAMILIES)
def test_with_the_setpoint_elsewhere_the_drive_runs_on_its_own_setpoint(profile: str) -> None:
    drive = SimulatedDrive.from_profile(profile, factory=True)
    _set(drive, "command", 5)
    _switch_on(drive)
    drive.exchange([ON, HALF], 100.0)
    assert drive.state is DriveState.OPERATION  # the control word is taken
    assert drive.actual_value() == 0 and drive.machine.setpoint == 0.0  # PZD2 is not


@pytest.mark.parametrize("profile", FAMILIES)
def test_with_the_commands_elsewhere_the_setpoint_of_uss_is_still_taken(profile: str) -> None:
    drive = SimulatedDrive.from_profile(profile, factory=True)
    _set(drive, "setpoint", 5)
    drive.exchange([ON, HALF], 0.0)
    assert drive.machine.setpoint == 0.5 and drive.machine.control == 0
    assert drive.state is DriveState.SWITCH_ON_INHIBIT


@pytest.mark.parametrize("profile", FAMILIES)
def test_after_writing_5_to_both_the_drive_follows_uss(profile: str) -> None:
    drive = SimulatedDrive.from_profile(profile, factory=True)
    _set(drive, "command", 5)
    _set(drive, "setpoint", 5)
    _switch_on(drive)
    drive.exchange([ON, HALF], 100.0)
    assert drive.state is DriveState.OPERATION and drive.actual_value() == HALF


@pytest.mark.parametrize("profile", FAMILIES)
def test_a_drive_starts_ready_for_uss_unless_asked_for_its_factory_values(profile: str) -> None:
    drive = SimulatedDrive.from_profile(profile)
    assert drive.ref_value(_ref(drive, "command")) == 5
    assert drive.ref_value(_ref(drive, "setpoint")) == 5
    _switch_on(drive)
    drive.exchange([ON, HALF], 100.0)
    assert drive.actual_value() == HALF


def test_a_stored_source_wins_over_the_start_ready_for_uss(tmp_path: Path) -> None:
    store = tmp_path / "v20.store"
    drive = SimulatedDrive.from_profile("sinamics-v20", store=store)
    drive.write(700, 2, 0, interface="uss", eeprom=True)  # terminals, kept
    again = SimulatedDrive.from_profile("sinamics-v20", store=store)
    assert (again.value(700, 0), again.value(1000, 0)) == (2, 5)
    assert not again.follows_uss("command")


def test_a_factory_reset_brings_back_the_factory_sources() -> None:
    drive = SimulatedDrive.from_profile("sinamics-v20")
    drive.write(10, 30, interface="uss")
    drive.write(970, 1, interface="uss")
    assert (drive.value(700, 0), drive.value(1000, 0)) == (1, 1)
    _switch_on(drive)
    assert drive.state is DriveState.SWITCH_ON_INHIBIT


def test_a_family_without_sources_always_follows_uss() -> None:
    drive = SimulatedDrive.from_profile("micromaster4", factory=True)
    assert not list(drive.db.sources)
    _switch_on(drive)
    drive.exchange([ON, HALF], 100.0)
    assert drive.actual_value() == HALF


BASE = """
[profile]
name = "t"
extends = "generic"

[[parameter]]
pnu = 900
name = "Command source"
type = "uint16"
allowed = [1, 5]
default = 1
"""


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ("command = 900\ncommand_uss = 5\nother = 1", "field 'other': unknown"),
        ("command = 900", "field 'command_uss': required with 'command'"),
        ("command_uss = 5", "field 'command_uss': needs 'command'"),
        ("command = 900\ncommand_uss = 3", "field 'command_uss': P900 does not take 3"),
        ("command = 901\ncommand_uss = 5", "field 'command': refers to P901"),
        ("command = [900, 0]\ncommand_uss = 5", "P900 is not an array"),
    ],
)
def test_a_bad_sources_table_is_refused_naming_the_field(table: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_database(BASE + "\n[sources]\n" + table + "\n")


def test_a_sources_table_of_ones_own_gates_the_drive() -> None:
    db = parse_database(BASE + "\n[sources]\ncommand = 900\ncommand_uss = 5\n")
    drive = SimulatedDrive(db, factory=True)
    _switch_on(drive)
    assert drive.machine.control == 0
    assert SimulatedDrive(db).value(900) == 5
