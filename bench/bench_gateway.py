"""Gateway figures (`make bench`), in two set-ups.

In one process: simulated drives on a virtual bus (one station answering every address, as
``uss simulate`` does), the gateway in the same event loop, real clients over loopback sockets
and a real mosquitto, 1 and 31 drives, with the Modbus face alone and with all three:

- latency of a Modbus write until the drive answered the telegram carrying it (the write
  returns then), in bus cycles: goal at most 2; the same of an MQTT command and its reply
  (no goal: the broker's two hops with their QoS 1 acknowledgements take milliseconds of
  their own, more than a cycle of one drive alone on its bus);
- the state messages per drive while the drives ramp, over the drive's answers, with the
  MQTT face's throttle off (``max_rate = 0``: every answer changes what it shows, so each
  gives one message): goal at least 0.95;
- CPU time per second of the whole process (bus, simulated drives, master, gateway).

As deployed: the drives in other processes (``uss simulate --bus-tcp``, one per bus of at most
31 drives), ``uss gateway --config`` in a process of its own, for 1, 31 and 124 drives (four
buses), once with the Modbus face alone (a Modbus port per bus) and once with all three faces
on (MQTT to a real mosquitto with Home Assistant discovery, and OPC UA). The drives are all
switched on at once and ramp up during the window, so every answer changes what the faces
show. Measured over a window:

- the gateway process's CPU time (``/proc/PID/stat``) per drive update (an answer of a drive
  to the gateway's master, counted by the gateway's own "answers received" registers): goal at
  most 0.2 ms with all faces; the same with the Modbus face alone is the master's and the
  virtual wire's cost (the Modbus face does nothing per update: it reads the state when asked),
  and the difference is the faces' share, goal at most 0.2 ms as well;
- each bus's exchanges per second against the wire's limit for the layout (request, answer and
  the two start pauses of A 5.1.2 and A 5.2.1.1: 2 x 16 + 4 character times with PKW 4 + PZD 2):
  goal at least 0.95 on the slowest bus;
- state messages on the broker per drive update (no goal here: shown beside the answers).

The runs with all three faces are made with the MQTT face's default throttle (``max_rate =
10``: at most 10 states a second per drive) and once more with it off (``max_rate = 0``, one
state per answer that changes anything), for 1 and 31 drives: what the throttle saves the
gateway per drive update, and the state messages per update it leaves.

Beside them, the floor under those figures (``bare``): ``bench/bare_exchange.py``, a process
that only exchanges telegrams made once with the same simulator, as fast as the wire allows,
one wake-up, one read and one write per exchange; its CPU per exchange is what no Python
process polling drives over ``bus://`` goes under on the same machine.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib.util
import json
import math
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from common import (
    LOOPS,
    Figure,
    cpu_seconds,
    free_port,
    gateway,
    mosquitto,
    simulator_bus,
    table,
)

from pyuss.bus import VirtualBus
from pyuss.gateway.config import GatewayConfig, ModbusOptions, MqttOptions, OpcuaOptions
from pyuss.gateway.run import Gateway
from pyuss.master.testing import simulated_drives
from pyuss.points.config import plant_from_flags
from pyuss.points.endpoint import parse_endpoint
from pyuss.protocol.layout import Layout
from pyuss.protocol.timing import char_time

BAUD = 38400
TELEGRAM = 16
"""Characters of a telegram with PKW 4 + PZD 2: STX, LGE, ADR, 12 bytes of net data, BCC."""
DEPLOYED_COUNTS = (1, 31, 124)
MONITORED_COUNT = 31
"""The run as deployed that is made once more with an OPC UA client monitoring every value."""
UNTHROTTLED_COUNTS = (1, 31)
"""The runs as deployed made once more with the MQTT face's throttle off (``max_rate = 0``)."""
_COMPARED = {
    "all, no uv": "all faces, pyuss.loop",
    "all, ua mon": "all faces, an OPC UA client monitoring every value",
    "all, no thr": "all faces, the MQTT throttle off (max_rate 0)",
}
"""The runs as deployed without a goal of their own, and their figures' names."""
BUS_SIZE = 31
WINDOW = 5.0
GOAL_CPU_MS = 0.2
GOAL_SHARE = 0.95
GOAL_CYCLES = 2.0
"""A write or command returns once the drive answered the telegram carrying it: the drive's
turn in the poll list comes within one bus cycle, its answer within the next."""
GOAL_STATES = 0.95
"""While a drive ramps every answer changes what it shows: one state message per answer."""


