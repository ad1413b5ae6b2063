"""The page over the broker assumes nothing of a drive that its gateway did not say: a drive
of unknown kind, or of a family this version does not know, gets no family's facts."""

from __future__ import annotations

import socket
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("aiomqtt")

from gateway.harness import Broker
from pyuss.errors import ConfigError
from pyuss.gateway.config import mqtt_options
from pyuss.plant.remote import RemoteParams, RemotePlant, drives_of, parse_message
from pyuss.points.config import Where


def _message(profile: str) -> dict[str, Any]:
    point = [{"key": "main", "pzd": 2, "dword": False}]
    drive = {"name": "pump", "address": 0, "profile": profile, "layout": "4,2", "unit": "%"}
    return {"bus": "line9", "drives": [{**drive, "setpoints": point, "actual": point}]}


@pytest.mark.parametrize("profile", ["unknown", "a-family-of-a-newer-version"])
def test_a_drive_the_gateway_names_no_known_family_for_gets_no_family_s_facts(
    profile: str,
) -> None:
    (drive,) = drives_of(_message(profile))
    assert drive.profile == "unknown"
    plant = RemotePlant(mqtt_options({"broker": "mqtt://127.0.0.1:1"}, Where("web")))
    params = RemoteParams(plant, drive)
    assert not params.profile_named and params.named_profile is None
    assert params.kind == "unknown"
    assert params.params.get(1120) is None  # the generic file's parameter is not applied


def test_a_named_family_s_facts_apply() -> None:
    (drive,) = drives_of(_message("sinamics-v20"))
    plant = RemotePlant(mqtt_options({"broker": "mqtt://127.0.0.1:1"}, Where("web")))
    params = RemoteParams(plant, drive)
    assert params.profile_named and params.kind == "sinamics-v20"
    assert params.params.get(1120) is not None


async def test_the_page_s_client_sends_each_command_at_once(tmp_path: Path) -> None:
    """No Nagle delay on the page's connection either: a command leaves when it is made."""
    broker = Broker(tmp_path)
    broker.start()
    plant = RemotePlant(mqtt_options({"broker": broker.url}, Where("web")))
    try:
        await plant.start()
        client = plant._client
        assert client is not None
        sock = client._client.socket()
        assert isinstance(sock, socket.socket)
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
    finally:
        await plant.close()
        broker.stop()


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_a_message_holding_nan_or_infinity_is_refused(constant: str) -> None:
    """A lying gateway's NaN never reaches the page's answers (a browser reads no NaN)."""
    with pytest.raises(ConfigError, match=f"{constant} is no JSON number"):
        parse_message(f'{{"v": 1, "actual": {{"main": {{"value": {constant}}}}}}}'.encode())
