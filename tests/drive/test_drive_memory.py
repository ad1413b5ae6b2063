"""Parameter reads and writes of the simulated drive: the C 8 examples and every refusal."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive.database import Access
from pyuss.drive.database import Parameter as ParameterSpec
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import DriveErrorNumber, NoWriteAuthority, ParameterFault
from pyuss.drive.loader import builtin_profiles, load_profile, parse_database
from pyuss.drive.memory import LOCAL, WHOLE_ARRAY, ParameterChange, ParameterMemory
from pyuss.protocol.bico import MAX_INDEX, MAX_SOURCE, Bico
from pyuss.protocol.pkw import ErrorNumber
from support.paths import load_vectors


def words_of(name: str) -> list[int]:
    for vector in load_vectors("uss")["telegrams"]:
        if vector["name"] == name:
            return [int(w, 16) for w in vector["words_hex"]]
    raise KeyError(name)


@pytest.fixture
def drive() -> ParameterMemory:
    return ParameterMemory(load_profile("generic"))


def fault_number(call: object, *args: object, **kwargs: object) -> int:
    assert callable(call)
    with pytest.raises(ParameterFault) as info:
        call(*args, **kwargs)
    return info.value.number


def test_c8_example_2_reads_p52(drive: ParameterMemory) -> None:
    response = words_of("read_word_response")
    assert drive.read_words(52) == (response[2],)


def test_c8_example_5_writes_a_double_word_into_an_array(drive: ParameterMemory) -> None:
    request = words_of("write_array_dword_request")  # PKE 8004, IND 2, PWE 4000 0000
    pnu, index, pwe = request[0] & 0x7FF, request[1], request[2:4]
    response = words_of("write_array_dword_response")
    assert drive.write_words(pnu, pwe, index, interface="uss") == tuple(response[2:4])
    assert drive.value(4, 2) == 0x4000_0000
    assert drive.value(4, 1) == 0


def test_c8_example_6_writes_a_word(drive: ParameterMemory) -> None:
    request = words_of("write_word_pkw4_request")  # PKW 4: the word travels in PWE2
    assert drive.write_words(request[0] & 0x7FF, [request[3]], interface="uss") == (0x7000,)
    assert drive.value(18) == 0x7000


def test_c8_example_7_reads_the_text_of_value_2(drive: ParameterMemory) -> None:
    request = words_of("read_text_request")
    response = words_of("read_text_response")
    assert drive.text_words(request[0] & 0x7FF, request[1] & 0xFF) == tuple(response[2:])
    assert drive.text(7, 3) == "300 BAUD".ljust(16)


def test_texts_of_array_indices_values_and_bits(drive: ParameterMemory) -> None:
    assert drive.text(683, 2).rstrip() == "SCB"  # first field of an array: its indices
    assert drive.text(684, 7, second=True).rstrip() == "9600 BAUD"  # value 6 + 1
    assert drive.text(552, 1).rstrip() == "NOT READY TO ON"  # bit 0 = 0
    assert drive.text(552, 2).rstrip() == "READY TO ON"  # bit 0 = 1
    assert drive.text(552, 21).rstrip() == "F NOT REACHED"  # bit 10 = 0


@pytest.mark.parametrize(
    ("pnu", "y", "second", "number"),
    [
        (18, 1, False, DriveErrorNumber.NO_TEXT_ARRAY),  # no texts at all
        (7, 1, True, DriveErrorNumber.NO_TEXT_ARRAY),  # second field exists for arrays only
        (683, 1, True, DriveErrorNumber.NO_TEXT_ARRAY),  # array without value texts
        (7, 0, False, ErrorNumber.BAD_INDEX),
        (7, 255, False, ErrorNumber.BAD_INDEX),  # C 4.2.2: 255 has no meaning for texts
        (7, 12, False, ErrorNumber.BAD_INDEX),  # value 11 has no text
        (999, 1, False, ErrorNumber.ILLEGAL_PNU),
    ],
)
def test_text_refusals(drive: ParameterMemory, pnu: int, y: int, second: bool, number: int) -> None:
    assert fault_number(drive.text, pnu, y, second=second) == number


def test_texts_can_be_changed_where_the_profile_allows(drive: ParameterMemory) -> None:
    assert drive.write_text(7, 3, "300 BD", interface="uss").rstrip() == "300 BD"
    assert drive.text(7, 3).rstrip() == "300 BD"
    assert drive.write_text(683, 3, "SST TWO").rstrip() == "SST TWO"
    assert fault_number(drive.write_text, 7, 3, "x" * 17) == ErrorNumber.LIMIT_EXCEEDED
    fixed = ParameterMemory(load_profile("6se21"))
    assert fault_number(fixed.write_text, 20, 2, "X") == ErrorNumber.DESCRIPTION_NOT_CHANGEABLE
    assert ParameterMemory(load_profile("generic")).text(7, 3).rstrip() == "300 BAUD"


def test_refusals_carry_the_error_numbers_of_table_4_3(drive: ParameterMemory) -> None:
    assert fault_number(drive.read_words, 999) == ErrorNumber.ILLEGAL_PNU
    assert fault_number(drive.write, 52, 1) == ErrorNumber.NOT_CHANGEABLE
    assert fault_number(drive.write, 683, 31, 1) == ErrorNumber.LIMIT_EXCEEDED
    assert fault_number(drive.write, 685, 5, 1) == ErrorNumber.LIMIT_EXCEEDED  # not 0/3/4/127
    assert fault_number(drive.read_words, 683, 4) == ErrorNumber.BAD_INDEX
    assert fault_number(drive.read_words, 683, 0) == ErrorNumber.BAD_INDEX  # counts from 1
    assert fault_number(drive.read_words, 683) == ErrorNumber.BAD_INDEX  # index needed
    assert fault_number(drive.read_words, 18, 1) == ErrorNumber.NOT_ARRAY
    assert fault_number(drive.array_length, 18) == ErrorNumber.NOT_ARRAY
    assert fault_number(drive.write_words, 4, [0x4000], 2) == ErrorNumber.WRONG_TYPE
    assert fault_number(drive.write_words, 18, [0, 1]) == ErrorNumber.WRONG_TYPE
    assert fault_number(drive.write, 18, "text") == ErrorNumber.WRONG_TYPE
    assert fault_number(drive.write, 825, 5) == ErrorNumber.SET_NOT_ALLOWED
    assert drive.write(825, 0) == 0
    assert fault_number(drive.write, 352, 6000) == DriveErrorNumber.KEYWORD_MISSING
    drive.write(51, 3)  # access level "expert" unlocks protected parameters
    assert drive.write(352, 6000) == 6000


def test_write_without_authority_is_not_processed_at_all(drive: ParameterMemory) -> None:
    drive.set_write_authority("uss", False)
    for call in (
        lambda: drive.write_words(18, [1], interface="uss"),
        lambda: drive.write_words(999, [1], interface="uss"),  # even an illegal PNU
        lambda: drive.write_text(7, 3, "X", interface="uss"),
        lambda: drive.write_description_element(52, 7, interface="uss"),
    ):
        with pytest.raises(NoWriteAuthority) as info:
            call()
        assert info.value.number == DriveErrorNumber.NO_WRITE_AUTHORITY
    assert drive.read_words(18) == (0,)  # reads go on
    drive.write_words(18, [1], interface="bass")  # other interfaces keep theirs
    drive.set_write_authority("uss", True)
    assert drive.write_words(18, [2], interface="uss") == (2,)


def test_stopped_only_parameter_refuses_while_running() -> None:
    running = [True]
    drive = ParameterMemory(load_profile("generic"), running=lambda: running[0])
    assert fault_number(drive.write, 107, 60.0) == DriveErrorNumber.WRONG_STATE
    running[0] = False
    assert drive.write(107, 60.0) == 60.0


def test_whole_array_read_and_write(drive: ParameterMemory) -> None:
    assert drive.array_length(683) == 3
    assert drive.read_array_words(685) == (127, 127, 127)
    assert drive.write_array_words(683, [1, 2, 3]) == (1, 2, 3)
    assert drive.values(683) == (1, 2, 3)
    assert drive.read_array_words(4) == (0,) * 8  # 4 double words
    # all or nothing: the third element is out of limits, nothing changes
    assert fault_number(drive.write_array_words, 683, [4, 5, 31]) == ErrorNumber.LIMIT_EXCEEDED
    assert drive.values(683) == (1, 2, 3)
    assert fault_number(drive.write_array_words, 683, [4, 5]) == ErrorNumber.WRONG_TYPE
    assert fault_number(drive.read_array_words, 18) == ErrorNumber.NOT_ARRAY


def test_strings_floats_and_octets(drive: ParameterMemory) -> None:
    assert drive.value(90) == "PYUSS DRIVE".ljust(16)
    assert drive.write(90, "LINE 3").rstrip() == "LINE 3"
    assert len(drive.read_words(90)) == 8
    assert drive.read_words(91) == (0x0000, 0x3039)
    assert drive.write_words(107, [0x4248, 0x0000]) == (0x4248, 0x0000)  # 50.0
    assert drive.value(107) == 50.0
    assert fault_number(drive.write, 107, 700.0) == ErrorNumber.LIMIT_EXCEEDED


class Recorder:
    def __init__(self) -> None:
        self.changes: list[ParameterChange] = []

    def __call__(self, change: ParameterChange) -> None:
        self.changes.append(change)


def test_active_parameter_changes_are_reported_to_the_other_interfaces(
    drive: ParameterMemory,
) -> None:
    uss, bass = Recorder(), Recorder()
    drive.subscribe("uss", uss)
    stop = drive.subscribe("bass", bass)
    assert drive.update(52, 0x0123)  # the drive's own change (uss.json spontaneous_word)
    expected = ParameterChange(52, None, (0x0123,), False, LOCAL)
    assert uss.changes == [expected] and bass.changes == [expected]
    assert not drive.update(52, 0x0123)  # no change, no report
    drive.write(18, 5, interface="bass")  # passive parameter: nothing
    assert len(uss.changes) == 1
    stop()
    drive.update(52, 7)
    assert len(uss.changes) == 2 and len(bass.changes) == 1


def test_change_by_an_interface_is_not_reported_back_to_it() -> None:
    db = parse_database(
        '[profile]\nname = "t"\n[[parameter]]\npnu = 10\nname = "A"\ntype = "int32"\n'
        "array = 2\nactive = true\n"
    )
    drive = ParameterMemory(db)
    uss, bass = Recorder(), Recorder()
    drive.subscribe("uss", uss)
    drive.subscribe("bass", bass)
    drive.write_words(10, [0, 9], 2, interface="bass")
    assert bass.changes == []
    assert uss.changes == [ParameterChange(10, 2, (0, 9), True, "bass")]
    drive.write_array_words(10, [0, 1, 0, 2], interface="bass")
    assert uss.changes[-1] == ParameterChange(10, WHOLE_ARRAY, (0, 1, 0, 2), True, "bass")


def test_update_ignores_limits_but_not_the_type(drive: ParameterMemory) -> None:
    drive.update(52, 0x0100)  # below the 5FFFh display limit: a display shows what is
    assert drive.value(52) == 0x0100
    assert fault_number(drive.update, 52, 0x8000) == ErrorNumber.LIMIT_EXCEEDED


def _values_of(param: ParameterSpec) -> st.SearchStrategy[object]:
    if param.bico:  # a signal source: parameter and index or bit (pyuss.protocol.bico)
        return st.builds(Bico, st.integers(0, MAX_SOURCE), st.integers(0, MAX_INDEX))
    if param.allowed is not None:
        return st.sampled_from(param.allowed)
    if param.dtype is DataType.FLOAT:
        return st.floats(float(param.low), float(param.high), width=32)
    if param.dtype is DataType.VISIBLE_STRING:
        alphabet = st.characters(min_codepoint=0x20, max_codepoint=0x7E)
        return st.text(alphabet, max_size=param.length)
    if param.dtype is DataType.OCTET_STRING:
        return st.binary(max_size=param.length)
    return st.integers(int(param.low), int(param.high))


@settings(max_examples=80, deadline=None)
@given(data=st.data())
def test_every_writable_value_round_trips_through_pkw_words(data: st.DataObject) -> None:
    drive = ParameterMemory(load_profile(data.draw(st.sampled_from(builtin_profiles()))))
    rule = drive.db.commissioning
    ending = set() if rule is None else {rule.end}  # writing it ends commissioning at once
    candidates = [
        p for p in drive.db if p.access is Access.RW and not p.reset_only and p.pnu not in ending
    ]
    param = data.draw(st.sampled_from(candidates))
    if param.changeable is not None and "T" not in param.changeable:
        assert rule is not None
        drive.write(rule.parameter, rule.quick)  # changeable in commissioning only
    value = param.check_write(data.draw(_values_of(param)))
    index = None if param.array is None else drive.db.profile.index_base + param.array - 1
    words = param.to_words(value)
    assert drive.write_words(param.pnu, words, index, interface="uss") == words
    assert drive.read_words(param.pnu, index) == words
    assert drive.value(param.pnu, index) == value


def test_baumueller_write_enable_bit_of_126() -> None:
    drive = ParameterMemory(load_profile("baumueller"))
    assert drive.write(182, 19200, interface="bass") == 19200
    drive.write(126, 0, interface="bass")  # bit 0 = 0: the interfaces may only read
    assert not drive.has_write_authority("uss")
    with pytest.raises(NoWriteAuthority):
        drive.write_words(182, [9600], interface="uss")
    assert drive.read_words(182) == (19200,)
    assert drive.write(182, 9600) == 9600  # the drive itself still may
    drive.write(126, 1, interface="uss")  # giving authority back stays possible
    assert drive.write_words(182, [4800], interface="uss") == (4800,)
