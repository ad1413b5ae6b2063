"""Every telegram of the shared vectors through the net data layer (C 4, C 5, C 8, appendix):
unpacked into its words and meaning, and built again from meaning to the exact bytes."""

from __future__ import annotations

from typing import Any

import pytest

from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import PKW_VARIABLE, Layout, NetData
from pyuss.protocol.pkw import (
    ErrorNumber,
    Pkw,
    RequestId,
    ResponseId,
    error_meaning,
    pwe_dword,
    pwe_text,
    pwe_word,
)
from pyuss.protocol.pzd import ControlWord, StatusWord, raw16_to_percent
from pyuss.protocol.telegram import AddressMode, Telegram
from support.paths import load_vectors

VECTORS = load_vectors("uss")["telegrams"]
BY_NAME = {v["name"]: v for v in VECTORS}


def layout_of(vec: dict[str, Any]) -> Layout:
    pkw = vec["layout"]["pkw"]
    return Layout(PKW_VARIABLE if pkw == "variable" else pkw, vec["layout"]["pzd"])


def unpack(name: str) -> NetData:
    vec = BY_NAME[name]
    return layout_of(vec).unpack(Telegram.decode(bytes.fromhex(vec["hex"])).data)


def build(name: str, pkw: Pkw | None, pzd: list[int]) -> bytes:
    vec = BY_NAME[name]
    address = vec["adr"] & 0x1F
    mode = AddressMode(vec["adr"] & 0xE0)
    return Telegram(address, mode, layout_of(vec).pack(pkw, pzd)).encode()


@pytest.mark.parametrize("vec", VECTORS, ids=[v["name"] for v in VECTORS])
def test_vector_unpacks_to_its_words_and_packs_back(vec: dict[str, Any]) -> None:
    layout = layout_of(vec)
    data = Telegram.decode(bytes.fromhex(vec["hex"])).data
    net = layout.unpack(data)
    words = (net.pkw.words() if net.pkw else ()) + net.pzd
    assert [f"{w:04X}" for w in words] == vec["words_hex"]
    assert layout.pack(net.pkw, net.pzd) == data


def test_c81_example_1_process_data_only() -> None:
    request = unpack("pzd_only_request")
    assert request.pkw is None
    control = ControlWord(request.pzd[0])
    assert control == (
        ControlWord.ON
        | ControlWord.NO_OFF2
        | ControlWord.NO_OFF3
        | ControlWord.ENABLE_OPERATION
        | ControlWord.ENABLE_RAMP_GENERATOR
        | ControlWord.START_RAMP_GENERATOR
        | ControlWord.ENABLE_SETPOINT
        | ControlWord.CONTROL_BY_PLC
    )
    assert raw16_to_percent(request.pzd[1]) == 50.0
    status = StatusWord(unpack("pzd_only_response").pzd[0])
    assert status == (
        StatusWord.READY_TO_SWITCH_ON
        | StatusWord.READY
        | StatusWord.OPERATION_ENABLED
        | StatusWord.NO_OFF2
        | StatusWord.NO_OFF3
        | StatusWord.IN_TOLERANCE
        | StatusWord.CONTROL_REQUESTED
    )
    assert build("pzd_only_request", None, [int(control), 0x2000]) == bytes.fromhex(
        BY_NAME["pzd_only_request"]["hex"]
    )


def test_c81_example_2_read_word() -> None:
    request = Pkw(RequestId.READ_VALUE, 52)
    assert unpack("read_word_request").pkw == Pkw(1, 52, 0, False, (0,))
    raw = build("read_word_request", request, [0x047E, 0])
    assert raw.hex(" ").upper() == BY_NAME["read_word_request"]["hex"]
    response = unpack("read_word_response").pkw
    assert response is not None
    assert response.response_id is ResponseId.VALUE_WORD
    assert response.word() == 0x4000
    assert response.is_answer_to(request)
    assert StatusWord(unpack("read_word_response").pzd[0]) == (
        StatusWord.READY_TO_SWITCH_ON
        | StatusWord.NO_OFF2
        | StatusWord.NO_OFF3
        | StatusWord.CONTROL_REQUESTED
    )


def test_c81_example_3_whole_description_refused() -> None:
    request = unpack("read_whole_pbe_request").pkw
    assert request is not None
    assert request.request_id is RequestId.READ_PBE_ELEMENT
    assert request.subindex == 255
    refused = unpack("read_whole_pbe_refused").pkw
    assert refused is not None
    assert refused.response_id is ResponseId.REFUSED
    assert refused.error_number == 103
    assert refused.is_answer_to(request)
    meaning = error_meaning(103, {103: "format too large for the PKW area"})
    assert meaning == "format too large for the PKW area"


