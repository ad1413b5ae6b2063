"""One simulated drive on two interfaces: the USS drive model as a BASS station (Baumueller manual
part 1
and 2), in process - the ring's in-process port, the virtual bus for USS."""

from __future__ import annotations

import asyncio
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.bass.codec import BassAnswer, BassRequest, checksum, decode_answer
from pyuss.bass.drive import FAULT_TO_BASS, DriveOperatingData, bass_error, drive_ring
from pyuss.bass.errors import BassErrorNumber, BassRefusal
from pyuss.bass.master import BassMaster
from pyuss.bass.ring import ID_COMM_SOURCE, ID_SV_BAUD, ID_SV_STATE, OperatingData
from pyuss.bus import VirtualBus
from pyuss.drive import SimulatedDrive
from pyuss.drive.faults import DriveErrorNumber, ParameterFault
from pyuss.errors import ConfigError
from pyuss.master import Master, SpontaneousMessage
from pyuss.profiles import get_profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import ErrorNumber
from pyuss.slave import JobLatency, SlaveEngine, SlaveServer
from support.paths import load_vectors

E = BassErrorNumber
VECTORS = load_vectors("bass")


def baumueller() -> SimulatedDrive:
    return SimulatedDrive.from_profile("baumueller")


def line(text: str) -> bytes:
    return text.replace("\\r\\n", "\r\n").encode("ascii")


def test_document_examples_byte_for_byte_against_the_simulated_drive() -> None:
    """Baumueller manual 1.1 examples 1 and 2 on drive 00: the drive echoes each line unchanged,
    then
    answers it from its parameters (ID 2 = 75.00 %, ID 51 = the actual speed)."""
    drive = baumueller()
    ring = drive_ring([(0, drive)])
    write, read = (line(v["line"]) for v in VECTORS["lines"])
    for vector in VECTORS["lines"]:
        body = vector["body"].encode()
        assert f"{checksum(body):02X}" == vector["checksum"]
    back = ring.inject(write)
    assert back == write + BassAnswer.value(0, 2, 0x1D4C).encode()
    assert drive.value(2) == 7500  # the USS side's parameter 2: one drive
    back = ring.inject(read)
    assert back[: len(read)] == read
    answer = decode_answer(back[len(read) :])
    assert (answer.address, answer.ident, answer.is_error) == (0, 51, False)
    assert answer.to_int() == drive.read_words(51)[0]


def test_ids_are_parameter_numbers_with_the_parameter_width() -> None:
    drive = baumueller()
    ring = drive_ring([(4, drive)])
    data = ring.station(4).data
    assert data.digits(60) == 4  # uint16
    assert data.digits(70) == 8  # int32: a double word
    out = ring.inject(BassRequest.write(4, 70, -5, digits=8).encode())
    assert out.endswith(BassAnswer.value(4, 70, -5, 8).encode())
    assert drive.value(70) == -5
    assert data.read(70) == 0xFFFF_FFFB
    drive.write(60, 1234, interface="uss")
    assert decode_answer(ring.inject(BassRequest.read(4, 60).encode())[15:]).to_int() == 1234


REFUSED = [
    (BassRequest.read(1, 999), E.ELEMENT_NOT_AVAILABLE),
    (BassRequest(1, 0x3E, 2, "1D4"), E.DATA_TOO_SHORT),
    (BassRequest.write(1, 70, 1, digits=4), E.DATA_TOO_SHORT),  # int32: 8 digits
    (BassRequest(1, 0x3E, 2, "01D4C"), E.DATA_TOO_LONG),
    (BassRequest(1, 0x3C, 2, "0001"), E.DATA_TOO_LONG),  # a read carries no data
    (BassRequest.write(1, ID_SV_BAUD, 19200), E.DATA_NOT_CHANGEABLE),
    (BassRequest.write(1, ID_SV_STATE, 1), E.DATA_NOT_CHANGEABLE),
    (BassRequest.write(1, 51, 1), E.DATA_NOT_CHANGEABLE),  # actual speed: read-only
    (BassRequest.write(1, 2, -10001), E.BELOW_MINIMUM),
    (BassRequest.write(1, 2, 10001), E.ABOVE_MAXIMUM),
    (BassRequest.write(1, 183, 5), E.ABOVE_MAXIMUM),  # PKW count: 0, 3 or 4
    (BassRequest.write(1, 183, 2), E.DATA_NOT_VALID),
    (BassRequest(1, 0x0040, 2), E.ACCESS_NOT_VALID),  # not a read or write command
]