def config(count: int, faces: bool, mqtt_port: int | None) -> GatewayConfig:
    plant = plant_from_flags(
        port="bus://simulated:1",
        addresses=list(range(1, count + 1)),
        baud=BAUD,
        profile="generic",  # the simulated drives' family
        layout="4,2",
    )
    if not faces:
        return GatewayConfig(
            plant, modbus=ModbusOptions(parse_endpoint(f":{free_port()}", "modbus"))
        )
    return GatewayConfig(
        plant,
        modbus=ModbusOptions(parse_endpoint(f":{free_port()}", "modbus")),
        # the throttle off: every answer of a ramping drive a state (GOAL_STATES)
        mqtt=MqttOptions(parse_endpoint(f"mqtt://127.0.0.1:{mqtt_port}", "mqtt"), max_rate=0.0)
        if mqtt_port
        else None,
        opcua=OpcuaOptions(parse_endpoint(f"opc.tcp://127.0.0.1:{free_port()}", "opcua")),
    )


async def run(count: int, faces: bool, mqtt_port: int | None, seconds: float) -> dict[str, float]:
    from pymodbus.client import AsyncModbusTcpClient

    bus = VirtualBus(BAUD)
    drives = [(a, "generic", Layout(4, 2)) for a in range(1, count + 1)]
    figures: dict[str, float] = {}
    async with simulated_drives(bus, drives, one_station=True):
        gateway = Gateway(config(count, faces, mqtt_port), transports={"bus": bus.attach("gw")})
        async with gateway:
            plant = gateway.plant
            for drive in plant.drives:
                await drive.drive.next_update(timeout=10)
            while any(d.reference is None for d in plant.drives):
                await asyncio.sleep(0.05)
            master = plant.bus("bus").master
            modbus = gateway.modbus[0].endpoint
            client = AsyncModbusTcpClient(modbus.host, port=modbus.port)
            await client.connect()
            for address in range(1, count + 1):
                await client.write_register(1, 1, device_id=address)  # ON
            latencies = []
            for i in range(20):
                value = 10.0 + i
                words = list(struct.unpack(">HH", struct.pack(">f", value)))
                start = time.perf_counter()
                await client.write_registers(24, words, device_id=1)
                latencies.append(time.perf_counter() - start)
            client.close()
            figures["modbus_ms"] = statistics.median(latencies) * 1000
            cycle = master.cycle_stats().achieved
            figures["cycle_ms"] = cycle.median * 1000
            publishes = 0
            if faces and mqtt_port:
                import aiomqtt

                async with aiomqtt.Client("127.0.0.1", mqtt_port) as mqtt:
                    await mqtt.subscribe("uss/bus/+/state")
                    await mqtt.subscribe("uss/bus/drive1/reply", qos=1)
                    latencies = []
                    for i in range(20):
                        start = time.perf_counter()
                        payload = json.dumps({"id": f"b{i}", "value": 20.0 + i})
                        await mqtt.publish("uss/bus/drive1/cmd/setpoint", payload, qos=1)
                        async for message in mqtt.messages:
                            if message.topic.value.endswith("/reply"):
                                break
                        latencies.append(time.perf_counter() - start)
                    figures["mqtt_ms"] = statistics.median(latencies) * 1000
                    # ramp every drive from 0 to 50 Hz and count the state messages
                    for drive in plant.drives:
                        await drive.set_setpoint(0.0)
                    await asyncio.sleep(1.0)
                    for drive in plant.drives:
                        drive.drive.set_pzd(2, 0x4000)
                    cycles_before = master.cycle_stats().cycles
                    cpu, wall = time.process_time(), time.perf_counter()
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(seconds):
                            async for message in mqtt.messages:
                                # states queued before the window are no part of it
                                late = message.topic.value.endswith("/state")
                                publishes += late and time.perf_counter() - wall > 0.05
                    wall = time.perf_counter() - wall
                    figures["cpu"] = (time.process_time() - cpu) / wall
                    figures["cycles_per_s"] = (master.cycle_stats().cycles - cycles_before) / wall
                    figures["states_per_drive_s"] = publishes / wall / count
            else:
                for drive in plant.drives:
                    drive.drive.set_pzd(2, 0x4000)
                cycles_before = master.cycle_stats().cycles
                cpu, wall = time.process_time(), time.perf_counter()
                await asyncio.sleep(seconds)
                wall = time.perf_counter() - wall
                figures["cpu"] = (time.process_time() - cpu) / wall
                figures["cycles_per_s"] = (master.cycle_stats().cycles - cycles_before) / wall
    return figures


