"""Which telegrams a slave answers (A 2.1, A 3, A 4.3, A 5.2.2, A 5.3, A 5.4), over TCP."""

from __future__ import annotations

from pyuss.drive import DriveState, SimulatedDrive, parse_database
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import SlaveEngine
from slave.harness import LineSim, engine, frame

L32 = Layout(3, 2)
READ_P52 = "1034 0000 0000 047E 0000"


def test_answers_only_telegrams_addressed_to_it() -> None:
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        assert master.silent(frame(6, READ_P52))
        assert master.silent(frame(4, READ_P52))
        answer = master.exchange(frame(5, READ_P52))
    assert answer[2] == 5


def test_telegrams_with_errors_are_not_answered() -> None:
    good = frame(5, READ_P52)
    bad_bcc = good[:-1] + bytes((good[-1] ^ 0xFF,))
    bad_lge = bytes((0x02, 0xFF)) + good[2:]
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        assert master.silent(bad_bcc)
        assert master.silent(bad_lge)
        assert master.silent(frame(5, "1034 0000 0000 047E 0000 0000"))  # fixed length: LGE 14
        assert master.exchange(good)
        counters = sim.call(lambda: sim.server.diagnostics.snapshot(0.0))
    assert counters.bcc == 1
    assert counters.bad_lge >= 2
    assert counters.good == 1


def test_variable_layout_discards_telegrams_too_short_for_it() -> None:
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        assert master.silent(frame(5, "1034 0000 047E 0000"))  # PKE, IND, PZD: no PWE
        assert master.exchange(frame(5, READ_P52))


def test_undefined_adr_combinations_lead_to_no_reaction() -> None:
    """A 4.3 and Table 5.2: 011, 110, 111 in bits 7..5 are undefined."""
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        for mode_bits in (0x60, 0xC0, 0xE0):
            assert master.silent(frame(mode_bits | 5, "0000 0000 0000 047F 2000"))
        control = sim.call(lambda: sim.drive.machine.control)
    assert control == 0  # nothing of them was taken


def test_mirror_returns_the_telegram_unchanged_and_processes_nothing() -> None:
    """A 5.3: the slave sends the telegram back without any change and takes nothing from it."""
    job = frame(0x40 | 5, "2012 0000 7000 047F 2000")  # a write job and ON, mirrored
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        assert master.exchange(job) == job
        assert master.silent(frame(0x40 | 5, "2012 0000 7000"))  # fixed length: LGE checked
        p18, control = sim.call(lambda: (sim.drive.value(18), sim.drive.machine.control))
    assert p18 == 0
    assert control == 0


def test_variable_length_slave_mirrors_any_length() -> None:
    odd = frame(0x40 | 5, "20 12 00 00 70")  # an odd length that fits no layout
    with LineSim(engine(5, "generic", "v,2")) as sim, sim.master() as master:
        assert master.exchange(odd) == odd


def test_broadcast_jobs_are_never_executed_nor_answered() -> None:
    with LineSim(engine(5, "generic", "4,2")) as sim, sim.master() as master:
        assert master.silent(frame(0x20, "2012 0000 0000 7000 047F 2000"))  # no flag in word a
        p18, control = sim.call(lambda: (sim.drive.value(18), sim.drive.machine.control))
    assert p18 == 0
    assert control == 0


def test_broadcast_without_a_4_word_pkw_area_is_not_taken() -> None:
    """The Broadcast Enable Array needs 4 PKW words; a PKW 3 slave takes nothing."""
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        assert master.silent(frame(0x20, "0005 0000 0000 047E 2000"))
        setpoint = sim.call(lambda: sim.drive.machine.setpoint)
    assert setpoint == 0.0


def test_pzd16_is_never_taken_from_a_broadcast() -> None:
    """Appendix: word 16 is not broadcast-capable, even with every enable bit set."""
    pzd = " ".join(f"{0x1000 + i:04X}" for i in range(16))
    with LineSim(engine(5, "generic", "4,16")) as sim, sim.master() as master:
        master.exchange(frame(5, "0000 0000 0000 0000 " + " ".join(["0000"] * 16)))
        assert master.silent(frame(0x20, f"FFFF FFFF FFFF FFFF {pzd}"))
        last = sim.call(lambda: sim.engines[0]._last_pzd)
    assert last == (0,) * 16  # the image of the last non-broadcast telegram is kept


