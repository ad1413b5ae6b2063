"""The profiles' telegram-level facts, as pure functions and data."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyuss.drive import SimulatedDrive
from pyuss.errors import ConfigError
from pyuss.profiles import PROFILES, BroadcastForm, baumueller, get_profile, profile_names
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import char_time
from pyuss.slave import SlaveEngine
from support.paths import load_vectors

MM4 = get_profile("micromaster4")


def test_registry() -> None:
    assert profile_names() == (
        "generic",
        "6se21",
        "baumueller",
        "nord",
        "micromaster4",
        "micromaster420",
        "micromaster440",
        "sinamics-g110",
        "sinamics-g120",
        "sinamics-v20",
        "sinamics-g120c",
        "sinamics-cu240e2",
        "nord-sk500e",
    )
    assert get_profile("nord") is PROFILES["nord"]
    with pytest.raises(ConfigError, match=r"unknown profile 'simovert'.*generic"):
        get_profile("simovert")


@pytest.mark.parametrize("name", list(PROFILES))
def test_every_profile_serves_its_parameter_file(name: str) -> None:
    profile = get_profile(name)
    engine = SlaveEngine(3, SimulatedDrive(profile.database()), profile)
    assert engine.layout == profile.default_layout
    first = profile.diagnostic_pnu
    assert first not in profile.database()  # the diagnostic parameters fit beside the file's
    assert engine.drive.db.profile.name == name


# -- layouts ---------------------------------------------------------------------------------


def test_layouts_each_profile_accepts() -> None:
    assert get_profile("generic").check_layout(Layout(127, 16))
    with pytest.raises(ConfigError, match="fixed layout 3,2 only"):
        get_profile("6se21").check_layout(Layout(4, 2))
    with pytest.raises(ConfigError, match="PKW must be one of 0, 3, 4"):
        get_profile("baumueller").check_layout(Layout(127, 2))
    with pytest.raises(ConfigError, match="at most 3 PZD"):
        get_profile("baumueller").check_layout(Layout(3, 4))
    assert get_profile("baumueller").fixed_length_only
    assert not get_profile("generic").fixed_length_only


# -- timing ----------------------------------------------------------------------------------


def test_response_windows() -> None:
    ct9600 = char_time(9600)
    assert get_profile("generic").response_delay(9600) == (2 * ct9600, 0.020)
    assert get_profile("6se21").response_delay(9600) == (
        0.0025,
        0.0175,
    )  # SIMOVERT P 6SE21 manual 7.5
    # Baumueller: 33 bit times before every telegram, answer within 2 ms (never below it)
    bm = get_profile("baumueller")
    assert bm.start_pause(9600) == pytest.approx(33 / 9600)
    assert bm.response_delay(9600) == (3 * ct9600, 3 * ct9600)
    assert bm.response_delay(19200) == (pytest.approx(33 / 19200), 0.002)
    assert bm.response_delay(19200, delayed=True)[1] == 0.020
    # A 5.2.1.1 / reading 10: at 300 baud the start pause is longer than 20 ms
    assert get_profile("nord").response_delay(300) == (2 * char_time(300), 2 * char_time(300))


# -- parameter numbers -----------------------------------------------------------------------


def test_micromaster4_pages() -> None:
    assert MM4.encode_pnu(2010) == (10, 0x8000)  # page 1: bit 15 alone
    assert MM4.encode_pnu(4010) == (10, 0x1000)  # page 2: bit 12
    assert MM4.encode_pnu(1999) == (1999, 0)
    assert MM4.encode_pnu(31999) == (1999, 0xF000)
    assert MM4.decode_pnu(10, 0x8000 | 0x0301) == 2010  # subindex and text bits ignored
    assert MM4.strip_page(0x8301) == 0x0301
    with pytest.raises(ConfigError, match=r"0\.\.31999"):
        MM4.encode_pnu(32000)


@settings(max_examples=200)
@given(st.integers(0, 31999))
def test_micromaster4_numbers_round_trip(pnu: int) -> None:
    bits, page = MM4.encode_pnu(pnu)
    assert 0 <= bits <= 1999
    assert page & ~0xF000 == 0
    assert MM4.decode_pnu(bits, page | 0x00FF) == pnu


def test_other_profiles_use_pke_alone() -> None:
    generic = get_profile("generic")
    assert generic.encode_pnu(2010) == (2010, 0)
    assert generic.decode_pnu(2010, 0x8000) == 2010  # device bits are not evaluated
    with pytest.raises(ConfigError):
        generic.encode_pnu(2048)


# -- broadcast, errors -----------------------------------------------------------------------


def test_broadcast_forms() -> None:
    assert get_profile("generic").broadcast is BroadcastForm.ENABLE_ARRAY
    assert get_profile("baumueller").broadcast is BroadcastForm.MASKED_CONTROL
    assert get_profile("micromaster4").broadcast is BroadcastForm.NONE


@given(st.frozensets(st.integers(0, 31)))
def test_broadcast_address_coding_round_trip(addresses: frozenset[int]) -> None:
    high, low = baumueller.address_mask(addresses)
    assert baumueller.addresses_in_mask(high, low) == addresses


def test_broadcast_address_coding_example() -> None:
    """Baumueller manual 2.5 (181 bit 1): addresses 0, 9 and 23 react."""
    assert baumueller.address_mask([0, 9, 23]) == (0x0080, 0x0201)
    with pytest.raises(ConfigError):
        baumueller.address_mask([32])


@given(st.integers(-(2**31), 2**31 - 1))
def test_32_bit_values_over_pzd2_and_pzd3(value: int) -> None:
    words = baumueller.value_words(value, 3, double=True)
    assert words is not None
    assert baumueller.join_value(words, double=True, signed=True) == value


def test_value_channel_formats() -> None:
    assert baumueller.value_words(0x1234, 2, double=False) == (0x1234,)
    assert baumueller.value_words(0x1234, 3, double=False) == (0, 0x1234)
    assert baumueller.value_words(1, 2, double=True) is None  # bit 8/9 of USS state
    assert baumueller.value_words(1, 1, double=False) == ()
    assert baumueller.join_value((0, 0x8000), double=False, signed=True) == -0x8000
    assert baumueller.masked_control_pkw(0x0021).words() == (0, 0, 0x0021)
    # With PKW 4 the mask must stay in PWE1, where the drives read it (reading 9).
    four = Layout(4, 2).pack(baumueller.masked_control_pkw(0x0021, 4), [0x047F, 0])
    assert four[4:6] == b"\x00\x21" and four[6:8] == b"\x00\x00"


def test_error_meanings() -> None:
    assert get_profile("baumueller").error_meaning(103) == "format too large for the PKW area"
    assert get_profile("micromaster4").error_meaning(102).startswith("channel width")
    assert get_profile("nord").error_meaning(202).startswith("internal response label")
    assert get_profile("generic").error_meaning(2) == "lower or upper limit exceeded"


def test_generic_window_matches_the_timing_vectors() -> None:
    """The vectors' start pause and maximum response delay per baud rate (A 5.1.2, A 5.2.1.1)."""
    generic = get_profile("generic")
    for item in load_vectors("uss")["timing"]:
        low, high = generic.response_delay(item["baud"])
        assert low * 1000 == pytest.approx(item["start_pause_ms"], abs=1e-6)
        assert high * 1000 == pytest.approx(item["max_response_delay_ms"])
