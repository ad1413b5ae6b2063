"""Broker figures for a plant (`make bench`): the MQTT face at its full rate, what it costs a
broker and how long its messages take. Its gateways run with the throttle off (``max_rate =
0``): every answer of a ramping drive is a state, which the goals below count; with the
default throttle (10 states a drive and second) a broker carries less (`bench_gateway` has
the CPU of both).

Each case runs as users run it: a real mosquitto (``sys_interval 1``, so its ``$SYS`` counters
come every second), per bus ``uss simulate --bus-tcp`` with its drives and ``uss gateway
--config`` with the MQTT face alone (Home Assistant discovery on), each in a process of its own,
at 38400 baud with PKW 4 + PZD 2: 1 drive, 31 drives (a full bus) and 93 drives (three buses of
31, three gateways: a plant with three lines). One subscriber on ``uss/#`` (a SCADA, a page)
and ``$SYS/broker/#`` (its own socket without Nagle's algorithm, so its commands go out at
once) measures, for every case with mosquitto's ``set_tcp_nodelay true`` and for 1 drive also
with mosquitto's defaults (Nagle's algorithm on: a small message may wait up to 40 ms for the
acknowledgement of the one before):

- once every drive is online: the retained messages the broker holds (what a new subscriber
  to ``#`` is handed), per drive;
- every drive switched on at once over MQTT (``cmd/setpoint_percent`` 100, ``cmd/on``), so it
  ramps (10 s) and every answer changes what it shows; then over a window: the messages and
  bytes (topic and payload) per second the gateways publish, in all and per drive, the
  broker's own byte rate from ``$SYS``, the CPU time of mosquitto (``/proc/PID/schedstat``)
  and of the gateways (``/proc/PID/stat``) per message and in percent of a core, each
  drive's answers per second (from the ``health.answers`` count and ``time`` of its states)
  and so the bus cycle;
- latency of a value: a state's ``time`` (stamped by the gateway when it built the state from
  the drive's answer, to the millisecond) against its arrival at the subscriber; goal: at most
  the broker's round trip (the value takes one of its two hops);
- the broker's round trip: a QoS 1 message published by the subscriber to a topic of its own
  until it comes back to it, during the window (the same load as everything else);
- latency of a command: ``cmd/setpoint_percent`` with an ``id`` published (QoS 1) until its
  reply arrives, for drive 1 of each bus in turn; goal: two bus cycles (the drive's turn in
  the poll list within one, its answer within the next) plus the broker's round trip.

Then the broker alone, as a plant of 300 buses x 31 drives would load it: a real state message
published (QoS 0, retained) to 9300 state topics, round after round as fast as one client
sends, with one subscriber on ``uss/#``: the broker's CPU per message (in and out once), the
rate it carried and the growth of its resident memory (``VmRSS``) per retained state.

A case whose drives do not answer, even after switching them on again (a machine too loaded
for the simulators), is printed as not measured and left out of the figures.

``python bench/bench_plant.py --quick`` (or ``USS_BENCH_QUICK=1``, also through
``bench/run.py``) runs shorter windows and fewer commands.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import json
import logging
import math
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from common import (
    TRIES,
    Broker,
    Figure,
    cpu_seconds,
    gateway,
    mosquitto,
    percentile,
    simulator_bus,
    table,
)

from pyuss.protocol.timing import char_time

QUICK = "--quick" in sys.argv or os.environ.get("USS_BENCH_QUICK") == "1"
BAUD = 38400
TELEGRAM = 16
"""Characters of a telegram with PKW 4 + PZD 2: STX, LGE, ADR, 12 bytes of net data, BCC."""
EXCHANGE = 2 * TELEGRAM + 4
"""Characters of one exchange on the wire: request, answer and the two start pauses of
USS specification A 5.1.2 and A 5.2.1.1."""
CASES: tuple[tuple[int, ...], ...] = ((1,), (31,), (31, 31, 31))
"""Drives per bus of each case; a gateway per bus."""
WINDOW = 2.0 if QUICK else 5.0
COMMANDS = 3 if QUICK else 10
"""Commands per bus for the command latency."""
FLOOD_BUSES = 300
FLOOD_ROUNDS = 1 if QUICK else 3
GOAL_STATES = 0.95
"""While a drive ramps every answer changes what it shows: one state message per answer."""
GOAL_CYCLES = 2.0
RESOLUTION_MS = 1.0
"""A state's ``time`` counts whole milliseconds (cut, not rounded): a value's latency measured
from it is up to this much too long."""
MQTT_SETTINGS = ("sys_interval 1", "persistence false", "max_queued_messages 100000")
"""Of every broker the bench starts: $SYS every second, nothing written to disk, room for the
broker-alone round of messages queued for the one subscriber."""
NO_DELAY = "set_tcp_nodelay true"
"""mosquitto's setting that turns Nagle's algorithm off on its clients' sockets (default off:
a small message waits up to 40 ms for the acknowledgement of the one before it)."""
QUIET = logging.getLogger("bench.mqtt")
QUIET.setLevel(logging.ERROR)


def broker_cpu_seconds(pid: int) -> float:
    """mosquitto's CPU time so far, to the nanosecond: the first field of
    ``/proc/PID/schedstat`` (of the process's one thread; mosquitto runs one).
    ``/proc/PID/stat`` counts clock ticks (10 ms), too coarse for a broker that takes a few
    milliseconds a second."""
    with open(f"/proc/{pid}/schedstat", encoding="ascii") as stat:
        return int(stat.read().split()[0]) / 1e9


def parse_time(text: str) -> float:
    """A state's ``time`` ("2026-11-27T00:11:03.645Z") as Unix seconds."""
    return datetime.datetime.fromisoformat(text.replace("Z", "+00:00")).timestamp()


@dataclass
class DriveSeen:
    """What the subscriber saw of one drive during the window: its first and last state's
    time and answer count, and how many states came."""

    first: tuple[float, int] | None = None
    last: tuple[float, int] | None = None
    states: int = 0

    def see(self, stamp: float, answers: int) -> None:
        if self.first is None:
            self.first = (stamp, answers)
        self.last = (stamp, answers)
        self.states += 1

    @property
    def answers_per_s(self) -> float | None:
        if self.first is None or self.last is None or self.last[0] <= self.first[0]:
            return None
        return (self.last[1] - self.first[1]) / (self.last[0] - self.first[0])


@dataclass
class Watch:
    """The subscriber's record: states by drive, latencies, the latest ``$SYS`` values with
    the moment they came, replies and echoes waited for."""

    counting: bool = False
    messages: int = 0
    bytes: int = 0
    drives: dict[str, DriveSeen] = field(default_factory=lambda: defaultdict(DriveSeen))
    state_ms: list[float] = field(default_factory=list)
    online: set[str] = field(default_factory=set)
    sys: dict[str, tuple[float, float]] = field(default_factory=dict)
    waiting: dict[str, asyncio.Future[float]] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)
    """Commands whose reply was an error, by id: the error."""
    sample: bytes = b""
    """The longest state message seen (the broker-alone figures publish it)."""

    def take(self, topic: str, payload: bytes, arrived: float) -> None:
        if topic.startswith("$SYS/"):
            with contextlib.suppress(ValueError):
                self.sys[topic] = (arrived, float(payload.split()[0]))
            return
        if topic.startswith("bench/echo/"):
            self._done(topic, arrived)
            return
        if self.counting:
            self.messages += 1
            self.bytes += len(topic) + len(payload)
        if topic.endswith("/availability") and topic.count("/") == 3:
            drive = topic.rsplit("/", 1)[0]
            if payload == b"online":
                self.online.add(drive)
            else:
                self.online.discard(drive)
        elif topic.endswith("/state"):
            state = json.loads(payload)
            if len(payload) > len(self.sample):
                self.sample = payload
            if self.counting:
                stamp = parse_time(state["time"])
                self.state_ms.append((arrived - stamp) * 1000)
                self.drives[topic].see(stamp, state["health"]["answers"])
        elif topic.endswith("/reply"):
            reply = json.loads(payload)
            if not reply.get("ok"):
                self.failed[str(reply.get("id"))] = f"{topic}: {reply.get('error')}"
            self._done(str(reply.get("id")), arrived)

    def _done(self, key: str, arrived: float) -> None:
        future = self.waiting.pop(key, None)
        if future is not None and not future.done():
            future.set_result(arrived)

    def rate(self, topic: str, since: tuple[float, float]) -> float:
        """The rate of the ``$SYS`` counter ``topic`` from the reading ``since`` to its latest."""
        now = self.sys[topic]
        return (now[1] - since[1]) / (now[0] - since[0]) if now[0] > since[0] else 0.0


