"""The drive families (SINAMICS V20, G110, G120, MICROMASTER 420/440, NORD SK 500E) through the
master against the simulator: every parameter of each file read with its type and page bits,
written where it is writable, the refusals with the family's error numbers, the family's
rules (commissioning, control and status word bits) and its identification."""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import subprocess
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from pyuss.bus import VirtualBus
from pyuss.drive import SimulatedDrive
from pyuss.drive.database import TIME_UNITS, Access, Parameter
from pyuss.drive.datatypes import DataType
from pyuss.errors import DriveRefusal
from pyuss.master import Master
from pyuss.master.drive import Drive
from pyuss.master.identify import identify_on
from pyuss.master.scheduler import ACYCLIC
from pyuss.master.testing import simulated_drives
from pyuss.profiles import get_profile, profile_names
from pyuss.profiles.base import Profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, RequestId
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import SlaveEngine
from support.processes import line_within

FAMILIES = [
    "micromaster420",
    "micromaster440",
    "sinamics-g110",
    "sinamics-g120",
    "sinamics-v20",
    "nord-sk500e",
]
SIEMENS = FAMILIES[:5]
ADDRESS = 3
BAUD = 187500
USS = (sys.executable, "-m", "pyuss.cli.main")


def fastest(name: str) -> int:
    """The fastest baud rate a drive of family ``name`` has (it shows the line's rate in its
    baud rate parameter, and runs at no other, C 3)."""
    codes = get_profile(name).database().baud_codes() or {}
    return min(BAUD, max(codes.values(), default=BAUD))


@contextlib.asynccontextmanager
async def family(name: str) -> AsyncIterator[tuple[Drive, SlaveEngine]]:
    """A simulated drive of family ``name`` on a virtual bus and its handle on a master."""
    bus = VirtualBus(fastest(name))
    try:
        async with (
            simulated_drives(bus, [(ADDRESS, name, None)]) as engines,
            Master(bus.attach("master"), profile=name, mode=ACYCLIC, job_timeout=5.0) as master,
        ):
            yield master.drive(ADDRESS), engines[ADDRESS]
    finally:
        await bus.close()


def last_index(param: Parameter, base: int) -> int | None:
    return None if param.array is None else base + param.array - 1


async def read_value(drive: Drive, param: Parameter, index: int | None) -> int | float:
    """The raw value as the simulator holds it (unscaled), from the words the drive sent."""
    words = await drive.read_raw(param.pnu, index)
    value = param.from_words(words[-param.word_count :])
    assert isinstance(value, int | float)
    return value


async def write_value(
    drive: Drive, param: Parameter, value: int | float, index: int | None
) -> int | float:
    """Write a raw value (unscaled) and return the one the drive answered with."""
    words = await drive.write_raw(param.pnu, param.to_words(value), index)
    answered = param.from_words(words[-param.word_count :])
    assert isinstance(answered, int | float)
    return answered


def other_value(param: Parameter, current: int | float) -> int | float:
    """A value within the limits that differs from ``current`` where the limits allow."""
    if param.allowed is not None:
        return next((v for v in param.allowed if v != current), param.allowed[0])
    value = param.high if current != param.high else param.low
    return float(value) if param.dtype is DataType.FLOAT else int(value)


