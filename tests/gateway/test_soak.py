"""A fault soak of ``uss gateway`` with MQTT, every part a process of its own as in a plant:
``uss simulate`` (two drives) on a TCP line, a lossy proxy between it and the gateway
(`support.lossy`), ``uss gateway --config`` publishing to a real mosquitto, and a subscriber
that records every message with the time it came.

The faults, one after the other: single answers and short bursts lost (fewer than
``offline_after_missed``), a burst of exactly ``offline_after_missed`` answers lost, one
drive's answers all lost for a while, the line lost and back five times (the proxy cuts it, or
the simulator is killed and started again on its port), the broker restarted, the gateway
killed (SIGKILL: no goodbye, its last will) and started again. Commands go in at the points a
user would worry about: once while online, once to the drive that does not answer, once while
the bus is down, once while the gateway is dead, and one retained.

What the subscriber saw is then held to the documented rules (docs/gateway.md, "MQTT" and
"Availability and lost lines"): no drive goes offline for losses below
``offline_after_missed``, and goes offline for that many and for every outage of the line,
and online again after it; every state message renders every template of its drive's
discovery messages; a gateway started again publishes each drive's state of now before it
says ``online``, never the state of before as fresh; a command sent while online is carried
out once, and no other ever acts. ``python -m pytest tests/gateway/test_soak.py -s`` prints
the run's figures (docs/gateway.md, "Soak test")."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime
from itertools import pairwise
from pathlib import Path
from typing import Any

import paho.mqtt.client as paho
import pytest

from gateway.ha_templates import render
from gateway.harness import Broker
from support.lossy import LossyProxy
from support.network import free_port
from support.processes import first_line
from support.waiting import eventually_sync

pytestmark = pytest.mark.soak

USS = [sys.executable, "-m", "pyuss.cli.main"]
BAUD = "38400"
BUS = "line1"
DRIVES = {5: "conveyor", 6: "pump"}
MISSED = 3
"""``offline_after_missed``, its default, written in the configuration all the same."""
OUTAGES = 5
WAIT = 45.0
"""The bound of every wait (against hanging: no timing is asserted)."""


@dataclass(frozen=True)
class Message:
    at: float
    """time.monotonic() when it came."""
    wall: float
    topic: str
    payload: bytes
    retained: bool

    @property
    def text(self) -> str:
        return self.payload.decode("utf-8")

    def json(self) -> Any:
        return json.loads(self.payload)


class Subscriber:
    """A paho client subscribed to the bus's topics and the discovery messages, again after
    every reconnection (the broker restarts), keeping every message with its time; it also
    publishes the commands."""

    def __init__(self, port: int, name: str = "soak-subscriber") -> None:
        self.port = port
        self.messages: list[Message] = []
        self.lock = threading.Lock()
        self.subscribed = threading.Event()
        client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id=name)
        client.on_connect = lambda c, *_: c.subscribe([("uss/#", 1), ("homeassistant/#", 1)])
        client.on_subscribe = lambda *_: self.subscribed.set()
        client.on_message = self._on_message
        client.reconnect_delay_set(0.05, 0.5)
        self.client = client

    def _on_message(self, _client: object, _data: object, message: paho.MQTTMessage) -> None:
        with self.lock:
            self.messages.append(
                Message(
                    time.monotonic(), time.time(), message.topic, bytes(message.payload),
                    bool(message.retain),
                )
            )  # fmt: skip

    def start(self) -> None:
        self.client.connect("127.0.0.1", self.port)
        self.client.loop_start()
        assert self.subscribed.wait(10), "the subscriber did not subscribe"

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()

    def mark(self) -> int:
        """Where the messages from now on begin."""
        with self.lock:
            return len(self.messages)

    def since(self, start: int = 0, topic: str | None = None) -> list[Message]:
        with self.lock:
            found = self.messages[start:]
        return [m for m in found if topic is None or m.topic == topic]

    def publish(self, topic: str, payload: str, *, retain: bool = False) -> None:
        self.client.publish(topic, payload, qos=1, retain=retain).wait_for_publish(10)

    def command(self, drive: str, name: str, body: dict[str, Any], *, retain: bool = False) -> None:
        self.publish(f"uss/{BUS}/{drive}/cmd/{name}", json.dumps(body), retain=retain)

    def replies(self, drive: str, ident: str, start: int = 0) -> list[dict[str, Any]]:
        found = [m.json() for m in self.since(start, f"uss/{BUS}/{drive}/reply")]
        return [r for r in found if r.get("id") == ident]

    def availability(self, drive: str, start: int = 0) -> list[str]:
        return [m.text for m in self.since(start, f"uss/{BUS}/{drive}/availability")]

    def saw(self, drive: str, word: str, start: int) -> bool:
        return word in self.availability(drive, start)

    def all_say(self, word: str, start: int) -> bool:
        """Whether every drive's availability said ``word`` since ``start``."""
        return all(word in self.availability(name, start) for name in DRIVES.values())

    def bus(self, start: int = 0) -> list[str]:
        """What the bus's availability (the gateway's, on the broker) said since ``start``."""
        return [m.text for m in self.since(start, f"uss/{BUS}/availability")]

    def states(self, drive: str, start: int = 0) -> list[Message]:
        return self.since(start, f"uss/{BUS}/{drive}/state")


