"""What the MQTT face refuses, against a real mosquitto and its own clients (mosquitto_pub):
retained and stale commands, reply topics that could act, oversize, deeply nested, wrongly
typed and huge payloads, a flood; an unreachable broker. Each case checks that no telegram
that moves a drive went out (the simulated drives' control word, setpoint and parameters are
as before) and that a well-behaved client is served afterwards."""

from __future__ import annotations

import contextlib
import json
import logging
import shutil
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

from gateway.harness import Broker, MqttClient, mosquitto_pub, simulated_gateway, subscribed
from pyuss.gateway.mqtt import MqttBusFace
from pyuss.gateway.run import Gateway
from pyuss.slave import SlaveEngine
from support.waiting import eventually

pytestmark = pytest.mark.skipif(
    shutil.which("mosquitto_pub") is None,
    reason="mosquitto_pub is not installed (apt-get install mosquitto-clients)",
)


@contextlib.asynccontextmanager
async def listener(broker: Broker, *topics: str) -> AsyncIterator[list[tuple[str, bytes]]]:
    """Every message on ``topics``, in order, as (topic, payload)."""
    seen: list[tuple[str, bytes]] = []
    async with subscribed(broker, *topics, on=lambda topic, payload: seen.append((topic, payload))):
        yield seen


def errors(seen: list[tuple[str, bytes]], topic: str) -> list[dict[str, Any]]:
    """The refusals among the replies on ``topic``."""
    replies = [json.loads(payload) for at, payload in seen if at == topic]
    return [reply["error"] for reply in replies if not reply["ok"]]


def drives(engines: dict[int, SlaveEngine]) -> dict[int, tuple[object, ...]]:
    """What a telegram can move in each simulated drive: the control word and setpoint in
    force, and the parameters the tests write."""
    return {
        address: (
            engine.drive.machine.control,
            engine.drive.machine.setpoint,
            engine.drive.value(107),
            engine.drive.value(18),
        )
        for address, engine in engines.items()
    }


async def served(gateway: Gateway, *addresses: int) -> None:
    """A well-behaved client is served: its read of P107 is answered by every drive."""
    async with MqttClient(gateway) as client:
        for address in addresses:
            value, unit = await client.read_parameter(address, 107)
            assert (value, unit) == (50.0, "Hz")


def face_of(gateway: Gateway) -> MqttBusFace:
    face: MqttBusFace = gateway.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
    return face