@pytest.mark.parametrize("name", FAMILIES)
async def test_every_parameter_reads_and_writes_through_the_master(name: str) -> None:
    profile = get_profile(name)
    db = profile.database()
    assert len(db) >= 80
    assert db.profile.manual  # each file names the manuals its facts come from
    base = db.profile.index_base
    rule = db.commissioning
    special = set() if rule is None else {rule.parameter, rule.end, rule.reset}
    baud = db.interface.get("baud")
    special |= set() if baud is None else {baud.pnu}
    async with family(name) as (drive, engine):
        sim = engine.drive
        for param in db:
            index = last_index(param, base)
            value = await read_value(drive, param, index)
            assert value == pytest.approx(sim.value(param.pnu, index)), param
            # type code and read-only bit of the description (C 6 element 1)
            described = await drive.read_description(param.pnu, 1)
            element = described.elements[1]
            # a word in a 4-word PKW area travels in PWE2 (C 4.2.3)
            ident = element.value if isinstance(element.value, int) else element.words[-1]
            assert ident & 0xFF == param.dtype.value, param
            assert bool(ident >> 9 & 1) == (param.access is Access.RO), param
            if param.pnu >= 2000:  # the page travels in IND bits 12..15, also in the answer
                bits, page_bits = profile.encode_pnu(param.pnu)
                assert page_bits and bits == param.pnu % 2000
                answer = await drive.job(
                    Pkw(RequestId.READ_ARRAY, bits, page_bits | (index or 0))
                    if param.array is not None
                    else Pkw(RequestId.READ_VALUE, bits, page_bits)
                )
                assert answer.index & 0xF000 == page_bits
                assert profile.decode_pnu(answer.pnu, answer.index) == param.pnu
            if param.access is Access.RO or param.pnu in special:
                continue
            if param.changeable is not None and "T" not in param.changeable:
                assert rule is not None
                await drive.write(rule.parameter, rule.quick)
            new = other_value(param, value)
            assert await write_value(drive, param, new, index) == pytest.approx(new), param
            assert await read_value(drive, param, index) == pytest.approx(new), param
            if rule is not None and sim.commissioning_active():
                await drive.write(rule.parameter, 0)


@pytest.mark.parametrize("name", FAMILIES)
async def test_refusals_carry_the_family_error_numbers(name: str) -> None:
    profile = get_profile(name)
    db = profile.database()
    ro = next(p for p in db if p.access is Access.RO and p.array is None)
    limited = next(  # a writable scalar with an upper limit, changeable while ready (T)
        p
        for p in db
        if p.access is Access.RW
        and p.array is None
        and p.maximum is not None
        and (p.changeable is None or "T" in p.changeable)
    )
    async with family(name) as (drive, _):
        with pytest.raises(DriveRefusal) as refused:
            await write_value(drive, ro, 0.0 if ro.dtype is DataType.FLOAT else 0, None)
        assert refused.value.number == 1  # not changeable
        too_big = limited.maximum + 1 if limited.dtype.is_integer else float(limited.maximum) * 2
        assert isinstance(too_big, int | float)
        with pytest.raises(DriveRefusal) as refused:
            await write_value(drive, limited, too_big, None)
        assert refused.value.number == 2  # limits
        with pytest.raises(DriveRefusal) as refused:
            await drive.read(1999)
        assert refused.value.number == 0  # no such parameter
        with pytest.raises(DriveRefusal) as refused:
            await drive.job(Pkw(10, 0, 0))  # the reserved request ID
        assert refused.value.number == profile.unsupported_error
        assert refused.value.meaning == profile.error_meaning(profile.unsupported_error)


@pytest.mark.parametrize("name", SIEMENS)
async def test_quick_commissioning_ends_as_the_manual_says(name: str) -> None:
    db = get_profile(name).database()
    dds = 0 if db.parameter(310).array else None
    async with family(name) as (drive, engine):
        with pytest.raises(DriveRefusal) as refused:  # motor data: in commissioning only
            await drive.write(304, 400, dds)
        assert refused.value.number == 17
        with pytest.raises(DriveRefusal) as refused:
            await drive.write(3900, 1)
        assert refused.value.number == 17
        await drive.write(10, 1)
        assert await drive.read(2) == 0  # r0002: commissioning
        status = await drive.control_word(0x047F)  # ON is not taken in commissioning
        assert status.word & 0x0004 == 0
        await drive.control_word(0x047E)
        await drive.write(304, 400, dds)
        await drive.write(310, 60.0, dds)
        await drive.write(311, 1740, dds)
        await drive.write(3900, 1)
        assert await drive.read(10) == 0
        assert await drive.read(3900) == 0
        assert await drive.read(313, dds) == 2  # 60 x 60 Hz / 1740 1/min, rounded
        assert await drive.read(2) == 1
        assert engine.drive.value(304, dds) == 400


async def test_factory_reset_keeps_what_the_family_keeps() -> None:
    async with family("sinamics-v20") as (drive, engine):
        await drive.write(1120, 3.0, 0)
        await drive.write(2023, 2)
        with pytest.raises(DriveRefusal) as refused:  # P0970 is changeable in commissioning
            await drive.write(970, 1)
        assert refused.value.number == 17
        await drive.write(10, 1)
        await drive.write(970, 1)  # quick commissioning, not factory setting: nothing happens
        assert await drive.read(1120, 0) == 3.0
        await drive.write(970, 0)
        await drive.write(10, 30)
        await drive.write(970, 1)
        assert await drive.read(1120, 0) == 10.0
        assert await drive.read(2023) == 2  # kept (V20 manual, chapter 6)
        assert await drive.read(10) == 0 and await drive.read(970) == 0
        assert engine.drive.phase() == "T"


