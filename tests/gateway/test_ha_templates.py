"""Every template of every Home Assistant discovery message the gateway publishes renders with
every state message it publishes - just started (no answer yet), running, in a fault, during
an outage, after a refused job -, so that Home Assistant never meets an undefined value (it
logs an error per entity and message for one): all keys are there, null where nothing is
known, and what a template renders is a state its entity takes (``None``: unknown). Checked
on states made here for every kind of drive, and on every message of a session against a real
mosquitto (`tests/gateway/ha_templates.py` renders the templates)."""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import json
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import pytest

from gateway.ha_templates import TemplateError, Undefined, render
from gateway.harness import Broker, simulated_gateway, subscribed
from pyuss.bus import VirtualBus
from pyuss.errors import UssError
from pyuss.gateway.homeassistant import discovery
from pyuss.gateway.payloads import param_payload, state_payload
from pyuss.gateway.topics import DriveTopics
from pyuss.points.config import plant_from_flags
from pyuss.points.model import DriveModel, resolve
from pyuss.points.state import DriveState, Health, ParamValue, now, process_value
from support.waiting import eventually

FAULT = 0x0008
RUNNING = 0x0437  # ready, operation enabled, no OFF2/3, in tolerance


def model(
    profile: str | None, parameters: tuple[str, ...] = (), *, bus: str = "line", address: int = 5
) -> DriveModel:
    plant = plant_from_flags(
        port="bus://simulated:1", addresses=[address], baud=38400, layout="4,2", name=bus,
        profile=profile, parameters=list(parameters),
    )  # fmt: skip
    return resolve(plant).drives[0]


def state(
    drive: DriveModel,
    status: int | None,
    *,
    words: tuple[int, ...] = (0x2000,),
    reference: float | None = 50.0,
    **health: Any,
) -> DriveState:
    """A state of ``drive``: ``status`` None: it has not answered yet (no actual values)."""

    def values(which: tuple[Any, ...], given: tuple[int, ...]) -> dict[str, Any]:
        found = {}
        for item in which:
            value = process_value(item.key, item.pzd, item.dword, given, reference, drive.unit)
            if value is not None:
                found[item.key] = value
        return found

    read = status is not None
    parameters = {
        point.key: ParamValue(point.meta, 12.3456789 if read else None, now() if read else None)
        for point in drive.parameters
    }
    return DriveState(
        model=drive,
        time=now(),
        status_word=status,
        control_word=0x047F if status == RUNNING else 0,
        actual=values(drive.actual, words) if read else {},
        setpoints=values(drive.setpoints, (0x1000,)),
        parameters=parameters,
        health=Health(**health),
        reference=reference,
        actual_words=words if read else (),
        setpoint_words=(0x1000,),
    )


def kinds(drive: DriveModel) -> Iterator[tuple[str, DriveState]]:
    refused = {"type": "DriveRefusal", "message": "m", "class": "refused", "number": 17}
    yield "just started", state(drive, None, reference=None)
    yield "no answer, reference known", state(drive, None)
    yield "running", state(drive, RUNNING)
    yield "running, reference not known", state(drive, RUNNING, reference=None)
    fault_time = datetime.datetime.now(datetime.UTC)
    yield "fault", state(drive, FAULT, last_fault=72, last_fault_time=fault_time)
    yield "fault without a text", state(drive, FAULT, last_fault=9999, last_fault_time=fault_time)
    yield "outage", state(drive, RUNNING, not_sending=True)
    yield "refusal", state(drive, RUNNING, last_refusal=refused)


def payloads(topics: DriveTopics, of: DriveState) -> dict[str, bytes]:
    """The message on each topic a discovery config of ``of``'s drive may read."""
    found = {topics.state: state_payload(of)}
    for key, reading in of.parameters.items():
        found[topics.param(key)] = param_payload(reading)
    return found


TEMPLATES = (
    ("value_template", "state_topic"),
    ("json_attributes_template", "json_attributes_topic"),
)
"""The templates of a discovery message, each with the topic whose messages it renders."""


def rendered(topic: str, config: dict[str, Any], messages: dict[str, bytes]) -> list[str]:
    """What breaks: a template that meets an undefined value, renders what its entity does
    not take, or is beyond the subset of Jinja known."""
    problems = []
    component = topic.split("/")[1]
    for key, source in TEMPLATES:
        if key not in config:
            continue
        payload = messages.get(config[source])
        if payload is None:
            problems.append(f"{topic}: no message on {config[source]}")
            continue
        try:
            text = render(config[key], payload)
        except (Undefined, TemplateError) as exc:
            problems.append(f"{topic} {key}: {exc}")
            continue
        problems += [f"{topic} {key}: {why}" for why in _taken(component, key, config, text)]
    return problems


def _taken(component: str, key: str, config: dict[str, Any], text: str) -> list[str]:
    if key == "json_attributes_template":
        return [] if isinstance(json.loads(text), dict) else [f"{text!r} is no JSON object"]
    if component in ("binary_sensor", "switch"):
        states = {config.get("payload_on", "ON"), config.get("payload_off", "OFF"), "None"}
        return [] if text in states else [f"{text!r} is none of {sorted(states)}"]
    numeric = component == "number" or any(
        k in config for k in ("unit_of_measurement", "state_class", "suggested_display_precision")
    )
    if numeric and text != "None":
        try:
            float(text)
        except ValueError:
            return [f"{text!r} is no number"]
    if not numeric and text in ("", "None"):
        return [f"{text!r}: a text sensor would show it"]
    return []


