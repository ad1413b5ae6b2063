"""The registry of faces: a face of another package is one `FaceSpec` - registered from Python
or through the ``pyuss.faces`` entry points - and the gateway reads its table, takes its flag,
checks its library, starts it, prints its endpoint and stops it like its own faces."""

from __future__ import annotations

import asyncio
import dataclasses
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from gateway import dummyface
from gateway.test_cli import USS, first_line, start, stop
from pyuss.bus import VirtualBus
from pyuss.cli.main import main
from pyuss.errors import ConfigError
from pyuss.gateway.config import parse_config
from pyuss.gateway.extras import Library, MissingExtra
from pyuss.gateway.faces import FaceSpec, Flag, faces, register, unregister
from pyuss.gateway.run import Gateway
from support.paths import ROOT

TESTS = ROOT / "tests"
PLANT = {"bus": [{"port": "bus://simulated:1", "baud": 38400, "drive": [{"address": 5}]}]}


@pytest.fixture
def dummy() -> Iterator[FaceSpec]:
    register(dummyface.SPEC)
    try:
        yield dummyface.SPEC
    finally:
        unregister("dummy")


async def _line(endpoint: str) -> str:
    host, _, port = endpoint.removeprefix("dummy://").rpartition(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    try:
        return (await reader.readline()).decode().strip()
    finally:
        writer.close()


async def test_a_registered_face_is_read_from_its_table_started_named_and_stopped(
    dummy: FaceSpec,
) -> None:
    config = parse_config({**PLANT, "dummy": {"greeting": "hi", "listen": "127.0.0.1:0"}})
    assert config.face("dummy") == dummyface.DummyOptions("127.0.0.1", 0, "hi")
    bus = VirtualBus(38400)
    gateway = Gateway(config, transports={"bus": bus.attach("gateway")})
    assert list(gateway.faces) == ["dummy"] and gateway.faces_of("dummy")
    async with gateway:
        ((name, endpoint),) = gateway.endpoints()
        assert name == "dummy" and endpoint.startswith("dummy://127.0.0.1:")
        assert not endpoint.endswith(":0")
        assert await _line(endpoint) == "hi bus=5 writable"
    with pytest.raises(OSError):  # closed with the gateway
        await _line(endpoint)


def test_a_registered_face_s_table_is_checked_like_the_others(dummy: FaceSpec) -> None:
    with pytest.raises(ConfigError, match=r"^dummy\.colour: unknown key \(known: listen, "):
        parse_config({**PLANT, "dummy": {"colour": "red"}})
    with pytest.raises(ConfigError, match=r"^dummy\.listen: 'nowhere': expected HOST:PORT$"):
        parse_config({**PLANT, "dummy": {"listen": "nowhere"}})
    unregister("dummy")
    with pytest.raises(ConfigError, match=r"^dummy: unknown key \(known: bus, modbus, mqtt, "):
        parse_config({**PLANT, "dummy": {}})


def test_the_registry_refuses_a_name_that_is_no_face_s_or_is_taken(dummy: FaceSpec) -> None:
    for name in ("bus", "web", "port", "read-only", "Modbus", ""):
        with pytest.raises(ConfigError, match="a face's name is lower-case letters"):
            register(dataclasses.replace(dummy, name=name))
    for name in ("dummy", "modbus"):
        with pytest.raises(ConfigError, match="there is such a face already"):
            register(dataclasses.replace(dummy, name=name))
    assert list(faces()) == ["modbus", "mqtt", "opcua", "dummy"]
    assert faces()["modbus"].module == "pyuss.gateway.modbus"


def test_a_face_whose_library_is_missing_is_refused_before_anything_starts(
    dummy: FaceSpec,
) -> None:
    needs = dataclasses.replace(
        dummy, library=Library("pyuss_no_such_library", "no-such-library", (1, 0), (2, 0))
    )
    register(needs, replace=True)
    config = parse_config({**PLANT, "dummy": {}})
    with pytest.raises(
        MissingExtra,
        match=r"the dummy face needs no-such-library .*: .*-m pip install 'no-such-library'$",
    ):
        Gateway(config)
    register(dataclasses.replace(needs, extra="dummy"), replace=True)
    with pytest.raises(MissingExtra, match=r"pip install 'pyuss\[dummy\]'$"):
        Gateway(config)


def test_read_only_refuses_to_start_a_face_that_cannot_refuse_writes(
    dummy: FaceSpec, capsys: pytest.CaptureFixture[str]
) -> None:
    # a face whose options have no read_only would take writes: it is not started at all
    @dataclasses.dataclass(frozen=True)
    class Writable:
        port: int = 0

    register(
        dataclasses.replace(dummy, flag=Flag("PORT", "", lambda o, t: Writable())), replace=True
    )
    args = ["gateway", "--port", "/dev/null", "--address", "5", "--dummy", ":0", "--read-only"]
    assert main(args) == 2
    assert capsys.readouterr().err == (
        "uss gateway: --read-only: the dummy face: its options have no read_only, "
        "so it cannot refuse writes\n"
    )


def _package(tmp_path: Path, entry: str) -> dict[str, str]:
    """An installed distribution with a ``pyuss.faces`` entry point, and the environment of a
    process that sees it."""
    info = tmp_path / "pyuss_dummy-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pyuss-dummy\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[pyuss.faces]\n{entry}\n")
    path = os.pathsep.join([str(tmp_path), str(TESTS), os.environ.get("PYTHONPATH", "")])
    return {**os.environ, "PYTHONPATH": path, "PYTHONUNBUFFERED": "1"}