async def test_micromaster420_pid_settings_as_its_parameter_list_gives_them() -> None:
    # MICROMASTER 420 Parameter List 04/02: P2280 0..125 (the V20 stops at 65), P2285 and
    # P2293 0..100 s, P2291/P2292 -200..200 %, all changeable while the motor runs (CUT).
    db = get_profile("micromaster420").database()
    async with family("micromaster420") as (drive, _):
        assert await drive.read(2280) == 3.0 and await drive.read(2293) == 1.0
        assert await drive.read(2291) == 100.0 and await drive.read(2292) == 0.0
        await drive.control_word(0x047E)
        await drive.control_word(0x047F)  # running: U
        await drive.write(2280, 100.0)
        await drive.write(2292, -200.0)  # both directions
        await drive.write(2285, 100.0)
        for pnu, too_far in ((2280, 125.5), (2291, 200.5), (2293, 100.5)):
            with pytest.raises(DriveRefusal) as refused:  # the drive itself refuses it
                await write_value(drive, db.parameter(pnu), too_far, None)
            assert refused.value.number == 2, pnu
        assert await drive.read(2280) == 100.0 and await drive.read(2292) == -200.0
    v20 = get_profile("sinamics-v20").database()
    async with family("sinamics-v20") as (drive, _):
        with pytest.raises(DriveRefusal) as refused:
            await write_value(drive, v20.parameter(2280), 100.0, None)
        assert refused.value.number == 2


@pytest.mark.parametrize("name", SIEMENS)
async def test_status_and_control_word_bits_of_the_family(name: str) -> None:
    async with family(name) as (drive, engine):
        status = await drive.control_word(0x047E)
        assert status.word & 0xA800 == 0xA800  # bits 11, 13, 15: no such warning
        assert status.word & 0x4000  # bit 14: right (the setpoint is not negative)
        dds = 0 if engine.drive.db.parameter(1120).array else None
        await drive.write(1120, 0.0, dds)  # ramps of no time: each answer shows the setpoint
        await drive.write(1121, 0.0, dds)
        await drive.control_word(0x047F)
        status = await drive.setpoint(raw=0x2000)
        for _ in range(50):  # the ramp takes no time: the next answers show 50 %
            if status.actual[0] == 0x2000:
                break
            status = await drive.next_update()
        assert status.word & 0x0004 and status.actual[0] == 0x2000
        status = await drive.control_word(0x047F | 0x0800)  # bit 11: reverse
        for _ in range(50):
            if status.actual[0] & 0x8000:
                break
            status = await drive.next_update()
        assert status.actual[0] == 0x10000 - 0x2000  # -50 %
        assert not status.word & 0x4000  # bit 14: left
        assert engine.drive.value(21) < 0  # r0021 shows the frequency in Hz


@pytest.mark.parametrize("name", [*FAMILIES, "generic"])
async def test_identification(name: str) -> None:
    bus = VirtualBus(fastest(name))
    try:
        async with (
            simulated_drives(bus, [(ADDRESS, name, None)]) as engines,
            Master(bus.attach("master"), profile="micromaster4", mode=ACYCLIC) as master,
        ):
            identity = await identify_on(master, ADDRESS, engines[ADDRESS].layout)
    finally:
        await bus.close()
    assert identity is not None
    expected = {
        "micromaster420": ("micromaster420", "micromaster420"),
        "micromaster440": ("micromaster440", "micromaster440"),
        "sinamics-g110": (None, "micromaster4"),
        "sinamics-g120": (None, "micromaster4"),
        "sinamics-v20": ("sinamics-v20", "sinamics-v20"),
        "nord-sk500e": ("nord-sk500e", "nord-sk500e"),
        "generic": (None, None),
    }[name]
    assert (identity.family, identity.profile) == expected


