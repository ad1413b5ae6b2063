"""PROFIBUS FDL codec and the DP slave state machine (pure), plus the slave on a real pty and on
a serial port (the far end of a pty pair)."""

from __future__ import annotations

import asyncio
import os
import struct

import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.ksvario.address import Address
from pyuss.ksvario.coupler import Coupler, ForceKind
from pyuss.ksvario.diag import Alarms, DeviceDiagnosis, Diagnosis, Status1, Status2
from pyuss.ksvario.dp.fdl import (
    FC,
    SAP,
    SC,
    SD1,
    SD2,
    SD3,
    SD4,
    Frame,
    FrameReceiver,
    decode_frame,
)
from pyuss.ksvario.dp.slave import DpSlave, State
from pyuss.ksvario.errors import FdlError
from pyuss.ksvario.modules import chk_cfg_bytes, parse_modules
from pyuss.ksvario.simulate import dp_line, serve
from pyuss.transport.serialport import SerialTransport

REQ = FC.REQ | FC.SRD_HI


def test_fdl_status_request_bytes() -> None:
    raw = Frame(SD1, 8, 2, FC.REQ | FC.FDL_STATUS).encode()
    assert raw == bytes.fromhex("10 08 02 49 53 16")
    assert decode_frame(raw) == Frame(SD1, 8, 2, 0x49)


def test_sd2_with_saps_and_sd3() -> None:
    raw = Frame(SD2, 8, 2, 0x6D, b"", dsap=60, ssap=62).encode()
    assert raw == bytes.fromhex("68 05 05 68 88 82 6D 3C 3E") + bytes((sum(raw[4:9]) & 0xFF, 0x16))
    eight = Frame(SD3, 8, 2, 0x5D, bytes(range(8))).encode()
    assert eight[0] == 0xA2 and len(eight) == 14
    assert decode_frame(eight).du == bytes(range(8))


@settings(max_examples=100)
@given(
    st.integers(0, 127),
    st.integers(0, 127),
    st.integers(0, 255),
    st.binary(max_size=240),
    st.one_of(st.none(), st.tuples(st.integers(0, 63), st.integers(0, 63))),
)
def test_frame_round_trip(
    da: int, sa: int, fc: int, du: bytes, saps: tuple[int, int] | None
) -> None:
    frame = Frame(SD2, da, sa, fc, du, *(saps or (None, None)))
    back = decode_frame(frame.encode())
    assert (back.da, back.sa, back.fc, back.du) == (da, sa, fc, du)
    assert (back.dsap, back.ssap) == (saps or (None, None))


def test_receiver_skips_noise_and_bad_fcs() -> None:
    good = Frame(SD1, 8, 2, 0x49).encode()
    bad = bytearray(good)
    bad[4] ^= 1
    rx = FrameReceiver()
    frames = rx.feed(b"\x00\xff" + bytes(bad) + good[:3])
    frames += rx.feed(good[3:] + bytes((SC,)))
    assert [f.sd for f in frames] == [SD1, SC]
    assert rx.errors > 0


@pytest.mark.parametrize("raw", ["10 08 02 49 00 16", "10 08 02 49 53 00", "68 05 06 68 00", "77"])
def test_bad_frames_are_refused(raw: str) -> None:
    with pytest.raises(FdlError):
        decode_frame(bytes.fromhex(raw))


def _req(dsap: int | None, du: bytes = b"", fc: int = REQ) -> Frame:
    return Frame(SD2, 8, 2, fc, du, dsap, 62 if dsap is not None else None)


def _set_prm(ident: int = 0x1030, user: bytes = bytes(4), status: int = 0x88) -> Frame:
    return _req(SAP.SET_PRM, bytes((status, 10, 10, 11, ident >> 8, ident & 0xFF, 1)) + user)


def _diag(slave: DpSlave) -> Diagnosis:
    answer = slave.handle(_req(SAP.SLAVE_DIAG), 0.0)
    assert answer is not None
    frame = decode_frame(answer)
    assert (frame.dsap, frame.ssap) == (62, 60)
    return Diagnosis.decode(frame.du)


