"""Each face's CPU per drive update, as deployed, over the bare exchange's (`make bench`).

For 1, 31 and 124 drives (a ``uss simulate --bus-tcp`` per bus of at most 31 drives, PKW 4 +
PZD 2 at 38400 baud), each face on its own, in the process users run it in:

- **modbus**: ``uss gateway --config`` with the Modbus face alone (a port per bus; it does
  nothing per update, it reads the state when asked), every drive ramping;
- **mqtt**: the same gateway with the MQTT face too (a real mosquitto, Home Assistant
  discovery, the default throttle), every drive ramping;
- **opcua**: the same gateway with the OPC UA face instead, an OPC UA client (asyncua, in
  this process) monitoring every variable at 50 ms, every drive ramping;
- **web**: ``uss web`` per bus (a page serves one line), each with one client on its
  WebSocket that takes the live stream (every answer's process data, 20 messages a second);
- **log**: `log_drives.py`, a CSV file per drive with the data logger of ``uss log``, a row
  for every answer (``uss log`` logs one drive on a master of its own); **uss log**: the
  command itself, one drive, a row for every answer (1 drive only).

The gateway's Modbus ports carry the answers-received counters; they are read before and
after the window only. Each figure is the process's CPU time (``/proc/PID/stat``; the log and
the floor measure their own) over the answers its masters received in the window; the floor,
``bare`` (`bare_exchange.py`: telegrams made once, one process for all buses), is measured in
the same run, with as many drives on as many buses. Goal: at most `GOAL_RATIO` times the
floor.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench_gateway import BAUD, DEPLOYED_COUNTS, _drives, _sizes, bare, deployed
from common import LOOPS, USS, Figure, cpu_seconds, mosquitto, processes, simulator_bus

WINDOW = 4.0
"""Seconds measured per run (shorter than the gateway's own figures: 19 runs). The CPU time
from /proc counts in clock ticks of 10 ms: with one bus (some 390 updates in the window, 0.1
to 0.3 s of CPU) a figure is good to some 10 %, with four buses to some 3 %."""
GOAL_RATIO = 3.0
"""A face's CPU per drive update at most this many times the bare exchange's."""
FACES = ("modbus", "mqtt", "opcua", "web", "log", "uss log")


def gateway_face(face: str, count: int, mqtt_port: int) -> float:
    """ms of ``uss gateway`` CPU per drive update with the Modbus face and ``face``."""
    if face == "modbus":
        result = deployed(count, None, window=WINDOW)
    elif face == "mqtt":
        result = deployed(count, mqtt_port, opcua=False, window=WINDOW)
    else:
        result = deployed(count, None, opcua=True, monitor=True, window=WINDOW)
    return result["cpu_ms"]


async def _watch_pages(urls: list[str], pids: list[int], seconds: float) -> tuple[float, int]:
    """A WebSocket client on each page (``urls``); the CPU seconds of the pages' processes
    and the samples (answers) their live stream carried over ``seconds``."""
    import aiohttp

    counted = [0]
    counting = [False]

    async def take(ws: Any) -> None:
        async for message in ws:
            if message.type == aiohttp.WSMsgType.TEXT and counting[0]:
                data = json.loads(message.data)
                if data["type"] == "tick":
                    counted[0] += sum(len(d["samples"]) for d in data["drives"].values())

    async with aiohttp.ClientSession() as session:
        sockets = [await session.ws_connect(url.rstrip("/") + "/ws") for url in urls]
        readers = [asyncio.create_task(take(ws)) for ws in sockets]
        await asyncio.sleep(1.0)  # the drives' first answers, the reference read
        cpu = sum(cpu_seconds(pid) for pid in pids)
        counting[0] = True
        await asyncio.sleep(seconds)
        counting[0] = False
        cpu = sum(cpu_seconds(pid) for pid in pids) - cpu
        for ws in sockets:
            await ws.close()
        for reader in readers:
            reader.cancel()
        await asyncio.gather(*readers, return_exceptions=True)
    return cpu, counted[0]


def web_face(count: int) -> float:
    """ms of ``uss web`` CPU per drive update, a page per bus with a client on each."""
    sizes = _sizes(count)
    with contextlib.ExitStack() as stack:
        urls = [stack.enter_context(simulator_bus(BAUD, n, layout="4,2")) for n in sizes]
        pages = []
        for url, size in zip(urls, sizes, strict=True):
            addresses = [w for a in range(1, size + 1) for w in ("--address", str(a))]
            line = ["--port", url, "--baud", str(BAUD), "--layout", "4,2"]
            args = ["web", *line, "--profile", "generic", "--listen", "127.0.0.1:0", *addresses]
            pages.append((args, 1))
        started = stack.enter_context(processes(*pages))
        cpu, answers = asyncio.run(
            _watch_pages([p.lines[0] for p in started], [p.proc.pid for p in started], WINDOW)
        )
    return cpu / max(1, answers) * 1000


def log_face(count: int) -> float:
    """ms of CPU per drive update of `log_drives.py`: a CSV file per drive."""
    sizes = _sizes(count)
    with contextlib.ExitStack() as stack:
        urls = [stack.enter_context(simulator_bus(BAUD, n, layout="4,2")) for n in sizes]
        directory = stack.enter_context(tempfile.TemporaryDirectory())
        script = Path(__file__).with_name("log_drives.py")
        drives = ",".join(str(n) for n in sizes)
        args = [sys.executable, str(script), ",".join(urls), drives, str(BAUD), str(WINDOW)]
        out = subprocess.run(
            [*args, directory], capture_output=True, text=True, timeout=120, check=True
        )
    result: dict[str, float] = json.loads(out.stdout)
    return result["cpu_us"] / 1000


def _rows(path: Path) -> int:
    return path.read_bytes().count(b"\n") if path.exists() else 0


def uss_log_face() -> float:
    """ms of ``uss log`` CPU per drive update: one drive, a row for every answer (rows
    counted in the file)."""
    from log_drives import RATE

    with simulator_bus(BAUD, 1, layout="4,2") as url, tempfile.TemporaryDirectory() as where:
        path = Path(where) / "run.csv"
        line = ["--port", url, "--baud", str(BAUD), "--layout", "4,2", "--profile", "generic"]
        args = [*USS, "log", "1", "status", "actual", "--rate", str(RATE), "-o", str(path)]
        process = subprocess.Popen(
            [*args, *line], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        try:
            deadline = time.monotonic() + 30
            while _rows(path) < 10:
                if time.monotonic() > deadline or process.poll() is not None:
                    raise RuntimeError(f"uss log did not log: {process.communicate()[1]}")
                time.sleep(0.1)
            time.sleep(0.5)
            rows, cpu = _rows(path), cpu_seconds(process.pid)
            time.sleep(WINDOW)
            rows, cpu = _rows(path) - rows, cpu_seconds(process.pid) - cpu
        finally:
            process.send_signal(signal.SIGINT)
            process.communicate(timeout=10)
    return cpu / max(1, rows) * 1000


def main() -> list[Figure]:
    figures: list[Figure] = []
    costs: dict[tuple[str, int], float] = {}
    floors: dict[int, float] = {}
    loop = ""
    with mosquitto() as broker:
        if broker is None:
            print("faces: skipped (no mosquitto; .ci/system-deps mosquitto)")
            return figures
        for count in DEPLOYED_COUNTS:
            floor = bare(count, WINDOW)
            floors[count], loop = floor["cpu_us"] / 1000, str(floor["loop"])
            for face in FACES:
                if face == "uss log":
                    if count == 1:
                        costs[face, count] = uss_log_face()
                elif face == "web":
                    costs[face, count] = web_face(count)
                elif face == "log":
                    costs[face, count] = log_face(count)
                else:
                    costs[face, count] = gateway_face(face, count, broker.port)
    print(
        f"{'face':>8} {'drives':>6} {'ms/update':>9} {'bare ms/exch':>12} {'ratio':>6} "
        f"{'goal <= ' + format(GOAL_RATIO, 'g') + 'x':>11}"
    )
    for (face, count), ms in sorted(costs.items(), key=lambda item: FACES.index(item[0][0])):
        ratio = ms / floors[count]
        met = "yes" if ratio <= GOAL_RATIO else "no"
        print(f"{face:>8} {count:>6} {ms:>9.3f} {floors[count]:>12.3f} {ratio:>6.2f} {met:>11}")
        figures.append(
            Figure(
                f"{face} as deployed, {_drives(count)}: CPU per drive update over bare's",
                ratio,
                GOAL_RATIO,
                False,
                "x",
            )
        )
    print(
        f"event loops: uss gateway {LOOPS.get('uvloop if installed', '?')}; uss web, uss log "
        f"and log_drives.py the uss command's (pyuss.loop); bare {loop}"
    )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return figures


if __name__ == "__main__":
    from common import table

    print(table(main()))