async def _request(client: Any, watch: Watch, key: str, topic: str, payload: str) -> float:
    """Publish (QoS 1) and wait for the reply or echo ``key``: the time it took (s)."""
    future: asyncio.Future[float] = asyncio.get_running_loop().create_future()
    watch.waiting[key] = future
    start = time.time()
    await client.publish(topic, payload, qos=1)
    async with asyncio.timeout(30):
        return await future - start


def _no_delay(client: Any) -> None:
    """Nagle's algorithm off on the subscriber's socket (paho leaves it on): its messages (a
    command, an acknowledgement) go out at once instead of waiting for the broker's delayed
    acknowledgement of the one before."""
    sock = client._client.socket()
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


def _plant_file(directory: Path, number: int, url: str, size: int, port: int) -> Path:
    lines = [
        "[[bus]]",
        f'name = "line{number}"',
        f'port = "{url}"',
        f"baud = {BAUD}",
        'layout = "4,2"',
    ]
    for address in range(1, size + 1):
        lines += ["[[bus.drive]]", f"address = {address}"]
    lines += ["[mqtt]", f'broker = "mqtt://127.0.0.1:{port}"', "discovery = true", "max_rate = 0"]
    path = directory / f"line{number}.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


async def _measure(broker: Broker, sizes: Sequence[int], pids: list[int]) -> dict[str, Any]:
    import aiomqtt

    watch = Watch()
    drives = [f"uss/line{b}/drive{a}" for b, n in enumerate(sizes, 1) for a in range(1, n + 1)]
    async with aiomqtt.Client("127.0.0.1", broker.port, logger=QUIET) as client:
        _no_delay(client)
        await client.subscribe("uss/#")
        await client.subscribe("$SYS/broker/#")
        await client.subscribe("bench/echo/#", qos=1)

        async def listen() -> None:
            async for message in client.messages:
                payload = message.payload
                data = payload if isinstance(payload, bytes) else str(payload).encode()
                watch.take(message.topic.value, data, time.time())

        listener = asyncio.create_task(listen())
        try:
            return await _run_case(client, watch, broker, sizes, drives, pids)
        finally:
            listener.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await listener