def in_process() -> list[Figure]:
    figures: list[Figure] = []
    with mosquitto() as broker:
        mqtt_port = broker.port if broker else None
        print(
            f"{'drives':>6} {'faces':>12} {'cycle':>9} {'modbus write':>13} {'mqtt cmd':>9} "
            f"{'states/drive/s':>15} {'cycles/s':>9} {'CPU':>6}"
        )
        for count in (1, 31):
            for faces in (False, True):
                r = asyncio.run(run(count, faces, mqtt_port, 5.0))
                label = "all three" if faces else "modbus only"
                mqtt = f"{r['mqtt_ms']:.1f}ms" if "mqtt_ms" in r else "-"
                states = f"{r['states_per_drive_s']:.1f}" if "states_per_drive_s" in r else "-"
                print(
                    f"{count:>6} {label:>12} {r['cycle_ms']:>7.1f}ms "
                    f"{r['modbus_ms']:>11.1f}ms {mqtt:>9} {states:>15} "
                    f"{r['cycles_per_s']:>9.1f} {r['cpu'] * 100:>5.0f}%"
                )
                if not faces:
                    continue
                where = f"gateway in-process {_drives(count)}, all faces"
                cycle = r["cycle_ms"]
                figures.append(_cycles(f"{where}: Modbus write latency", r["modbus_ms"], cycle))
                if "mqtt_ms" in r:
                    # through the broker and back, each way with its QoS 1 acknowledgement:
                    # milliseconds of its own, more than a cycle of one drive alone on its bus
                    figures.append(
                        Figure(f"{where}: MQTT command latency", r["mqtt_ms"], unit="ms", digits=1)
                    )
                    figures.append(
                        Figure(
                            f"{where}: states per drive over answers (ramping)",
                            r["states_per_drive_s"] / (r["cycles_per_s"] or 1),
                            GOAL_STATES,
                        )
                    )
    return figures


def _drives(count: int) -> str:
    return f"{count} drive{'s' if count > 1 else ''}"


def _cycles(name: str, ms: float, cycle_ms: float) -> Figure:
    """A latency in bus cycles, against the goal of `GOAL_CYCLES`."""
    return Figure(name, ms / cycle_ms, GOAL_CYCLES, False, "cycles")


# -- as deployed ------------------------------------------------------------------------------


def _sizes(count: int) -> list[int]:
    return [min(BUS_SIZE, count - start) for start in range(0, count, BUS_SIZE)]