@pytest.mark.parametrize("profile", ["generic", "micromaster440", "nord-sk500e", None])
@pytest.mark.parametrize("read_only", [False, True])
def test_every_template_renders_with_every_kind_of_state(
    profile: str | None, read_only: bool
) -> None:
    parameters = {"generic": ("107",), "micromaster440": ("r0027", "r0039", "P1120.0")}
    drive = model(profile, parameters.get(profile or "", ()))
    topics = DriveTopics("uss", drive.bus, drive.name)
    problems = []
    seen = 0
    for kind, shown in kinds(drive):
        # the discovery of every state (it follows the reference) with every state's message
        for _, other in kinds(drive):
            for topic, config in discovery(drive, other, prefix="uss", read_only=read_only):
                seen += 1
                found = rendered(topic, config, payloads(topics, shown))
                problems += [f"{kind}: {problem}" for problem in found]
    assert seen > 100
    assert problems == []


def test_a_template_that_meets_an_undefined_value_is_found() -> None:
    message = json.dumps({"actual": {}, "status_word": None, "health": {"last_fault": 3}})
    with pytest.raises(Undefined):  # what the state message of a drive not answering was
        render('{{ value_json.actual["main"].value }}', message)
    with pytest.raises(Undefined):
        render("{{ value_json.nothing }}", message)
    with pytest.raises(TemplateError):
        render("{{ value_json.health.last_fault | float }}", message)
    with pytest.raises(TemplateError):
        render("{% if value_json %}x{% endif %}", message)
    bit = "{{ 'None' if value_json.status_word is none else ('ON' if value_json.status_word | bitwise_and(8) else 'OFF') }}"  # noqa: E501
    assert render(bit, message) == "None"
    assert render(bit, json.dumps({"status_word": 8})) == "ON"
    assert render(bit, json.dumps({"status_word": 7})) == "OFF"
    text = '{{ {"text": {3: "x"}.get(value_json.health.last_fault)} | tojson }}'
    assert json.loads(render(text, message)) == {"text": "x"}


async def test_every_template_renders_with_every_message_of_a_session(broker: Broker) -> None:
    # a drive that never answers (address 7) beside two that run, ramp, trip, are refused a
    # job, stop answering and come back
    configs: dict[str, dict[str, Any]] = {}
    messages: list[tuple[str, bytes]] = []

    def keep(topic: str, payload: bytes) -> None:
        if topic.startswith("homeassistant/"):
            if payload:
                configs[topic] = json.loads(payload)
        else:
            messages.append((topic, payload))

    bus = VirtualBus(38400)
    async with (
        subscribed(broker, "homeassistant/#", "uss/#", on=keep),
        simulated_gateway(mqtt=broker.url, silent=(7,), bus=bus) as (gateway, engines),
    ):
        drive = gateway.plant.drive("bus", 5)
        await drive.set_setpoint(40.0)
        await drive.command("on")
        await eventually(lambda: drive.state.running)
        with contextlib.suppress(UssError):  # P107 may not change while it runs
            await drive.write_parameter(107, 60.0)
        await drive.read_parameter(107)
        engines[5].drive.raise_fault(65)
        await eventually(lambda: drive.state.health.last_fault is not None)
        bus.make_dead("drive6", 1.5)
        six = gateway.plant.drive("bus", 6)
        await eventually(lambda: not six.state.online)
        await eventually(lambda: six.state.online, timeout=10)
        await asyncio.sleep(0.3)
    states = [json.loads(p) for t, p in messages if t.endswith("/state")]
    assert any(s["status_word"] is None for s in states)  # drive 7, and each one's first
    assert any(s["health"]["last_fault"] == 65 for s in states)
    assert any(s["health"]["last_refusal"] is not None for s in states)
    assert any(s["name"] == "drive6" and not s["online"] and s["status_word"] for s in states)
    assert len(configs) > 3 * 15
    latest: dict[str, bytes] = {}
    problems = []
    for topic, payload in messages:
        latest[topic] = payload
        for config_topic, config in configs.items():
            if topic in (config.get("state_topic"), config.get("json_attributes_topic")):
                problems += rendered(config_topic, config, latest)
    assert problems == []


@pytest.mark.parametrize("profile", ["generic", "micromaster440"])
def test_a_fault_number_comes_with_its_text(profile: str) -> None:
    drive = model(profile)
    topics = DriveTopics("uss", drive.bus, drive.name)
    (config,) = [
        c for t, c in discovery(drive, state(drive, None), prefix="uss") if "last_fault" in t
    ]
    fault = state(drive, FAULT, last_fault=72 if profile != "generic" else 65)
    attributes = json.loads(
        render(config["json_attributes_template"], payloads(topics, fault)[topics.state])
    )
    assert render(config["value_template"], payloads(topics, fault)[topics.state]) in ("65", "72")
    assert attributes["text"] == (
        "telegram failure" if profile == "generic" else "USS (COM link) setpoint fault"
    )
    none = replace(fault, health=Health())
    assert render(config["value_template"], state_payload(none)) == "None"  # unknown