async def _online(watch: Watch, drives: Sequence[str]) -> None:
    """Wait until every drive of ``drives`` answers (its availability is ``online``)."""
    async with asyncio.timeout(60):
        while not watch.online.issuperset(drives):
            await asyncio.sleep(0.1)


async def _retained(broker: Broker) -> int:
    """The retained messages the broker holds (``$SYS`` aside): what a new subscriber to
    ``#`` is handed at once."""
    import aiomqtt

    count = 0
    async with aiomqtt.Client("127.0.0.1", broker.port, logger=QUIET) as client:
        await client.subscribe("#")
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(1.0):
                async for message in client.messages:
                    count += bool(message.retain)
    return count


async def _run_case(
    client: Any,
    watch: Watch,
    broker: Broker,
    sizes: Sequence[int],
    drives: list[str],
    pids: list[int],
) -> dict[str, Any]:
    await _online(watch, drives)
    retained = await _retained(broker)
    # every drive on at once, so all ramp through the window; on a loaded machine a simulator
    # may miss its answers for a moment ("does not send"): such a command is sent again
    for name, value in (("setpoint_percent", 100.0), ("on", None)):
        left = list(enumerate(drives))
        for attempt in range(TRIES):
            jobs = []
            for n, drive in left:
                key = f"{name}{n}-{attempt}"
                body = json.dumps({"id": key, **({"value": value} if value is not None else {})})
                jobs.append(_request(client, watch, key, f"{drive}/cmd/{name}", body))
            await asyncio.gather(*jobs)
            left = [(n, d) for n, d in left if f"{name}{n}-{attempt}" in watch.failed]
            if not left:
                break
            await asyncio.sleep(1.0)
            await _online(watch, [d for _, d in left])
        else:
            raise RuntimeError(f"{name} failed: {watch.failed[f'{name}{left[0][0]}-{TRIES - 1}']}")
    await asyncio.sleep(0.3)
    sys_topics = ("$SYS/broker/bytes/received", "$SYS/broker/messages/received")
    since = {topic: watch.sys[topic] for topic in sys_topics}
    cpu = [broker_cpu_seconds(broker.pid), *map(cpu_seconds, pids)]
    start = time.perf_counter()
    watch.counting = True
    rtt: list[float] = []
    end = start + WINDOW
    while time.perf_counter() < end:
        key = f"bench/echo/{len(rtt)}"
        rtt.append(await _request(client, watch, key, key, "x" * 100))
        await asyncio.sleep(0.1)
    watch.counting = False
    wall = time.perf_counter() - start
    now = [broker_cpu_seconds(broker.pid), *map(cpu_seconds, pids)]
    used = [after - before for before, after in zip(cpu, now, strict=True)]
    await asyncio.sleep(1.1)  # the next $SYS round, after the window
    broker_bytes = {t: watch.rate(t, since[t]) for t in sys_topics}

    async def commands(bus: int) -> list[float]:
        drive = f"uss/line{bus}/drive1"
        taken = []
        for i in range(COMMANDS):
            key = f"c{bus}-{i}"
            body = json.dumps({"id": key, "value": 100.0 - i % 2})
            took = await _request(client, watch, key, f"{drive}/cmd/setpoint_percent", body)
            if key not in watch.failed:  # a failed one is counted, not timed
                taken.append(took)
        return taken

    command_s = [
        t for ts in await asyncio.gather(*map(commands, range(1, len(sizes) + 1))) for t in ts
    ]
    failed = [key for key in watch.failed if key[0] == "c" and key[1].isdigit()]
    cycles = []
    answers = []
    for b, n in enumerate(sizes, 1):
        rates = [watch.drives[f"uss/line{b}/drive{a}/state"].answers_per_s for a in range(1, n + 1)]
        known = [r for r in rates if r]
        answers += known
        cycles.append(1 / statistics.median(known) if known else float("nan"))
    states = sum(seen.states for seen in watch.drives.values())
    count = len(drives)
    return {
        "drives": count,
        "buses": len(sizes),
        "retained": retained,
        "messages_s": watch.messages / wall,
        "states_s": states / wall,
        "bytes_s": watch.bytes / wall,
        "bytes_per_message": watch.bytes / max(1, watch.messages),
        "broker_bytes_s": broker_bytes["$SYS/broker/bytes/received"],
        "broker_messages_s": broker_bytes["$SYS/broker/messages/received"],
        "broker_cpu": used[0] / wall,
        "broker_us": used[0] / max(1, watch.messages + len(rtt)) * 1e6,
        "gateway_cpu": sum(used[1:]) / wall,
        "gateway_us": sum(used[1:]) / max(1, watch.messages) * 1e6,
        "answers_s": sum(answers) / max(1, len(answers)),
        "cycle_ms": max(cycles) * 1000,
        "rtt_ms": [t * 1000 for t in rtt],
        "state_ms": watch.state_ms,
        "command_ms": [t * 1000 for t in command_s],
        "commands_failed": len(failed),
        "sample": watch.sample,
    }