def _plant_file(
    directory: Path,
    urls: list[str],
    sizes: list[int],
    mqtt_port: int | None,
    max_rate: float | None = None,
    opcua: bool | None = None,
) -> Path:
    """The plant: a bus per simulator, a Modbus port per bus; with ``mqtt_port`` the MQTT
    face too (with discovery; ``max_rate``: its throttle, None: the default); ``opcua``: the
    OPC UA face too (None: with the MQTT face); without either the Modbus face alone."""
    lines = []
    for number, (url, size) in enumerate(zip(urls, sizes, strict=True), start=1):
        lines += [
            "[[bus]]",
            f'name = "line{number}"',
            f'port = "{url}"',
            f"baud = {BAUD}",
            'profile = "generic"',
            'layout = "4,2"',
            f'modbus = "127.0.0.1:{free_port()}"',
        ]
        for address in range(1, size + 1):
            lines += ["[[bus.drive]]", f"address = {address}"]
    lines += ["[modbus]", f'listen = "127.0.0.1:{free_port()}"']
    if mqtt_port is not None:
        lines += [
            "[mqtt]",
            f'broker = "mqtt://127.0.0.1:{mqtt_port}"',
            "discovery = true",
            *([] if max_rate is None else [f"max_rate = {max_rate}"]),
        ]
    if opcua or (opcua is None and mqtt_port is not None):
        lines += ["[opcua]", f'listen = "opc.tcp://127.0.0.1:{free_port()}"']
    path = directory / "plant.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _modbus_ports(path: Path) -> list[int]:
    import tomllib

    data = tomllib.loads(path.read_text(encoding="utf-8"))
    return [int(bus["modbus"].rpartition(":")[2]) for bus in data["bus"]]


def _answers(clients: list[Any], sizes: list[int]) -> list[int]:
    """Answers received so far per bus (input registers 56..57 of every drive)."""
    totals = []
    for client, size in zip(clients, sizes, strict=True):
        total = 0
        for address in range(1, size + 1):
            regs = client.read_input_registers(56, count=2, device_id=address).registers
            total += regs[0] << 16 | regs[1]
        totals.append(total)
    return totals


async def _count_states(mqtt_port: int, seconds: float) -> int:
    """State messages on the broker in ``seconds``, after the retained ones (those that come
    in the first half second are not counted)."""
    import aiomqtt

    count = 0
    async with aiomqtt.Client("127.0.0.1", mqtt_port) as mqtt:
        await mqtt.subscribe("uss/+/+/state")
        start = time.perf_counter() + 0.5
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(seconds + 0.5):
                async for _message in mqtt.messages:
                    count += time.perf_counter() >= start
    return count


def _start(where: tuple[int, int]) -> None:
    """Ramp drive ``where`` = (Modbus port, address) up: 100 % setpoint, then ON, over a
    connection of its own (a connection's writes wait for each other)."""
    from pymodbus.client import ModbusTcpClient

    port, address = where
    client = ModbusTcpClient("127.0.0.1", port=port)
    client.connect()
    try:
        words = list(struct.unpack(">HH", struct.pack(">f", 100.0)))
        client.write_registers(26, words, device_id=address)  # 100 %: ramp up when on
        client.write_register(1, 1, device_id=address)  # ON
    finally:
        client.close()


@contextlib.contextmanager
def _monitoring(config: Path) -> Iterator[int]:
    """An OPC UA client (asyncua, on a thread of its own) that monitors every variable of
    the gateway of ``config``, as a SCADA system does; yields the number of them."""
    import logging
    import threading
    import tomllib

    from asyncua import Client, ua

    logging.getLogger("asyncua").setLevel(logging.ERROR)  # its notes on revised values

    url = tomllib.loads(config.read_text(encoding="utf-8"))["opcua"]["listen"]
    stop, ready, items = threading.Event(), threading.Event(), [0]

    async def run() -> None:
        async with Client(url, timeout=30) as client:
            ns = await client.get_namespace_index("urn:pyuss:gateway")
            found: list[Any] = []

            async def walk(node: Any) -> None:
                for child in await node.get_children():
                    kind = await child.read_node_class()
                    if kind == ua.NodeClass.Variable and child.nodeid.NamespaceIndex == ns:
                        found.append(child)
                    elif kind == ua.NodeClass.Object:
                        await walk(child)

            await walk(client.nodes.objects)

            class Handler:
                def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
                    pass

            subscription = await client.create_subscription(50, Handler())
            for start in range(0, len(found), 200):
                await subscription.subscribe_data_change(found[start : start + 200])
            items[0] = len(found)
            ready.set()
            while not stop.is_set():
                await asyncio.sleep(0.1)
            await subscription.delete()

    thread = threading.Thread(target=lambda: asyncio.run(run()), daemon=True)
    thread.start()
    if not ready.wait(60):
        raise RuntimeError("the OPC UA client did not subscribe within 60 s")
    try:
        yield items[0]
    finally:
        stop.set()
        thread.join(10)