def test_a_familys_facts_live_in_its_parameter_file_alone() -> None:
    # The reference parameter, the baud codes and the fault and warning texts cannot be given
    # in Python: the profile reads them from the family's file.
    fields = {f.name for f in dataclasses.fields(Profile)}
    assert not fields & {"reference", "baud_codes", "faults", "warnings"}
    for name in profile_names():
        profile = get_profile(name)
        db = profile.database()
        ref = db.roles.get("reference")
        assert profile.reference == (None if ref is None else ref.pnu)
        assert profile.baud_codes == (db.baud_codes() or {})
        assert profile.faults == db.fault_texts and profile.warnings == db.warning_texts


def test_family_facts() -> None:
    v20 = get_profile("sinamics-v20")
    assert v20.reference == 2000 and v20.baud_of_code(8) == 38400 and v20.code_of_baud(1200) is None
    assert v20.fault_text(72).startswith("USS/MODBUS")
    assert v20.encode_pnu(2010) == (10, 0x8000)
    assert get_profile("micromaster440").status_bits[12] == "motor holding brake active"
    nord = get_profile("nord-sk500e")
    assert nord.reference == 105 and nord.baud_of_code(3) == 38400
    assert nord.check_layout(Layout(0, 6)) and nord.fixed_length_only
    assert nord.fault_text(100).startswith("E010")
    p102 = nord.database().parameter(102)
    assert p102.scaling == 0.01 and p102.unit == "s" and p102.array == 4
    for name in FAMILIES:
        db = get_profile(name).database()
        assert all(p.level is None or 0 <= p.level <= 4 for p in db)


@pytest.mark.parametrize("name", ["micromaster440", "sinamics-g120"])
async def test_pid_settings_as_the_micromaster_440_list_gives_them(name: str) -> None:
    """MICROMASTER 440 Parameter List 01/06 pages 237/238, shared by the G120 (CU240S): the PID
    settings keep their factory values and limits, are not per data set and can be changed
    while the motor runs (CUT); the PID output is a display."""
    async with family(name) as (drive, engine):
        assert await drive.read(2280) == pytest.approx(3.0)  # proportional gain
        assert await drive.read(2293) == pytest.approx(1.0)  # limit ramp, s
        assert await drive.read(2291) == pytest.approx(100.0)  # upper limit, %
        db = engine.drive.db
        with pytest.raises(DriveRefusal) as refused:  # -200..200 %, refused by the drive
            await write_value(drive, db.parameter(2291), 200.5, None)
        assert refused.value.number == 2
        bits, page = get_profile(name).encode_pnu(2280)
        with pytest.raises(DriveRefusal) as refused:  # one value, not one a drive data set
            await drive.job(Pkw(RequestId.READ_ARRAY, bits, page))
        assert refused.value.number == 4
        await drive.control_word(0x047E)
        await drive.control_word(0x047F)
        assert engine.drive.phase() == "U"
        assert await drive.write(2285, 2.5) == pytest.approx(2.5)  # integral time, running
        assert await drive.read(2285) == pytest.approx(2.5)
        with pytest.raises(DriveRefusal) as refused:  # the PID output: a display
            await write_value(drive, db.parameter(2294), 0.0, None)
        assert refused.value.number == 1
        assert db.parameter(2291).level is None  # not confirmed
        assert db.parameter(948).array == 12
        assert db.parameter(706).array == 3 and engine.drive.value(706, 2) == 15


def _simulate(*args: str) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "pyuss.cli.main", "simulate", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc, line_within(proc.stdout, 20, "uss simulate printed nothing")


@pytest.mark.posix("stops uss simulate with SIGTERM and checks it ended cleanly")
@pytest.mark.parametrize("name", FAMILIES)
async def test_uss_simulate_serves_the_family_on_tcp(name: str) -> None:
    profile = get_profile(name)
    db = profile.database()
    line = ("--tcp", "127.0.0.1:0")
    proc, device = _simulate("--profile", name, "--address", "4", "--baud", "19200", *line)
    try:
        async with Master(device, baud=19200, profile=name, mode=ACYCLIC) as master:
            drive = master.drive(4)
            # the interface parameters show the line the simulator serves
            address = db.interface["address"]
            assert await drive.read(address.pnu, address.index) == 4
            ramp = db.roles["ramp_up_time"]
            param = db.parameter(ramp.pnu)
            if param.dtype is DataType.FLOAT:
                assert await drive.write(ramp.pnu, 2.5, ramp.index) == 2.5
            else:
                assert await drive.write(ramp.pnu, 250, ramp.index) == 250  # 2.50 s in 0.01 s
            status = await drive.control_word(0x047E)
            assert status.word & 0x0001  # ready to switch on
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err


