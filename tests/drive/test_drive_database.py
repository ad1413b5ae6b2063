"""The declarative parameter file: built-in profiles load, bad files are refused by name."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyuss.drive.database import Access
from pyuss.drive.datatypes import DataType
from pyuss.drive.faults import ParameterFault
from pyuss.drive.loader import builtin_profiles, load_database, load_profile, parse_database
from pyuss.errors import ConfigError
from pyuss.protocol.pkw import ErrorNumber

HEAD = '[profile]\nname = "test"\n'


def test_every_builtin_profile_loads() -> None:
    assert set(builtin_profiles()) == {
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
    }
    for name in builtin_profiles():
        db = load_profile(name)
        assert db.profile.name == name
        assert len(db) > 0


def test_generic_interface_parameters_are_arrays_over_three_interfaces() -> None:
    db = load_profile("generic")
    for pnu in (683, 684, 685, 686, 687):
        param = db.parameter(pnu)
        assert param.array == 3  # C 3.2: SST 1, SCB, SST 2
        assert param.dtype is DataType.UINT16  # "Array mit Datentyp O2"
        assert param.index_texts == ("SST 1", "SCB", "SST 2")
    assert db.parameter(685).allowed == (0, 3, 4, 127)
    assert db.parameter(686).high == 16
    assert db.parameter(683).high == 30  # C 3.2: 0 bis 30
    assert db.interface["address"].pnu == 683


def test_profile_specific_parameters() -> None:
    assert load_profile("6se21").parameter(20).default == (3,)  # SIMOVERT P 6SE21 manual: P20 = 003
    assert load_profile("6se21").interface["address"].pnu == 21
    baum = load_profile("baumueller")
    assert [p.pnu for p in baum if 180 <= p.pnu <= 186] == list(range(180, 187))
    assert baum.parameter(183).allowed == (0, 3, 4)
    assert baum.parameter(185).access is Access.RO
    mm4 = load_profile("micromaster4")
    assert mm4.parameter(2010).array == 2 and mm4.profile.index_base == 0
    assert mm4.parameter(2011).high == 31


def test_unknown_pnu_is_error_0() -> None:
    with pytest.raises(ParameterFault) as info:
        load_profile("generic").parameter(999)  # uss.json error_illegal_pnu
    assert info.value.number == ErrorNumber.ILLEGAL_PNU


def test_unknown_profile_names_the_known_ones() -> None:
    with pytest.raises(ConfigError, match="generic"):
        load_profile("nonsense")


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "params.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("body", "parts"),
    [
        ('pnu = 5\nname = "X"\ntype = "int16"\nmax = 40000\n', ["parameter 5", "'max'", "int16"]),
        ('pnu = 5\nname = "X"\ntype = "int17"\n', ["parameter 5", "'type'"]),
        ('pnu = 5\nname = "X"\ntype = "int16"\ncolour = 1\n', ["parameter 5", "'colour'"]),
        ('pnu = 5\nname = "X"\ntype = "uint16"\nmin = 3\ndefault = 2\n', ["'default'", "2"]),
        ('pnu = 5\nname = "Seventeen chars!!"\ntype = "int16"\n', ["'name'"]),
        ('pnu = 5\nname = "X"\ntype = "int16"\ntexts = { 1 = "A" }\n', ["'texts'", "unsigned"]),
        ('pnu = 5\nname = "X"\ntype = "uint16"\narray = 300\n', ["'array'"]),
        ('pnu = 5\nname = "X"\ntype = "string"\n', ["'length'"]),
        ('pnu = 5\nname = "X"\ntype = "uint16"\naccess = "secret"\n', ["'access'"]),
        ('pnu = 3000\nname = "X"\ntype = "uint16"\n', ["'pnu'", "2047"]),
        ('pnu = 5\nname = "X"\ntype = "v2"\nmax = 7\n', ["'max'", "v2"]),
        ('pnu = 5\nname = "X"\ntype = "uint16"\nallowed = [1, 2]\ndefault = 3\n', ["'default'"]),
    ],
)
def test_bad_parameter_is_refused_naming_file_parameter_and_field(
    tmp_path: Path, body: str, parts: list[str]
) -> None:
    path = _write(tmp_path, HEAD + "[[parameter]]\n" + body)
    with pytest.raises(ConfigError) as info:
        load_database(path)
    message = str(info.value)
    assert str(path) in message
    for part in parts:
        assert part in message


def test_read_only_display_may_hold_a_value_outside_its_limits() -> None:
    # C 8 examples 2 and 4: P52 reads 4000h, its lower limit reads 5FFFh
    db = parse_database(
        HEAD + '[[parameter]]\npnu = 52\nname = "D"\ntype = "int16"\naccess = "ro"\n'
        "default = 0x4000\nmin = 0x5FFF\n"
    )
    assert db.parameter(52).default == (0x4000,)


def test_duplicate_parameter_and_bad_toml(tmp_path: Path) -> None:
    entry = '[[parameter]]\npnu = 5\nname = "X"\ntype = "int16"\n'
    with pytest.raises(ConfigError, match="defined twice"):
        load_database(_write(tmp_path, HEAD + entry + entry))
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_database(_write(tmp_path, HEAD + "[[parameter]\n"))
    with pytest.raises(ConfigError, match="cannot read"):
        load_database(tmp_path / "missing.toml")


def test_roles_are_checked(tmp_path: Path) -> None:
    text = (
        HEAD
        + "[drive]\nramp_up_time = 5\n"
        + '[[parameter]]\npnu = 5\nname = "X"\ntype = "uint16"\nunit = "Hz"\n'
    )
    with pytest.raises(ConfigError, match=r"\[drive\].*'ramp_up_time'.*time unit"):
        load_database(_write(tmp_path, text))
    with pytest.raises(ConfigError, match=r"'speed'.*unknown"):
        load_database(_write(tmp_path, HEAD + "[drive]\nspeed = 5\n"))
    with pytest.raises(ConfigError, match="not defined"):
        load_database(_write(tmp_path, HEAD + "[drive]\nramp_up_time = 5\n"))
    # the motor model's roles take the unit they are computed in
    motor = text.replace("ramp_up_time", "output_current")
    with pytest.raises(ConfigError, match=r"'output_current'.*must have the unit A, not 'Hz'"):
        load_database(_write(tmp_path, motor))


def test_a_file_extends_a_builtin_profile(tmp_path: Path) -> None:
    text = """