def test_broadcast_merges_into_the_process_data_in_force() -> None:
    """Appendix, C Table 5.4 bit 10: telegrams whose control word has bit 10 = 0 are ignored
    and the old process data stay in force; a broadcast enabling bit 0 of PZD1 merges into
    that control word (047Eh), not into the ignored 0000h, and switches the drive on."""
    broadcast = bytes.fromhex("02 0E 20 00 03 00 01 00 00 00 00 04 7F 30 00 65")
    assert broadcast == frame(0x20, "0003 0001 0000 0000 047F 3000")
    with LineSim(engine(6, "generic", "4,2")) as sim, sim.master() as master:
        master.exchange(frame(6, "0000 0000 0000 0000 047E 1000"))
        for _ in range(3):
            ignored = master.exchange(frame(6, "0000 0000 0000 0000 0000 1000"))
        assert ignored[11:13] == bytes.fromhex("0231")  # ready to switch on
        assert master.silent(broadcast)
        answer = master.exchange(frame(6, "0000 0000 0000 0000 0000 0000"))
        control, state = sim.call(lambda: (sim.drive.machine.control, sim.drive.state))
    assert control == 0x047F
    assert state is DriveState.OPERATION
    assert answer[12] & 0x07 == 0x07  # status bits 0..2: ready to switch on, ready, operation


def test_special_telegrams_go_to_a_registered_handler() -> None:
    """A 5.4: with special-telegram handling the slave answers them (not special broadcasts)."""
    seen: list[Telegram] = []

    def handler(telegram: Telegram, now: float) -> Telegram | None:
        seen.append(telegram)
        return Telegram(telegram.address, AddressMode.SPECIAL, telegram.data[::-1])

    with LineSim(engine(5, "generic", "3,2", special=handler)) as sim, sim.master() as master:
        answer = master.exchange(frame(0x85, "01 02 03"))
        assert master.silent(frame(0xA0, "09 08"))  # special broadcast: taken, not answered
        assert master.silent(frame(0x86, "01 02 03"))  # another address
        normal = master.ask(5, L32, Pkw(1, 52), (0x047E, 0))
    assert answer == frame(0x85, "03 02 01")
    assert [t.mode for t in seen] == [AddressMode.SPECIAL, AddressMode.SPECIAL_BROADCAST]
    assert normal.pkw.values == (0x4000,)


BEA_FILE = """
[profile]
name = "bea"
extends = "generic"

[process]
setpoints = [60, 61, 62]

[[parameter]]
pnu = 60
name = "Setpoint PZD3"
type = "uint16"

[[parameter]]
pnu = 61
name = "Command PZD4"
type = "uint16"

[[parameter]]
pnu = 62
name = "Command PZD5"
type = "uint16"
"""


def test_broadcast_enable_words_c_and_d_select_bits_of_pzd_4_and_5() -> None:
    """Appendix: word a enables PZD 3, 4, 5 (not 1, 2); word c selects bits of PZD 4, d of
    PZD 5; word b is ignored as word 1 is not enabled. The rest keeps the last values."""

    def make(now: float) -> list[SlaveEngine]:
        drive = SimulatedDrive(parse_database(BEA_FILE), now=now)
        return [SlaveEngine(5, drive, get_profile("generic"), layout=Layout(4, 5), now=now)]

    with LineSim(make) as sim, sim.master() as master:
        master.exchange(frame(5, "0000 0000 0000 0000 047E 1000 1111 2222 3333"))
        # a = 0039h (flag, PZD 3, 4, 5), b = FFFFh, c = 00FFh, d = F000h
        assert master.silent(frame(0x20, "0039 FFFF 00FF F000 047F 4000 AAAA BBBB CCCC"))
        taken = sim.call(
            lambda: (
                sim.drive.machine.control,
                sim.drive.machine.setpoint,
                [sim.drive.value(p) for p in (60, 61, 62)],
            )
        )
    assert taken == (0x047E, 0.25, [0xAAAA, 0x22BB, 0xC333])
