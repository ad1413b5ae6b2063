"""SINAMICS G120 firmware 4 (``sinamics-g120c``, ``sinamics-cu240e2``): the USS parameters of
p2020..p2040, the editions that differ, and the BICO inputs the simulated drive serves as the
G120C Operating Instructions 02/2023 (8.8) interconnect them for USS."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.bus import VirtualBus
from pyuss.drive import DriveState, SimulatedDrive
from pyuss.errors import DriveRefusal
from pyuss.master import Master
from pyuss.master.testing import simulated_drives
from pyuss.profiles import get_profile
from pyuss.protocol.bico import Bico, parse_bico

FW4 = ["sinamics-g120c", "sinamics-cu240e2"]

USS_SINKS = {  # sink: bit of control word 1 (r2090) it reads over USS (8.8)
    840: 0, 844: 1, 848: 2, 852: 3, 1140: 4, 1141: 5, 1142: 6, 2103: 7,
    854: 10, 1113: 11, 1035: 13, 1036: 14,
}  # fmt: skip

ZSW1 = [
    "r899.0", "r899.1", "r899.2", "r2139.3", "r899.4", "r899.5", "r899.6", "r2139.7",
    "r2197.7", "r899.9", "r2199.1", "r1407.7", "r899.12", "r2135.14", "r2197.3", "r2135.15",
]  # fmt: skip


@pytest.mark.parametrize("name", FW4)
def test_the_uss_interface_of_firmware_4(name: str) -> None:
    profile = get_profile(name)
    db = profile.database()
    # p2020 codes 4..13 = 2400..187500 baud (factory 8 = 38400)
    assert profile.baud_codes == {
        4: 2400, 5: 4800, 6: 9600, 7: 19200, 8: 38400, 9: 57600,
        10: 76800, 11: 93750, 12: 115200, 13: 187500,
    }  # fmt: skip
    assert db.parameter(2020).default == (8,)
    assert {k: (r.pnu, r.index) for k, r in db.interface.items()} == {
        "address": (2021, None),
        "baud": (2020, None),
        "pzd": (2022, None),
        "pkw": (2023, None),
        "failure_time": (2040, None),
    }
    address, pzd, pkw = db.parameter(2021), db.parameter(2022), db.parameter(2023)
    assert (address.minimum, address.maximum) == (0, 30) and profile.addresses == (0, 30)
    assert (pzd.minimum, pzd.maximum, pzd.default) == (0, 16, (2,)) and profile.max_pzd == 16
    assert pkw.allowed == (0, 3, 4, 127) and pkw.default == (127,)
    assert db.faults["telegram_failure"] == 1910 and profile.fault_text(1910)
    # p2020 travels as PNU 20 with the page index 80h in IND (8.6)
    assert profile.encode_pnu(2020) == (20, 0x8000)
    assert profile.diagnostic_pnu not in db and profile.diagnostic_pnu + 17 not in db
    assert db.profile.manual


def test_the_editions_differ_in_p2024_and_p2040() -> None:
    g120c = get_profile("sinamics-g120c").database()
    cu240e2 = get_profile("sinamics-cu240e2").database()
    # the G120C Operating Instructions' Modbus settings: 100 ms, [0] 1000 ms
    assert g120c.parameter(2040).default == (100.0,) and g120c.parameter(2040).unit == "ms"
    assert g120c.parameter(2024).default == (1000.0, 0.0, 0.0)
    # Fieldbuses Function Manual 04/2018, 5.4.1.2: 1000 ms, [0] 6000 ms
    assert cu240e2.parameter(2040).default == (1000.0,)
    assert cu240e2.parameter(2024).default == (6000.0, 0.0, 0.0)
    # the rest comes from the shared base
    same = {p.pnu for p in g120c} - {2024, 2040}
    assert same == {p.pnu for p in cu240e2} - {2024, 2040}
    for pnu in same:
        assert g120c.parameter(pnu).default == cu240e2.parameter(pnu).default, pnu


@pytest.mark.parametrize("name", FW4)
def test_the_bico_inputs_hold_the_uss_interconnection(name: str) -> None:
    db = get_profile(name).database()
    for pnu, bit in USS_SINKS.items():
        param = db.parameter(pnu)
        assert param.bico and param.array == 2, pnu
        assert param.default[0] == Bico(2090, bit), pnu
    assert db.parameter(2080).default == tuple(parse_bico(t) for t in ZSW1)
    assert db.sources.command is not None
    assert db.sources.command.uss == Bico(2090, 0)


@pytest.mark.parametrize("name", FW4)
async def test_the_simulated_drive_answers_the_factory_sources(name: str) -> None:
    bus = VirtualBus(38400)
    try:
        async with (
            simulated_drives(bus, [(5, name, None)]),
            Master(bus.attach("master"), profile=name) as master,
        ):
            drive = master.drive(5)
            assert await drive.read_raw(840, 0) == (0x082A, 0xFC00)  # r2090.0
            reading = await drive.read_param(840, 0)
            assert reading.text() == "P0840.0 = r2090.0 (ON/OFF1 source)"
            whole = await drive.read_param(2080)
            assert [str(v) for v in whole.value] == ZSW1  # type: ignore[union-attr]
            written = await drive.write_param(840, "r722.2", 1)
            assert written.words == (0x02D2, 0xFC02) and str(written.value) == "r722.2"
            with pytest.raises(DriveRefusal) as refused:  # no 3Fh in PWE2 bits 15..10
                await drive.write_raw(840, (0x02D2, 0x0002), 1)
            assert refused.value.number == 2
            assert await drive.read_raw(840, 1) == (0x02D2, 0xFC02)
    finally:
        await bus.close()


def test_control_word_1_counts_only_while_p0840_reads_it() -> None:
    drive = SimulatedDrive.from_profile("sinamics-g120c", now=0.0)
    drive.write(840, "r722.2", 0, interface="uss")  # ON/OFF1 from digital input 2
    drive.exchange([0x047E, 0], now=0.0)
    drive.exchange([0x047F, 0], now=0.1)
    assert drive.state is DriveState.SWITCH_ON_INHIBIT
    drive.write(840, "r2090.0", 0, interface="uss")  # back to the fieldbus
    drive.exchange([0x047E, 0], now=0.2)
    drive.exchange([0x047F, 0], now=0.3)
    assert drive.state is DriveState.OPERATION


def test_a_source_survives_a_restart_in_the_eeprom_store(tmp_path: Path) -> None:
    store = tmp_path / "g120c.store"
    drive = SimulatedDrive.from_profile("sinamics-g120c", store=store, now=0.0)
    drive.write_words(1113, [0x02D2, 0xFC03], 1, interface="uss", eeprom=True)
    again = SimulatedDrive.from_profile("sinamics-g120c", store=store, now=0.0)
    assert again.value(1113, 1) == Bico(722, 3) and str(again.value(1113, 1)) == "r722.3"