@contextlib.contextmanager
def _plant(broker: Broker, sizes: Sequence[int]) -> Iterator[list[int]]:
    """The simulators and gateways of one case; yields the gateways' process ids."""
    with contextlib.ExitStack() as stack:
        directory = Path(stack.enter_context(tempfile.TemporaryDirectory()))
        pids = []
        for number, size in enumerate(sizes, 1):
            url = stack.enter_context(simulator_bus(BAUD, size, layout="4,2"))
            config = _plant_file(directory, number, url, size, broker.port)
            pids.append(stack.enter_context(gateway(config)).pid)
        yield pids


def case(sizes: Sequence[int], *settings: str) -> dict[str, Any]:
    with mosquitto(*MQTT_SETTINGS, *settings) as broker:
        if broker is None:
            raise RuntimeError("no mosquitto (.ci/system-deps mosquitto)")
        with _plant(broker, sizes) as pids:
            return asyncio.run(_measure(broker, sizes, pids))


# -- the broker alone, loaded as a plant of 300 buses ----------------------------------------


def _rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status", encoding="ascii") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def flood(payload: bytes) -> dict[str, float]:
    """``payload`` published retained to every state topic of `FLOOD_BUSES` buses of 31
    drives, `FLOOD_ROUNDS` times, with one subscriber on ``uss/#``."""
    from paho.mqtt import client as mqtt

    topics = [f"uss/bus{b}/drive{a}/state" for b in range(FLOOD_BUSES) for a in range(1, 32)]
    total = len(topics) * FLOOD_ROUNDS
    got = threading.Semaphore(0)
    received = [0]

    def on_message(*_: object) -> None:
        received[0] += 1
        if received[0] == total:
            got.release()

    def client(name: str) -> Any:
        c = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, name, protocol=mqtt.MQTTv5)
        return c

    with mosquitto(*MQTT_SETTINGS, NO_DELAY) as broker:
        if broker is None:
            raise RuntimeError("no mosquitto (.ci/system-deps mosquitto)")
        subscriber, publisher = client("bench-sub"), client("bench-pub")
        subscriber.on_message = on_message
        subscriber.connect("127.0.0.1", broker.port)
        subscriber.subscribe("uss/#", 0)
        subscriber.loop_start()
        publisher.connect("127.0.0.1", broker.port)
        publisher.loop_start()
        try:
            time.sleep(0.5)
            rss = _rss_kib(broker.pid)
            cpu = broker_cpu_seconds(broker.pid)
            start = time.perf_counter()
            for _ in range(FLOOD_ROUNDS):
                for topic in topics:
                    publisher.publish(topic, payload, 0, True)
            complete = got.acquire(timeout=120)
            wall = time.perf_counter() - start
            used = broker_cpu_seconds(broker.pid) - cpu
            grown = _rss_kib(broker.pid) - rss
        finally:
            for c in (publisher, subscriber):
                c.disconnect()
                c.loop_stop()
    return {
        "topics": len(topics),
        "messages": total,
        "received": received[0],
        "complete": complete,
        "rate": received[0] / wall,
        "cpu": used / wall,
        "us": used / max(1, received[0]) * 1e6,
        "bytes_per_retained": grown * 1024 / len(topics),
        "payload": len(payload),
    }


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else math.nan


