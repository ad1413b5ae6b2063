"""Every request ID of C Table 4.1 with its answers (C Tables 4.2, 4.3, 4.8..4.11; C 7),
over TCP against the generic profile's drive."""

from __future__ import annotations

from typing import Any

import pytest

from pyuss.drive import SimulatedDrive, parse_database
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw, make_index, pwe_float, pwe_text
from pyuss.slave import SlaveEngine
from slave.harness import LineSim, engine

OFF1 = (0x047E, 0)
LV = Layout(127, 2)
TEXT_WRITE = 0x0100
SECOND_FIELD = 0x0200


def answers(layout: str, *jobs: Pkw, **options: Any) -> list[Pkw]:
    """The PKW answers to ``jobs`` sent one after the other to slave 5."""
    shape = Layout.parse(layout)
    out = []
    with LineSim(engine(5, "generic", layout, **options)) as sim, sim.master() as master:
        for job in jobs:
            out.append(master.ask(5, shape, job, OFF1).pkw)
    return out


def answer(layout: str, job: Pkw, **options: Any) -> Pkw:
    return answers(layout, job, **options)[0]


def refused(pkw: Pkw) -> int | None:
    return pkw.values[-1] if pkw.id == 7 else None


# -- values ------------------------------------------------------------------------------


def test_read_word_and_double_word_values() -> None:
    word, dword, floating, text = answers("v,2", Pkw(1, 52), Pkw(1, 825), Pkw(1, 107), Pkw(1, 90))
    assert (word.id, word.values) == (1, (0x4000,))
    assert (dword.id, dword.values) == (2, (0, 0))
    assert (floating.id, floating.values) == (2, pwe_float(50.0))
    assert (text.id, text.values) == (1, pwe_text("PYUSS DRIVE", 16))


def test_write_word_and_double_word() -> None:
    word, dword, wrong_size, wrong_size2 = answers(
        "v,2",
        Pkw(2, 18, values=(0xFFF9,)),
        Pkw(3, 107, values=pwe_float(60.0)),
        Pkw(2, 825, values=(1,)),
        Pkw(3, 18, values=(0, 1)),
    )
    assert (word.id, word.pnu, word.values) == (1, 18, (0xFFF9,))
    assert (dword.id, dword.pnu, dword.values) == (2, 107, pwe_float(60.0))
    assert refused(wrong_size) == 5  # a word job for a double word parameter
    assert refused(wrong_size2) == 5


def test_write_refusals_carry_the_drive_error_numbers() -> None:
    read_only, limit, reset_only, missing = answers(
        "v,2",
        Pkw(2, 52, values=(1,)),
        Pkw(2, 51, values=(9,)),
        Pkw(3, 825, values=(0, 5)),
        Pkw(1, 999),
    )
    assert refused(read_only) == 1
    assert refused(limit) == 2
    assert refused(reset_only) == 6
    assert refused(missing) == 0
    assert missing.pnu == 999


def test_pkw4_carries_words_in_pwe2_and_double_words_in_both() -> None:
    word, dword, write = answers("4,2", Pkw(1, 52), Pkw(1, 107), Pkw(2, 18, values=(0, 0x7000)))
    assert word.values == (0, 0x4000)
    assert dword.values == pwe_float(50.0)
    assert (write.id, write.values) == (1, (0, 0x7000))


def test_double_words_do_not_fit_pkw3() -> None:
    """C 7: "PWE anfordern (Doppelwort)" cannot be carried out with PKW_ANZ = 3."""
    read, write = answers("3,2", Pkw(1, 107), Pkw(3, 107, values=(0x4270,)))
    assert refused(read) == 103
    assert refused(write) == 103


# -- descriptions ----------------------------------------------------------------------------


