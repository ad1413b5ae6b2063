"""The rate of a drive's state messages (`StateThrottle`, ``max_rate`` and ``deadband`` in
``[mqtt]``): a ramping drive publishes at most ``max_rate`` states a second, the newest one
each time, so the last state of a ramp is always published; a change of a status bit, a
fault or anything but the actual values is published at once; an actual value that moves less
than the deadband publishes nothing."""

from __future__ import annotations

import asyncio
import json
import time

import pytest

from gateway.harness import Broker, MqttClient, simulated_gateway, subscribed
from gateway.test_ha_templates import model, state
from pyuss.errors import ConfigError
from pyuss.gateway.config import parse_config
from pyuss.gateway.payloads import StateThrottle
from support.waiting import eventually

RUNNING = 0x0437


def test_only_actual_values_wait_and_the_deadband_drops_what_hardly_moved() -> None:
    drive = model("generic")
    throttle = StateThrottle(interval=0.1, deadband=0.5)
    first = state(drive, RUNNING, words=(0x2000,))
    assert throttle.offer(first, 10.0) == 0.0  # the first: at once
    throttle.sent(first, 10.0)
    small = state(drive, RUNNING, words=(0x2000 + 10,))  # 0.06 %: within the deadband
    assert throttle.offer(small, 10.01) is None
    moved = state(drive, RUNNING, words=(0x2000 + 200,))  # 1.2 %
    assert throttle.offer(moved, 10.01) == pytest.approx(0.09)  # held until 10.1
    assert throttle.offer(moved, 10.2) == 0.0
    tripped = state(drive, RUNNING | 0x0008, words=(0x2000 + 10,))
    assert throttle.offer(tripped, 10.01) == 0.0  # a status bit: at once
    refused = state(drive, RUNNING, words=(0x2000 + 10,), last_fault=7)
    assert throttle.offer(refused, 10.01) == 0.0
    # no limit, no deadband: every change at once
    free = StateThrottle()
    free.sent(first, 10.0)
    assert free.offer(small, 10.0) == 0.0


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"max_rate": -1}, "mqtt.max_rate: -1 is not 0..1000"),
        ({"max_rate": "fast"}, "mqtt.max_rate: expected a number"),
        ({"deadband": 101}, "mqtt.deadband: 101 is not 0..100"),
        ({"deadband": True}, "mqtt.deadband: expected a number"),
    ],
)
def test_a_bad_rate_or_deadband_is_refused_naming_the_key(
    table: dict[str, object], message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config({"bus": [{"port": "bus://x:1", "drive": [{"address": 5}]}], "mqtt": table})


def test_the_rate_and_deadband_are_read_from_the_mqtt_table() -> None:
    base = {"bus": [{"port": "bus://x:1", "drive": [{"address": 5}]}]}
    default = parse_config({**base, "mqtt": {}}).mqtt
    assert default is not None and (default.max_rate, default.deadband) == (10.0, 0.0)
    given = parse_config({**base, "mqtt": {"max_rate": 2, "deadband": 0.5}}).mqtt
    assert given is not None and (given.max_rate, given.deadband) == (2.0, 0.5)


async def ramp_states(broker: Broker, **options: float) -> tuple[float, list[dict[str, object]]]:
    """Drive 5 ramped from 0 to 10 Hz (20 %, two seconds of ramp): its state messages a
    second during the ramp, and every state message of it until it stood still a while."""
    seen: list[tuple[float, dict[str, object]]] = []

    def keep(_topic: str, payload: bytes) -> None:
        seen.append((time.monotonic(), json.loads(payload)))

    async with (
        simulated_gateway(mqtt=broker.url, mqtt_options=dict(options)) as (gateway, engines),
        MqttClient(gateway) as client,
    ):
        await client.command(5, "setpoint", value=10.0)
        async with subscribed(broker, "uss/bus/drive5/state", on=keep):
            await client.command(5, "on")
            start = time.monotonic()
            await asyncio.sleep(1.5)  # the ramp of the simulated drive takes longer
            during = [s for at, s in seen if at >= start + 0.2]
            rate = len(during) / 1.3
            drive = gateway.plant.drive("bus", 5)
            await eventually(lambda: drive.state.actual["main"].percent >= 19.99)
            await asyncio.sleep(0.5)
        final = drive.state.actual["main"].percent
        assert engines[5].drive.machine.control & 1
    states = [s for _, s in seen]
    last = states[-1]["actual"]
    assert isinstance(last, dict) and last["main"]["percent"] == pytest.approx(final, abs=0.01)
    return rate, states


async def test_a_ramping_drive_publishes_ten_states_a_second_and_its_last(
    broker: Broker,
) -> None:
    rate, _ = await ramp_states(broker)
    print(f"states a second while ramping: {rate:.1f} (max_rate 10)")
    assert 3 < rate <= 12  # max_rate 10, and a status bit's change now and then
    unlimited, _ = await ramp_states(broker, max_rate=0.0)
    print(f"states a second while ramping: {unlimited:.1f} (no limit)")
    assert unlimited > 2 * rate  # every answer that changes the actual value


async def test_a_status_bit_is_published_at_once_however_slow_the_rate(broker: Broker) -> None:
    seen: list[tuple[float, int]] = []

    def keep(_topic: str, payload: bytes) -> None:
        seen.append((time.monotonic(), json.loads(payload)["status_word"] or 0))

    async with (
        simulated_gateway(mqtt=broker.url, mqtt_options={"max_rate": 0.2}) as (gateway, _),
        MqttClient(gateway) as client,
        subscribed(broker, "uss/bus/drive5/state", on=keep),
    ):
        await client.command(5, "setpoint", value=50.0)
        await client.command(5, "on")
        await asyncio.sleep(1.0)  # ramping: at most one state in 5 s for the values alone
        sent = time.monotonic()
        await client.command(5, "off2")  # coast: operation enabled (bit 2) drops
        await eventually(lambda: any(at > sent and not word & 0x0004 for at, word in seen))
        shown = min(at for at, word in seen if at > sent and not word & 0x0004)
    assert shown - sent < 1.0