def _stats(values: Sequence[float]) -> str:
    if not values:
        return "-"
    return f"{statistics.median(values):.1f}/{percentile(values, 0.95):.1f}/{max(values):.1f}"


def _drives(count: int) -> str:
    return f"{count} drive{'s' if count > 1 else ''}"


def _row(limit: float, label: str, sizes: Sequence[int], r: dict[str, Any]) -> None:
    count = r["drives"]
    print(
        f"{label:>28} {r['retained'] / count:>8.1f} {r['cycle_ms']:>6.1f}ms "
        f"{r['messages_s']:>7.0f} {r['messages_s'] / count:>7.2f} {limit / max(sizes):>10.2f} "
        f"{r['bytes_per_message']:>9.0f} {r['bytes_s']:>8.0f} {r['broker_bytes_s']:>10.0f} "
        f"{r['broker_cpu'] * 100:>9.1f}% {r['broker_us']:>6.0f} "
        f"{r['gateway_cpu'] * 100:>11.0f}% {r['gateway_us']:>6.0f}"
    )


def _latency(label: str, r: dict[str, Any]) -> None:
    print(
        f"{label:>28} {r['cycle_ms']:>6.1f}ms {_stats(r['rtt_ms']):>23} "
        f"{_stats(r['command_ms']):>27} {_stats(r['state_ms']):>30} {r['commands_failed']:>6}"
    )