async def test_every_error_number_of_table_1_3() -> None:
    drive = baumueller()
    ring = drive_ring([(1, drive)])
    locked = (BassRequest.write(1, 2, 5), E.WRITE_PROTECTED)
    assert {n for _, n in [*REFUSED, locked]} == set(E) - {E.NO_ERROR}
    async with ring.port() as port:
        master = BassMaster(port, timeout=1.0, retries=0)
        for request, number in [*REFUSED, locked]:
            if (request, number) == locked:
                drive.write(ID_COMM_SOURCE, 0)  # the drive's own panel takes the authority away
            with pytest.raises(BassRefusal) as info:
                await master.exchange(request)
            assert (request.ident, info.value.number) == (request.ident, number)
    assert drive.value(2) == 0 and drive.value(183) == 3  # nothing refused was written


def float_bits(value: float) -> str:
    return struct.pack(">f", value).hex().upper()


@pytest.mark.parametrize(
    ("pnu", "data", "number"),
    [
        (999, "0001", E.ELEMENT_NOT_AVAILABLE),  # C 4.3 error 0
        (52, "0001", E.DATA_NOT_CHANGEABLE),  # 1: read-only
        (683, "0001", E.ACCESS_NOT_VALID),  # an array: no single element on BASS
        (90, "0001", E.ACCESS_NOT_VALID),  # a string
        (352, "03E8", E.WRITE_PROTECTED),  # 12: keyword missing (protected parameter)
        (825, "00000005", E.DATA_NOT_VALID),  # 6: reset only
        (107, float_bits(5.0), E.BELOW_MINIMUM),  # 2: min 8.0
        (107, float_bits(700.0), E.ABOVE_MAXIMUM),  # 2: max 600.0
        (107, "7FC00000", E.DATA_NOT_VALID),  # 2: NaN
        (107, "0001", E.DATA_TOO_SHORT),  # a float takes 8 digits
    ],
)
def test_drive_refusals_become_bass_error_numbers(pnu: int, data: str, number: int) -> None:
    """Refusals of the drive (C Table 4.3) on the generic profile's parameters."""
    drive = SimulatedDrive.from_profile("generic")
    station = drive_ring([(7, drive)]).stations[0]
    before = drive.values(pnu) if pnu in drive.db else None
    answer = station.answer(BassRequest(7, 0x3E, pnu, data))
    assert (answer.is_error, answer.error_number) == (True, number)
    if before is not None:
        assert drive.values(pnu) == before


def test_a_running_drive_refuses_stopped_only_parameters_with_4() -> None:
    drive = SimulatedDrive.from_profile("generic")
    data = DriveOperatingData(drive, 7)
    data.write(107, struct.unpack(">I", struct.pack(">f", 60.0))[0])
    assert drive.value(107) == 60.0
    drive.exchange([0x047E, 0], 0.0)
    drive.exchange([0x047F, 0x2000], 0.0)
    with pytest.raises(BassRefusal) as info:
        data.write(107, struct.unpack(">I", struct.pack(">f", 50.0))[0])
    assert info.value.code is E.DATA_NOT_CHANGEABLE
    assert drive.value(107) == 60.0


def test_numbers_outside_the_mapping_are_access_not_valid() -> None:
    assert FAULT_TO_BASS[ErrorNumber.ILLEGAL_PNU] is E.ELEMENT_NOT_AVAILABLE
    assert bass_error(ParameterFault(101)) is E.ACCESS_NOT_VALID
    assert bass_error(ParameterFault(ErrorNumber.BAD_INDEX)) is E.ACCESS_NOT_VALID
    assert bass_error(ParameterFault(ErrorNumber.LIMIT_EXCEEDED)) is E.DATA_NOT_VALID
    assert bass_error(ParameterFault(DriveErrorNumber.NO_WRITE_AUTHORITY)) is E.WRITE_PROTECTED
    assert bass_error(ParameterFault(DriveErrorNumber.WRONG_STATE)) is E.DATA_NOT_CHANGEABLE


def test_write_authority_is_id_126_bit_0_and_170_shows_it() -> None:
    drive = baumueller()
    data = DriveOperatingData(drive, 0x15)
    assert data.write_authorized()
    assert data.read(ID_SV_STATE) == 0x151  # RUN, address 15h
    assert drive.value(ID_SV_STATE) == 0x151  # the USS side reads the same word
    drive.write(ID_COMM_SOURCE, 0)  # the drive's panel
    assert not data.write_authorized()
    assert drive.value(ID_SV_STATE) == 0x150  # STOP, seen over USS at once
    assert data.read(ID_SV_STATE) == 0x150
    drive.write_words(ID_COMM_SOURCE, [1], interface="uss")  # USS may give it back
    assert data.read(ID_SV_STATE) == 0x151 and drive.value(ID_SV_STATE) == 0x151
    data.write(ID_COMM_SOURCE, 0)  # the PC gives up the authority itself
    assert drive.value(ID_SV_STATE) == 0x150
    drive.write(ID_COMM_SOURCE, 0xFFFE)  # only bit 0 counts
    assert not data.write_authorized() and data.read(ID_SV_STATE) == 0x150
    drive.write(ID_COMM_SOURCE, 0x0003)
    assert data.write_authorized() and data.read(ID_SV_STATE) == 0x151
    drive.write(ID_COMM_SOURCE, 1)
    drive.set_write_authority("bass", False)  # an interface can also be locked alone
    assert data.read(ID_SV_STATE) == 0x150
    assert drive.has_write_authority("uss")
    data.close()


