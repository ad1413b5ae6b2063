"""The MQTT contract: the JSON Schema files ship in the package, what the gateway publishes
validates against them (here, and in every test of the `broker` fixture), what breaks them is
refused by them, the gateway tells its version in every JSON payload and refuses a command
of a version it does not speak or with a field its topic does not take, and the examples of
docs/gateway.md "The MQTT contract" are valid."""

from __future__ import annotations

import glob
import json
import re
import tomllib
from typing import Any

import pytest
from jsonschema import Draft202012Validator

from gateway import contract
from gateway.contract import KINDS, SCHEMAS, check, load, problems
from gateway.harness import Broker, MqttClient, simulated_gateway, subscribed
from gateway.test_mqtt_attacks import drives, mosquitto_pub
from pyuss.gateway.topics import COMMAND_NAMES, CONTRACT_VERSION, VERSIONS
from support.paths import ROOT
from support.waiting import eventually


def test_the_schema_files_ship_in_the_package_and_are_draft_2020_12() -> None:
    names = sorted(entry.name for entry in SCHEMAS.iterdir() if entry.name.endswith(".json"))
    assert names == sorted(f"{kind}.json" for kind in (*KINDS, "common"))
    for name in names:
        schema = load(name.removesuffix(".json"))
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        Draft202012Validator.check_schema(schema)
        assert schema["title"].startswith("pyuss MQTT contract")
    # the package data of the build names them: they are in the wheel beside the code
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = pyproject["tool"]["setuptools"]["package-data"]["pyuss"]
    package = ROOT / "src" / "pyuss"
    shipped = {path for pattern in patterns for path in glob.glob(str(package / pattern))}
    assert {str(package / "gateway" / "schemas" / name) for name in names} <= shipped
    assert load("common")["$defs"]["version"]["const"] == CONTRACT_VERSION == max(VERSIONS)
    assert set(COMMAND_NAMES) <= set(load("command")["$defs"])  # one definition per command


@pytest.mark.parametrize(
    ("schema", "instance"),
    [
        ("availability", "online"),
        ("availability", "offline"),
        ("command#/$defs/on", "PRESS"),
        ("command#/$defs/on", None),
        ("command#/$defs/off2", {"id": 7, "reply_to": "client/replies"}),
        ("command#/$defs/run", "ON"),
        ("command#/$defs/run", {"v": 1, "id": "r", "value": "off"}),
        ("command#/$defs/setpoint", 25),
        ("command#/$defs/setpoint", "-12.5"),
        ("command#/$defs/setpoint_percent", {"value": 40.0, "key": "main"}),
        ("command#/$defs/control_word", "0x047F"),
        ("command#/$defs/read", "P4.2"),
        ("command#/$defs/read", {"pnu": 4, "index": 2}),
        ("command#/$defs/write", {"pnu": "107", "value": "60", "eeprom": True}),
        ("command#/$defs/param_get", None),
        ("command", "ON"),
        ("param_set", 50),
        ("param_set", {"id": "p", "value": 50.0, "eeprom": False}),
    ],
)
def test_the_schemas_take_the_payloads_the_gateway_takes(schema: str, instance: object) -> None:
    assert problems(schema, instance) == []


REPLY = {"v": 1, "id": "1", "command": "on", "drive": "d", "ok": True}
DRIVE_RESULT = {"status_word": 823, "state": "ready", "control_word": 1150, "setpoint": {}}
READING = {"pnu": 107, "index": None, "name": "f", "value": 50.0, "unit": "Hz", "time": None}
ERROR = {"type": "ConfigError", "message": "m", "class": "bad_value"}