def test_description_elements() -> None:
    low, name, whole, changed = answers(
        "v,2",
        Pkw(4, 52, 7),
        Pkw(4, 52, 6),
        Pkw(4, 52, 255),
        Pkw(5, 52, 7, values=(0,)),
    )
    assert (low.id, low.index, low.values) == (3, 7, (0x5FFF,))
    assert name.values == pwe_text("Load display", 16)
    assert refused(changed) == 7
    assert (whole.id, whole.index) == (3, 255)
    elements = answers("v,2", *(Pkw(4, 52, n) for n in range(1, 11)))
    # C 6, Bild 6.2: the whole description is the elements one after the other
    assert whole.values == tuple(w for e in elements for w in e.values)


def test_description_parts_too_long_for_a_fixed_pkw_area() -> None:
    name, whole = answers("4,2", Pkw(4, 52, 6), Pkw(4, 52, 255))
    assert refused(name) == 103
    assert refused(whole) == 103


# -- arrays ----------------------------------------------------------------------------------


def test_array_reads() -> None:
    element, dword, whole, count, scalar_count, scalar_index, bad_index = answers(
        "v,2",
        Pkw(6, 684, 1),
        Pkw(6, 4, 2),
        Pkw(6, 685, 255),
        Pkw(9, 683),
        Pkw(9, 52),
        Pkw(6, 52, 2),
        Pkw(6, 683, 9),
    )
    assert (element.id, element.index, element.values) == (4, 1, (10,))  # 187500 baud (C 3.1)
    assert (dword.id, dword.values) == (5, (0, 0))
    assert (whole.id, whole.index, whole.values) == (4, 255, (127, 127, 127))
    assert (count.id, count.values) == (6, (3,))
    assert refused(scalar_count) == 4
    assert refused(scalar_index) == 4
    assert refused(bad_index) == 3


def test_array_writes() -> None:
    word, dword, whole, read_back = answers(
        "v,2",
        Pkw(7, 683, 2, values=(7,)),
        Pkw(8, 4, 3, values=(0x4000, 0)),
        Pkw(7, 686, 255, values=(1, 2, 3)),
        Pkw(6, 686, 255),
    )
    assert (word.id, word.index, word.values) == (4, 2, (7,))
    assert (dword.id, dword.index, dword.values) == (5, 3, (0x4000, 0))
    assert (whole.id, whole.index, whole.values) == (4, 255, (1, 2, 3))
    assert read_back.values == (1, 2, 3)


def test_whole_arrays_need_the_variable_length() -> None:
    """C 4.2.2: IND 255 with a fixed length is refused like an answer too long."""
    read, write = answers("4,2", Pkw(6, 685, 255), Pkw(7, 686, 255, values=(0, 2)))
    assert refused(read) == 103
    assert refused(write) == 103


# -- texts, reserved ID, authority ----------------------------------------------------------


def test_texts() -> None:
    value_text, second_field, written, read_back, whole, none = answers(
        "v,2",
        Pkw(15, 7, 3),
        Pkw(15, 684, make_index(7, text=SECOND_FIELD)),
        Pkw(15, 7, make_index(3, text=TEXT_WRITE), values=pwe_text("FAST", 16)),
        Pkw(15, 7, 3),
        Pkw(15, 7, 255),
        Pkw(15, 52, 1),
    )
    assert (value_text.id, value_text.index, value_text.text()) == (15, 3, "300 BAUD")
    assert (second_field.index, second_field.text()) == (0x0207, "9600 BAUD")  # y = 6 + 1
    assert (written.id, written.index, written.text()) == (15, 0x0103, "FAST")
    assert read_back.text() == "FAST"
    assert refused(whole) == 3
    assert refused(none) == 15


def test_texts_need_the_variable_length() -> None:
    assert refused(answer("4,2", Pkw(15, 7, 3))) == 103


def test_reserved_request_id() -> None:
    assert refused(answer("v,2", Pkw(10, 52))) == 102