def _gateway(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*USS, "gateway", *args], capture_output=True, text=True, timeout=60)


def test_a_face_of_another_package_joins_uss_gateway_through_its_entry_point(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    env = _package(tmp_path, "dummy = gateway.dummyface:SPEC")
    monkeypatch.setenv("PYTHONPATH", env["PYTHONPATH"])  # for the processes `start` runs
    usage = _gateway("--help")
    assert usage.returncode == 0
    assert "--dummy HOST:PORT" in usage.stdout and "serve the dummy face here" in usage.stdout
    bad = _gateway("--port", "/dev/null", "--address", "5", "--dummy", "x")
    assert bad.returncode == 2
    assert bad.stderr == "uss gateway: --dummy: 'x': expected HOST:PORT\n"
    bus = start("bus", "--baud", "38400", "--bus-tcp", "127.0.0.1:0")
    try:
        url = first_line(bus, "bus://")
        gateway = start(
            "gateway", "--port", url, "--baud", "38400", "--address", "5", "--dummy", ":0",
            "--read-only",
        )  # fmt: skip
        try:
            endpoint = first_line(gateway, "dummy: ").removeprefix("dummy: ")
            first_line(gateway, "ready")
            assert asyncio.run(_line(endpoint)) == "hello bus=5 read-only"
            assert stop(gateway) == 0
        finally:
            stop(gateway)
    finally:
        stop(bus)


def test_an_entry_point_that_cannot_be_loaded_is_left_out_with_a_warning(tmp_path: Path) -> None:
    env = _package(tmp_path, "broken = pyuss_no_such_module:SPEC")
    code = "from pyuss.gateway.faces import faces\nprint(sorted(faces()))\n"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "['modbus', 'mqtt', 'opcua']"
    assert "face broken (pyuss_no_such_module:SPEC) left out: " in result.stderr


def test_the_modbus_entry_builds_a_server_per_address_each_named() -> None:
    # the Modbus entry's builder: a server shared by the buses without an address of their own
    config = parse_config(
        {
            "bus": [
                {"name": "a", "port": "bus://x:1", "drive": [{"address": 5}]},
                {"name": "b", "port": "bus://x:2", "modbus": ":0", "drive": [{"address": 6}]},
            ],
            "modbus": {"listen": ":0"},
        }
    )
    assert config.modbus is not None
    gateway = Gateway(config)
    assert [name for name, _ in gateway.endpoints()] == ["modbus", "modbus b"]
    assert [face.endpoint for face in gateway.modbus] == [
        config.modbus.endpoint,
        config.modbus.bus_endpoints["b"],
    ]
