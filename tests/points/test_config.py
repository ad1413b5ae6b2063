"""The plant's configuration: bad values are refused with one line naming the key, before
anything is opened; endpoint addresses are parsed in one place."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyuss.errors import ConfigError
from pyuss.gateway.config import parse_config
from pyuss.points.config import parse_plant, plant_from_flags
from pyuss.points.endpoint import parse_endpoint
from pyuss.points.model import resolve
from pyuss.points.parameters import ParameterModel

GOOD = """
[[bus]]
name = "line1"
port = "bus://127.0.0.1:4000"
baud = 38400
profile = "generic"
layout = "4,2"
[[bus.drive]]
address = 5
name = "conveyor"
parameters = [107, "4.2", { pnu = 52, poll = 5.0 }]
"""


def test_a_good_file_gives_the_plant() -> None:
    config = parse_config(tomllib.loads(GOOD + "[modbus]\n"))
    bus = config.plant.buses[0]
    assert (bus.name, bus.port, bus.baud, str(bus.layout)) == (
        "line1",
        "bus://127.0.0.1:4000",
        38400,
        "4,2",
    )
    drive = bus.drives[0]
    assert [p.key for p in drive.parameters] == ["P107", "P4.2", "P52"]
    assert drive.parameters[2].poll == 5.0
    assert config.modbus is not None and config.modbus.endpoint.host == "127.0.0.1"
    model = resolve(config.plant)
    assert model.drives[0].unit == "Hz"  # from the generic profile's reference P352
    assert model.drives[0].parameters[0].meta.is_float


def test_a_bus_that_names_no_profile_has_drives_of_unknown_kind() -> None:
    plant = parse_config(tomllib.loads(GOOD.replace('profile = "generic"\n', ""))).plant
    assert plant.buses[0].profile is None
    drive = resolve(plant).drives[0]
    # no family's facts: no reference (process values in percent), P107 a word as it travels
    assert (drive.profile, drive.reference, drive.unit, drive.fault) == (None, None, "%", None)
    meta = drive.parameters[0].meta
    assert (meta.known, meta.is_float, meta.scaling) == (False, False, None)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("address = 5", "address = 40"), "bus[0].drive[0].address: 40 is not 0..31"),
        (("baud = 38400", "baud = 1234"), "bus[0].baud:"),
        (('layout = "4,2"', 'layout = "5,2"'), "bus[0].layout:"),
        (('name = "conveyor"', 'name = "con veyor"'), "bus[0].drive[0].name:"),
        (("poll = 5.0", "poll = -1"), "bus[0].drive[0].parameters[2].poll:"),
        (('"4.2"', '"4.x"'), "bus[0].drive[0].parameters[1]:"),
        (("[[bus.drive]]", "[[bus.drives]]"), "bus[0].drives: unknown key"),
        (('port = "bus://127.0.0.1:4000"', ""), "bus[0].port: missing"),
    ],
)
def test_bad_configuration_names_the_key(change: tuple[str, str], message: str) -> None:
    text = GOOD.replace(*change)
    with pytest.raises(ConfigError) as error:
        parse_config(tomllib.loads(text + "[modbus]\n"))
    assert message in str(error.value)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('[modbus]\nlisten = "0.0.0.0:99999"\n', "modbus.listen:"),
        ('[modbus]\nword_order = "middle"\n', "modbus.word_order:"),
        ('[mqtt]\nbroker = "http://x"\n', "mqtt.broker:"),
        ('[mqtt]\nprefix = "a/#"\n', "mqtt.prefix:"),
        ('[mqtt]\nca = "/nonexistent.pem"\n', "mqtt.ca:"),
        ('[opcua]\nsecurity = ["Basic256Sha256_Sign"]\n', "opcua.security:"),
        ('[opcua]\nanonymous = "admin"\n', "opcua.anonymous:"),
        ("[gateway]\n", "gateway: unknown key"),
        # what would be left unapplied, or applied otherwise than written
        ('[mqtt]\nclient_id = "{bus!r:>99999999}"\n', "mqtt.client_id: "),
        ('[mqtt]\nclient_id = "{bus.__class__}"\n', "mqtt.client_id: "),
        (f'[mqtt]\nkey = "{__file__}"\n', "mqtt.key: is the key of a client certificate"),
        ("[mqtt]\ninsecure = true\n", "mqtt.insecure: skips the checks of TLS"),
        ("[mqtt]\nreconnect = 1e300\n", "mqtt.reconnect: 1e+300 s is more than"),
        ('[mqtt]\nprefix = "$SYS/uss"\n', "mqtt.prefix: '$SYS/uss': topics that start with $"),
        ('[mqtt]\ndiscovery_prefix = "$ha"\n', "mqtt.discovery_prefix: "),
        ('[mqtt]\nprefix = "u\\u0000s"\n', "mqtt.prefix: 'u\\x00s': no control characters"),
    ],
)
def test_bad_face_options_name_the_key(extra: str, message: str) -> None:
    with pytest.raises(ConfigError) as error:
        parse_config(tomllib.loads(GOOD + extra))
    assert message in str(error.value)


def test_a_bus_key_of_a_face_without_its_table_is_refused_not_left_unapplied() -> None:
    own = GOOD.replace("[[bus.drive]]", 'modbus = "127.0.0.1:5021"\n[[bus.drive]]')
    with pytest.raises(ConfigError, match=r"^bus\[0\]\.modbus: belongs to the modbus face"):
        parse_config(tomllib.loads(own + "[mqtt]\n"))
    assert parse_config(tomllib.loads(own + "[modbus]\n")).modbus is not None


def test_two_drives_that_would_be_one_home_assistant_device_are_refused() -> None:
    two = GOOD.replace('name = "line1"', 'name = "line_1"') + (
        '[[bus]]\nname = "line"\nport = "bus://127.0.0.1:4001"\n'
        '[[bus.drive]]\naddress = 5\nname = "1_conveyor"\n'
    )
    with pytest.raises(ConfigError, match=r"^bus\[1\]\.drive\[0\]\.name: .*pyuss_line_1_conveyor"):
        parse_config(tomllib.loads(two + "[mqtt]\n"))
    assert parse_config(tomllib.loads(two + "[mqtt]\ndiscovery = false\n")).mqtt is not None


def test_face_options_that_fit_are_taken() -> None:
    tls = (
        f'[mqtt]\nbroker = "mqtts://b"\ninsecure = true\ncert = "{__file__}"\nkey = "{__file__}"\n'
    )
    for extra in (tls, '[mqtt]\nclient_id = "plant-{bus}-gw"\nreconnect = 60\n'):
        assert parse_config(tomllib.loads(GOOD + extra)).mqtt is not None


GENERIC = {"profile": "generic"}  # the facts refused on below are the generic profile's


def test_what_the_points_cannot_show_is_refused_with_its_key() -> None:
    with pytest.raises(ConfigError, match=r"parameters\[0\]: P90 .*numbers only"):
        resolve(
            parse_plant([{"port": "x", **GENERIC, "drive": [{"address": 1, "parameters": [90]}]}])
        )
    with pytest.raises(ConfigError, match=r"parameters\[0\]: P4 .*name an element"):
        resolve(
            parse_plant([{"port": "x", **GENERIC, "drive": [{"address": 1, "parameters": [4]}]}])
        )
    with pytest.raises(ConfigError, match="double word: layout 3,2"):
        plant = parse_plant(
            [
                {
                    "port": "x",
                    **GENERIC,
                    "layout": "3,2",
                    "drive": [{"address": 1, "parameters": [107]}],
                }
            ]
        )
        resolve(plant)
    with pytest.raises(ConfigError, match=r"actual\[0\].pzd: PZD3"):
        parse_plant([{"port": "x", "layout": "3,2", "drive": [{"address": 1, "actual": [3]}]}])


@pytest.mark.parametrize(
    "setpoints",
    [
        [{"key": "a", "pzd": 2, "dword": True}, {"key": "b", "pzd": 3}],
        [{"key": "a", "pzd": 3}, {"key": "b", "pzd": 2, "dword": True}],
        [{"key": "a", "pzd": 2}, {"key": "b", "pzd": 2}],
    ],
)
def test_setpoints_that_share_a_process_word_are_refused(setpoints: list[object]) -> None:
    # a write of setpoint b would change the word setpoint a sends
    drive = {"address": 1, "layout": "4,4", "setpoints": setpoints}
    with pytest.raises(ConfigError, match=r"^bus\[0\]\.drive\[0\]\.setpoints\[1\]\.pzd: PZD"):
        parse_plant([{"port": "x", "drive": [drive]}])
    # actual values may show one word twice: reading moves nothing
    drive = {"address": 1, "layout": "4,4", "actual": setpoints}
    assert len(parse_plant([{"port": "x", "drive": [drive]}]).buses[0].drives[0].actual) == 2


def test_two_buses_on_one_line_are_refused_however_the_port_is_written(tmp_path: Path) -> None:
    # two masters on one RS-485 line: each one's telegrams garble the other's
    device = tmp_path / "ttyUSB0"
    device.touch()
    link = tmp_path / "usb-FTDI-port0"
    link.symlink_to(device)
    for one, two in (
        (str(device), str(link)),
        (str(device), f"{device}?rs485=rts"),
        ("bus://127.0.0.1:4000", "bus://127.0.0.1:4000?name=second"),
        ("tcp://Converter:4001", "tcp://converter:4001?echo=1"),
    ):
        buses = [
            {"name": "a", "port": one, "drive": [{"address": 1}]},
            {"name": "b", "port": two, "drive": [{"address": 2}]},
        ]
        with pytest.raises(ConfigError, match=r"^bus\[1\]\.port: .*one master per line"):
            parse_plant(buses)
    buses[1]["port"] = "tcp://converter:4002"
    assert len(parse_plant(buses).buses) == 2


def test_flags_name_the_flag() -> None:
    with pytest.raises(ConfigError, match=r"^--address: 40 is not 0..31$"):
        plant_from_flags(port="x", addresses=[40])
    with pytest.raises(ConfigError, match=r"^--baud: "):
        plant_from_flags(port="x", addresses=[5], baud=1234)
    with pytest.raises(ConfigError, match=r"^--address: "):
        plant_from_flags(port="x", addresses=[5, 5])
    with pytest.raises(ConfigError, match=r"^--address: give at least one"):
        plant_from_flags(port="x", addresses=[])


@pytest.mark.parametrize(
    ("text", "face", "url"),
    [
        ("5020", "modbus", "modbus://127.0.0.1:5020"),
        (":5020", "modbus", "modbus://127.0.0.1:5020"),
        ("0.0.0.0:502", "modbus", "modbus://0.0.0.0:502"),
        ("mqtt://broker", "mqtt", "mqtt://broker:1883"),
        ("mqtts://user:pw@broker", "mqtt", "mqtts://user@broker:8883"),
        ("opc.tcp://127.0.0.1", "opcua", "opc.tcp://127.0.0.1:4840"),
        ("opc.tcp://127.0.0.1:4841/uss", "opcua", "opc.tcp://127.0.0.1:4841/uss"),
        ("localhost:8080", "web", "http://localhost:8080"),
    ],
)
def test_endpoints_default_to_loopback_and_the_face_port(text: str, face: str, url: str) -> None:
    endpoint = parse_endpoint(text, face)
    assert endpoint.url == url
    if text.startswith(("5020", ":")):
        assert endpoint.loopback


@pytest.mark.parametrize(
    ("text", "face"),
    [("", "modbus"), ("mqtt://x", "modbus"), ("host:99999", "modbus"), ("http://u:p@h", "web")],
)
def test_bad_endpoints_are_refused(text: str, face: str) -> None:
    with pytest.raises(ConfigError):
        parse_endpoint(text, face)


@pytest.mark.parametrize(
    "text",
    [
        "0.0.0.0:502?read_only=1",
        "modbus://127.0.0.1:5020?read_only=true",
        "127.0.0.1:5020?",
        "modbus://127.0.0.1:5020#read_only",
    ],
)
def test_an_option_written_into_an_address_is_refused_not_left_unapplied(text: str) -> None:
    # a face's options are its table's keys and flags: one in the address would not apply,
    # and a face meant to refuse writes would take them
    with pytest.raises(ConfigError, match="modbus") as error:
        parse_config(tomllib.loads(GOOD + f'[modbus]\nlisten = "{text}"\n'))
    assert str(error.value).startswith("modbus.listen: ")
    with pytest.raises(ConfigError) as error:
        own = GOOD.replace("[[bus.drive]]", f'modbus = "{text}"\n[[bus.drive]]')
        parse_config(tomllib.loads(own + "[modbus]\n"))
    assert str(error.value).startswith("bus[0].modbus: ")


@given(st.integers(min_value=800, max_value=60000))
def test_a_scaled_parameter_converts_both_ways(raw: int) -> None:
    meta = ParameterModel("generic").meta(352)  # 0.01 Hz
    value = meta.physical(raw)
    assert meta.raw(value) == raw


def test_a_value_between_steps_or_beyond_the_limits_is_refused_before_sending() -> None:
    meta = ParameterModel("generic").meta(352)
    with pytest.raises(ConfigError, match=r"steps of 0\.01"):
        meta.raw(50.005)
    with pytest.raises(ConfigError, match="above the maximum"):
        meta.raw(601.0)


def test_gateway_parameters_take_every_spelling_and_keep_their_keys() -> None:
    text = GOOD.replace('[107, "4.2", { pnu = 52, poll = 5.0 }]', '["r0021", "P0947[1]", "p52"]')
    drive = parse_config(tomllib.loads(text + "[modbus]\n")).plant.buses[0].drives[0]
    assert [(p.pnu, p.index) for p in drive.parameters] == [(21, None), (947, 1), (52, None)]
    assert [p.key for p in drive.parameters] == ["P21", "P947.1", "P52"]  # stable keys
    bad = GOOD.replace('"4.2"', '"P21x"')
    with pytest.raises(ConfigError) as error:
        parse_config(tomllib.loads(bad + "[modbus]\n"))
    assert "bus[0].drive[0].parameters[1]: 'P21x' is not a parameter number" in str(error.value)
