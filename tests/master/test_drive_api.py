"""The rest of the Drive API against the drive simulator on the virtual bus: EEPROM writes,
whole descriptions and arrays in one telegram, texts written and read back, 32-bit and raw
setpoints, jog 2; bad values; and the constructors, which open nothing and touch no event loop."""

from __future__ import annotations

import asyncio
import itertools
import threading
from concurrent.futures import ThreadPoolExecutor

import pytest

from pyuss.bus import VirtualBus
from pyuss.errors import ConfigError, DriveRefusal
from pyuss.master import Drive, Master
from pyuss.master import sync as sync_master
from pyuss.master.drive import Bus
from pyuss.master.profile import response_limit
from pyuss.params.values import ValueRefused
from pyuss.profiles import get_profile
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.protocol.timing import char_time
from support.buses import SimulatorThread, line_telegrams, simulated_bus

VARIABLE = Layout(PKW_VARIABLE, 3)


async def test_eeprom_writes_use_the_eeprom_requests() -> None:
    async with simulated_bus([(5, "generic", VARIABLE)], record=True) as env:
        drive = env.master.drive(5, layout=VARIABLE)
        assert await drive.write(18, 0x1234, eeprom=True) == 0x1234
        assert await drive.write(4, -5, 3, eeprom=True) == -5  # int32: a double word
        assert await drive.write(107, 60.0, eeprom=True) == 60.0
        assert await drive.write(683, 9, 2, eeprom=True) == 9
        assert await drive.read(4, 3) == -5
        assert await drive.read(683, 2) == 9
    assert env.recorder is not None
    sent = [VARIABLE.unpack(r.telegram.data).pkw for r in line_telegrams(env.recorder, 38400)]
    jobs = [k for k, _ in itertools.groupby(p.id for p in sent if p is not None and p.id)]
    assert jobs == [
        RequestId.WRITE_WORD_EEPROM,  # 14
        RequestId.WRITE_ARRAY_DWORD_EEPROM,  # 11
        RequestId.WRITE_DWORD_EEPROM,  # 13 (a float is a double word)
        RequestId.WRITE_ARRAY_WORD_EEPROM,  # 12
        RequestId.READ_ARRAY,
    ]


async def test_a_master_without_a_profile_applies_no_familys_facts() -> None:
    async with simulated_bus([(5, "generic", Layout(4, 2))], profile=None, record=True) as env:
        unknown = env.master.drive(5, layout=Layout(4, 2))
        assert len(unknown.params) == 0
        with pytest.raises(DriveRefusal) as refused:  # the drive says so, not the generic file
            await unknown.write(3, 5)
        assert refused.value.number == 1
        assert await unknown.read(52) == 0x4000  # a word, as it travels
    assert env.recorder is not None
    sent = [Layout(4, 2).unpack(r.telegram.data).pkw for r in line_telegrams(env.recorder, 38400)]
    assert RequestId.READ_PBE_ELEMENT not in {p.id for p in sent if p is not None}
    async with simulated_bus([(5, "generic", Layout(4, 2))]) as env:
        named = env.master.drive(5, layout=Layout(4, 2))
        with pytest.raises(ValueRefused, match="read-only"):  # the generic profile's fact
            await named.write(3, 5)


async def test_whole_description_array_and_texts_with_the_variable_layout() -> None:
    async with simulated_bus([(5, "generic", VARIABLE)], record=True) as env:
        drive = env.master.drive(5, layout=VARIABLE)
        description = await drive.read_description(52)  # IND 255: all of it in one telegram
        assert description.name == "Load display"
        assert (description.low, description.high) == (0x5FFF, 0x7FFF)
        assert sorted(description.elements) == list(range(1, 11))
        assert await drive.array_length(4) == 4
        assert await drive.write(4, 0x4000_0000, 2) == 0x4000_0000
        assert await drive.read_array(4) == [0, 0x4000_0000, 0, 0]
        assert await drive.write_text(7, 3, "300 BD") == "300 BD"
        assert await drive.read_text(7, 3) == "300 BD"
        assert env.engines[5].drive.text(7, 3).rstrip() == "300 BD"
    assert env.recorder is not None
    sent = [VARIABLE.unpack(r.telegram.data).pkw for r in line_telegrams(env.recorder, 38400)]
    jobs = [(p.id, p.index & 0xFF) for p in sent if p is not None and p.id]
    # one telegram kind each: no element-by-element walk with the variable layout
    assert (RequestId.READ_PBE_ELEMENT, 255) in jobs
    assert {i for r, i in jobs if r == RequestId.READ_PBE_ELEMENT} == {255}
    assert {i for r, i in jobs if r == RequestId.READ_ARRAY} == {255}