def refusals(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [
        r.getMessage()
        for r in caplog.records
        if r.name == "pyuss.gateway.mqtt" and "refused" in r.getMessage()
    ]


async def test_a_retained_command_never_acts_before_or_after_the_gateway_started(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    await mosquitto_pub(broker, "uss/bus/drive5/cmd/run", "ON", retain=True)
    retained = {"id": "r1", "value": 30.0, "reply_to": "client/replies"}
    await mosquitto_pub(broker, "uss/bus/drive6/cmd/setpoint", json.dumps(retained), retain=True)
    async with (
        listener(broker, "client/replies", "uss/bus/+/reply") as seen,
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
    ):
        await eventually(
            lambda: errors(seen, "client/replies") and errors(seen, "uss/bus/drive5/reply")
        )
        await served(gateway, 5, 6)
        for engine in engines.values():
            assert not engine.drive.machine.control & 1  # no ON went out
            assert engine.drive.machine.setpoint == 0.0
            assert not engine.drive.status_word() & 4
        # published retained while the gateway is connected: refused all the same
        before = drives(engines)
        await mosquitto_pub(broker, "uss/bus/drive5/cmd/on", "PRESS", retain=True)
        await eventually(lambda: len(errors(seen, "uss/bus/drive5/reply")) == 2)
        await served(gateway, 5)
        assert drives(engines) == before
    (error,) = errors(seen, "client/replies")
    assert error["type"] == "Retained"
    assert "retained" in error["message"]
    assert len(refusals(caplog)) == 3  # one line each


async def test_commands_sent_while_the_gateway_is_away_never_act(broker: Broker) -> None:
    # a session the broker keeps for the gateway's client id, as an older gateway left it
    async with aiomqtt.Client(
        "127.0.0.1", broker.port, identifier="pyuss-bus", clean_session=False
    ) as old:
        await old.subscribe("uss/bus/+/cmd/+", qos=1)
    await mosquitto_pub(broker, "uss/bus/drive5/cmd/on")
    async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
        await served(gateway, 5)
        assert not engines[5].drive.machine.control & 1
    # sent between two runs of the gateway
    await mosquitto_pub(broker, "uss/bus/drive5/cmd/setpoint", json.dumps({"value": 25.0}))
    await mosquitto_pub(broker, "uss/bus/drive5/cmd/on")
    async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
        await served(gateway, 5)
        assert not engines[5].drive.machine.control & 1
        assert engines[5].drive.machine.setpoint == 0.0


@pytest.mark.parametrize(
    "reply_to",
    [
        "uss/bus/drive5/cmd/on",  # another drive's command
        "uss/bus/drive6/cmd/on",  # its own drive's command
        "uss/bus/drive5/param/P107/set",
        "uss/bus/drive5/reply",  # under the prefix, not the drive's own reply topic
        "uss/bus/availability",
        "uss/#",
        "other/bus/drive5/cmd/on",  # another gateway's command
        "plant/gw/param/P107/get",
        "zigbee2mqtt/lamp/set",
        "homeassistant/switch/x/config",
        "$SYS/broker/x",
    ],
)
async def test_a_reply_topic_that_could_act_is_refused(
    broker: Broker, caplog: pytest.LogCaptureFixture, reply_to: str
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        listener(broker, "#") as seen,
    ):
        before = drives(engines)
        command = {"id": "x", "pnu": 107, "reply_to": reply_to}
        await mosquitto_pub(broker, "uss/bus/drive6/cmd/read", json.dumps(command))
        await eventually(lambda: errors(seen, "uss/bus/drive6/reply"))
        await served(gateway, 5, 6)
        assert drives(engines) == before
    (error,) = errors(seen, "uss/bus/drive6/reply")
    assert error["class"] == "bad_value"
    assert "reply_to" in error["message"]
    assert not any(topic == reply_to and b'"id": "x"' in payload for topic, payload in seen)
    assert len(refusals(caplog)) == 1


async def test_a_reply_goes_to_a_reply_topic_outside_the_prefix_or_below_the_drives_own(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (_, _engines),
        listener(broker, "client/#", "uss/bus/drive6/reply/#") as seen,
    ):
        for reply_to in ("client/7/replies", "uss/bus/drive6/reply/client7"):
            command = {"id": reply_to, "pnu": 107, "reply_to": reply_to}
            await mosquitto_pub(broker, "uss/bus/drive6/cmd/read", json.dumps(command))
        await eventually(lambda: len(seen) == 2)
    for topic, payload in seen:
        reply = json.loads(payload)
        assert reply["ok"] and reply["id"] == topic
        assert reply["result"]["value"] == 50.0


async def test_the_face_never_acts_on_what_it_publishes_itself(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        listener(broker, "uss/bus/drive5/cmd/on") as seen,
    ):
        before = drives(engines)
        assert await face_of(gateway).publish("uss/bus/drive5/cmd/on", "", qos=1)
        await eventually(lambda: seen)  # the broker carried it
        await served(gateway, 5)
        assert drives(engines) == before


BAD = [
    # (topic, payload, what the error names)
    ("cmd/read", b"[" * 200000, "bytes"),
    ("cmd/read", b"[" * 4000, "nested"),
    ("cmd/setpoint", b'{"value": [[[[[1]]]]]}', "nested"),
    ("cmd/write", json.dumps({"pnu": 107, "value": 1, "pad": "x" * 5000}).encode(), "bytes"),
    ("param/P107/set", b"9" * 400, "characters"),
    ("param/P107/set", b'{"value": ' + b"9" * 400 + b"}", "characters"),
    ("cmd/setpoint", b'{"value": 1e999}', "finite"),
    ("cmd/setpoint", b'{"value": NaN}', "finite"),
    ("cmd/setpoint", b"0x" + b"F" * 20, "hexadecimal"),
    ("cmd/setpoint", b"0x10", "hexadecimal"),  # not 16 Hz: who writes hex means a word
    ("cmd/setpoint_percent", b"1_0", "not a number"),
    ("cmd/setpoint", b'{"value": true}', "number"),
    ("cmd/setpoint", b'{"value": 20, "key": 5}', "key"),
    ("cmd/run", b'{"value": "maybe"}', "ON or OFF"),
    ("cmd/write", b'{"pnu": 107, "value": 50, "eeprom": "no"}', "eeprom"),
    ("cmd/write", b'{"pnu": 18, "value": 1e300}', "out of range"),
    ("cmd/read", b'{"pnu": [107]}', "parameter"),
    ("cmd/read", b'{"pnu": 107, "index": "1"}', "index"),
    ("cmd/control_word", b"65536", "control word"),
    ("cmd/control_word", b"1.5", "whole number"),
    ("cmd/on", b'{"id": {"a": 1}}', "id"),
    ("cmd/on", b'{"id": "' + b"i" * 300 + b'"}', "id"),
    ("cmd/on", b"\xff\xfe", "UTF-8"),
    ("cmd/jump", b"", "unknown command"),
]


async def test_malformed_oversize_nested_and_huge_payloads_get_an_error_reply(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        listener(broker, "uss/bus/drive5/reply") as seen,
    ):
        await served(gateway, 5)  # P107 read once: its value is known below
        before = drives(engines)
        caplog.clear()
        seen.clear()
        for topic, payload, _ in BAD:
            await mosquitto_pub(broker, f"uss/bus/drive5/{topic}", payload)
        await eventually(lambda: len(seen) == len(BAD), timeout=30)
        await served(gateway, 5, 6)  # the face and drive 5's commands are alive
        assert drives(engines) == before
    problems = errors(seen, "uss/bus/drive5/reply")
    assert len(problems) == len(BAD)
    # a refusal while parsing is sent at once, one while carrying out after the commands
    # before it: the replies come in another order
    messages = [error["message"] for error in problems]
    for topic, _, what in BAD:
        assert any(what in message for message in messages), (topic, what, messages)
    assert all(len(message) < 300 for message in messages)  # no payload echoed back whole
    lines = [r for r in caplog.records if r.name == "pyuss.gateway.mqtt"]
    assert len([r for r in lines if r.levelno >= logging.WARNING]) == len(BAD)  # one each


async def test_a_flood_of_messages_moves_nothing_and_the_drives_are_served_afterwards(
    broker: Broker,
) -> None:
    junk: list[tuple[str, bytes, bool]] = [
        ("cmd/setpoint", b"fast", False),
        ("cmd/read", b"[" * 3000, False),
        ("param/P107/set", b"9" * 400, False),
        ("cmd/on", b"PRESS", True),  # retained
        ("cmd/read", b'{"pnu": 107, "reply_to": "uss/bus/drive5/cmd/on"}', False),
    ]
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        listener(broker, "uss/bus/+/reply") as seen,
        aiomqtt.Client("127.0.0.1", broker.port) as flood,
    ):
        before = drives(engines)
        sent = 0
        for _ in range(40):
            for topic, payload, retain in junk:
                await flood.publish(f"uss/bus/drive5/{topic}", payload, qos=1, retain=retain)
                sent += 1
        for _ in range(150):  # more reads than a drive queues: the rest are refused as busy
            await flood.publish("uss/bus/drive6/cmd/read", b'{"pnu": 107}', qos=1)
            sent += 1
        await eventually(lambda: len(seen) >= sent, timeout=60)
        assert len(seen) == sent  # one reply each
        await served(gateway, 5, 6)
        assert drives(engines) == before
    classes = {error["class"] for error in errors(seen, "uss/bus/drive6/reply")}
    assert classes <= {"busy"}


async def test_an_unreachable_broker_is_one_warning_and_the_face_connects_once_it_is_up(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="pyuss.gateway.mqtt")
    broker = Broker(tmp_path)  # its port has no broker yet
    try:
        async with simulated_gateway(mqtt=broker.url, connected=False) as (gateway, _):
            face = face_of(gateway)
            await eventually(lambda: face.attempts >= 4)
            broker.start()
            await eventually(lambda: face.connected.is_set(), timeout=20)
            await served(gateway, 5)
            broker.stop()
            await eventually(lambda: not face.connected.is_set())
            broker.start()
            await eventually(lambda: face.connections == 2, timeout=20)
            await served(gateway, 5)
    finally:
        broker.stop()
    lines = [r for r in caplog.records if r.name == "pyuss.gateway.mqtt"]
    warnings = [r.getMessage() for r in lines if r.levelno >= logging.WARNING]
    assert len(warnings) == 4, warnings  # lost, back, lost, back
    assert "unreachable" in warnings[0] and "back" in warnings[1]
    assert "lost" in warnings[2] and "back" in warnings[3]


async def test_a_broker_refusing_the_login_is_one_warning_naming_its_reason(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="pyuss.gateway.mqtt")
    broker = Broker(tmp_path)
    (tmp_path / "passwords").write_text("", encoding="utf-8")
    text = broker.config.read_text(encoding="utf-8")
    broker.config.write_text(
        text.replace(
            "allow_anonymous true", f"allow_anonymous false\npassword_file {tmp_path}/passwords"
        ),
        encoding="utf-8",
    )
    broker.start()
    try:
        async with simulated_gateway(mqtt=broker.url, connected=False) as (gateway, engines):
            face = face_of(gateway)
            await eventually(lambda: face.attempts >= 3)
            assert not face.connected.is_set()
            assert all(not e.drive.machine.control & 1 for e in engines.values())
    finally:
        broker.stop()
    lines = [r for r in caplog.records if r.name == "pyuss.gateway.mqtt"]
    (warning,) = [r.getMessage() for r in lines if r.levelno >= logging.WARNING]
    assert "refused the connection" in warning and "not authori" in warning.lower(), warning
    assert "unreachable" not in warning