@pytest.mark.parametrize(
    "job",
    [
        Pkw(2, 18, values=(1,)),
        Pkw(14, 18, values=(1,)),
        Pkw(7, 683, 1, values=(1,)),
        Pkw(12, 683, 1, values=(1,)),
        Pkw(3, 107, values=pwe_float(55.0)),
        Pkw(5, 52, 7, values=(0,)),
        Pkw(15, 7, make_index(3, text=TEXT_WRITE), values=pwe_text("X", 16)),
    ],
)
def test_without_write_authority_change_jobs_get_response_8(job: Pkw) -> None:
    """C 4.2.1.1: change and EEPROM jobs are answered "keine PKW-Bedienhoheit"."""
    denied = answer("v,2", job, write_authority=False)
    assert (denied.id, denied.pnu) == (8, job.pnu)


def test_without_write_authority_reads_are_processed() -> None:
    read, text = answers("v,2", Pkw(1, 52), Pkw(15, 7, 3), write_authority=False)
    assert read.values == (0x4000,)
    assert text.text() == "300 BAUD"


# -- a parameter file of the user's own -------------------------------------------------------

TYPES_FILE = """
[profile]
name = "types"
extends = "generic"

[[parameter]]
pnu = 60
name = "Int8"
type = "int8"
min = -100
max = 100
default = -5

[[parameter]]
pnu = 61
name = "Uint8"
type = "uint8"
default = 200

[[parameter]]
pnu = 62
name = "Int32"
type = "int32"
default = -70000

[[parameter]]
pnu = 63
name = "Uint32"
type = "uint32"
default = 0x12345678

[[parameter]]
pnu = 64
name = "Float"
type = "float"
default = 1.5

[[parameter]]
pnu = 65
name = "Bits"
type = "v2"
default = 0x8001

[[parameter]]
pnu = 66
name = "Octets"
type = "octets"
length = 4
default = "01 A0 FF 00"

[[parameter]]
pnu = 67
name = "Label"
type = "string"
length = 6
default = "ABC"

[[parameter]]
pnu = 68
name = "Protected"
type = "int16"
access = "protected"

[[parameter]]
pnu = 69
name = "Position"
type = "uint16"
active = true
unit = "mm"
scaling = 0.1
"""


def test_every_data_type_and_attribute_of_a_parameter_file() -> None:
    def make(now: float) -> list[SlaveEngine]:
        drive = SimulatedDrive(parse_database(TYPES_FILE), now=now)
        return [SlaveEngine(5, drive, get_profile("generic"), layout=LV, now=now)]

    with LineSim(make) as sim, sim.master() as master:
        ask = lambda job: master.ask(5, LV, job, OFF1).pkw  # noqa: E731
        values = [ask(Pkw(1, pnu)) for pnu in range(60, 68)]
        codes = [ask(Pkw(4, pnu, 1)).values[0] & 0xFF for pnu in range(60, 68)]
        beyond = ask(Pkw(2, 60, values=(101,)))
        locked = ask(Pkw(2, 68, values=(1,)))
        ask(Pkw(2, 51, values=(3,)))  # the keyword parameter opens protected parameters
        unlocked = ask(Pkw(2, 68, values=(1,)))
        factor = ask(Pkw(4, 69, 3))
        sim.call(lambda: sim.drive.write(69, 250, interface="panel"))
        reported = ask(Pkw(0))
    assert [(a.id, a.values) for a in values] == [
        (1, (0xFFFB,)),  # -5
        (1, (200,)),
        (2, (0xFFFE, 0xEE90)),  # -70000, high word first
        (2, (0x1234, 0x5678)),
        (2, pwe_float(1.5)),
        (1, (0x8001,)),
        (1, (0x01A0, 0xFF00)),  # octets in storage order
        (1, pwe_text("ABC", 6)),
    ]
    assert codes == [2, 5, 4, 7, 8, 35, 10, 9]  # PBE element 1, bits 0..7: the type code
    assert refused(beyond) == 2
    assert refused(locked) == 12
    assert (unlocked.id, unlocked.values) == (1, (1,))
    assert factor.values == pwe_float(0.1)  # PBE element 3: the scaling
    assert (reported.id, reported.pnu, reported.values) == (9, 69, (250,))