async def test_setpoints_raw_and_32_bit_and_jog_2() -> None:
    async with simulated_bus([(5, "generic", VARIABLE)]) as env:
        drive = env.master.drive(5, layout=VARIABLE)
        await drive.setpoint(25.0, dword=True)  # 1000 0000h, high word first
        assert drive.setpoints == (0x1000, 0x0000)
        status = await drive.setpoint(raw=-2, pzd=3)
        assert drive.setpoints == (0x1000, 0xFFFE)
        assert status.control == 0  # a setpoint alone does not take control of the drive
        await drive.on()
        status = await drive.jog(2)
        assert status.control == 0x067F
        assert (await drive.jog(None)).control == 0x047F
        for bad in (float("inf"), float("nan"), 250.0):
            with pytest.raises(ConfigError):
                await drive.setpoint(bad)
        with pytest.raises(ConfigError):
            await drive.setpoint(raw=0x10000)
        with pytest.raises(ConfigError):
            await drive.jog(3)
        for value in (float("nan"), float("inf")):
            with pytest.raises(ConfigError, match="finite"):
                await drive.write(107, value)
        with pytest.raises(ConfigError, match=r"0\.\.31"):
            await env.master.mirror(40)
        with pytest.raises(ConfigError, match="252"):
            await env.master.mirror(5, bytes(300))


def test_response_limit_is_never_below_the_profiles_start_pause() -> None:
    # Baumueller keeps 3 character times before every telegram (reading 2): a limit asked
    # for below that would time out every answer (A 5.2.1.1).
    baumueller = get_profile("baumueller")
    assert response_limit(baumueller, 9600, 0.001) == pytest.approx(3 * char_time(9600))
    assert response_limit(get_profile("generic"), 9600, 0.001) == pytest.approx(2 * char_time(9600))


def test_constructors_open_nothing_and_touch_no_event_loop() -> None:
    bus = VirtualBus(9600)
    made: list[object] = []

    def construct() -> None:
        # a thread of its own has no event loop: asking for one would raise here
        made.append(Master(bus.attach("master"), layout="3,2", cycle_time=0.1))
        made.append(sync_master.Master(bus.attach("sync"), layout="3,2"))
        with pytest.raises(RuntimeError):
            asyncio.get_event_loop()

    worker = threading.Thread(target=construct)
    worker.start()
    worker.join()
    assert len(made) == 2
    assert not loop_threads()  # the facade starts its thread on open()
    master = made[0]
    assert isinstance(master, Master) and not master.running
    assert not master.transport.is_open

    async def use() -> int:
        async with master:
            drive = master.drive(5)
            return drive.address

    assert asyncio.run(use()) == 5  # built without a loop, used on another thread's loop
    asyncio.run(bus.close())


def test_the_sync_facade_offers_every_public_name_of_the_asyncio_api() -> None:
    def public(cls: type) -> set[str]:
        return {name for name in dir(cls) if not name.startswith("_")}

    assert public(Drive) <= public(sync_master.Drive)
    # open() starts it; what a Drive asks of its master is no user's call
    assert public(Master) - {"start"} - public(Bus) <= public(sync_master.Master)


def loop_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "uss master"]


def test_the_sync_facade_runs_the_same_core_in_one_thread() -> None:
    with SimulatorThread([(5, "generic", Layout(3, 2))]) as sim:
        master = sync_master.Master(sim.paths[0], baud=sim.baud, layout="3,2")
        assert not loop_threads()
        with master:
            assert master.running and len(loop_threads()) == 1
            with ThreadPoolExecutor(8) as pool:  # one handle per address, whoever asks first
                handles = list(pool.map(lambda _: master.drive(5), range(16)))
            drive = master.drive(5)
            assert all(handle is drive for handle in handles)
            assert master.drives == (drive,)
            assert master.core.drives == (drive.core,)
            assert drive.read(52) == 0x4000
            assert drive.job(Pkw(RequestId.READ_VALUE, 18)).id == ResponseId.VALUE_WORD
            assert drive.setpoints == (0,)
            assert drive.response_delay == pytest.approx(0.02)
            reply = master.request(Telegram(5, AddressMode.MIRROR, bytes(10)))
            assert reply is not None and reply.telegram.mode is AddressMode.MIRROR
        assert not master.running and not loop_threads()


