"""The parameter description (PBE): C 6 layout, C 8 example 4, Baumueller elements."""

from __future__ import annotations

import pytest

from pyuss.drive.datatypes import DataType, encode
from pyuss.drive.faults import DriveErrorNumber, ParameterFault
from pyuss.drive.loader import load_profile
from pyuss.drive.memory import ParameterMemory
from pyuss.protocol.pkw import ErrorNumber


@pytest.fixture
def generic() -> ParameterMemory:
    return ParameterMemory(load_profile("generic"))


def test_lower_limit_element_of_p52_is_5fff(generic: ParameterMemory) -> None:
    # C 8 example 4 (uss.json read_pbe_element_response): one word fits PKW_ANZ = 3
    assert generic.description_element(52, 7).words == (0x5FFF,)
    assert generic.description_element(52, 8).words == (0x7FFF,)


def test_identifier_carries_type_array_read_only_text_and_active_bits(
    generic: ParameterMemory,
) -> None:
    p4 = generic.description_element(4, 1).words[0]
    assert p4 & 0xFF == DataType.INT32.value
    assert p4 & (1 << 14)  # array
    assert not p4 & (1 << 9)  # writable
    p52 = generic.description_element(52, 1).words[0]
    assert p52 & (1 << 9) and p52 & (1 << 15)  # read-only, active
    p7 = generic.description_element(7, 1).words[0]
    assert p7 & (1 << 10)  # has a text array
    assert not p7 & (1 << 12)
    generic.write(7, 3)
    assert generic.description_element(7, 1).words[0] & (1 << 12)  # differs from factory
    assert generic.description_element(825, 1).words[0] & (1 << 13)  # reset only


def test_elements_of_the_profibus_layout(generic: ParameterMemory) -> None:
    assert generic.description_element(683, 2).words == (3,)
    assert generic.description_element(90, 2).words == (16,)  # string length
    assert generic.description_element(7, 6).words == encode(
        DataType.VISIBLE_STRING, "Service baud", 16
    )
    assert generic.description_element(462, 3).words == encode(DataType.FLOAT, 0.1)
    assert generic.description_element(4, 7).words == (0x8000, 0x0000)  # int32 lower limit
    whole_word = generic.description(18)
    assert [e.number for e in whole_word] == list(range(1, 11))
    assert len(generic.description_words(18)) == 19
    assert len(generic.description_words(4)) == 21  # limits in double words


@pytest.mark.parametrize("number", [0, 11, 254])
def test_missing_element_is_faulty_index(generic: ParameterMemory, number: int) -> None:
    with pytest.raises(ParameterFault) as info:
        generic.description_element(52, number)
    assert info.value.number == ErrorNumber.BAD_INDEX


def test_description_cannot_be_changed(generic: ParameterMemory) -> None:
    with pytest.raises(ParameterFault) as info:
        generic.write_description_element(52, 7)
    assert info.value.number == ErrorNumber.DESCRIPTION_NOT_CHANGEABLE


def test_baumueller_attribute_info_min_max() -> None:
    drive = ParameterMemory(load_profile("baumueller"))
    # 183: unsigned 16, one element, data, decimal: length 01, type 01, format 0001
    assert drive.description_element(183, 1).words == (0b0001_0000_0101,)
    # 180: display only -> write protected, stored
    assert drive.description_element(180, 2).words == (0x0000, 0b1001)
    assert drive.description_element(181, 2).words == (0x0000, 0b1000)
    assert drive.description_element(184, 5).words == (0,)
    assert drive.description_element(184, 6).words == (3,)
    # 70: int32 -> length 10 (4 bytes), signed
    assert drive.description_element(70, 1).words[0] & 0xF == 0b0010
    assert drive.description_element(120, 1).words[0] & 0xC0 == 0x40  # command
    assert [e.number for e in drive.description(183)] == [1, 2, 5, 6]
    for number in (3, 4, 7):
        with pytest.raises(ParameterFault) as info:
            drive.description_element(183, number)
        assert info.value.number == DriveErrorNumber.NO_SUCH_ELEMENT  # 104


def test_limits_of_a_parameter_with_allowed_values_are_their_extremes() -> None:
    drive = ParameterMemory(load_profile("baumueller"))
    assert drive.description_element(183, 5).words == (0,)
    assert drive.description_element(183, 6).words == (4,)  # allowed 0, 3, 4