def _config(path: Path, line: int, broker: int) -> Path:
    drives = "".join(
        f'[[bus.drive]]\naddress = {address}\nname = "{name}"\n' for address, name in DRIVES.items()
    )
    path.write_text(
        f'[[bus]]\nname = "{BUS}"\nport = "tcp://127.0.0.1:{line}"\nbaud = {BAUD}\n'
        f'profile = "generic"\nlayout = "4,2"\noffline_after_missed = {MISSED}\n{drives}'
        f'[mqtt]\nbroker = "mqtt://127.0.0.1:{broker}"\nreconnect = 0.2\nkeepalive = 5\n',
        encoding="utf-8",
    )
    return path


class Plant:
    """The processes of the soak: the simulator on ``line`` and the gateway, its log lines
    (stderr) appended to ``log`` over its restarts."""

    def __init__(self, directory: Path, line: int, proxy: int, broker: int) -> None:
        self.line = line
        self.config = _config(directory / "gateway.toml", proxy, broker)
        self.log = directory / "gateway.log"
        self.simulator: subprocess.Popen[str] | None = None
        self.gateway: subprocess.Popen[str] | None = None

    def start_simulator(self) -> None:
        addresses = [a for address in DRIVES for a in ("--address", str(address))]
        self.simulator = subprocess.Popen(
            [*USS, "simulate", *addresses, "--layout", "4,2", "--baud", BAUD,
             "--tcp", f"127.0.0.1:{self.line}"],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        )  # fmt: skip
        assert first_line(self.simulator, "tcp://") == f"tcp://127.0.0.1:{self.line}"

    def kill_simulator(self) -> None:
        """As a crash or a pulled plug ends it: nothing said goodbye."""
        _kill(self.simulator)
        self.simulator = None

    def start_gateway(self) -> None:
        with self.log.open("a", encoding="utf-8") as stderr:
            self.gateway = subprocess.Popen(
                [*USS, "gateway", "--config", str(self.config)],
                stdout=subprocess.PIPE, stderr=stderr, text=True,
            )  # fmt: skip
        first_line(self.gateway, "ready")

    def kill_gateway(self) -> None:
        """SIGKILL on POSIX (TerminateProcess on Windows): no last state, no ``offline``."""
        _kill(self.gateway)
        self.gateway = None

    def stop(self) -> None:
        for process in (self.gateway, self.simulator):
            _kill(process)

    def log_lines(self, pattern: str = r" (WARNING|ERROR) ") -> list[str]:
        """The gateway's log lines of pyuss matching ``pattern`` (default: its warnings)."""
        return [
            line
            for line in self.log.read_text(encoding="utf-8").splitlines()
            if " pyuss." in line and re.search(pattern, line)
        ]


def _kill(process: subprocess.Popen[str] | None) -> None:
    if process is not None and process.poll() is None:
        process.kill()
    if process is not None:
        process.wait(30)
        if process.stdout is not None:
            process.stdout.close()


@contextmanager
def _soak(tmp_path: Path, broker: Broker) -> Iterator[tuple[Plant, LossyProxy, Subscriber]]:
    subscriber = Subscriber(broker.port)
    subscriber.start()
    line = free_port()
    proxy = LossyProxy(line).start()
    plant = Plant(tmp_path, line, proxy.port, broker.port)
    try:
        plant.start_simulator()
        plant.start_gateway()
        yield plant, proxy, subscriber
    finally:
        plant.stop()
        proxy.close()
        subscriber.stop()


def _until(check: Callable[[], object], what: str) -> None:
    eventually_sync(check, what, WAIT)


def _all_online(subscriber: Subscriber, start: int) -> bool:
    return all(subscriber.availability(name, start)[-1:] == ["online"] for name in DRIVES.values())