[profile]
name = "my-generic"
extends = "generic"
remove = [52]

[[parameter]]
pnu = 18
name = "Other word"
type = "uint16"
default = 7

[[parameter]]
pnu = 900
name = "New one"
type = "int32"
"""
    db = load_database(_write(tmp_path, text))
    assert db.profile.name == "my-generic"
    assert db.profile.index_base == 1  # inherited
    assert db.parameter(18).name == "Other word"
    assert db.parameter(900).dtype is DataType.INT32
    assert 683 in db and 52 not in db
    assert db.roles["ramp_up_time"].pnu == 462


def test_extends_cycle_is_refused(tmp_path: Path) -> None:
    (tmp_path / "a.toml").write_text('[profile]\nname = "a"\nextends = "b.toml"\n')
    (tmp_path / "b.toml").write_text('[profile]\nname = "b"\nextends = "a.toml"\n')
    with pytest.raises(ConfigError, match="cycle"):
        load_database(tmp_path / "a.toml")


def test_parameter_text_extends_a_builtin_profile() -> None:
    db = parse_database(
        '[profile]\nname = "more"\nextends = "generic"\n\n'
        '[[parameter]]\npnu = 60\nname = "Extra"\ntype = "int16"\n'
    )
    assert 60 in db and 683 in db  # the generic parameters are there
    assert db.faults["telegram_failure"] == 65
    with pytest.raises(ConfigError, match="can only extend built-in profiles"):
        parse_database('[profile]\nname = "x"\nextends = "base.toml"\n')


def test_fault_and_warning_texts_extend_and_drop() -> None:
    db = parse_database(
        '[profile]\nname = "mine"\nextends = "sinamics-v20"\n\n'
        '[fault_texts]\n1 = "my overcurrent"\n2 = ""\n900 = "my own fault"\n\n'
        '[warning_texts]\n501 = "my current limit"\n'
    )
    assert db.fault_texts[1] == "my overcurrent" and db.fault_texts[900] == "my own fault"
    assert 2 not in db.fault_texts and 70 not in db.fault_texts  # dropped here and by the V20
    assert db.fault_texts[72].startswith("USS/MODBUS")  # the V20's own text over _siemens
    assert db.warning_texts[501] == "my current limit" and 502 in db.warning_texts
    for bad, words in (('x = "t"', "must be a number"), ("5 = 7", "must be a text")):
        with pytest.raises(ConfigError, match=rf"\[fault_texts\] field .*{words}"):
            parse_database(f'[profile]\nname = "x"\n\n[fault_texts]\n{bad}\n')


def test_extends_an_unknown_profile_names_the_file(tmp_path: Path) -> None:
    path = _write(tmp_path, '[profile]\nname = "x"\nextends = "genric"\n')
    with pytest.raises(ConfigError, match=r"\.toml: \[profile\] field 'extends': unknown profile"):
        load_database(path)


def test_names_style_is_the_familys_and_a_bad_one_is_refused(tmp_path: Path) -> None:
    from pyuss.drive.database import NameStyle

    assert load_profile("sinamics-g120").profile.names is NameStyle.SIEMENS  # from _siemens
    assert load_profile("micromaster4").profile.names is NameStyle.SIEMENS
    assert load_profile("nord").profile.names is NameStyle.PROJECT
    assert load_profile("generic").profile.names is NameStyle.PROJECT
    path = _write(tmp_path, HEAD + 'names = "manual"\n')
    with pytest.raises(ConfigError) as info:
        load_database(path)
    message = str(info.value)
    assert str(path) in message and "'names'" in message and "'siemens'" in message


def test_the_response_delay_of_the_manual_is_read_from_the_profile_table() -> None:
    assert load_profile("sinamics-v20").profile.response_delay_ms == 20.0
    assert load_profile("generic").profile.response_delay_ms is None


@pytest.mark.parametrize("value", ["-1", "true", '"20"', "2000"])
def test_a_response_delay_that_is_no_delay_is_refused(value: str) -> None:
    text = HEAD.replace("[profile]\n", f"[profile]\nresponse_delay_ms = {value}\n", 1)
    with pytest.raises(ConfigError, match="response_delay_ms"):
        parse_database(text)
