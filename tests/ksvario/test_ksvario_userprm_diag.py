"""User parameters (KS VARIO interface description 6) and diagnosis (6.1): bytes, flags, round
trips."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.errors import ConfigError, ProtocolError
from pyuss.ksvario.channel import ByteOrder
from pyuss.ksvario.diag import (
    Alarms,
    DeviceDiagnosis,
    DeviceErrors,
    Diagnosis,
    InputFlags,
    Status1,
    Status2,
    Status3,
)
from pyuss.ksvario.userprm import DiagnosisFormat, FailSafe, UserParameters


def test_user_parameter_defaults_are_zero() -> None:
    assert UserParameters().encode() == bytes(4)


def test_user_parameter_bits() -> None:
    prm = UserParameters.decode(bytes((0, 0, 0, 0b101)))
    assert prm.byte_order is ByteOrder.INTEL
    assert prm.diagnosis is DiagnosisFormat.EXTENDED
    assert prm.fail_safe is FailSafe.ZERO
    assert UserParameters(diagnosis=DiagnosisFormat.STANDARD).encode() == bytes((0, 0, 0, 2))


def test_short_user_parameters_take_defaults() -> None:
    assert UserParameters.decode(bytes(3)) == UserParameters()


@pytest.mark.parametrize("data", [bytes((0, 0, 0, 8)), bytes(5)])
def test_bad_user_parameters_are_refused(data: bytes) -> None:
    with pytest.raises(ConfigError):
        UserParameters.decode(data)


@settings(max_examples=50)
@given(
    st.sampled_from(list(ByteOrder)),
    st.sampled_from(list(DiagnosisFormat)),
    st.sampled_from(list(FailSafe)),
)
def test_user_parameters_round_trip(o: ByteOrder, d: DiagnosisFormat, f: FailSafe) -> None:
    prm = UserParameters(o, d, f)
    assert UserParameters.decode(prm.encode()) == prm


def test_power_up_standard_diagnosis_bytes() -> None:
    diag = Diagnosis(Status1.STATION_NOT_READY, Status2.PRM_REQ)
    assert diag.encode() == bytes.fromhex("02 05 00 FF 10 30")
    assert not diag.ready_for_data_exchange


def test_extended_diagnosis_layout() -> None:
    dev = DeviceDiagnosis(
        revision=3,
        firmware=21,
        errors=DeviceErrors.E4_HARDWARE,
        alarms=Alarms.LIMIT | Alarms.LOOP,
        inputs=InputFlags.FAIL,
    )
    raw = Diagnosis(Status1.EXT_DIAG, Status2.WD_ON, master_address=2, device=dev).encode()
    assert raw == bytes.fromhex("08 0C 00 02 10 30  C3 08 81 00 00 15 08 09 01")
    back = Diagnosis.decode(raw)
    assert back.device == dev
    assert back.device is not None and back.device.firmware_text == "V2.1"
    assert {"ext_diag", "wd_on", "e4_hardware", "limit", "loop", "fail"} <= set(back.flags())


@settings(max_examples=100)
@given(
    st.integers(0, 255),
    st.integers(0, 255).map(lambda b: b & ~0x40),
    st.sampled_from([0, 0x80]),
    st.integers(0, 255),
    st.integers(0, 0xFFFF),
    st.one_of(
        st.none(),
        st.builds(
            DeviceDiagnosis,
            st.integers(0, 63),
            st.integers(0, 127),
            st.integers(0, 31).map(DeviceErrors),
            st.integers(0, 15).map(Alarms),
            st.integers(0, 1).map(InputFlags),
        ),
    ),
)
def test_diagnosis_round_trip(
    s1: int, s2: int, s3: int, master: int, ident: int, device: DeviceDiagnosis | None
) -> None:
    diag = Diagnosis(Status1(s1), Status2(s2 | 4), Status3(s3), master, ident, device)
    assert Diagnosis.decode(diag.encode()) == diag


@pytest.mark.parametrize(
    "raw",
    [
        "02 05 00 FF 10",
        "02 05 00 FF 10 30 00 08 81 00 00 0A 00 00 00",
        "02 05 00 FF 10 30 C1 07 81 00 00 0A 00 00 00",
    ],
)
def test_bad_diagnosis_is_refused(raw: str) -> None:
    with pytest.raises(ProtocolError):
        Diagnosis.decode(bytes.fromhex(raw))