@pytest.mark.parametrize(
    ("schema", "instance"),
    [
        ("availability", "on"),
        ("availability", '"online"'),
        ("param", READING),  # no version
        ("param", {**READING, "v": 2}),  # a newer version
        ("param", {**READING, "v": 1, "extra": 1}),
        ("param", {**READING, "v": 1, "index": 255}),
        ("reply", {**REPLY, "result": DRIVE_RESULT, "error": ERROR}),
        ("reply", {**REPLY, "ok": False}),
        ("reply", {**REPLY, "result": READING}),  # the result of "on" is the drive's
        ("reply", {**REPLY, "command": "read", "result": DRIVE_RESULT}),
        ("reply", {**REPLY, "ok": False, "error": {**ERROR, "class": "oops"}}),
        ("reply", {**REPLY, "result": {**DRIVE_RESULT, "state": "running"}}),
        ("reply", {**REPLY, "result": DRIVE_RESULT, "duplicate": False}),
        ("reply", {**REPLY, "command": "jump", "result": DRIVE_RESULT}),
        ("command#/$defs/on", {"id": "x", "valeu": 1}),
        ("command#/$defs/on", {"id": ""}),
        ("command#/$defs/on", {"v": 2}),
        ("command#/$defs/run", "maybe"),
        ("command#/$defs/setpoint", "fast"),
        ("command#/$defs/setpoint", {"value": True}),
        ("command#/$defs/setpoint", {"value": 20, "eeprom": True}),
        ("command#/$defs/setpoint", {"value": 20, "reply_to": "uss/#"}),
        ("command#/$defs/setpoint", {"value": 20, "reply_to": "$SYS/x"}),
        ("command#/$defs/control_word", 65536),
        ("command#/$defs/read", {"index": 2}),
        ("command#/$defs/write", {"pnu": 107}),
        ("command#/$defs/write", {"pnu": 18, "value": 5, "idx": 1}),
        ("command#/$defs/param_get", {"pnu": 18}),
        ("param_set", {"value": 5, "pnu": 18}),
        ("param_set", {"value": 5, "index": 2}),
        ("param_set", "9" * 30),
    ],
)
def test_the_schemas_refuse_what_breaks_the_contract(schema: str, instance: object) -> None:
    assert problems(schema, instance)


def test_the_state_schema_is_closed_and_names_the_version() -> None:
    schema = load("state")
    assert schema["additionalProperties"] is False
    assert "v" in schema["required"]
    for name in ("param", "reply"):
        assert "v" in load(name)["required"]


async def test_every_message_of_a_session_validates_against_its_schema(broker: Broker) -> None:
    seen: list[tuple[str, bytes]] = []
    async with (
        subscribed(broker, "uss/#", on=lambda topic, payload: seen.append((topic, payload))),
        simulated_gateway(mqtt=broker.url) as (gateway, _),
        MqttClient(gateway) as client,
    ):
        sent = [
            ("cmd/on", {"id": "a"}),
            ("cmd/setpoint", {"id": "b", "value": 20.0, "v": 1}),
            ("cmd/setpoint_percent", {"id": "c", "value": 10.0}),
            ("cmd/read", {"id": "d", "pnu": 107}),
            ("cmd/write", {"id": "e", "pnu": 18, "value": 3}),
            ("cmd/setpoint", {"id": "f", "value": "fast"}),  # refused by the drive's points
            ("param/P107/get", {"id": "g"}),
            ("param/P18/set", {"id": "h", "value": 4}),
            ("cmd/off1", {"id": "i"}),
        ]
        for topic, payload in sent:
            valid = check(f"uss/bus/drive5/{topic}", json.dumps(payload).encode()) == []
            assert valid == (payload["id"] != "f")
            await client.client.publish(f"uss/bus/drive5/{topic}", json.dumps(payload), qos=1)
        await eventually(lambda: set("abcdefghi") <= set(client.replies))
        repeat = json.dumps({"id": "b", "value": 30.0})  # the first reply again
        await client.client.publish("uss/bus/drive5/cmd/setpoint", repeat, qos=1)
        await eventually(lambda: client.replies["b"].get("duplicate"))
        await client.client.publish("uss/bus/drive5/cmd/jump", b"", qos=1)  # no command
        await eventually(lambda: "None" in client.replies)
        await eventually(lambda: "uss/bus/drive5/param/P107" in {t for t, _ in seen})
    published = [(t, p) for t, p in seen if str(contract.schema_of(t)) in contract.OUTPUTS]
    assert {contract.schema_of(topic) for topic, _ in published} == set(contract.OUTPUTS)
    assert [p for topic, payload in published for p in check(topic, payload)] == []
    replies = [json.loads(p) for t, p in seen if t == "uss/bus/drive5/reply"]
    assert all(reply["v"] == CONTRACT_VERSION for reply in replies)
    assert any(reply.get("duplicate") for reply in replies)
    assert any(not reply["ok"] and reply["command"] == "?" for reply in replies)
    states = [json.loads(p) for t, p in seen if t.endswith("/state")]
    assert states and all(state["v"] == CONTRACT_VERSION for state in states)


