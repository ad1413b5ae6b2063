"""The MQTT face against a real mosquitto: discovery, availability, values rounded to their
resolution, commands carried out once, nothing applied twice over a broker restart, two
gateways on one broker (what the face refuses: test_mqtt_attacks.py)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import selectors
import socket
import time
from collections.abc import AsyncIterator
from typing import Any

import aiomqtt
import pytest

from gateway import ha_schema
from gateway.contract import problems
from gateway.harness import Broker, MqttClient, simulated_gateway, subscribed
from pyuss.gateway.mqtt import MqttFace
from pyuss.gateway.payloads import param_value
from pyuss.points.parameters import ParamMeta
from pyuss.points.state import decimals
from support.limits import limit_writes
from support.waiting import eventually


@contextlib.asynccontextmanager
async def watcher(broker: Broker, *topics: str) -> AsyncIterator[dict[str, bytes]]:
    """A client that keeps the last payload of every topic it sees."""
    seen: dict[str, bytes] = {}
    async with subscribed(broker, *topics, on=seen.__setitem__):
        yield seen


async def test_home_assistant_discovery_validates_against_the_documented_schema(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (_gateway, _),
        watcher(broker, "homeassistant/#") as seen,
    ):
        await eventually(lambda: len(seen) >= 2 * 12)  # 12 entities per drive
        await asyncio.sleep(0.3)
        configs = {topic: json.loads(payload) for topic, payload in seen.items() if payload}
    components = {topic.split("/")[1] for topic in configs}
    assert components == {"sensor", "binary_sensor", "number", "switch", "button"}
    problems = [p for topic, config in configs.items() for p in ha_schema.check(topic, config)]
    assert problems == []
    unique = [config["unique_id"] for config in configs.values()]
    assert len(unique) == len(set(unique))
    frequency = configs["homeassistant/sensor/pyuss_bus_drive5/actual_main/config"]
    assert frequency["unit_of_measurement"] == "Hz"
    assert frequency["device_class"] == "frequency"
    assert frequency["default_entity_id"] == "sensor.pyuss_bus_drive5_actual_main"
    assert frequency["suggested_display_precision"] == 2  # steps of 0.003 Hz
    assert "object_id" not in frequency
    setpoint = configs["homeassistant/number/pyuss_bus_drive5/setpoint/config"]
    assert setpoint["min"] == -100.0  # -200 % of the 50 Hz reference
    assert setpoint["command_topic"] == "uss/bus/drive5/cmd/setpoint"
    commands = [config for config in configs.values() if "command_topic" in config]
    assert commands and all(config["retain"] is False for config in commands)
    parameter = configs["homeassistant/sensor/pyuss_bus_drive5/param_P107/config"]
    assert parameter["unit_of_measurement"] == "Hz"
    assert parameter["state_topic"] == "uss/bus/drive5/param/P107"


def test_the_schema_check_finds_what_home_assistant_refuses() -> None:
    good = {
        "name": "x",
        "unique_id": "u",
        "device": {"identifiers": ["d"]},
        "state_topic": "a/b",
        "unit_of_measurement": "Hz",
        "device_class": "frequency",
    }
    assert ha_schema.check("homeassistant/sensor/n/o/config", good) == []
    assert ha_schema.check("homeassistant/sensor/n o/o/config", good)
    assert ha_schema.check(
        "homeassistant/sensor/n/o/config", {**good, "unit_of_measurement": "rpm"}
    )
    assert ha_schema.check("homeassistant/sensor/n/o/config", {**good, "state_topic": "a/#"})
    assert ha_schema.check("homeassistant/number/n/o/config", {**good, "min": 5, "max": 1})
    assert ha_schema.check("homeassistant/button/n/o/config", {"name": "x", "unique_id": "u"})
    assert ha_schema.check("homeassistant/sensor/n/o/config", {**good, "object_id": "u"})
    assert ha_schema.check(
        "homeassistant/sensor/n/o/config", {**good, "default_entity_id": "switch.u"}
    )
    assert ha_schema.check("homeassistant/sensor/n/o/config", {**good, "default_entity_id": "u"})
    assert (
        ha_schema.check(
            "homeassistant/sensor/n/o/config", {**good, "default_entity_id": "sensor.u"}
        )
        == []
    )


async def test_home_assistant_commands_switch_and_set_the_drive(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (_, engines),
        aiomqtt.Client("127.0.0.1", broker.port) as client,
    ):
        await client.publish("uss/bus/drive5/cmd/run", "ON", qos=1)
        await client.publish("uss/bus/drive5/cmd/setpoint", "12.5", qos=1)
        drive = engines[5].drive
        await eventually(lambda: drive.value(3) == 1250 and drive.status_word() & 4)
        await client.publish("uss/bus/drive5/cmd/run", "OFF", qos=1)
        await eventually(lambda: not drive.status_word() & 4)


async def test_state_is_retained_json_with_units(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as _,
        watcher(broker, "uss/bus/drive5/state", "uss/bus/drive5/availability") as seen,
    ):
        # retained; the first state may come before the drive's first answer (its values
        # null) or before the reference is read (the value in Hz null)
        def value() -> Any:
            actual = json.loads(seen.get("uss/bus/drive5/state", b"{}")).get("actual", {})
            return actual.get("main", {}).get("value")

        await eventually(lambda: value() is not None)
        state = json.loads(seen["uss/bus/drive5/state"])
        await eventually(lambda: seen.get("uss/bus/drive5/availability") == b"online")
    assert state["address"] == 5
    assert state["actual"]["main"]["unit"] == "Hz"
    assert state["reference"] == {"value": 50.0, "unit": "Hz"}
    assert state["bits"]["switch_on_inhibited"] is True
    # the words as a person reads them (pyuss.params.words), as uss status shows them
    assert state["status_text"].startswith(f"{state['status_hex']}h  switch-on inhibited")
    assert state["control_text"] == f"{state['control_word']:04X}h  " + (
        "no bit set" if state["control_word"] == 0 else state["control_text"][7:]
    )


async def test_values_are_published_to_their_resolution(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        MqttClient(gateway) as client,
        watcher(broker, "uss/bus/drive5/state") as seen,
    ):
        result = await client.command(5, "setpoint", value=20.0)
        assert engines[5].drive.machine.setpoint * 50 != 20.0  # 199Ah: 20.001221 Hz

        def setpoint() -> Any:
            state = json.loads(seen.get("uss/bus/drive5/state", b"{}"))
            return state.get("setpoint", {}).get("main", {}).get("value")

        await eventually(lambda: setpoint() == 20.0)
    assert result["setpoint"]["main"]["value"] == 20.0
    assert result["setpoint"]["main"]["percent"] == 40.0


def test_parameters_are_rounded_to_their_resolution() -> None:
    scaled = ParamMeta(18, None, "scaled", unit="s", scaling=0.01)
    single = ParamMeta(107, None, "float", unit="Hz", is_float=True)
    assert param_value(scaled, 12.340000000001) == 12.34
    assert param_value(single, 0.10000000149011612) == 0.1  # 0.1 as a 32-bit float
    assert param_value(ParamMeta(5, None, "integer"), 1234567) == 1234567
    assert [decimals(step) for step in (50 / 0x4000, 0.01, 0.1, 1.0, 5.0)] == [2, 2, 1, 0, 0]


async def test_a_command_repeated_with_its_id_is_carried_out_once(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        MqttClient(gateway) as client,
    ):
        await client.command(5, "on")
        topic = "uss/bus/drive5/cmd/setpoint"
        await client.client.publish(topic, json.dumps({"id": "once", "value": 10.0}), qos=1)
        await eventually(lambda: "once" in client.replies)
        first = client.replies.pop("once")
        client.events.pop("once")
        # the same id again (a QoS 1 duplicate, a retry) with another value
        await client.client.publish(topic, json.dumps({"id": "once", "value": 20.0}), qos=1)
        await eventually(lambda: "once" in client.replies)
        again = client.replies["once"]
    assert first["ok"] and again["ok"]
    assert again["duplicate"] is True
    assert again["result"] == first["result"]
    assert engines[5].drive.value(3) == 1000  # 10.00 Hz: the second was not applied


async def test_a_bad_command_gets_a_reply_naming_what_was_wrong(broker: Broker) -> None:
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, _),
        MqttClient(gateway) as client,
    ):
        await client.client.publish(
            "uss/bus/drive5/cmd/setpoint", json.dumps({"id": "bad", "value": "fast"}), qos=1
        )
        await eventually(lambda: "bad" in client.replies)
        await client.client.publish("uss/bus/drive5/cmd/jump", "", qos=1)
        await eventually(lambda: "None" in client.replies)
    assert client.replies["bad"]["error"]["class"] == "bad_value"
    assert "not a number" in client.replies["bad"]["error"]["message"]
    assert "unknown command 'jump'" in client.replies["None"]["error"]["message"]


async def test_no_command_is_applied_twice_over_a_broker_restart(broker: Broker) -> None:
    async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
        face = gateway.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
        sent: list[str] = []
        replies: dict[str, list[dict[str, Any]]] = {}

        async def client_session(values: range) -> None:
            async with aiomqtt.Client(
                "127.0.0.1", broker.port, identifier="test-client", clean_session=True
            ) as client:
                await client.subscribe("uss/bus/drive5/reply", qos=1)
                for value in values:
                    ident = f"w{value}"
                    sent.append(ident)
                    payload = {"id": ident, "pnu": 18, "value": value}
                    await client.publish("uss/bus/drive5/cmd/write", json.dumps(payload), qos=1)
                async with asyncio.timeout(20):
                    async for message in client.messages:
                        reply = json.loads(bytes(message.payload))  # type: ignore[arg-type]
                        replies.setdefault(reply["id"], []).append(reply)
                        if all(i in replies for i in sent):
                            return

        await client_session(range(1, 6))
        broker.stop()
        await eventually(lambda: not face.connected.is_set())
        broker.start()
        # commands sent while the gateway is away never act (tests/gateway/test_mqtt_attacks.py);
        # once it is back, each is carried out once
        await eventually(lambda: face.connections >= 2)
        await client_session(range(6, 11))
    assert sorted(replies) == sorted(sent)
    assert all(len(r) == 1 and r[0]["ok"] for r in replies.values()), replies
    assert engines[5].drive.value(18) == 10


async def writes_waiting(broker: Broker, face: Any) -> list[str]:
    """60 writes of P18 (values 1..60, ids w1..w60) to drive 5, returned once the face has
    them all and some still wait for the drive (a write takes a bus cycle or two)."""
    sent = [f"w{value}" for value in range(1, 61)]
    async with aiomqtt.Client("127.0.0.1", broker.port) as client:
        for value, ident in enumerate(sent, 1):
            payload = json.dumps({"id": ident, "pnu": 18, "value": value})
            await client.publish("uss/bus/drive5/cmd/write", payload, qos=1)
        await eventually(lambda: len(face._pending) + len(face._done) == len(sent))
    assert len(face._pending) > 1
    return sent


async def test_commands_waiting_when_the_broker_is_lost_never_act_and_are_answered(
    broker: Broker,
) -> None:
    # the broker's last will told everyone the gateway is offline: a command that waited for
    # its drive must not act while the gateway is away or once it is back
    async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
        face = gateway.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
        sent = await writes_waiting(broker, face)
        broker.stop()
        await eventually(lambda: not face.connected.is_set())
        await eventually(lambda: not face._pending)  # each has its reply
        kept = engines[5].drive.value(18)
        broker.start()
        await eventually(lambda: face.connections == 2, timeout=20)
        async with MqttClient(gateway) as client:  # served again
            assert (await client.read_parameter(5, 107))[0] == 50.0
        assert engines[5].drive.value(18) == kept  # nothing of what waited acted since
    replies = [face._done[("drive5", ident)] for ident in sent]
    done = [int(r["id"][1:]) for r in replies if r["ok"]]
    refused = [r["error"] for r in replies if not r["ok"]]
    assert refused and all(e["class"] == "unavailable" for e in refused)
    assert kept == max(done)


async def test_two_gateways_share_one_broker_and_one_client_commands_every_drive(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url, bus_name="line1") as (one, engines1),
        simulated_gateway(mqtt=broker.url, bus_name="line2") as (_two, engines2),
        watcher(broker, "uss/+/+/state") as seen,
    ):
        await eventually(lambda: len(seen) == 4)
        assert sorted(seen) == [
            "uss/line1/drive5/state",
            "uss/line1/drive6/state",
            "uss/line2/drive5/state",
            "uss/line2/drive6/state",
        ]
        async with MqttClient(one) as client:  # one client for both buses
            for bus in ("line1", "line2"):
                for address, value in ((5, 5.0), (6, 6.0)):
                    await client.command(address, "on", bus=bus)
                    await client.command(
                        address, "setpoint", bus=bus, value=value + (bus == "line2")
                    )
        for engines, extra in ((engines1, 0), (engines2, 100)):
            assert engines[5].drive.value(3) == 500 + extra
            assert engines[6].drive.value(3) == 600 + extra


async def test_a_second_gateway_of_the_same_bus_takes_the_session_and_the_first_never_takes_it_back(
    broker: Broker, caplog: pytest.LogCaptureFixture
) -> None:
    # two gateways named alike (two lines both called "bus", say) share one client id: the
    # broker ends the older one's connection; were it to connect again, the two would take
    # the session from each other in turn, and a command would act on either line's drive
    async with simulated_gateway(mqtt=broker.url) as (first, old_engines):
        old = first.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
        await eventually(lambda: old.connected.is_set())
        async with simulated_gateway(mqtt=broker.url) as (second, new_engines):
            new = second.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
            await eventually(lambda: old.taken_over is not None)
            assert "started after this one" in old.taken_over
            runner = old._runner
            assert runner is not None and runner.done()  # it tries no more
            assert not old.connected.is_set()
            # the first one's last try may have taken the session from the second once more:
            # on once the second answers (a read, which moves nothing)
            async with MqttClient(second) as client:
                await answered(client)
                for address in (5, 6):
                    await client.switch_on(address)
                    await client.set_setpoint(address, 20.0)
            assert new.taken_over is None and not old.connected.is_set()
            for address in (5, 6):
                assert new_engines[address].drive.machine.control & 1
                assert not old_engines[address].drive.machine.control & 1
                assert old_engines[address].drive.machine.setpoint == 0.0
    lines = [r.getMessage() for r in caplog.records if r.name == "pyuss.gateway.mqtt"]
    assert len([line for line in lines if "started after this one" in line]) == 1


async def answered(client: MqttClient) -> None:
    """Once the gateway answers ``client`` (a read of P107 of drive 5, tried again after a
    second without a reply: one sent while the gateway was away never reaches it)."""
    for _ in range(15):
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(1.0):
                await client.read_parameter(5, 107)
                return
    raise AssertionError("the gateway did not answer within 15 s")


async def test_of_two_gateways_of_one_bus_under_their_own_client_ids_the_newer_alone_acts(
    broker: Broker,
) -> None:
    # with client ids of their own both would stay connected and both would carry out every
    # command: one command, two drives moved on two lines
    async with simulated_gateway(mqtt=broker.url, client_id="gw-a-{bus}") as (first, old_engines):
        old = first.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
        await eventually(lambda: old.connected.is_set())
        async with simulated_gateway(mqtt=broker.url, client_id="gw-b-{bus}") as (second, engines):
            new = second.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
            await eventually(lambda: old.taken_over is not None)
            assert not old.connected.is_set() and new.connected.is_set()
            async with MqttClient(second) as client:
                await client.switch_on(5)
            assert engines[5].drive.machine.control & 1
            assert not old_engines[5].drive.machine.control & 1
            assert new.taken_over is None and new.connections == 1


async def test_a_gateway_message_left_by_an_earlier_run_with_a_clock_ahead_stops_nothing(
    broker: Broker,
) -> None:
    # an edge device without a real-time clock may start with its clock behind that of its
    # last run: the retained gateway message of that run must not stop the new one's face
    from paho.mqtt.packettypes import PacketTypes
    from paho.mqtt.properties import Properties

    from pyuss.gateway.announce import gateway_payload
    from pyuss.gateway.mqtt_client import INSTANCE

    ahead = f"{time.time_ns() + 3600 * 10**9:020d}-00000000"  # an hour ahead
    properties = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
    properties.UserProperty = [(INSTANCE, ahead)]
    async with aiomqtt.Client(
        "127.0.0.1", broker.port, protocol=aiomqtt.ProtocolVersion.V5
    ) as earlier:
        payload = gateway_payload("bus", [], read_only=False, keepalive=30)
        await earlier.publish("uss/bus/gateway", payload, qos=1, retain=True, properties=properties)
    async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
        face = gateway.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
        await eventually(lambda: face.connected.is_set())
        assert face.instance > ahead  # one generation beyond it
        async with MqttClient(gateway) as client:
            await client.switch_on(5)
        assert face.taken_over is None and face.connected.is_set()
        assert engines[5].drive.machine.control & 1


async def test_a_stop_answers_every_command_and_cuts_none_off(broker: Broker) -> None:
    # commands in flight and waiting when the gateway stops (SIGTERM): the one being carried
    # out finishes and is answered, the waiting ones are refused, and the drive holds the
    # value of the last write answered ok
    replies: dict[str, dict[str, Any]] = {}

    def on(topic: str, payload: bytes) -> None:
        reply = json.loads(payload)
        assert reply["id"] not in replies, reply  # one reply each
        replies[reply["id"]] = reply

    sent = [f"w{value}" for value in range(1, 61)]
    async with subscribed(broker, "uss/bus/drive5/reply", on=on):
        async with simulated_gateway(mqtt=broker.url) as (gateway, engines):
            face = gateway.faces["mqtt"].buses["bus"]  # type: ignore[attr-defined]
            assert await writes_waiting(broker, face) == sent
        await eventually(lambda: len(replies) == len(sent), timeout=30)
    done = [int(ident[1:]) for ident in sent if replies[ident]["ok"]]
    refused = [replies[ident]["error"] for ident in sent if not replies[ident]["ok"]]
    assert done and refused
    assert all(e["class"] == "unavailable" and "stopping" in e["message"] for e in refused)
    assert engines[5].drive.value(18) == max(done)


async def test_stopping_the_gateway_says_offline(broker: Broker) -> None:
    async with simulated_gateway(mqtt=broker.url) as _:
        pass
    async with watcher(broker, "uss/bus/availability", "uss/bus/drive5/availability") as seen:
        await eventually(lambda: len(seen) == 2)
    assert seen == {
        "uss/bus/availability": b"offline",
        "uss/bus/drive5/availability": b"offline",
    }


async def test_a_state_sent_while_another_message_waits_leaves_the_socket_unwatched(
    broker: Broker,
) -> None:
    """A state goes out in the turn of the loop that made it; one published while another
    message still waits for the socket goes out with it, and afterwards the client's socket
    is not watched for writing (a watch left behind would wake the loop at every turn, and
    end in an error when the connection closes)."""
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, _),
        watcher(broker, "test/#") as seen,
    ):
        face = gateway.faces["mqtt"]
        assert isinstance(face, MqttFace)
        bus = face.buses["bus"]
        await eventually(bus.connected.is_set)
        # both in one turn of the loop: the first is queued and asks for a watch, which the
        # loop sets up in its next turn; the state goes out at once, and the first with it
        sent = await asyncio.gather(
            bus.publish("test/one", "1", qos=1), bus.publish("test/two", "2", qos=0)
        )
        assert sent == [True, True]
        await eventually(lambda: seen.get("test/one") == b"1" and seen.get("test/two") == b"2")
        client = bus._client
        assert client is not None
        sock = client._client.socket()
        assert sock is not None
        selector = asyncio.get_running_loop()._selector  # type: ignore[attr-defined]

        def watched() -> bool:
            key = selector.get_map().get(sock.fileno())
            return key is not None and bool(key.events & selectors.EVENT_WRITE)

        await eventually(lambda: not watched())


async def test_the_gateway_message_tells_a_reader_the_bus_its_drives_and_read_only(
    broker: Broker,
) -> None:
    async with (
        simulated_gateway(mqtt=broker.url, bus_name="line7", read_only=True) as _,
        watcher(broker, "uss/line7/gateway") as seen,
    ):
        await eventually(lambda: "uss/line7/gateway" in seen)
        # retained: a reader that comes later gets it at once
        async with watcher(broker, "uss/line7/gateway") as later:
            await eventually(lambda: "uss/line7/gateway" in later)
    message = json.loads(later["uss/line7/gateway"])
    assert problems("gateway", message) == []
    assert message["bus"] == "line7" and message["read_only"] is True
    assert message["keepalive"] == 5
    drives = {drive["address"]: drive for drive in message["drives"]}
    assert sorted(drives) == [5, 6]
    assert drives[5]["name"] == "drive5" and drives[5]["unit"] == "Hz"
    assert drives[5]["setpoints"] == [{"key": "main", "pzd": 2, "dword": False}]


async def test_messages_the_socket_cannot_take_at_once_arrive_whole_and_in_order(
    broker: Broker,
) -> None:
    """The face writes a QoS 0 message to the socket itself once paho has taken its topic;
    what a full socket does not take is written after it, before anything else."""
    got: list[bytes] = []
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, _),
        subscribed(broker, "test/big", on=lambda _topic, payload: got.append(payload)),
    ):
        bus, sock = await face_socket(gateway)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
        payloads = [b"%04d" % n + bytes(range(256)) * 40 for n in range(200)]
        assert await bus.publish("test/big", payloads[0], qos=0)  # through paho: the topic
        await eventually(lambda: len(got) == 1)
        for payload in payloads[1:]:  # in one turn of the loop, as fast as they are made
            assert await bus.publish("test/big", payload, qos=0)
        await eventually(lambda: len(got) == len(payloads), timeout=20)
        assert got == payloads
        assert bus.connections == 1


async def test_the_face_sends_each_packet_at_once(broker: Broker) -> None:
    """No Nagle delay: a state or reply leaves when it is made, not after the broker's
    (delayed) acknowledgement of the packet before - the value and command latencies of
    docs/bench.md depend on it."""
    async with simulated_gateway(mqtt=broker.url) as (gateway, _):
        _bus, sock = await face_socket(gateway)
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)


async def face_socket(gateway: Any) -> tuple[Any, socket.socket]:
    """The MQTT face of the gateway's bus ``bus`` once connected, and its TCP socket."""
    face = gateway.faces["mqtt"]
    assert isinstance(face, MqttFace)
    bus = face.buses["bus"]
    await eventually(bus.connected.is_set)
    client = bus._client
    assert client is not None
    sock = client._client.socket()
    assert isinstance(sock, socket.socket)
    return bus, sock


async def test_a_write_the_drive_answers_with_another_value_says_what_was_written(
    broker: Broker,
) -> None:
    # the drive holds at most 1000 in P18: the reply gives what it holds, and what was written
    async with (
        simulated_gateway(mqtt=broker.url) as (gateway, engines),
        MqttClient(gateway) as client,
    ):
        limit_writes(engines[5].drive, 18, 1000)
        for ident, value in (("big", 5000), ("small", 700)):
            payload = json.dumps({"id": ident, "pnu": 18, "value": value})
            await client.client.publish("uss/bus/drive5/cmd/write", payload, qos=1)
            await eventually(lambda ident=ident: ident in client.replies)  # type: ignore[misc]
        big, small = client.replies["big"]["result"], client.replies["small"]["result"]
    assert (big["value"], big["written"]) == (1000, 5000)
    assert small["value"] == 700 and "written" not in small