def bring_up(modules: str = "A.1,B.1", user: bytes = bytes(4)) -> tuple[DpSlave, Coupler]:
    coupler = Coupler()
    slave = DpSlave(coupler, 8)
    assert slave.handle(_set_prm(user=user), 0.0) == bytes((SC,))
    assert slave.handle(_req(SAP.CHK_CFG, chk_cfg_bytes(parse_modules(modules))), 0.0) == b"\xe5"
    return slave, coupler


def test_start_up_sequence_to_data_exchange() -> None:
    coupler = Coupler()
    slave = DpSlave(coupler, 8)
    answer = slave.handle(Frame(SD1, 8, 2, FC.REQ | FC.FDL_STATUS), 0.0)
    assert answer == Frame(SD1, 2, 8, 0x00).encode()
    first = _diag(slave)
    assert first.status1 & Status1.STATION_NOT_READY and first.status2 & Status2.PRM_REQ
    assert first.master_address == 0xFF and first.ident_number == 0x1030
    assert first.device is not None  # extended diagnosis by default
    # Data_Exchange before parameters: service not activated
    rs = decode_frame(slave.handle(_req(None, bytes(8)), 0.0) or b"")
    assert rs.fc == FC.RS
    slave, coupler = bring_up()
    diag = _diag(slave)
    assert diag.ready_for_data_exchange and diag.master_address == 2
    assert diag.status2 & Status2.WD_ON
    answer = decode_frame(slave.handle(_req(None, bytes(8)), 0.0) or b"")
    assert answer.fc == FC.DL and len(answer.du) == 10
    get_cfg = decode_frame(slave.handle(_req(SAP.GET_CFG), 0.0) or b"")
    assert get_cfg.du == bytes.fromhex("F3 50")


def test_wrong_ident_is_a_prm_fault() -> None:
    slave = DpSlave(Coupler(), 8)
    slave.handle(_set_prm(ident=0x1234), 0.0)
    diag = _diag(slave)
    assert diag.status1 & Status1.PRM_FAULT and not diag.ready_for_data_exchange


def test_bad_user_parameters_are_a_prm_fault() -> None:
    slave = DpSlave(Coupler(), 8)
    slave.handle(_set_prm(user=bytes((0, 0, 0, 0x80))), 0.0)
    assert _diag(slave).status1 & Status1.PRM_FAULT


def test_standard_diagnosis_by_user_parameter() -> None:
    slave = DpSlave(Coupler(), 8)
    slave.handle(_set_prm(user=bytes((0, 0, 0, 2))), 0.0)
    assert _diag(slave).device is None


def test_configuration_breaking_a_rule_is_a_cfg_fault() -> None:
    slave = DpSlave(Coupler(), 8)
    slave.handle(_set_prm(), 0.0)
    slave.handle(_req(SAP.CHK_CFG, bytes((0x71,))), 0.0)  # A.2 without an I/O module behind
    diag = _diag(slave)
    assert diag.status1 & Status1.CFG_FAULT
    assert slave.state is State.WAIT_PRM


def test_repeated_fcb_gets_the_same_answer_without_acting_twice() -> None:
    slave, _coupler = bring_up("A.1")
    start = bytes.fromhex("10 00 00 04 00 00 00 01")
    first = slave.handle(_req(None, start, REQ | FC.FCV), 0.0)
    assert first is not None and first[0] == SD3  # 8 input bytes of A.1 travel in SD3
    assert slave.exchanges == 1
    again = slave.handle(_req(None, start, REQ | FC.FCV), 0.0)
    assert again == first and slave.exchanges == 1
    slave.handle(_req(None, start, REQ | FC.FCV | FC.FCB), 0.0)
    assert slave.exchanges == 2
    # the same FCB with other data is no repetition (a master that did not toggle FCB)
    end = bytes.fromhex("16 00 00 00 00 00 00 00")
    slave.handle(_req(None, end, REQ | FC.FCV | FC.FCB), 0.0)
    assert slave.exchanges == 3 and slave.outputs == end


