"""Typed values through `Drive.read` / `Drive.write` against the simulator over TCP: every
data type, scaled values, arrays whole and by element, refusals before anything is sent, the
raw words, and what the master learns from the drive's own descriptions (C 6)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.errors import ConfigError, DriveRefusal
from pyuss.master import sync
from pyuss.params import Describe, ParamBook, Source
from pyuss.protocol.pkw import pwe_float
from support.typed import Simulator

EXPECTED = {
    800: -7,
    801: 200,
    802: -12.5,
    803: 3_000_000_000,
    804: -123.456,
    805: 1500.5,
    806: "PUMP 3",
    807: bytes.fromhex("01A0FF10"),
    808: 5,
    809: [10.0, 20.0, -30.0],
    810: 1,
}


def bus(sim: Simulator) -> sync.Master:
    """A master for the typed drive, a generic one (which has descriptions, C 6)."""
    return sync.Master(sim.path, baud=38400, profile="generic", layout="v,2")


def test_every_type_reads_as_its_value_with_the_users_file(typed_sim: Simulator) -> None:
    with bus(typed_sim) as master:
        drive = master.drive(5)
        drive.use_params(typed_sim.params)
        for pnu, value in EXPECTED.items():
            assert drive.read(pnu) == value, pnu
        assert drive.params[805].source is Source.USER
        assert drive.read_raw(805) == pwe_float(1500.5)
        assert drive.read_raw(802) == (0xFF83,)  # -125 in two's complement
        assert drive.read(809, 2) == 20.0  # the generic profile counts from 1
        assert drive.read_param(802).text() == "P802 = -12.5 % (Signed torque)"  # 0.1: one place


def test_the_drives_descriptions_type_what_no_file_knows(typed_sim: Simulator) -> None:
    with bus(typed_sim) as master:
        drive = master.drive(5)  # the generic profile's file knows none of P800..P811
        for pnu, value in EXPECTED.items():
            if pnu == 807:  # octets: a description gives no way to tell them from text
                continue
            assert drive.read(pnu) == value, pnu
        info = drive.params[804]
        assert (info.source, info.name, info.scaling, info.type_name) == (
            Source.DRIVE,
            "Position",
            0.001,  # sent as a single precision float: 0.0010000000474974513
            "int32",
        )
        assert drive.info(811) is not None and drive.params[811].read_only
        assert drive.params[800].minimum == -100  # element 7


def test_typed_writes_and_their_refusals_before_sending(typed_sim: Simulator) -> None:
    with bus(typed_sim) as master:
        drive = master.drive(5)
        drive.use_params(typed_sim.params)
        assert drive.write(800, -100) == -100
        assert drive.write(802, 99.9) == 99.9
        assert drive.read_raw(802) == (999,)
        assert drive.write(803, 4_000_000_000) == 4_000_000_000
        assert drive.write(804, 1.5) == 1.5
        assert drive.write(805, 2999.25) == 2999.25
        assert drive.write(806, "FAN 1") == "FAN 1"
        assert drive.write(809, -5.5, 3) == -5.5
        assert drive.read(809) == [10.0, 20.0, -5.5]
        assert drive.write(810, 2) == 2
        sent = drive.diagnostics().jobs.completed
        for pnu, value, index, message in (
            (800, -101, None, "outside -100..100"),
            (801, 256, None, "does not fit uint8"),
            (802, 0.05, None, "resolution 0.1"),
            (805, 3000.5, None, "outside"),
            (805, "fast", None, "takes a number"),
            (806, "A" * 13, None, "at most 12"),
            (808, 1, None, "bit field"),
            (811, 1.0, None, "read-only"),
            (809, 1.0, None, "is an array"),
            (809, 1.0, 4, "index 1..3"),
            (805, 1.0, 1, "not an array"),
        ):
            with pytest.raises(ConfigError, match=message):
                drive.write(pnu, value, index)
        assert drive.diagnostics().jobs.completed == sent  # nothing was sent
        assert drive.write_raw(808, [0x0103]) == (0x0103,)
        assert drive.read(808) == 0x0103


def test_the_drive_refuses_what_the_file_allows_and_that_comes_back_typed(
    typed_sim: Simulator, tmp_path: Path
) -> None:
    looser = tmp_path / "looser.toml"
    text = typed_sim.params.read_text(encoding="utf-8")
    looser.write_text(text.replace("min = -100\nmax = 100", "min = -128\nmax = 127"), "utf-8")
    with bus(typed_sim) as master:
        drive = master.drive(5)
        drive.use_params(looser)
        with pytest.raises(DriveRefusal) as refused:
            drive.write(800, 120)
        assert refused.value.number == 2  # limit exceeded, said by the drive


def test_the_description_cache_file_spares_the_next_run_the_questions(
    typed_sim: Simulator, tmp_path: Path
) -> None:
    cache = tmp_path / "descriptions.json"
    with bus(typed_sim) as master:
        drive = master.drive(5)
        assert drive.read(801) == 200
        drive.params.save_cache(cache, "drive 5")
    with bus(typed_sim) as master:
        drive = master.drive(5)
        drive.params.describe = Describe.NEVER
        drive.params.load_cache(cache, "drive 5")
        assert drive.params[801].source is Source.DRIVE
        assert drive.read(801) == 200
        assert drive.diagnostics().jobs.completed == 1  # the value only, no description


def test_a_fresh_book_without_descriptions_reads_words() -> None:
    book = ParamBook(describe=Describe.NEVER)
    assert book.get(805) is None and not book.needs_description(805)
