"""Diagnostics of A 5.2.3: status bits, the 16 parameters, per-minute rates."""

from __future__ import annotations

from pyuss.protocol.diagnostics import Counters, Diagnostics, ErrorStatus, FaultKind


def test_status_bits_are_those_of_a_5_2_3() -> None:
    assert [int(bit) for bit in ErrorStatus if bit] == [1, 2, 4, 8, 16, 32, 64, 128]
    assert ErrorStatus.FRAMING == 1 << 0
    assert ErrorStatus.OVERRUN == 1 << 1
    assert ErrorStatus.PARITY == 1 << 2
    assert ErrorStatus.NO_STX == 1 << 3
    assert ErrorStatus.BCC == 1 << 4
    assert ErrorStatus.RESIDUAL_TIME == 1 << 5
    assert ErrorStatus.BAD_LGE == 1 << 6
    assert ErrorStatus.TIMEOUT == 1 << 7


def test_fault_kinds_are_never_false() -> None:
    assert all(FaultKind)
    assert [kind.status for kind in FaultKind][:7] == [bit for bit in ErrorStatus if bit][:7]


def test_each_fault_kind_has_its_counter_and_bit() -> None:
    for kind in FaultKind:
        diag = Diagnostics()
        diag.record_fault(kind, 10.0)
        assert diag.discarded == 1
        assert diag.status == kind.status
        if kind is FaultKind.BAD_ADR:
            assert kind.status == ErrorStatus.NONE
        else:
            assert getattr(diag, kind.name.lower()) == 1


def test_timeout_sets_bit_7() -> None:
    diag = Diagnostics()
    diag.record_timeout(1.0)
    assert diag.timeout == 1
    assert diag.status == ErrorStatus.TIMEOUT
    assert diag.discarded == 0


def test_status_latches_until_cleared() -> None:
    diag = Diagnostics()
    diag.record_fault(FaultKind.BCC, 1.0)
    diag.record_received(2.0)
    assert diag.status == ErrorStatus.BCC
    diag.clear_status()
    assert diag.status == ErrorStatus.NONE
    assert diag.bcc == 1


def test_per_minute_rates_cover_the_last_sixty_seconds() -> None:
    diag = Diagnostics()
    for t in (0.5, 10.0, 30.2, 59.9):
        diag.record_received(t)
    diag.record_fault(FaultKind.BCC, 20.0)
    assert diag.good_per_minute(59.9) == 4
    assert diag.discarded_per_minute(59.9) == 1
    assert diag.good_per_minute(60.0) == 3  # second 0 has left the window
    assert diag.good_per_minute(80.0) == 2
    assert diag.discarded_per_minute(80.0) == 0
    assert diag.good_per_minute(200.0) == 0
    assert diag.good == 4  # the counters keep everything


def test_snapshot_words_in_document_order() -> None:
    diag = Diagnostics(hardware_version=3, software_version=0x0102)
    diag.record_received(1.0)
    diag.record_received(2.0)
    diag.record_fault(FaultKind.FRAMING, 2.0)
    diag.record_fault(FaultKind.RESIDUAL_TIME, 2.0)
    diag.record_timeout(2.0)
    snap = diag.snapshot(3.0)
    assert isinstance(snap, Counters)
    assert snap.words() == (3, 0x0102, 0, 0xA1, 2, 2, 2, 2, 1, 0, 0, 0, 1, 0, 0, 1)


def test_words_are_16_bit() -> None:
    snap = Counters(good=70000, good_per_minute=70000)
    assert snap.words()[6] == 70000 - 65536
    assert snap.words()[4] == 0xFFFF


def test_reset_keeps_versions() -> None:
    diag = Diagnostics(hardware_version=7)
    diag.record_fault(FaultKind.BCC, 1.0)
    diag.reset()
    snap = diag.snapshot(1.0)
    assert snap == Counters(hardware_version=7)
