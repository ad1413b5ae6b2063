"""The master with the device profiles, against the drive simulator: parameter numbers from
2000 on (micromaster4), answers with IND 0 (6se21), pipelined answers and the longer start
pause (baumueller), another profile's timing (nord)."""

from __future__ import annotations

import itertools

import pytest

from pyuss.errors import ConfigError
from pyuss.master import ACYCLIC
from pyuss.master.profile import answers, resolve_profile, response_limit
from pyuss.profiles import get_profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId
from pyuss.protocol.timing import char_time
from support.buses import simulated_bus


async def test_micromaster4_reaches_parameters_from_2000_on_through_the_page_bits() -> None:
    layout = Layout(PKW_VARIABLE, 2)
    async with simulated_bus([(3, "micromaster4", layout)], profile="micromaster4") as env:
        drive = env.master.drive(3, layout=layout)
        assert await drive.read(2011, 0) == 3  # the interface shows its address
        assert await drive.read(2010, 0) == 8  # the COM link shows the bus's 38400 baud
        assert await drive.write(2010, 8, 1) == 8  # the BOP link
        assert await drive.read(2000) == 50.0  # a float parameter reads as a float
        assert await drive.read_raw(2000) == (0x4248, 0x0000)
        assert await drive.read_array(2012) == [2, 2]  # arrays count from 0 here
        # text element y = value + 1 (C 8 example 7)
        assert await drive.read_text(2010, 9, value_texts=True) == "38400 BAUD"


def test_a_page_mismatch_is_not_an_answer() -> None:
    mm4 = get_profile("micromaster4")
    bits, page = mm4.encode_pnu(2010)
    request = Pkw(RequestId.READ_VALUE, bits, page)
    assert answers(mm4, Pkw(ResponseId.VALUE_WORD, bits, page, values=(1,)), request)
    assert not answers(mm4, Pkw(ResponseId.VALUE_WORD, bits, 0, values=(1,)), request)  # P10
    with pytest.raises(ConfigError):
        get_profile("generic").encode_pnu(2048)


async def test_6se21_answers_with_ind_0_are_still_recognised() -> None:
    async with simulated_bus([(1, "6se21", Layout(3, 2))], profile="6se21") as env:
        drive = env.master.drive(1)
        assert drive.layout == Layout(3, 2)
        assert await drive.read(20) in (3, 8, 9, 11)
        assert await drive.write(2, 30) == 30
        status = await drive.on()
        assert status.control == 0x047F
        with pytest.raises(ConfigError, match="fixed layout"):
            env.master.drive(2, layout=Layout(4, 2), profile="6se21")


async def test_baumueller_pipelined_answers_and_three_character_start_pause() -> None:
    layout = Layout(3, 2)
    async with simulated_bus([(4, "baumueller", layout)], profile="baumueller", record=True) as env:
        drive = env.master.drive(4)
        assert await drive.read(60) == 2000
        assert await drive.write(60, 1500) == 1500
        assert await drive.read(61) == 2000
        assert drive.diagnostics().jobs.completed == 3
    assert env.recorder is not None
    records = env.recorder.records
    pause = 3 * char_time(env.bus.baud)
    gaps = [
        cur.start - prev.t
        for prev, cur in itertools.pairwise(records)
        if cur.sender == "master" and prev.sender != "master"
    ]
    assert gaps and min(gaps) >= pause - 1e-9


async def test_nord_drive_is_read_and_written() -> None:
    async with simulated_bus([(2, "nord", Layout(3, 2))], profile="nord") as env:
        drive = env.master.drive(2, layout=Layout(3, 2))
        assert await drive.read(102) == 2.0  # 200 x 0.01 s
        assert await drive.read_raw(102) == (200,)
        assert await drive.write(102, 1.5) == 1.5
        assert await drive.read_raw(102) == (150,)


def test_response_limit_follows_the_profile_and_never_drops_below_the_start_pause() -> None:
    assert response_limit(resolve_profile(None), 9600) == pytest.approx(0.020)
    assert response_limit(get_profile("6se21"), 9600) == pytest.approx(0.0175)
    assert response_limit(get_profile("baumueller"), 9600) == pytest.approx(0.020)
    assert response_limit(resolve_profile("generic"), 300) == pytest.approx(2 * 11 / 300)
    assert response_limit(resolve_profile("generic"), 9600, 0.05) == pytest.approx(0.05)
    with pytest.raises(ConfigError, match="unknown profile"):
        resolve_profile("nonesuch")


async def test_baumueller_masked_control_broadcast_with_address_coding() -> None:
    layout = Layout(3, 3)
    drives = [(1, "baumueller", layout), (2, "baumueller", layout), (3, "baumueller", layout)]
    async with simulated_bus(drives, profile="baumueller", mode=ACYCLIC) as env:
        handles = [env.master.drive(a, layout=layout) for a in (1, 2, 3)]
        for drive in handles:
            await drive.control_word(0x0406)
        machines = {a: env.engines[a].drive.machine for a in (1, 2, 3)}
        # Bit 0 for every drive: only the bits of the mask are taken.
        assert await env.master.broadcast_control(0xFFFF, mask=0x0001, layout=layout) == 0
        assert {a: m.control for a, m in machines.items()} == {1: 0x0407, 2: 0x0407, 3: 0x0407}
        # With the coding on (P181 bit 1) only the addresses named react.
        for address in (1, 2, 3):
            env.engines[address].drive.update(181, 0x0002)
        await env.master.broadcast_control(0x0000, mask=0x0001, layout=layout, addresses=[2])
        assert {a: m.control for a, m in machines.items()} == {1: 0x0407, 2: 0x0406, 3: 0x0407}


def test_broadcast_forms_check_what_they_are_given() -> None:
    from pyuss.master.broadcast import enable_array_data, masked_control_data
    from pyuss.protocol.broadcast import BroadcastEnableArray

    bea = BroadcastEnableArray.from_selection(words=[2])
    with pytest.raises(ConfigError, match="4-word PKW"):
        enable_array_data([0, 1], bea, Layout(3, 2))
    with pytest.raises(ConfigError, match="3 PZD words"):
        masked_control_data(1, layout=Layout(3, 2), addresses=[1])
    assert masked_control_data(0x47E, 0x0001, layout=Layout(4, 2)) == bytes.fromhex(
        "0000 0000 0001 0000 047E 0000"
    )
    assert masked_control_data(0x47E, layout=Layout(0, 2)) == bytes.fromhex("047E 0000")