@pytest.mark.parametrize("name", FAMILIES)
def test_interface_parameters_set_the_simulated_interface(name: str, tmp_path: Path) -> None:
    """The family's USS parameters, stored in the EEPROM, make the interface of the next
    power-up: telegram length (P2012/P2013) and the telegram off time with its fault."""
    profile = get_profile(name)
    db = profile.database()
    store = tmp_path / "drive.store"
    drive = SimulatedDrive(db, store=store)
    failure = db.interface["failure_time"]
    param = db.parameter(failure.pnu)
    raw = round(0.5 / ((param.scaling or 1.0) * TIME_UNITS[param.unit]))  # 0.5 s
    drive.write(failure.pnu, raw, failure.index, interface="uss", eeprom=True)
    layout = Layout(4, 2) if "pkw" in db.interface else None
    if layout is not None:
        pkw, pzd = db.interface["pkw"], db.interface["pzd"]
        drive.write(pkw.pnu, 4, pkw.index, interface="uss", eeprom=True)
        drive.write(pzd.pnu, 2, pzd.index, interface="uss", eeprom=True)
    again = SimulatedDrive(db, store=store)  # power-up
    engine = SlaveEngine(ADDRESS, again, profile)
    assert engine.layout == (layout or profile.default_layout)
    assert engine.failure_time == pytest.approx(0.5)
    request = Telegram(ADDRESS, AddressMode.NORMAL, engine.layout.pack(Pkw(0), [0x047E, 0]))
    assert engine.handle(request, 0.0) is not None
    engine.tick(0.6)  # no telegram for longer than the off time: the family's fault
    code = db.faults["telegram_failure"]
    assert again.status_word() & 0x0008
    assert again.ref_value(db.roles["fault"]) == code  # r0947[0] = 72, NORD P700 = 10.0 (E010)
    assert profile.fault_text(code)


def _read_auto(profile: str, parameter: str) -> subprocess.CompletedProcess[str]:
    """``uss read 2 PARAMETER --profile auto`` of a drive simulated with ``profile``."""
    proc, url = _simulate("--profile", profile, "--address", "2", "--tcp", "127.0.0.1:0")
    try:
        return subprocess.run(
            [*USS, "read", "2", parameter, "--port", url, "--profile", "auto", "--timeout", "0.5"],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)


@pytest.mark.parametrize(
    ("name", "parameter", "expected"),
    [
        ("sinamics-v20", "2023", "P2023 = 1 [USS] (RS485 protocol)"),
        ("nord-sk500e", "102.1", "P102.1 = 2.00 s (Accel. time)"),
    ],
)
def test_profile_auto_reads_with_the_family_the_drive_shows(
    name: str, parameter: str, expected: str
) -> None:
    done = _read_auto(name, parameter)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == expected


def test_profile_auto_takes_a_drive_that_shows_no_family_as_one_of_unknown_kind() -> None:
    """`--profile auto` assumes nothing the drive did not say: a drive that answers but shows
    no family is read as without a profile (its words), with one line saying so."""
    done = _read_auto("generic", "52")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "P52 = 16384 (4000h)"
    assert done.stderr.strip().splitlines() == [
        "uss read: address 2: the drive shows no family known here; it is taken as one of"
        " unknown kind (its parameters as words; --profile NAME gives a family's)"
    ]


def test_profile_auto_says_when_it_knows_the_kind_but_not_the_family() -> None:
    """A SINAMICS G120 shows it is a Siemens drive of the MICROMASTER 4 kind (r0964.0 = 42),
    but no product type known here: `--profile auto` reads it with the micromaster4 file,
    and says so, since that file's parameters, units and limits are not the drive's word."""
    done = _read_auto("sinamics-g120", "964.0")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().startswith("r0964.0 = 42")
    assert done.stderr.strip().splitlines() == [
        "uss read: address 2: Siemens, MICROMASTER 4 kind, product type 0: its family is not"
        " known here; its parameters, units and limits are taken from the micromaster4"
        " profile's file, not from the drive (--profile NAME gives its family's)"
    ]