def deployed(
    count: int,
    mqtt_port: int | None,
    uvloop: bool = True,
    monitor: bool = False,
    max_rate: float | None = None,
    opcua: bool | None = None,
    window: float = WINDOW,
) -> dict[str, float]:
    """One run as deployed; ``mqtt_port`` None: no MQTT face; ``opcua``: the OPC UA face
    (None: with the MQTT face; neither: the Modbus face alone); ``uvloop`` False: the
    gateway as if uvloop were not installed; ``monitor``: an OPC UA client monitors every
    value (`_monitoring`); ``max_rate``: the MQTT face's throttle (None: its default);
    ``window``: the seconds measured."""
    from pymodbus.client import ModbusTcpClient

    sizes = _sizes(count)
    with contextlib.ExitStack() as stack:
        urls = [stack.enter_context(simulator_bus(BAUD, n, layout="4,2")) for n in sizes]
        directory = Path(stack.enter_context(tempfile.TemporaryDirectory()))
        config = _plant_file(directory, urls, sizes, mqtt_port, max_rate, opcua)
        process = stack.enter_context(gateway(config, uvloop))
        ports = _modbus_ports(config)
        clients = [ModbusTcpClient("127.0.0.1", port=p) for p in ports]
        for client in clients:
            client.connect()
            stack.callback(client.close)
        deadline = time.monotonic() + 30
        while not all(_answers(clients, sizes)) and time.monotonic() < deadline:
            time.sleep(0.2)
        if monitor:
            stack.enter_context(_monitoring(config))
        with ThreadPoolExecutor(count) as pool:
            # all at once: one write after the other would take two bus cycles per drive,
            # and the first drives would be at full speed (nothing changing) in the window
            list(
                pool.map(
                    _start,
                    [(p, a) for p, n in zip(ports, sizes, strict=True) for a in range(1, n + 1)],
                )
            )
        time.sleep(0.5)
        running = sum(
            client.read_input_registers(1, count=1, device_id=address).registers[0] == 5
            for client, size in zip(clients, sizes, strict=True)
            for address in range(1, size + 1)
        )
        before = _answers(clients, sizes)
        cpu = cpu_seconds(process.pid)
        wall = time.perf_counter()
        if mqtt_port is None:
            states = 0
            time.sleep(window + 0.5)
        else:
            states = asyncio.run(_count_states(mqtt_port, window))
        wall = time.perf_counter() - wall
        cpu = cpu_seconds(process.pid) - cpu
        after = _answers(clients, sizes)
    updates = [b - a for a, b in zip(before, after, strict=True)]
    limit = 1 / ((2 * TELEGRAM + 4) * char_time(BAUD))
    return {
        "buses": len(sizes),
        "running": running,
        "updates_per_s": sum(updates) / wall,
        "cpu_ms": cpu / max(1, sum(updates)) * 1000,
        "cpu_share": cpu / wall,
        "share": min(u / wall for u in updates) / limit,
        "states_per_drive_s": states / window / count,
    }


def bare(count: int, window: float = WINDOW) -> dict[str, float]:
    """The floor under the figures as deployed: `bare_exchange.py` (a process that does
    nothing but exchange telegrams made once) against the same simulators (a bus of at most
    31 drives each), in its own process, over ``window`` seconds."""
    sizes = _sizes(count)
    with contextlib.ExitStack() as stack:
        urls = [stack.enter_context(simulator_bus(BAUD, n, layout="4,2")) for n in sizes]
        script = Path(__file__).with_name("bare_exchange.py")
        drives = ",".join(str(n) for n in sizes)
        args = [sys.executable, str(script), ",".join(urls), drives, str(BAUD), str(window)]
        out = subprocess.run(args, capture_output=True, text=True, timeout=60, check=True)
    result: dict[str, float] = json.loads(out.stdout)
    return result


