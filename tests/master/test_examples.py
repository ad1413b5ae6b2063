"""The examples of C 8 (and the other telegrams of the shared vectors), end to end: the Drive
API against the drive simulator on the virtual bus, byte-exact with the vectors."""

from __future__ import annotations

import asyncio

import pytest

from pyuss.errors import DriveRefusal
from pyuss.master import ACYCLIC, SpontaneousMessage
from pyuss.protocol.broadcast import BroadcastEnableArray
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from support.buses import line_telegrams, simulated_bus
from support.paths import load_vectors

VECTORS = {v["name"]: bytes.fromhex(v["hex"]) for v in load_vectors("uss")["telegrams"]}


def sent_by(setup, sender: str = "master") -> list[bytes]:  # type: ignore[no-untyped-def]
    assert setup.recorder is not None
    return [r.raw for r in line_telegrams(setup.recorder, setup.bus.baud, sender)]


async def test_example_1_process_data_only() -> None:
    async with simulated_bus([(5, "generic", Layout(0, 2))], record=True) as env:
        env.engines[5].drive.write(462, 2)  # ramp-up time 0.2 s (set on the panel)
        drive = env.master.drive(5, layout=Layout(0, 2))
        await drive.on()
        await drive.setpoint(50.0)
        status = await drive.wait_until(lambda s: s.actual_percent == 50.0, timeout=30)
        assert status.running
        assert status.in_tolerance
    assert VECTORS["pzd_only_request"] in sent_by(env)


async def test_example_2_read_a_word_parameter() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))], record=True) as env:
        drive = env.master.drive(5, layout=Layout(3, 2))
        await drive.off1()  # 047Eh, as in the example
        assert await drive.read(52) == 0x4000
    assert VECTORS["read_word_request"] in sent_by(env)
    answers = sent_by(env, "drive5")
    assert any(a[:9] == VECTORS["read_word_response"][:9] for a in answers)


async def test_example_3_whole_description_under_a_fixed_length_is_refused() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))], record=True) as env:
        drive = env.master.drive(5, layout=Layout(3, 2))
        await drive.off1()
        with pytest.raises(DriveRefusal) as info:
            await drive.read_description(52, 255)
        assert info.value.number == 103
        assert "too large" in info.value.meaning
    assert VECTORS["read_whole_pbe_request"] in sent_by(env)
    answers = sent_by(env, "drive5")
    assert any(a[:9] == VECTORS["read_whole_pbe_refused"][:9] for a in answers)


async def test_example_4_read_a_description_element() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))], record=True) as env:
        drive = env.master.drive(5, layout=Layout(3, 2))
        await drive.off1()
        element = (await drive.read_description(52, 7)).elements[7]
        assert element.name == "lower limit"
        assert element.words == (0x5FFF,)
    assert VECTORS["read_pbe_element_request"] in sent_by(env)


async def test_examples_5_and_6_write_with_a_4_word_pkw_area() -> None:
    async with simulated_bus([(5, "generic", Layout(4, 0))], record=True) as env:
        drive = env.master.drive(5, layout=Layout(4, 0))
        assert await drive.write(4, 0x4000_0000, 2) == 0x4000_0000
        assert await drive.write(18, 0x7000) == 0x7000
        assert await drive.read(4, 2) == 0x4000_0000
    sent = sent_by(env)
    assert VECTORS["write_array_dword_request"] in sent
    assert VECTORS["write_word_pkw4_request"] in sent
    answers = sent_by(env, "drive5")
    assert VECTORS["write_array_dword_response"] in answers
    assert VECTORS["write_word_pkw4_response"] in answers


async def test_example_7_read_a_text_with_the_variable_length() -> None:
    layout = Layout(PKW_VARIABLE, 0)
    async with simulated_bus([(5, "generic", layout)], record=True) as env:
        drive = env.master.drive(5, layout=layout)
        assert await drive.read_text(7, 3) == "300 BAUD"
    assert VECTORS["read_text_request"] in sent_by(env)
    assert VECTORS["read_text_response"] in sent_by(env, "drive5")


async def test_error_illegal_pnu_vector() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))], record=True) as env:
        drive = env.master.drive(5, layout=Layout(3, 2))
        with pytest.raises(DriveRefusal, match="illegal parameter number"):
            await drive.read(999)
    assert any(a[3:9] == VECTORS["error_illegal_pnu"][3:9] for a in sent_by(env, "drive5"))


async def test_mirror_vector() -> None:
    async with simulated_bus([(7, "generic", Layout(3, 2))], record=True) as env:
        env.master.drive(7, layout=Layout(3, 2))
        data = VECTORS["mirror_request"][3:-1]
        result = await env.master.mirror(7, data)
        assert result.sent == VECTORS["mirror_request"]
    assert VECTORS["mirror_request"] in sent_by(env, "drive7")


async def test_broadcast_vectors_reach_the_drives() -> None:
    # Acyclic traffic, so that no individual telegram overwrites what the broadcast set
    # (disabled words keep what the last individual telegram set, appendix).
    layout = Layout(4, 2)
    drives = [(1, "generic", layout), (2, "generic", layout)]
    async with simulated_bus(drives, record=True, mode=ACYCLIC) as env:
        one, two = env.master.drive(1, layout=layout), env.master.drive(2, layout=layout)
        for drive in (one, two):
            await drive.on()
            await drive.control_word(0x045F)  # ramp generator held (control bit 5 = 0)
        machines = [env.engines[a].drive.machine for a in (1, 2)]
        assert [m.setpoint for m in machines] == [0.0, 0.0]
        bea = BroadcastEnableArray.from_selection(words=[2])
        assert await env.master.broadcast([0, 0x2000], enable=bea) == 0
        assert [m.setpoint for m in machines] == [0.5, 0.5]
        assert [m.control for m in machines] == [0x045F, 0x045F]
        ramp = BroadcastEnableArray.from_selection(bits={1: 0x0020})
        assert await env.master.broadcast([0x0020, 0], enable=ramp, layout=layout) == 0
        assert [m.control for m in machines] == [0x047F, 0x047F]
    sent = sent_by(env)
    assert VECTORS["broadcast_setpoint"] in sent
    assert VECTORS["broadcast_ramp_enable"] in sent
    assert env.master.diagnostics().answered_broadcasts == 0


async def test_spontaneous_message_from_the_simulator_is_acknowledged() -> None:
    async with simulated_bus([(5, "generic", Layout(3, 2))]) as env:
        drive = env.master.drive(5, layout=Layout(3, 2))
        messages: list[SpontaneousMessage] = []
        drive.on_spontaneous(messages.append)
        assert await drive.read(52) == 0x4000
        engine = env.engines[5]
        engine.drive.update(52, 0x0123)  # the drive changes its display
        for _ in range(6):
            await drive.next_update()
        assert [(m.pnu, m.value) for m in messages] == [(52, 0x0123)]
        assert await drive.read(52) == 0x0123
        await asyncio.sleep(0)