def refusal(replies: dict[str, dict[str, Any]], ident: str) -> dict[str, Any]:
    reply = replies[ident]
    assert not reply["ok"], reply
    assert problems("reply", reply) == []
    error: dict[str, Any] = reply["error"]
    return error


async def test_a_command_of_a_newer_version_is_refused_naming_the_versions_spoken(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        MqttClient(gateway) as client,
    ):
        before = drives(engines)
        for ident, version in (("n2", 2), ("n99", 99), ("text", "1"), ("bool", True)):
            payload = {"id": ident, "v": version, "value": 10.0}
            await mosquitto_pub(broker, "uss/bus/drive5/cmd/setpoint", json.dumps(payload))
        await mosquitto_pub(broker, "uss/bus/drive5/cmd/on", '{"id": "on2", "v": 2}')
        await eventually(lambda: {"n2", "n99", "text", "bool", "on2"} <= set(client.replies))
        assert drives(engines) == before  # nothing went to a drive
        for ident in ("n2", "n99", "text", "bool", "on2"):
            error = refusal(client.replies, ident)
            assert error["type"] == "UnsupportedVersion"
            assert error["class"] == "bad_value"
            assert "speaks MQTT contract version 1" in error["message"]
        # the version it speaks, or none (a person typing): carried out
        await client.command(5, "on", v=1)
        await client.command(5, "setpoint", value=12.0)
        await client.command(5, "setpoint", value=13.0, v=1)
    assert engines[5].drive.value(3) == 1300  # 13.00 Hz


async def test_a_field_the_topic_does_not_take_is_refused_and_nothing_moves(
    broker: Broker,
) -> None:
    cases = [
        ("cmd/write", {"id": "w", "pnu": 18, "value": 5, "idx": 1}, "idx"),
        ("cmd/write", {"id": "e", "pnu": 18, "value": 5, "eprom": True}, "eprom"),
        ("param/P18/set", {"id": "p", "value": 5, "pnu": 107}, "pnu"),
        ("param/P18/set", {"id": "i", "value": 5, "index": 1}, "index"),
        ("cmd/setpoint", {"id": "s", "value": 20.0, "eeprom": True}, "eeprom"),
        ("cmd/on", {"id": "o", "force": True}, "force"),
        ("param/P107/get", {"id": "g", "pnu": 18}, "pnu"),
    ]
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        MqttClient(gateway) as client,
    ):
        before = drives(engines)
        for topic, payload, _ in cases:
            assert check(f"uss/bus/drive5/{topic}", json.dumps(payload).encode())
            await mosquitto_pub(broker, f"uss/bus/drive5/{topic}", json.dumps(payload))
        await eventually(lambda: {str(p["id"]) for _, p, _ in cases} <= set(client.replies))
        assert drives(engines) == before
    for _, payload, field in cases:
        error = refusal(client.replies, str(payload["id"]))
        assert (error["type"], error["class"]) == ("UnknownField", "bad_value")
        assert f"unknown field '{field}'" in error["message"]


def doc_messages() -> list[tuple[str, bytes]]:
    """The messages of the contract section's example: a line starting with ``uss/`` is a
    topic and its payload; indented lines continue the payload."""
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    section = text.split("\n## The MQTT contract\n", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(
        r"<!-- run by tests/gateway/test_contract.py -->\n```text\n(.*?)```", section, re.S
    )
    messages: list[tuple[str, str]] = []
    for line in block.splitlines():
        if line.startswith("uss/"):
            topic, _, payload = line.partition(" ")
            messages.append((topic, payload))
        else:
            topic, payload = messages[-1]
            messages[-1] = (topic, f"{payload} {line.strip()}")
    return [(topic, payload.encode()) for topic, payload in messages]


def test_the_examples_of_the_documentation_are_valid() -> None:
    messages = doc_messages()
    kinds = {contract.schema_of(topic, prefix="uss") for topic, _ in messages}
    assert {"availability", "param", "reply", "param_set"} <= kinds
    assert [p for topic, payload in messages for p in check(topic, payload)] == []
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    for kind in (*KINDS, "common"):
        assert f"`{kind}.json" in text
