"""EEPROM writes (request IDs 11..14) survive a restart; a damaged store is refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.drive import SimulatedDrive, StoreError
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, pwe_float
from slave.harness import LineSim, engine

LV = Layout(127, 2)
OFF1 = (0x047E, 0)


def _reads(store: Path) -> list[Pkw]:
    jobs = [
        Pkw(1, 18),
        Pkw(1, 449),
        Pkw(6, 4, 1),
        Pkw(6, 683, 2),
        Pkw(1, 107),
        Pkw(1, 448),
        Pkw(6, 684, 255),
    ]
    with LineSim(engine(5, "generic", "v,2", store=str(store))) as sim, sim.master() as master:
        return [master.ask(5, LV, job, OFF1).pkw for job in jobs]


def test_eeprom_writes_survive_a_power_cycle(tmp_path: Path) -> None:
    store = tmp_path / "drive5.store"
    writes = [
        Pkw(14, 18, values=(0x1234,)),  # word, EEPROM
        Pkw(2, 449, values=(0x0123,)),  # word, RAM only
        Pkw(11, 4, 1, values=(0x4000, 0)),  # array double word, EEPROM
        Pkw(12, 683, 2, values=(9,)),  # array word, EEPROM
        Pkw(13, 107, values=pwe_float(60.0)),  # double word, EEPROM
        Pkw(12, 684, 255, values=(8, 9, 10)),  # whole array, EEPROM (variable length)
    ]
    with LineSim(engine(5, "generic", "v,2", store=str(store))) as sim, sim.master() as master:
        answers = [master.ask(5, LV, job, OFF1).pkw for job in writes]
    assert [a.id for a in answers] == [1, 1, 5, 4, 2, 4]
    assert store.exists()

    p18, p449, p4, p683, p107, p448, p684 = _reads(store)  # the drive starts again from the store
    assert p18.values == (0x1234,)
    assert p449.values == (0xFE0C,)  # -500: the factory value, the write was not stored
    assert p4.values == (0x4000, 0)
    assert p683.values == (9,)
    assert p107.values == pwe_float(60.0)
    assert p448.values == (500,)
    assert p684.values == (10, 9, 10)  # SST 1 shows the rate the line runs at: 187500 baud


def test_a_damaged_store_is_refused_with_a_clear_message(tmp_path: Path) -> None:
    store = tmp_path / "drive5.store"
    with LineSim(engine(5, "generic", "v,2", store=str(store))) as sim, sim.master() as master:
        master.ask(5, LV, Pkw(14, 18, values=(0x1234,)), OFF1)
    data = bytearray(store.read_bytes())
    data[-3] ^= 0x01
    store.write_bytes(bytes(data))
    with pytest.raises(StoreError, match=r"drive5\.store.*corrupt"):
        SimulatedDrive.from_profile("generic", store=store)
    store.write_bytes(bytes(data[:-10]))  # torn: shorter than its header says
    with pytest.raises(StoreError, match="torn"):
        SimulatedDrive.from_profile("generic", store=store)


def test_an_eeprom_write_that_cannot_be_stored_is_refused_and_serving_goes_on(
    tmp_path: Path,
) -> None:
    """The store's folder vanishes while the drive runs: the EEPROM job is refused with error 1,
    RAM keeps the old value, and the slave goes on answering."""
    folder = tmp_path / "eeprom"
    folder.mkdir()
    store = folder / "drive5.store"
    with LineSim(engine(5, "generic", "v,2", store=str(store))) as sim, sim.master() as master:
        folder.rmdir()
        refused = master.ask(5, LV, Pkw(14, 18, values=(0x1234,)), OFF1).pkw
        in_ram = master.ask(5, LV, Pkw(1, 18), OFF1).pkw
        ram_write = master.ask(5, LV, Pkw(2, 18, values=(0x0042,)), OFF1).pkw
    assert (refused.id, refused.pnu, refused.values) == (7, 18, (1,))
    assert in_ram.values == (0,)
    assert ram_write.values == (0x0042,)
    assert not folder.exists()
