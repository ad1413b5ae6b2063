"""What Home Assistant is given, against a real mosquitto where it matters: the entities a
drive's family calls for (its maker and model, parameters named as its manual names them, an
energy counter as such, a binary sensor per named status bit, the fault number and its text),
a setpoint entity whose whole range the gateway takes and whose refusal names that range, no
old value shown as current after a restart, and no entity left behind by a configuration
that no longer has it."""

from __future__ import annotations

import dataclasses
import datetime
import json
from typing import Any

import aiomqtt

from gateway import ha_schema
from gateway.harness import Broker, MqttClient, Refused, simulated_gateway, subscribed
from gateway.test_ha_templates import model, state
from gateway.test_mqtt_attacks import listener
from pyuss.gateway.homeassistant import discovery
from pyuss.gateway.payloads import param_value, state_payload
from pyuss.points.parameters import ParamMeta
from support.waiting import eventually


def configs_of(profile: str | None, *parameters: str, **options: Any) -> dict[str, Any]:
    drive = model(profile, parameters)
    return {
        topic: config
        for topic, config in discovery(drive, state(drive, 0x0437), prefix="uss", **options)
    }


def test_a_siemens_drive_is_shown_as_its_manual_names_it() -> None:
    configs = configs_of("micromaster440", "r0027", "r0039", "P1120.0")
    problems = [p for topic, config in configs.items() for p in ha_schema.check(topic, config)]
    assert problems == []
    by_id = {topic.split("/")[3]: config for topic, config in configs.items()}
    device = by_id["state"]["device"]
    assert (device["manufacturer"], device["model"]) == ("Siemens", "MICROMASTER 440")
    assert by_id["param_P27"]["name"] == "r0027 Output current"
    assert by_id["param_P1120_0"]["name"].startswith("P1120")
    energy = by_id["param_P39"]
    assert (energy["device_class"], energy["state_class"]) == ("energy", "total_increasing")
    assert energy["unit_of_measurement"] == "kWh"
    # values the drive shows are on the device's page, its settings among the diagnostics
    assert "entity_category" not in energy and "entity_category" not in by_id["param_P27"]
    assert by_id["param_P1120_0"]["entity_category"] == "diagnostic"
    # one binary sensor per named bit of status word 1 (r0052): 16, three of them the fault,
    # warning and running sensors
    bits = sorted(t for t in by_id if t.startswith("bit"))
    assert len(bits) + 3 == 16
    assert by_id["bit4"]["name"] == "Status bit 4: OFF2 active"  # active while 0
    assert (
        "'OFF' if value_json.status_word | bitwise_and(16) else 'ON'"
        in (by_id["bit4"]["value_template"])
    )
    assert "status_word" not in by_id  # the word as a number is no entity
    assert "last_fault" in by_id


def test_a_drive_of_the_uss_profile_and_one_of_unknown_kind() -> None:
    generic = {t.split("/")[3]: c for t, c in configs_of("generic").items()}
    assert "manufacturer" not in generic["state"]["device"]  # the specification's profile
    assert generic["state"]["device"]["model_id"] == "generic"
    # the bits the USS specification names (C Table 5.5): 0..10
    assert sorted(int(t[3:]) for t in generic if t.startswith("bit")) == [0, 1, 4, 5, 6, 8, 9, 10]
    unknown = {t.split("/")[3]: c for t, c in configs_of(None).items()}
    assert "unknown kind" in unknown["state"]["device"]["model"]
    assert "last_fault" not in unknown  # no family: no fault parameter
    for profile in ("generic", None):
        configs = configs_of(profile, read_only=True)
        assert [p for t, c in configs.items() for p in ha_schema.check(t, c)] == []


def test_float_parameters_are_rounded_to_the_decimals_of_their_file() -> None:
    current = ParamMeta(27, None, "Output current", unit="A", is_float=True, decimals=2)
    assert param_value(current, 2.2516977787017822) == 2.25
    free = ParamMeta(1120, 0, "Ramp-up time", unit="s", is_float=True)
    assert param_value(free, 12.300000190734863) == 12.3  # the float's own 7 digits


def test_the_schema_check_finds_the_further_rules() -> None:
    good = {
        "name": "x",
        "unique_id": "u",
        "device": {"identifiers": ["d"]},
        "state_topic": "a/b",
        "unit_of_measurement": "kWh",
        "device_class": "energy",
        "state_class": "total_increasing",
    }
    sensor = "homeassistant/sensor/n/o/config"
    assert ha_schema.check(sensor, good) == []
    assert ha_schema.check(sensor, {**good, "state_class": "measurement"})
    assert ha_schema.check(sensor, {**good, "entity_category": "config"})
    assert ha_schema.check(sensor, {**good, "device": {"identifiers": ["d"], "maker": "x"}})
    assert ha_schema.check(sensor, {**good, "origin": {"sw_version": "1"}})
    assert ha_schema.check(sensor, {**good, "json_attributes_template": "{{ value_json }}"})
    number = {"name": "x", "unique_id": "u", "device": {"identifiers": ["d"]}}
    fine = {**number, "command_topic": "c", "step": 0.001}
    assert ha_schema.check("homeassistant/number/n/o/config", fine) == []
    assert ha_schema.check("homeassistant/number/n/o/config", {**fine, "step": 1e-4})