def _figures(where: str, r: dict[str, Any], goals: bool) -> list[Figure]:
    """The figures of one case; without ``goals`` the latencies are shown for comparison."""
    rtt = _median(r["rtt_ms"])
    command = GOAL_CYCLES * r["cycle_ms"] + rtt
    latencies = [
        Figure(
            f"{where}: command->reply median (goal 2 cycles + broker rtt)",
            _median(r["command_ms"]),
            command if goals else None,
            False,
            "ms",
            1,
        ),
        Figure(
            f"{where}: value->subscriber median (goal broker rtt + 1 ms)",
            _median(r["state_ms"]),
            rtt + RESOLUTION_MS if goals else None,
            False,
            "ms",
            1,
        ),
    ]
    if not goals:
        return latencies
    count = r["drives"]
    return [
        Figure(
            f"{where}: states per drive over answers (ramping)",
            r["states_s"] / count / (r["answers_s"] or 1),
            GOAL_STATES,
        ),
        *latencies,
        Figure(f"{where}: messages/s per drive", r["messages_s"] / count, unit="/s"),
        Figure(f"{where}: broker CPU per message", r["broker_us"], unit="us", digits=0),
    ]


def main() -> list[Figure]:
    limit = 1 / (EXCHANGE * char_time(BAUD))
    load = os.getloadavg()[0]
    runs: list[tuple[str, Sequence[int], dict[str, Any]]] = []
    for sizes, settings in [((1,), ()), *((sizes, (NO_DELAY,)) for sizes in CASES)]:
        count = sum(sizes)
        buses = f"{len(sizes)} bus{'es' if len(sizes) > 1 else ''}"
        label = f"{_drives(count)}, {buses}, {'no delay' if settings else 'defaults'}"
        try:
            runs.append((label, sizes, case(sizes, *settings)))
        except (RuntimeError, TimeoutError) as exc:  # a machine too loaded for the drives
            print(f"{label}: not measured: {exc}")
    print(
        f"MQTT face, throttle off (max_rate 0), {BAUD} baud, PKW 4 + PZD 2 (wire limit "
        f"{limit:.0f} exchanges/s"
        f" per bus); mosquitto with its defaults or with {NO_DELAY}"
        f"{'; quick' if QUICK else ''}; {os.cpu_count()} cores, load average {load:.1f} "
        "at the start:"
    )
    print(
        f"{'case':>28} {'retained':>8} {'cycle':>8} {'msgs/s':>7} {'/drive':>7} "
        f"{'wire/drive':>10} {'bytes/msg':>9} {'bytes/s':>8} {'broker B/s':>10} "
        f"{'broker CPU':>10} {'us/msg':>6} {'gateways CPU':>12} {'us/msg':>6}"
    )
    for label, sizes, r in runs:
        _row(limit, label, sizes, r)
    print()
    print(
        f"{'case':>28} {'cycle':>8} {'broker rtt med/p95/max':>23} "
        f"{'command->reply med/p95/max':>27} {'value->subscriber med/p95/max':>30} {'failed':>6}"
    )
    for label, _, r in runs:
        _latency(label, r)
    figures: list[Figure] = []
    for label, _, r in runs:
        count = r["drives"]
        where = f"plant MQTT {_drives(count)}"
        defaults = label.endswith("defaults")
        figures += _figures(where + (", mosquitto defaults" if defaults else ""), r, not defaults)
    sample = max((r["sample"] for _, _, r in runs), key=len, default=b"")
    return figures + (_broker_alone(sample) if sample else [])


def _broker_alone(sample: bytes) -> list[Figure]:
    f = flood(sample)
    print()
    print(
        f"broker alone: {f['messages']:.0f} state messages ({f['payload']:.0f} bytes) on "
        f"{f['topics']:.0f} topics ({FLOOD_BUSES} buses x 31 drives), retained, QoS 0, one "
        f"subscriber: {f['received']:.0f} delivered{'' if f['complete'] else ' (INCOMPLETE)'}, "
        f"{f['rate']:.0f} messages/s, broker CPU {f['cpu'] * 100:.0f}% = {f['us']:.1f} us per "
        f"message, {f['bytes_per_retained']:.0f} bytes of memory per retained state"
    )
    name = f"broker alone, {FLOOD_BUSES} x 31 retained states: CPU per message"
    return [Figure(name, f["us"], unit="us", digits=1)]


if __name__ == "__main__":
    print(table(main()))