def test_sv_baud_rate_is_the_drives_parameter_171() -> None:
    drive = baumueller()
    data = DriveOperatingData(drive, 1)
    assert data.read(ID_SV_BAUD) == 9600
    with pytest.raises(BassRefusal) as info:
        data.write(ID_SV_BAUD, 19200)
    assert info.value.code is E.DATA_NOT_CHANGEABLE


def test_bass_jobs_advance_the_drive_to_the_clock() -> None:
    now = [0.0]
    drive = baumueller()
    data = DriveOperatingData(drive, 1, clock=lambda: now[0])
    drive.apply_control(0x047E, 0, 0.0)
    drive.apply_control(0x047F, 0x2000, 0.0)  # on, 50 % (USS)
    assert data.read(51) == 0
    now[0] = 60.0  # no USS telegram since: the BASS read still sees the ramp's end
    assert data.read(51) == 0x2000


def test_a_ring_is_wired_in_address_order() -> None:
    drives = {a: baumueller() for a in (3, 1, 2)}
    ring = drive_ring(drives.items())
    assert [s.address for s in ring.stations] == [1, 2, 3]
    for station in ring.stations:
        assert isinstance(station.data, OperatingData)
        out = ring.inject(BassRequest.read(station.address, ID_SV_STATE).encode())
        assert decode_answer(out[15:]).to_int() == station.address << 4 | 1
    out = ring.inject(BassRequest.write(2, 2, 7500).encode())
    assert drives[2].value(2) == 7500 and drives[1].value(2) == drives[3].value(2) == 0
    with pytest.raises(ConfigError, match="1 to 16"):
        drive_ring([(a, baumueller()) for a in range(17)])
    with pytest.raises(ConfigError, match="two drives"):
        drive_ring([(1, baumueller()), (1, baumueller())])
    with pytest.raises(ConfigError, match=r"0\.\.255"):
        DriveOperatingData(baumueller(), 256)


@given(st.integers(0, 0xFFFF))
@settings(max_examples=60, deadline=None)
def test_any_word_is_stored_or_refused_by_its_limits(pattern: int) -> None:
    drive = baumueller()
    station = drive_ring([(1, drive)]).stations[0]
    request = BassRequest(1, 0x3E, 2, f"{pattern:04X}").encode()
    answer = decode_answer(station.receive(request)[len(request) :])
    value = pattern - 0x10000 if pattern & 0x8000 else pattern
    if value < -10000:
        assert answer.error_number == E.BELOW_MINIMUM
    elif value > 10000:
        assert answer.error_number == E.ABOVE_MAXIMUM
    else:
        assert not answer.is_error and answer.to_int(signed=True) == value == drive.value(2)


async def test_uss_master_sees_a_bass_write_as_a_spontaneous_message() -> None:
    """C 4.2.1.2 across the two interfaces: a job is open on USS (the drive answers it 25
    telegrams late), a BASS write of the active parameter 2 interrupts it with a spontaneous
    message, the master acknowledges it, and the job then gets its own answer."""
    drive = baumueller()
    engine = SlaveEngine(
        5,
        drive,
        get_profile("baumueller"),
        layout=Layout(3, 2),
        spontaneous=True,
        latency=JobLatency(cycles=25),
    )
    ring = drive_ring([(5, drive)])
    bus = VirtualBus(38400)
    stop = asyncio.Event()
    serving = asyncio.create_task(SlaveServer(bus.attach("drive5"), engine).run(stop))
    events: list[object] = []
    try:
        async with (
            Master(bus.attach("master"), profile="baumueller", layout="3,2") as master,
            ring.port() as port,
        ):
            uss = master.drive(5)
            uss.on_spontaneous(events.append)
            job = asyncio.create_task(uss.read(60, timeout=30))
            job.add_done_callback(lambda _: events.append("job done"))
            for _ in range(4):
                await uss.next_update()
            assert not job.done()
            await BassMaster(port, timeout=5).write(5, 2, 7500)
            assert await asyncio.wait_for(job, 30) == 2000
            assert await uss.read_raw(2) == (7500,)  # one drive
            stats = uss.diagnostics().jobs
    finally:
        stop.set()
        await asyncio.wait_for(serving, 10)
        engine.close()
        await bus.close()
    assert len(events) == 2 and events[1] == "job done"
    message = events[0]
    assert isinstance(message, SpontaneousMessage)
    assert (message.address, message.pnu, message.value) == (5, 2, 7500)
    assert stats.spontaneous == 1