def as_deployed() -> list[Figure]:
    figures: list[Figure] = []
    with mosquitto() as broker:
        if broker is None:
            print("as deployed: skipped (no mosquitto; .ci/system-deps mosquitto)")
            return figures
        print(
            f"{'drives':>6} {'faces':>11} {'running':>7} {'buses':>5} {'updates/s':>9} "
            f"{'CPU/update':>10} {'CPU':>5} {'bus share':>9} {'states/update':>13}"
        )
        # with uvloop installed, all faces once more on the loop of pyuss.loop, to compare
        compare = importlib.util.find_spec("uvloop") is not None
        for count in DEPLOYED_COUNTS:
            alone = deployed(count, None)
            full = deployed(count, broker.port)
            runs = [("modbus only", alone), ("all three", full)]
            if compare:
                runs.append(("all, no uv", deployed(count, broker.port, uvloop=False)))
            if count == MONITORED_COUNT:
                runs.append(("all, ua mon", deployed(count, broker.port, monitor=True)))
            if count in UNTHROTTLED_COUNTS:
                runs.append(("all, no thr", deployed(count, broker.port, max_rate=0.0)))
            for label, r in runs:
                states = r["states_per_drive_s"] * count / (r["updates_per_s"] or 1)
                print(
                    f"{count:>6} {label:>11} {int(r['running']):>7} {int(r['buses']):>5} "
                    f"{r['updates_per_s']:>9.0f} {r['cpu_ms']:>8.3f}ms "
                    f"{r['cpu_share'] * 100:>4.0f}% {r['share']:>9.2f} "
                    f"{states if r is not alone else math.nan:>13.2f}"
                )
            where = f"gateway as deployed, {_drives(count)}"
            faces = full["cpu_ms"] - alone["cpu_ms"]
            figures += [
                Figure(
                    f"{where}, all faces: CPU per drive update",
                    full["cpu_ms"],
                    GOAL_CPU_MS,
                    False,
                    "ms",
                    3,
                ),
                Figure(
                    f"{where}, Modbus face only: CPU per drive update",
                    alone["cpu_ms"],
                    None,
                    False,
                    "ms",
                    3,
                ),
                Figure(
                    f"{where}: the faces' share of CPU per update",
                    faces,
                    GOAL_CPU_MS,
                    False,
                    "ms",
                    3,
                ),
                Figure(
                    f"{where}, all faces: bus exchanges / wire limit", full["share"], GOAL_SHARE
                ),
            ]
            for label, r in runs:  # the set-ups beside the goals, for comparison
                if label in _COMPARED:
                    figures.append(
                        Figure(
                            f"{where}, {_COMPARED[label]}: CPU per drive update",
                            r["cpu_ms"],
                            None,
                            False,
                            "ms",
                            3,
                        )
                    )
        # the floor: what a process that only exchanges telegrams over bus:// takes
        for count in DEPLOYED_COUNTS[:2]:
            floor = bare(count)
            limit = 1 / ((2 * TELEGRAM + 4) * char_time(BAUD))
            print(
                f"{count:>6} {'bare':>11} {count:>7} {1:>5} {floor['exchanges_per_s']:>9.0f} "
                f"{floor['cpu_us'] / 1000:>8.3f}ms {'':>5} "
                f"{floor['exchanges_per_s'] / limit:>9.2f}"
            )
            figures.append(
                Figure(
                    f"bare exchange over bus://, {_drives(count)} (no master, no faces): "
                    "CPU per exchange",
                    floor["cpu_us"] / 1000,
                    None,
                    False,
                    "ms",
                    3,
                )
            )
        for setup, loop in LOOPS.items():
            print(f"uss gateway ({setup}) ran on: {loop}")
    return figures


def main() -> list[Figure]:
    print("in one process (drives, bus, master and gateway on one event loop):")
    figures = in_process()
    print()
    print("as deployed (drives in uss simulate --bus-tcp, uss gateway in its own process):")
    return figures + as_deployed()


if __name__ == "__main__":
    print(table(main()))
