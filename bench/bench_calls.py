"""Python calls per drive update in the gateway's process: a figure the machine's load does not
move (`make bench`).

The gateway's CPU time per drive update (``bench_gateway.py``) moves by 10-25 % with what else
the machine does; the number of Python function calls the process makes per update does not.
The drives run in another process (``uss simulate --bus-tcp``, 31 drives, PKW 4 + PZD 2 at
38400 baud), the gateway's plant and faces in this one, with the Modbus face alone and with
all three (MQTT to a real mosquitto, when one is installed, and OPC UA); the drives are
switched on and ramp, so every answer changes what the faces show. ``sys.setprofile`` counts
the calls of Python functions (coroutine steps included) and of C functions over a window,
and they are divided by the exchanges the master made in it. The profiler slows the process
several times over, so some answers come too late for it and count as exchanges without an
answer: the figures are per exchange, a drive update each.
"""

from __future__ import annotations

import asyncio
import collections
import os
import sys
from pathlib import Path
from types import FrameType
from typing import Any

from common import Figure, free_port, mosquitto, simulator_bus

from pyuss.gateway.config import GatewayConfig, ModbusOptions, MqttOptions, OpcuaOptions
from pyuss.gateway.run import Gateway
from pyuss.points.config import plant_from_flags
from pyuss.points.endpoint import parse_endpoint

DRIVES = 31
BAUD = 38400
WINDOW = 2.0 if os.environ.get("USS_BENCH_QUICK") else 4.0


def _config(url: str, all_faces: bool, mqtt_port: int | None) -> GatewayConfig:
    plant = plant_from_flags(
        port=url,
        addresses=list(range(1, DRIVES + 1)),
        baud=BAUD,
        profile="generic",  # the simulated drives' family
        layout="4,2",
    )
    modbus = ModbusOptions(parse_endpoint(f":{free_port()}", "modbus"))
    if not all_faces:
        return GatewayConfig(plant, modbus=modbus)
    mqtt = MqttOptions(parse_endpoint(f"mqtt://127.0.0.1:{mqtt_port}", "mqtt"))
    return GatewayConfig(
        plant,
        modbus=modbus,
        mqtt=mqtt if mqtt_port else None,
        opcua=OpcuaOptions(parse_endpoint(f"opc.tcp://127.0.0.1:{free_port()}", "opcua")),
    )


async def _count(
    url: str, all_faces: bool, mqtt_port: int | None
) -> tuple[float, float, dict[str, float]]:
    """Python calls and C calls per exchange, and the Python calls per exchange by package."""
    async with Gateway(_config(url, all_faces, mqtt_port)) as gateway:
        plant = gateway.plant
        for drive in plant.drives:
            await drive.drive.next_update(timeout=10)
        while any(d.reference is None for d in plant.drives):
            await asyncio.sleep(0.05)
        for drive in plant.drives:
            await drive.set_setpoint(0.0)
            await drive.command("on")
        for drive in plant.drives:
            drive.drive.set_pzd(2, 0x4000)  # ramp up: every answer changes what they show
        master = plant.bus("bus").master

        def exchanges() -> int:
            return sum(s.exchanges for s in master.diagnostics().slaves)

        python: collections.Counter[str] = collections.Counter()
        c_calls = 0

        def profile(frame: FrameType, event: str, arg: Any) -> None:
            nonlocal c_calls
            if event == "call":
                python[_package(frame.f_code.co_filename)] += 1
            elif event == "c_call":
                c_calls += 1

        before = exchanges()
        sys.setprofile(profile)
        try:
            await asyncio.sleep(WINDOW)
        finally:
            sys.setprofile(None)
        count = max(1, exchanges() - before)
    total = sum(python.values())
    return total / count, c_calls / count, {k: v / count for k, v in python.most_common(6)}


def _package(filename: str) -> str:
    """``pyuss/master``, ``asyncua``, ``asyncio``... for a code object's file."""
    parts = Path(filename).parts
    if "pyuss" in parts:
        i = parts.index("pyuss")
        return "/".join(parts[i : i + 2]).removesuffix(".py")
    if "site-packages" in parts:
        return parts[parts.index("site-packages") + 1]
    return parts[-2] if len(parts) > 1 else filename


def main() -> list[Figure]:
    figures: list[Figure] = []
    import uvloop

    with simulator_bus(BAUD, DRIVES, layout="4,2") as url, mosquitto() as broker:
        for all_faces in (False, True):
            port = broker.port if broker else None
            python, c_calls, by_package = uvloop.run(_count(url, all_faces, port))
            label = "all three faces" if all_faces else "Modbus face alone"
            if all_faces and port is None:
                label += " (no mosquitto: MQTT left out)"
            print(f"{label}: {python:.0f} Python calls, {c_calls:.0f} C calls per drive update")
            print("  " + ", ".join(f"{k} {v:.0f}" for k, v in by_package.items()))
            figures.append(
                Figure(
                    f"gateway, {DRIVES} drives, {label}: Python calls per update", python, digits=0
                )
            )
    return figures


if __name__ == "__main__":
    main()