def _round_trip(subscriber: Subscriber, ident: str, percent: float) -> dict[str, Any]:
    """A setpoint command to the conveyor and its one reply. The gateway publishes in order,
    so what it published before the reply (an ``offline``) has come when the reply has."""
    start = subscriber.mark()
    subscriber.command("conveyor", "setpoint_percent", {"id": ident, "value": percent})
    _until(lambda: subscriber.replies("conveyor", ident, start), f"the reply to {ident}")
    reply: dict[str, Any] = subscriber.replies("conveyor", ident, start)[0]
    return reply


def _answers_pass(proxy: LossyProxy, count: int) -> None:
    """Wait until every drive's next ``count`` answers went through the proxy."""
    now = dict(proxy.passed)
    _until(
        lambda: all(proxy.passed.get(a, 0) >= now.get(a, 0) + count for a in DRIVES),
        f"{count} more answers of each drive",
    )


def _timeouts(subscriber: Subscriber, percent: float) -> dict[int, int]:
    """Each drive's answers missed as the gateway counts them: from the state in which the
    setpoint ``percent`` (a new one, so that a state is published at once) is in force."""
    start = subscriber.mark()
    for name in DRIVES.values():
        subscriber.command(name, "setpoint_percent", {"id": f"count {percent}", "value": percent})

    def state(name: str) -> dict[str, Any] | None:
        for message in subscriber.states(name, start):
            found: dict[str, Any] = message.json()
            if found["setpoint"]["main"]["percent"] == percent:
                return found
        return None

    _until(lambda: all(state(n) for n in DRIVES.values()), f"the states with {percent} %")
    found = {address: state(name) for address, name in DRIVES.items()}
    return {address: f["health"]["timeouts"] for address, f in found.items() if f is not None}


def _setpoints(subscriber: Subscriber) -> list[float | None]:
    """The conveyor's setpoint (percent) in every state message, in order."""
    return [m.json()["setpoint"]["main"]["percent"] for m in subscriber.states("conveyor")]


def _iso(value: str) -> float:
    return datetime.fromisoformat(value.replace("Z", "+00:00")).timestamp()