def test_c81_example_4_description_element() -> None:
    request = Pkw(RequestId.READ_PBE_ELEMENT, 52, 7)
    raw = build("read_pbe_element_request", request, [0x047E, 0])
    assert raw.hex(" ").upper() == BY_NAME["read_pbe_element_request"]["hex"]
    response = unpack("read_pbe_element_response").pkw
    assert response is not None
    assert response.response_id is ResponseId.PBE_ELEMENT
    assert response.word() == 0x5FFF
    assert response.is_answer_to(request)
    assert not response.is_answer_to(Pkw(RequestId.READ_PBE_ELEMENT, 52, 255))


def test_c81_example_5_array_double_word() -> None:
    request = Pkw(RequestId.WRITE_ARRAY_DWORD, 4, 2, values=pwe_dword(0x4000_0000))
    raw = build("write_array_dword_request", request, [])
    assert raw.hex(" ").upper() == BY_NAME["write_array_dword_request"]["hex"]
    response = unpack("write_array_dword_response").pkw
    assert response is not None
    assert response.response_id is ResponseId.ARRAY_DWORD
    assert response.dword() == 0x4000_0000
    assert response.is_answer_to(request)
    assert not response.is_answer_to(Pkw(RequestId.WRITE_ARRAY_DWORD, 4, 3))


def test_c81_example_6_word_travels_in_pwe2_with_pkw_4() -> None:
    request = Pkw(RequestId.WRITE_WORD, 18, values=pwe_word(0x7000))
    raw = build("write_word_pkw4_request", request, [])
    assert raw.hex(" ").upper() == BY_NAME["write_word_pkw4_request"]["hex"]
    response = unpack("write_word_pkw4_response").pkw
    assert response is not None
    assert response.values == (0, 0x7000)
    assert response.word() == 0x7000
    assert response.is_answer_to(request)


def test_c82_example_7_text_with_variable_length() -> None:
    request = Pkw(RequestId.TEXT, 7, 3)
    raw = build("read_text_request", request, [])
    assert raw.hex(" ").upper() == BY_NAME["read_text_request"]["hex"]
    response = Pkw(ResponseId.TEXT, 7, 3, values=pwe_text("300 BAUD", 16))
    raw = build("read_text_response", response, [])
    assert raw.hex(" ").upper() == BY_NAME["read_text_response"]["hex"]
    received = unpack("read_text_response").pkw
    assert received is not None
    assert received.text() == "300 BAUD"
    assert received.is_answer_to(request)


def test_broadcast_examples_of_the_appendix() -> None:
    bea = BroadcastEnableArray.from_selection(words=[2])
    assert bea.to_pkw_words() == (0x0005, 0, 0, 0)
    raw = build("broadcast_setpoint", bea.to_pkw(), [0, 0x2000])
    assert raw.hex(" ").upper() == BY_NAME["broadcast_setpoint"]["hex"]
    bea = BroadcastEnableArray.from_selection(bits={1: 0x0020})
    assert bea.to_pkw_words() == (0x0003, 0x0020, 0, 0)
    raw = build("broadcast_ramp_enable", bea.to_pkw(), [0x0020, 0])
    assert raw.hex(" ").upper() == BY_NAME["broadcast_ramp_enable"]["hex"]
    pkw = unpack("broadcast_ramp_enable").pkw
    assert pkw is not None
    assert BroadcastEnableArray.from_pkw(pkw) == bea


def test_spontaneous_message_is_no_answer() -> None:
    spm = unpack("spontaneous_word").pkw
    assert spm is not None
    assert spm.response_id is ResponseId.SPONTANEOUS_WORD
    assert spm.response_id.is_spontaneous
    assert spm.spm_toggle
    assert spm.pnu == 52
    assert spm.word() == 0x0123
    assert not spm.is_answer_to(Pkw(RequestId.READ_VALUE, 52))


def test_error_illegal_pnu() -> None:
    pkw = unpack("error_illegal_pnu").pkw
    assert pkw is not None
    assert pkw.response_id is ResponseId.REFUSED
    assert pkw.pnu == 999
    assert pkw.error_number == ErrorNumber.ILLEGAL_PNU
    assert error_meaning(pkw.error_number) == "illegal parameter number"
    assert pkw.is_answer_to(Pkw(RequestId.READ_VALUE, 999))
    assert not pkw.is_answer_to(Pkw(RequestId.READ_VALUE, 998))


def test_6se21_initialisation_word() -> None:
    net = unpack("6se21_init")
    assert net.pkw == Pkw(0, values=(0,))
    assert ControlWord(net.pzd[0]) & ControlWord.ON == 0
    assert ControlWord(net.pzd[0]) & ControlWord.CONTROL_BY_PLC
    assert build("6se21_init", None, [0x047E, 0]).hex(" ").upper() == BY_NAME["6se21_init"]["hex"]