def test_the_sync_drive_offers_every_call_of_the_async_one_with_the_same_arguments() -> None:
    import inspect

    for name in (n for n in dir(Drive) if not n.startswith("_")):
        call = getattr(Drive, name)
        assert hasattr(sync_master.Drive, name), name
        if inspect.isfunction(call):
            mine = list(inspect.signature(getattr(sync_master.Drive, name)).parameters)
            assert mine == list(inspect.signature(call).parameters), name
    assert isinstance(sync_master.Drive.params, property)  # the async drive's book, shared


async def test_simulated_drives_from_one_station_answer_every_address() -> None:
    from pyuss.master.testing import simulated_drives

    bus = VirtualBus(38400)
    layout = Layout(3, 2)
    drives = [(3, "generic", layout), (17, "generic", layout)]
    try:
        async with (
            simulated_drives(bus, drives, one_station=True) as engines,
            Master(bus.attach("master"), layout=layout) as master,
        ):
            assert set(bus.stations) == {"drives", "master"}
            engines[17].drive.write(462, 77)  # ramp-up time, set on the drive's panel
            assert await master.drive(17).read_raw(462) == (77,)
            assert await master.drive(3).read_raw(462) != (77,)
    finally:
        await bus.close()


async def test_a_refusal_says_what_to_do_in_the_family_s_words() -> None:
    """A refused job names the parameter as the family writes it and what to do: the
    family's own hint where its parameter file has one (V20 error 17; Baumueller response 8:
    P126), the family-neutral one of C Table 4.3 otherwise."""
    from pyuss.master import NoWriteAuthority
    from pyuss.master.testing import simulated_drives

    bus = VirtualBus(38400)
    drives = [(3, "sinamics-v20", None), (4, "baumueller", None)]
    try:
        async with (
            simulated_drives(bus, drives),
            Master(bus.attach("master"), profile="sinamics-v20") as master,
        ):
            v20 = master.drive(3)
            with pytest.raises(DriveRefusal) as refused:
                await v20.write_raw(310, (0x4270, 0), 0)  # motor data outside commissioning
            assert str(refused.value).startswith("drive refused the job (P0310.0): error 17: ")
            assert refused.value.hint.endswith("set P0010 = 1 first and P0010 = 0 after")
            assert str(refused.value).endswith(refused.value.hint)
            with pytest.raises(DriveRefusal) as refused:
                await v20.read_raw(999)
            assert "(P0999): error 0: illegal parameter number; check the parameter" in str(
                refused.value
            )
            baumueller = master.drive(4, profile="baumueller")
            await baumueller.write_raw(126, (0,))  # communication may no longer change parameters
            with pytest.raises(NoWriteAuthority) as denied:
                await baumueller.write_raw(60, (1,))
            assert "no parameter change rights for P60" in str(denied.value)
            assert str(denied.value).endswith(
                ": set bit 0 of P126 (communication source) so that the communication "
                "interfaces may change parameters (Baumueller manual 1.5)"
            )
    finally:
        await bus.close()


async def test_every_telegram_carries_the_newest_process_data_and_the_open_job() -> None:
    # Without a job the master sends the telegram it made last as long as the process data
    # stay the same; a new setpoint or control word, or a job, goes out in the next one.
    layout = Layout(4, 2)
    async with simulated_bus([(5, "generic", layout)], record=True) as env:
        drive = env.master.drive(5, layout=layout)
        for _ in range(3):
            await drive.next_update()
        drive.set_pzd(2, 0x1234)
        await drive.next_update()
        await drive.next_update()
        assert await drive.read(52) == 0x4000
        drive.set_pzd(1, 0x047E)
        await drive.next_update()
        await drive.next_update()
    assert env.recorder is not None
    sent = [layout.unpack(r.telegram.data) for r in line_telegrams(env.recorder, 38400)]
    words = [(net.pzd, net.pkw.id if net.pkw else None) for net in sent]
    setpoint = next(i for i, (pzd, _) in enumerate(words) if pzd[1] == 0x1234)
    assert all(pzd[1] == 0x1234 for pzd, _ in words[setpoint:])
    read = [i for i, (_, job) in enumerate(words) if job == RequestId.READ_VALUE]
    assert read and read[0] > setpoint and words[read[-1] + 1][1] == RequestId.NO_JOB
    control = next(i for i, (pzd, _) in enumerate(words) if pzd[0] == 0x047E)
    assert control > read[-1] and all(pzd[0] == 0x047E for pzd, _ in words[control:])
    assert len(words) - control >= 2 and words[-1] == words[-2]