def test_the_gateway_rides_out_a_soak_of_faults_and_mqtt_says_the_truth_throughout(
    tmp_path: Path, broker: Broker
) -> None:
    began = time.monotonic()
    with _soak(tmp_path, broker) as (plant, proxy, subscriber):
        figures: dict[str, Any] = {"outages": [], "phases": []}
        _until(lambda: _all_online(subscriber, 0), "both drives online")
        _until(
            lambda: any(m.json()["reference"]["value"] for m in subscriber.states("conveyor")),
            "the reference read",
        )

        # a command sent once while online is carried out once; a retained one never acts
        assert _round_trip(subscriber, "once", 20.0)["ok"] is True
        assert _round_trip(subscriber, "then", 30.0)["ok"] is True
        subscriber.command("conveyor", "setpoint_percent", {"id": "kept", "value": 45.0},
                           retain=True)  # fmt: skip
        _until(lambda: subscriber.replies("conveyor", "kept"), "the retained command's refusal")
        for name in DRIVES.values():  # running, they publish a state at each change
            on = subscriber.mark()
            subscriber.command(name, "run", {"id": f"on {name}", "value": "ON"})
            _until(lambda n=name, at=on: subscriber.replies(n, f"on {n}", at), f"{name} on")
            assert subscriber.replies(name, f"on {name}", on)[0]["ok"] is True

        # single answers and short bursts lost: no drive goes offline
        quiet = subscriber.mark()
        figures["phases"].append(("losses below offline_after_missed", quiet))
        missed = _timeouts(subscriber, 31.0)
        for burst in [1, 1, 1, 1, 1, MISSED - 1, 1, MISSED - 1]:
            for address in DRIVES:
                proxy.drop(address, burst)
            _until(lambda: not any(proxy.pending(a) for a in DRIVES), "the losses")
            _answers_pass(proxy, 5)
        single = {a: proxy.dropped.get(a, 0) for a in DRIVES}
        # the answers a loaded machine lost on its own (late beyond the response window)
        # would add to the bursts: the rule holds for the losses the gateway counted
        own = {a: n - missed[a] - single[a] for a, n in _timeouts(subscriber, 30.0).items()}
        figures["own losses"] = own
        for address, name in DRIVES.items():
            if own[address] == 0:
                assert "offline" not in subscriber.availability(name, quiet), name
        if not any(own.values()):
            assert not plant.log_lines("offline"), plant.log_lines()

        # offline_after_missed answers lost: that drive, and only that, goes offline and back
        burst = subscriber.mark()
        figures["phases"].append(("a burst of offline_after_missed", burst))
        proxy.drop(5, MISSED)
        _until(lambda: subscriber.availability("conveyor", burst) == ["offline", "online"],
               "the conveyor offline and back")  # fmt: skip
        assert "offline" not in subscriber.availability("pump", burst)
        assert f"offline: {MISSED} answers missed in a row" in plant.log_lines("offline")[0]

        # a command to a drive that does not answer (its line up) fails, and never acts later
        silent = subscriber.mark()
        figures["phases"].append(("the conveyor silent, a command to it", silent))
        proxy.drop(5, 10**9)
        _until(lambda: subscriber.saw("conveyor", "offline", silent), "the conveyor offline")
        unanswered = _round_trip(subscriber, "unanswered", 55.0)
        assert unanswered["ok"] is False and unanswered["error"]["class"] == "no_answer"
        proxy.clear(5)
        _until(lambda: subscriber.saw("conveyor", "online", silent), "the conveyor back")
        assert "offline" not in subscriber.availability("pump", silent)

        # the line lost and back five times: every drive offline during each, online after it;
        # a command sent while the line is down is refused and never acts later
        for outage in range(OUTAGES):
            lost = subscriber.mark()
            if outage == 0:
                figures["phases"].append(("line lost 5 times", lost))
            cut = time.monotonic()
            if outage % 2 == 0:
                proxy.cut()
            else:
                plant.kill_simulator()
            _until(lambda at=lost: subscriber.all_say("offline", at), "every drive offline")
            offline = subscriber.since(lost, "uss/line1/conveyor/availability")[0].at
            refused = _round_trip(subscriber, f"down {outage}", 40.0)
            assert refused["ok"] is False and refused["error"]["class"] == "unavailable"
            back = time.monotonic()
            if outage % 2 == 0:
                proxy.restore()
            else:
                plant.start_simulator()
            _until(lambda at=lost: _all_online(subscriber, at), "every drive online again")
            if outage == 1:  # the drives started again stopped, and nothing switches them on
                restarted = subscriber.mark()
            online = subscriber.since(lost, "uss/line1/conveyor/availability")[-1].at
            # the outage is over once the line stayed up a second: its log line says so
            logged = outage + 1
            _until(lambda n=logged: len(plant.log_lines("link back")) == n, "link back logged")
            figures["outages"].append(
                ("proxy cut" if outage % 2 == 0 else "simulator killed", offline - cut,
                 online - back)
            )  # fmt: skip
        assert len(plant.log_lines("link lost")) == OUTAGES

        # the broker restarted: the gateway comes back, the drives never went offline
        # what the gateway counted so far: the answers left out, and any the load lost
        figures["timeouts"] = {
            address: subscriber.states(name)[-1].json()["health"]["timeouts"]
            for address, name in DRIVES.items()
        }
        figures["dropped"] = dict(proxy.dropped)
        restart = subscriber.mark()
        figures["phases"].append(("broker restarted", restart))
        broker.stop()
        broker.start()
        _until(lambda: "online" in subscriber.bus(restart), "the gateway back on the broker")
        assert _round_trip(subscriber, "after the broker", 30.0)["ok"] is True
        for name in DRIVES.values():
            assert "offline" not in subscriber.availability(name, restart), name

        # the gateway killed: its last will says offline; a command meanwhile never acts
        killed = subscriber.mark()
        figures["phases"].append(("gateway killed and started again", killed))
        plant.kill_gateway()
        _until(lambda: "offline" in subscriber.bus(killed), "the last will")
        subscriber.command("conveyor", "setpoint_percent", {"id": "dead", "value": 50.0})
        started = subscriber.mark()
        started_wall = time.time()
        plant.start_gateway()
        _until(lambda: subscriber.bus(started), "the new gateway online")
        _until(lambda: _all_online(subscriber, started), "both drives online again")
        _until(
            lambda: len(subscriber.replies("conveyor", "kept")) >= 3,
            "the retained command refused by the new gateway as well",
        )
        _round_trip(subscriber, "at the end", 30.0)
        ended = time.monotonic()

        # before it says online, the new gateway published each drive's state of now
        fresh = subscriber.since(started)
        first_online = next(i for i, m in enumerate(fresh) if m.topic == "uss/line1/availability")
        for name in DRIVES.values():
            before = [m for m in fresh[:first_online] if m.topic == f"uss/{BUS}/{name}/state"]
            assert before, f"no state of {name} before online"
            assert not before[0].retained
        for name in DRIVES.values():
            for message in subscriber.states(name, started):
                state = message.json()
                if state["online"]:  # an answer the new gateway got, none from before
                    assert _iso(state["time"]) >= started_wall - 0.01, state["time"]
                else:
                    assert state["status_word"] is None and state["state"] == "no answer", state
        log = plant.log_lines()
        messages = subscriber.since()

    # a command sent once while online was carried out once; none other ever acted
    assert len(subscriber.replies("conveyor", "once")) == 1
    assert subscriber.replies("conveyor", "dead") == []
    kept = subscriber.replies("conveyor", "kept")
    assert all(r["error"]["type"] == "Retained" for r in kept), kept
    setpoints = _setpoints(subscriber)
    assert not {40.0, 45.0, 50.0, 55.0} & set(setpoints), setpoints
    assert 20.0 not in setpoints[setpoints.index(30.0) :], "the first setpoint acted again"

    # each state says what the availability after it says; a drive stopped by its restart
    # is not switched on again (nothing is sent again after an outage)
    for name in DRIVES.values():
        said: tuple[str | None, bool | None] = (None, None)  # availability, the state's online
        for message in [*subscriber.since(0), None]:  # (None: the end of the recording)
            if message is not None and message.topic == f"uss/{BUS}/{name}/availability":
                said = (message.text, said[1])
            elif message is None or message.topic == f"uss/{BUS}/{name}/state":
                if None not in said:  # (a drive's state comes first, then its availability)
                    assert said[1] == (said[0] == "online"), (name, said, message)
                if message is not None:
                    said = (said[0], message.json()["online"])
        later = [m.json() for m in subscriber.states(name, restarted)]
        assert later and not any(s["bits"]["operation_enabled"] for s in later), name

    # what a reader subscribing now gets retained: the drives online, their states online
    late = Subscriber(broker.port, "soak-late")
    late.start()
    try:
        for name in DRIVES.values():
            _until(lambda n=name: late.availability(n) and late.states(n), f"{name} retained")
            assert late.availability(name) == ["online"]
            assert late.states(name)[0].json()["online"] is True
    finally:
        late.stop()

    # every state message renders every template of its drive's discovery messages
    templates: dict[str, set[str]] = {name: set() for name in DRIVES.values()}
    for message in messages:
        if message.topic.startswith("homeassistant/") and message.payload:
            config = message.json()
            for name in DRIVES.values():
                if config.get("state_topic") == f"uss/{BUS}/{name}/state":
                    for key in ("value_template", "json_attributes_template"):
                        if key in config:
                            templates[name].add(config[key])
    states = 0
    for name, found in templates.items():
        assert found, f"no discovery templates for {name}"
        for message in subscriber.states(name):
            states += 1
            for template in found:
                render(template, message.payload)  # Undefined if a key is missing

    seconds = ended - began
    kinds = Counter(m.topic.rsplit("/", 1)[-1] for m in messages if m.topic.startswith("uss/"))
    marks = [*figures["phases"], ("end", len(messages))]

    def offline(name: str, start: int, end: int) -> int:
        topic = f"uss/{BUS}/{name}/availability"
        return [m.text for m in messages[start:end] if m.topic == topic].count("offline")

    flaps = {
        what: {name: offline(name, start, end) for name in DRIVES.values()}
        for (what, start), (_, end) in pairwise(marks)
    }
    running = sum(m.json()["bits"]["operation_enabled"] for n in DRIVES.values()
                  for m in subscriber.states(n))  # fmt: skip
    print(f"\nsoak: {seconds:.1f} s, {len(messages)} messages, {len(messages) / seconds:.1f}/s;"
          f" {states} states ({states / seconds:.1f}/s), {kinds['availability']} availability,"
          f" {kinds['reply']} replies; {running} states of a running drive")  # fmt: skip
    print(f"answers left out one by one or {MISSED - 1} in a row, per address: {single}")
    print(f"answers lost besides, by the load: {figures['own losses']}")
    print(f"answers left out by the proxy in all: {figures['dropped']}, answers the gateway"
          f" missed (its timeouts): {figures['timeouts']}")  # fmt: skip
    for what, counts in flaps.items():
        print(f"offline, {what}: {counts}")
    for what, down, up in figures["outages"]:
        print(f"outage ({what}): offline seen {down:.2f} s after, online {up:.2f} s after the"
              " line was back")  # fmt: skip
    print("gateway log:")
    for line in log:
        print("  " + line)