def test_watchdog_drops_to_fail_safe() -> None:
    slave, _ = bring_up()
    slave.handle(_req(None, bytes(8)), 0.5)
    slave.tick(0.9)
    assert slave.state is State.DATA_EXCH
    slave.tick(2.0)  # 10 ms x 10 x 10 = 1 s without the master
    assert slave.state is State.WAIT_PRM
    assert _diag(slave).status2 & Status2.PRM_REQ


def test_global_control_freeze_and_other_stations() -> None:
    slave, _ = bring_up()
    gc = Frame(SD2, 127, 2, FC.REQ | FC.SDN_HI, bytes((0x08, 0)), 58, 62)
    assert slave.handle(gc, 0.0) is None
    assert _diag(slave).status2 & Status2.FREEZE_MODE
    other = Frame(SD2, 9, 2, REQ, b"", 60, 62)
    assert slave.handle(other, 0.0) is None


@pytest.mark.pty
async def test_slave_answers_on_a_real_pty() -> None:
    ready = asyncio.Event()
    devices: list[str] = []

    def on_ready(device: str) -> None:
        devices.append(device)
        ready.set()

    stop = asyncio.Event()
    task = asyncio.create_task(serve(station=8, on_ready=on_ready, stop=stop))
    await asyncio.wait_for(ready.wait(), 10)
    assert os.path.exists(devices[0])
    port = serial.Serial(devices[0], 19200, parity=serial.PARITY_EVEN, timeout=5)
    try:
        port.write(Frame(SD1, 8, 2, FC.REQ | FC.FDL_STATUS).encode())
        answer = await asyncio.to_thread(port.read, 6)
        assert answer == Frame(SD1, 2, 8, 0x00).encode()
        port.write(_req(SAP.SLAVE_DIAG).encode())
        head = await asyncio.to_thread(port.read, 4)
        rest = await asyncio.to_thread(port.read, head[1] + 2)
        diag = decode_frame(head + rest)
        assert Diagnosis.decode(diag.du).ident_number == 0x1030
    finally:
        port.close()
        stop.set()
        await asyncio.wait_for(task, 10)


def _exchange(slave: DpSlave, outputs: bytes, now: float = 0.0) -> Frame:
    return decode_frame(slave.handle(_req(None, outputs), now) or b"")


def test_tokens_pass_by() -> None:
    """SD4 tokens between masters are framed and left alone by the (passive) slave."""
    token = Frame(SD4, 8, 2).encode()
    assert token == bytes.fromhex("DC 08 02")
    rx = FrameReceiver()
    frames = rx.feed(token + Frame(SD1, 8, 2, FC.REQ | FC.FDL_STATUS).encode() + token)
    assert [f.sd for f in frames] == [SD4, SD1, SD4]
    slave = DpSlave(Coupler(), 8)
    assert slave.handle(frames[0], 0.0) is None
    assert slave.handle(frames[1], 0.0) is not None


def test_slave_without_inputs_answers_data_exchange_with_short_ack() -> None:
    slave, _coupler = bring_up("B.6")
    _diag(slave)
    assert slave.handle(_req(None, bytes.fromhex("0064")), 0.0) == bytes((SC,))


def test_new_diagnosis_is_announced_with_dh_until_read() -> None:
    """A DP slave answers Data_Exchange with DH while new diagnosis waits; reading Slave_Diag
    fetches it and the answers go back to DL."""
    slave, coupler = bring_up()
    _diag(slave)
    assert _exchange(slave, bytes(8)).fc == FC.DL
    coupler.device = DeviceDiagnosis(alarms=Alarms.LIMIT)
    answer = _exchange(slave, bytes(8))
    assert answer.fc == FC.DH and len(answer.du) == 10  # the inputs still come
    diag = _diag(slave)
    assert diag.status1 & Status1.EXT_DIAG and "limit" in diag.flags()
    assert _exchange(slave, bytes(8)).fc == FC.DL
    slave, coupler = bring_up("B.6")
    _diag(slave)
    coupler.device = DeviceDiagnosis(alarms=Alarms.LOOP)
    assert _exchange(slave, bytes(2)).fc == FC.DH  # no inputs: SD1 with DH, not E5


