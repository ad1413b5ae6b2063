"""Every telegram of the vectors file and the examples of C 8, over TCP, byte for byte."""

from __future__ import annotations

from typing import Any

import pytest

from pyuss.protocol.layout import Layout
from slave.harness import LineSim, engine, frame
from support.paths import load_vectors

VECTORS: dict[str, Any] = {t["name"]: t for t in load_vectors("uss")["telegrams"]}


def _layout(item: dict[str, Any]) -> str:
    pkw = item["layout"]["pkw"]
    return f"{'v' if pkw == 'variable' else pkw},{item['layout']['pzd']}"


def _hex(name: str) -> str:
    return str(VECTORS[name]["hex"])


@pytest.mark.parametrize(
    ("request_name", "response_name"),
    [
        ("read_word_request", "read_word_response"),  # C 8.1 example 2
        ("read_whole_pbe_request", "read_whole_pbe_refused"),  # C 8.1 example 3
        ("read_pbe_element_request", "read_pbe_element_response"),  # C 8.1 example 4
        ("write_array_dword_request", "write_array_dword_response"),  # C 8.1 example 5
        ("write_word_pkw4_request", "write_word_pkw4_response"),  # C 8.1 example 6
        ("read_text_request", "read_text_response"),  # C 8.2 example 7
    ],
)
def test_document_examples_are_answered_byte_for_byte(
    request_name: str, response_name: str
) -> None:
    item = VECTORS[request_name]
    with LineSim(engine(item["adr"], "generic", _layout(item))) as sim, sim.master() as master:
        answer = master.exchange(item["hex"])
    assert answer.hex(" ").upper() == VECTORS[response_name]["hex"]


def test_example_1_process_data_only() -> None:
    """C 8.1 example 1: PKW 0, PZD 2: control word 047Fh and 50 % give status 0337h, 50 %."""
    request = VECTORS["pzd_only_request"]

    def instant_ramp(now: float) -> Any:
        engines = engine(5, "generic", "0,2")(now)
        engines[0].drive.write(462, 0)  # ramp-up time 0: the actual value follows at once
        return engines

    with LineSim(instant_ramp) as sim, sim.master() as master:
        master.exchange(frame(5, "04 7E 00 00"))  # 047Eh: leave the switch-on inhibit
        answer = master.exchange(request["hex"])
    assert answer.hex(" ").upper() == VECTORS["pzd_only_response"]["hex"]


def test_mirror_telegram_comes_back_unchanged() -> None:
    item = VECTORS["mirror_request"]  # A 4.3, A 5.3: slave 7
    with LineSim(engine(7, "generic", "3,2")) as sim, sim.master() as master:
        assert master.exchange(item["hex"]).hex(" ").upper() == item["hex"]


@pytest.mark.parametrize("name", ["broadcast_setpoint", "broadcast_ramp_enable"])
def test_broadcasts_are_never_answered(name: str) -> None:
    item = VECTORS[name]  # appendix examples 1 and 2
    with LineSim(engine(5, "generic", _layout(item))) as sim, sim.master() as master:
        assert master.silent(item["hex"])


def test_broadcast_example_1_sets_every_setpoint() -> None:
    """Appendix example 1: word a = 0005h takes PZD2 only; the control word stays as it was."""
    with LineSim(engine(5, "generic", "4,2")) as sim, sim.master() as master:
        master.exchange(frame(5, "0000 0000 0000 0000 047E 0000"))  # 047Eh, 0 %
        assert master.silent(_hex("broadcast_setpoint"))
        control, setpoint = sim.call(
            lambda: (sim.drive.machine.control, sim.drive.machine.setpoint)
        )
    assert control == 0x047E
    assert setpoint == pytest.approx(0.5)


def test_broadcast_example_2_takes_control_bit_5_only() -> None:
    """Appendix example 2: word a = 0003h, word b = 0020h: only control bit 5 is taken."""
    with LineSim(engine(5, "generic", "4,2")) as sim, sim.master() as master:
        master.exchange(frame(5, "0000 0000 0000 0000 045E 0000"))  # bit 5 = 0
        assert master.silent(_hex("broadcast_ramp_enable"))
        control = sim.call(lambda: sim.drive.machine.control)
    assert control == 0x047E  # bit 5 from the broadcast, the rest from the last telegram


def test_special_telegram_is_discarded() -> None:
    item = VECTORS["special_telegram"]  # A 5.4: ADR 83h, slave 3 without special telegrams
    with LineSim(engine(3, "generic", "3,2")) as sim, sim.master() as master:
        assert master.silent(item["hex"])


def test_6se21_initialisation_clears_the_switch_on_inhibit() -> None:
    """SIMOVERT P 6SE21 manual 7.5.1.1: P20 = 003 after power-up; PZD1 047Eh clears it (status bit
    6)."""
    item = VECTORS["6se21_init"]
    with LineSim(engine(1, "6se21"), baud=9600) as sim, sim.master() as master:
        before = sim.call(lambda: sim.drive.value(20))
        answer = master.exchange(item["hex"])
        after = sim.call(lambda: sim.drive.value(20))
    assert before == 3
    assert len(answer) == 14 and answer[1] == 12
    status = answer[9] << 8 | answer[10]
    assert not status & 0x0040  # switch-on inhibit gone
    assert status & 0x0001  # ready to switch on
    assert after == 2


def test_spontaneous_message_vector() -> None:
    """C 4.2.1.2: P52 changed by the drive itself: ID 9, toggle 1, PNU 52, the new value."""
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        master.exchange(frame(5, "0000 0000 0000 047E 0000"))  # no job, 047Eh
        sim.call(lambda: sim.drive.update(52, 0x0123))
        answer = master.exchange(frame(5, "0000 0000 0000 047E 0000"))
    assert answer.hex(" ").upper() == _hex("spontaneous_word")


def test_illegal_pnu_vector() -> None:
    """C Table 4.3, error 0: P999 does not exist."""
    with LineSim(engine(5, "generic", "3,2")) as sim, sim.master() as master:
        answer = master.exchange(frame(5, "13E7 0000 0000 047E 0000"))
    assert answer.hex(" ").upper() == _hex("error_illegal_pnu")


def test_every_vector_telegram_is_covered() -> None:
    covered = {
        "read_word_request",
        "read_word_response",
        "read_whole_pbe_request",
        "read_whole_pbe_refused",
        "read_pbe_element_request",
        "read_pbe_element_response",
        "write_array_dword_request",
        "write_array_dword_response",
        "write_word_pkw4_request",
        "write_word_pkw4_response",
        "read_text_request",
        "read_text_response",
        "pzd_only_request",
        "pzd_only_response",
        "mirror_request",
        "broadcast_setpoint",
        "broadcast_ramp_enable",
        "special_telegram",
        "6se21_init",
        "spontaneous_word",
        "error_illegal_pnu",
    }
    assert set(VECTORS) == covered
    for item in VECTORS.values():
        Layout.parse(_layout(item))  # every vector's layout is one an engine takes