async def test_the_setpoint_entity_offers_what_the_gateway_takes_and_names_it(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, _),
        listener(broker, "homeassistant/number/pyuss_bus_drive5/setpoint/config") as seen,
        MqttClient(gateway) as client,
    ):
        await eventually(lambda: any(json.loads(p)["unit_of_measurement"] == "Hz" for _, p in seen))
        config = json.loads(seen[-1][1])
        assert (config["min"], config["max"], config["step"]) == (-100.0, 99.99, 0.01)
        raws = []
        for value in (config["max"], config["min"], round(config["max"] - config["step"], 2)):
            result = await client.command(5, "setpoint", value=value)  # as Home Assistant sends
            raws.append(result["setpoint"]["main"]["raw"])
        assert raws == [32765, -32768, 32761]  # 99.99 Hz: 7FFDh, within the word
        try:
            await client.command(5, "setpoint", value=100.0)
        except Refused as refused:
            assert refused.code == "bad_value"
        else:
            raise AssertionError("100 Hz was taken")
        reply = next(r for r in client.replies.values() if not r["ok"])
        assert "-100 Hz .. 99.99 Hz" in reply["error"]["message"]


async def test_a_restarted_gateway_never_shows_the_state_of_before_as_current(
    broker: Broker,
) -> None:
    # what a crashed gateway leaves: its last will said the bus is offline, each drive's last
    # state and "online" stay retained
    long_ago = datetime.datetime(2020, 1, 1, tzinfo=datetime.UTC)
    async with aiomqtt.Client("127.0.0.1", broker.port) as earlier:
        for drive in ("drive5", "drive6"):
            before = state(model("generic", bus="bus", address=int(drive[5:])), 0x0437)
            old = state_payload(dataclasses.replace(before, time=long_ago))
            await earlier.publish(f"uss/bus/{drive}/state", old, qos=1, retain=True)
            await earlier.publish(f"uss/bus/{drive}/availability", "online", qos=1, retain=True)
        await earlier.publish("uss/bus/availability", "offline", qos=1, retain=True)
    seen: list[tuple[str, bytes]] = []
    async with (
        subscribed(broker, "uss/bus/#", on=lambda t, p: seen.append((t, p))),
        simulated_gateway(mqtt=broker.url) as _,
    ):
        await eventually(lambda: ("uss/bus/availability", b"online") in seen)
    # what a reader holds the moment the bus says online again
    at = seen.index(("uss/bus/availability", b"online"))
    now: dict[str, bytes] = {}
    for topic, payload in seen[:at]:
        now[topic] = payload
    for drive in ("drive5", "drive6"):
        shown = json.loads(now[f"uss/bus/{drive}/state"])
        assert shown["time"] > "2021", shown  # made by this gateway, not the one of before
        online = b"online" if shown["online"] else b"offline"
        assert now[f"uss/bus/{drive}/availability"] == online


async def test_the_entities_a_configuration_no_longer_has_are_removed(broker: Broker) -> None:
    # a gateway with P107 and the commands, then the same bus without P107 and read-only:
    # the discovery messages of the entities gone are cleared, the others kept
    def discovered(seen: dict[str, bytes]) -> set[str]:
        return {topic.split("/", 2)[2] for topic, payload in seen.items() if payload}

    gone = {"pyuss_bus_drive5/param_P107/config", "pyuss_bus_drive5/setpoint/config"}
    retained: dict[str, bytes] = {}
    async with (
        simulated_gateway(mqtt=broker.url, addresses=(5,)) as _,
        subscribed(broker, "homeassistant/#", on=retained.__setitem__),
    ):
        await eventually(lambda: gone <= discovered(retained))
    foreign = "homeassistant/sensor/pyuss_bus_drive5/someone_elses/config"
    async with aiomqtt.Client("127.0.0.1", broker.port) as other:
        await other.publish(foreign, json.dumps({"name": "x"}), qos=1, retain=True)
    later: dict[str, bytes] = {}
    async with (
        simulated_gateway(mqtt=broker.url, addresses=(5,), parameters=(), read_only=True) as _,
        subscribed(broker, "homeassistant/#", on=later.__setitem__),
    ):
        kept = {
            "pyuss_bus_drive5/state/config",
            "pyuss_bus_drive5/actual_main/config",
            "pyuss_bus_drive5/someone_elses/config",  # not this gateway's
        }
        await eventually(lambda: kept <= discovered(later) and not gone & discovered(later))
    assert kept <= discovered(later) and not gone & discovered(later)