def test_intel_byte_order_from_set_prm() -> None:
    """The byte-order user parameter of Set_Prm (interface description 6, byte 4 bit 0) orders the
    reals of the
    parameter channel."""
    slave, coupler = bring_up("A.1", user=bytes((0, 0, 0, 1)))
    coupler.set(Address.channel(2, 0x69), 3.25)
    _exchange(slave, bytes.fromhex("10 01 01 8C D2 00 00 00"))
    answer = _exchange(slave, bytes.fromhex("68 01 00 00 00 00 00 00"), 0.01)
    assert answer.du[:2] == bytes((0x68, 1)) and answer.du[4:8] == struct.pack("<f", 3.25)


@pytest.mark.parametrize("how", ["watchdog", "clear"])
@pytest.mark.parametrize("fail_safe", [0, 4])
def test_fail_safe_on_bus_failure_and_master_stop(how: str, fail_safe: int) -> None:
    """interface description 2.4: on bus failure (the watchdog runs out) or master stop
    (Global_Control
    Clear_Data) forced analogue inputs go to FAIL; with fail-safe "zero" (user parameter byte 4
    bit 2) forced outputs go to 0, with "last value" they keep their value."""
    slave, coupler = bring_up(user=bytes((0, 0, 0, fail_safe)))
    ain, out = Address.channel(1, 0x01), Address.channel(1, 0x40)
    coupler.force(ain, ForceKind.ANALOG_INPUT)
    coupler.force(out, ForceKind.OUTPUT)
    coupler.set(out, 42.0)
    _exchange(slave, bytes(8), 0.5)
    if how == "watchdog":
        slave.tick(2.0)  # 10 ms x 10 x 10 = 1 s without the master
    else:
        clear = Frame(SD2, 127, 2, FC.REQ | FC.SDN_HI, bytes((0x02, 0)), 58, 62)
        assert slave.handle(clear, 0.6) is None
    assert coupler.get(out) == (0.0 if fail_safe else 42.0)
    device = _diag(slave).device
    assert device is not None and device.inputs  # FAIL of the forced analogue input


def test_dp_lines_are_8e1() -> None:
    """Serial lines of the simulator and of `uss ksvario read|write` carry PROFIBUS characters:
    8 data bits, even parity, 1 stop bit; baud rates are PROFIBUS-DP rates."""
    line = dp_line("loop://", baud=19200)
    assert isinstance(line, SerialTransport)
    assert (line.port.bytesize, line.port.parity, line.port.stopbits) == (8, "E", 1)
    assert line.port.baudrate == 19200
    with pytest.raises(ConfigError, match="not carry"):
        dp_line("loop://", baud=500000)
    with pytest.raises(ConfigError, match="not a PROFIBUS-DP baud rate"):
        dp_line(None, baud=38400)


@pytest.mark.pty
async def test_simulator_on_a_serial_port() -> None:
    """``serve(port=DEVICE)`` opens DEVICE as a serial port (here the far end of a pty pair)
    and answers on it."""
    master_fd, slave_fd = os.openpty()
    try:
        path = os.ttyname(slave_fd)
        ready = asyncio.Event()
        stop = asyncio.Event()
        task = asyncio.create_task(
            serve(station=8, port=path, on_ready=lambda _: ready.set(), stop=stop)
        )
        try:
            await asyncio.wait_for(ready.wait(), 10)
            os.write(master_fd, Frame(SD1, 8, 2, FC.REQ | FC.FDL_STATUS).encode())
            answer = b""
            while len(answer) < 6:
                answer += await asyncio.to_thread(os.read, master_fd, 6 - len(answer))
            assert answer == Frame(SD1, 2, 8, 0x00).encode()
        finally:
            stop.set()
            await asyncio.wait_for(task, 10)
    finally:
        os.close(master_fd)
        os.close(slave_fd)
