"""``uss gateway`` as a user runs it: separate processes for the bus, the simulated drives and
the gateway; bad configuration refused before any port opens; SIGTERM stops it cleanly."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gateway.harness import Broker
from support.network import free_port
from support.processes import first_line, start_uss, stop_uss
from test_userfile import bad_files, refuses

USS = [sys.executable, "-m", "pyuss.cli.main"]
start = start_uss
stop = stop_uss


@pytest.mark.posix("stops uss gateway with SIGTERM and checks it ended cleanly")
def test_bus_simulator_and_gateway_as_separate_processes(broker: Broker) -> None:
    import aiomqtt  # noqa: F401  (the mqtt extra is installed)
    from pymodbus.client import ModbusTcpClient

    bus = start("bus", "--baud", "38400", "--bus-tcp", "127.0.0.1:0")
    processes = [bus]
    try:
        url = first_line(bus, "bus://")
        host_port = url.removeprefix("bus://")
        sim = start(
            "simulate",
            "--baud",
            "38400",
            "--bus",
            host_port,
            "--layout",
            "4,2",
            "--address",
            "5",
            "--address",
            "6",
        )
        processes.append(sim)
        first_line(sim, "bus://")
        modbus_port = free_port()
        gateway = start(
            "gateway",
            "--port",
            url,
            "--baud",
            "38400",
            "--profile",
            "generic",  # the simulated drives' family: its reference and parameter types
            "--layout",
            "4,2",
            "--address",
            "5",
            "--address",
            "6",
            "--parameter",
            "107",
            "--modbus",
            f"127.0.0.1:{modbus_port}",
            "--mqtt",
            broker.url,
        )
        processes.append(gateway)
        first_line(gateway, "ready")
        client = ModbusTcpClient("127.0.0.1", port=modbus_port, timeout=10)
        assert client.connect()
        # wait until the gateway has read the reference (health bit 4), then set 25 Hz and ON
        deadline = time.monotonic() + 20
        while not client.read_input_registers(2, count=1, device_id=5).registers[0] & 16:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        words = list(struct.unpack(">HH", struct.pack(">f", 25.0)))
        assert not client.write_registers(24, words, device_id=5).isError()
        assert not client.write_register(1, 1, device_id=5).isError()
        status = client.read_input_registers(0, count=2, device_id=5).registers
        assert status[0] & 0x0004 and status[1] == 5  # operation enabled
        p107 = client.read_holding_registers(100, count=2, device_id=5).registers
        assert struct.unpack(">f", struct.pack(">HH", *p107))[0] == 50.0
        client.close()
        assert stop(gateway) == 0
        result = subprocess.run(
            [
                "mosquitto_sub",
                "-p",
                str(broker.port),
                "-t",
                "uss/bus/availability",
                "-C",
                "1",
                "-W",
                "5",
            ],
            capture_output=True,
            text=True,
            check=False,
        )
        assert result.stdout.strip() == "offline"
        state = subprocess.run(
            [
                "mosquitto_sub",
                "-p",
                str(broker.port),
                "-t",
                "uss/bus/drive5/state",
                "-C",
                "1",
                "-W",
                "5",
            ],
            capture_output=True,
            text=True,
            check=False,
        )
        assert json.loads(state.stdout)["setpoint"]["main"]["value"] == 25.0
    finally:
        for process in reversed(processes):
            stop(process)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--port", "/dev/null", "--address", "40", "--modbus", "5020"],
            "--address: 40 is not 0..31",
        ),
        (["--port", "/dev/null", "--address", "5"], "no face"),
        (["--port", "/dev/null", "--address", "5", "--modbus", "host:99999"], "--modbus:"),
        (["--port", "/dev/null", "--address", "5", "--mqtt", "ftp://x"], "--mqtt:"),
        (  # drives without a telegram for ages
            ["--port", "/dev/null", "--address", "5", "--modbus", ":0", "--cycle-time", "1e300"],
            "--cycle-time: 1e+300 seconds is more than the 60 allowed",
        ),
        (["--config", "/nonexistent.toml"], "cannot read the configuration"),
        (  # two faces on one port: refused before either listens, not by the second's bind
            [
                *("--port", "/dev/ttyNOPE", "--address", "5", "--modbus", "127.0.0.1:5999"),
                *("--opcua", "opc.tcp://0.0.0.0:5999"),
            ],
            "opcua opc.tcp://0.0.0.0:5999 and modbus modbus://127.0.0.1:5999 listen on one port",
        ),
    ],
)
def test_bad_configuration_is_one_line_and_exit_code_2(args: list[str], message: str) -> None:
    result = subprocess.run([*USS, "gateway", *args], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


def test_a_file_that_is_no_configuration_is_one_line_naming_it(tmp_path: Path) -> None:
    # missing, a folder, no UTF-8, binary, empty, nested 5000 deep: one line, at once
    for config, message in bad_files(tmp_path, "the configuration"):
        result = subprocess.run(
            [*USS, "gateway", "--config", str(config)], capture_output=True, text=True, timeout=60
        )
        assert result.returncode == 2, result.stderr
        line, *more = result.stderr.splitlines()
        assert not more and refuses(line.removeprefix("uss gateway: "), config, message), line


def refused_drive(tmp_path: Path, drive: str) -> tuple[Path, str]:
    """The one line ``uss gateway`` refuses a configuration with, whose one drive is given by
    the ``[[bus.drive]]`` lines ``drive`` (exit code 2, before any port opens)."""
    config = tmp_path / "plant.toml"
    config.write_text(
        f'[[bus]]\nport = "/dev/ttyNOPE"\nprofile = "generic"\n[[bus.drive]]\naddress = 5\n'
        f"{drive}[opcua]\n",
        encoding="utf-8",
    )
    result = subprocess.run(
        [*USS, "gateway", "--config", str(config)], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2
    return config, result.stderr.strip()


def test_a_bad_key_in_the_file_is_named_before_any_port_opens(tmp_path: Path) -> None:
    config, line = refused_drive(tmp_path, "parameters = [90]\n")
    assert line == (
        f"uss gateway: {config}, line 4: bus[0].drive[0].parameters[0]: P90 (Plant name) is a "
        "string parameter: the gateway exposes numbers only"
    )


def test_a_face_without_its_library_names_the_pip_install() -> None:
    code = (
        "import sys; sys.modules['asyncua'] = None\n"
        "from pyuss.gateway.extras import require\n"
        "try:\n    require('opcua')\nexcept Exception as exc:\n    print(exc)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60
    )
    assert "pip install 'pyuss[opcua]'" in result.stdout


def test_a_bad_parameter_of_a_siemens_drive_is_named_as_its_documents_write_it(
    tmp_path: Path,
) -> None:
    config, line = refused_drive(tmp_path, 'profile = "sinamics-v20"\nparameters = ["r0947"]\n')
    assert line == (
        f"uss gateway: {config}, line 4: bus[0].drive[0].parameters[0]: r0947 (Fault numbers) is "
        "an array of 8: name an element (r0947.0)"
    )


@pytest.mark.parametrize(
    "flag",
    [
        ["--baud", "38400"],
        ["--profile", "nord"],
        ["--layout", "4,2"],
        ["--cycle-time", "0.1"],
        ["--bus-name", "line9"],
        ["--address", "6"],
        ["--parameter", "107"],
        ["--port", "/dev/null"],
    ],
)
def test_a_bus_flag_beside_a_configuration_file_is_refused_not_left_unapplied(
    tmp_path: Path, flag: list[str]
) -> None:
    # the file's bus at 9600 baud with --baud 38400 would have run at 9600 without a word
    config = tmp_path / "plant.toml"
    config.write_text(
        '[[bus]]\nport = "/dev/ttyNOPE"\n[[bus.drive]]\naddress = 5\n[modbus]\n', encoding="utf-8"
    )
    ways: list[tuple[list[str], dict[str, str]]] = [(["--config", str(config)], {})]
    if flag[0] != "--port":  # --port alone means one bus from flags
        ways.append(([], {"USS_CONFIG": str(config)}))  # the file the other commands read
    for args, env in ways:
        result = subprocess.run(
            [*USS, "gateway", *args, *flag],
            capture_output=True,
            text=True,
            timeout=60,
            env={**os.environ, **env},
        )
        assert result.returncode == 2, result.stderr
        (line,) = result.stderr.splitlines()
        assert line.startswith(f"uss gateway: {flag[0]}: ") and str(config) in line, line


def test_two_buses_with_one_modbus_address_are_refused_before_any_port_opens(
    tmp_path: Path,
) -> None:
    config = tmp_path / "plant.toml"
    config.write_text(
        "".join(
            f'[[bus]]\nname = "{name}"\nport = "/dev/ttyNOPE{name}"\nmodbus = "127.0.0.1:5998"\n'
            f"[[bus.drive]]\naddress = {address}\n"
            for name, address in (("line1", 5), ("line2", 6))
        )
        + "[modbus]\n",
        encoding="utf-8",
    )
    result = subprocess.run(
        [*USS, "gateway", "--config", str(config)], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "uss gateway: modbus line2 modbus://127.0.0.1:5998 and modbus line1 "
        "modbus://127.0.0.1:5998 listen on one port: give each face and bus an address of its own"
    )


def test_the_mqtt_flag_beside_a_file_keeps_the_files_login(tmp_path: Path) -> None:
    from pyuss.cli.gateway import build_config
    from pyuss.cli.main import build_parser

    config = tmp_path / "plant.toml"
    config.write_text(
        '[[bus]]\nport = "/dev/ttyNOPE"\n[[bus.drive]]\naddress = 5\n'
        '[mqtt]\nbroker = "mqtt://broker.plant"\nusername = "gw"\npassword = "secret"\n',
        encoding="utf-8",
    )
    parser = build_parser("gateway")
    for url, login in (
        ("mqtt://test-broker:1884", ("gw", "secret")),  # another broker, the same login
        ("mqtt://other:pw@test-broker", ("other", "pw")),  # the URL's own login
    ):
        args = parser.parse_args(["gateway", "--config", str(config), "--mqtt", url])
        options = build_config(args).mqtt
        assert options.endpoint.host == "test-broker"
        assert (options.username, options.password) == login
