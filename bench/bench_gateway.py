"""Gateway figures (`make bench`): simulated drives on a virtual bus, the gateway in the same
event loop, real clients over loopback sockets and a real mosquitto.

- latency of a Modbus write and of an MQTT command until the drive answered the telegram
  carrying it (the write returns then), against the bus cycle;
- the state publish rate per drive while the drives ramp, against the bus cycle;
- CPU time per second of the whole process (bus, 31 simulated drives, master, gateway) with
  and without the three faces, so the faces' share shows.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import shutil
import socket
import statistics
import struct
import subprocess
import tempfile
import time
from pathlib import Path

from pyuss.bus import VirtualBus
from pyuss.gateway.config import GatewayConfig, ModbusOptions, MqttOptions, OpcuaOptions
from pyuss.gateway.run import Gateway
from pyuss.master.testing import simulated_drives
from pyuss.points.config import plant_from_flags
from pyuss.points.endpoint import parse_endpoint
from pyuss.protocol.layout import Layout

BAUD = 38400


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@contextlib.contextmanager
def mosquitto() -> object:
    if shutil.which("mosquitto") is None:
        yield None
        return
    port = free_port()
    with tempfile.TemporaryDirectory() as directory:
        config = Path(directory) / "m.conf"
        config.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\n", encoding="utf-8")
        process = subprocess.Popen(
            ["mosquitto", "-c", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        time.sleep(0.3)
        try:
            yield port
        finally:
            process.terminate()
            process.wait(10)


def config(count: int, faces: bool, mqtt_port: int | None) -> GatewayConfig:
    plant = plant_from_flags(
        port="bus://simulated:1", addresses=list(range(1, count + 1)), baud=BAUD, layout="4,2"
    )
    if not faces:
        return GatewayConfig(
            plant, modbus=ModbusOptions(parse_endpoint(f":{free_port()}", "modbus"))
        )
    return GatewayConfig(
        plant,
        modbus=ModbusOptions(parse_endpoint(f":{free_port()}", "modbus")),
        mqtt=MqttOptions(parse_endpoint(f"mqtt://127.0.0.1:{mqtt_port}", "mqtt"))
        if mqtt_port
        else None,
        opcua=OpcuaOptions(parse_endpoint(f"opc.tcp://127.0.0.1:{free_port()}", "opcua")),
    )


async def run(count: int, faces: bool, mqtt_port: int | None, seconds: float) -> dict[str, float]:
    from pymodbus.client import AsyncModbusTcpClient

    bus = VirtualBus(BAUD)
    drives = [(a, "generic", Layout(4, 2)) for a in range(1, count + 1)]
    figures: dict[str, float] = {}
    async with simulated_drives(bus, drives):
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
                                if message.topic.value.endswith("/state"):
                                    publishes += 1
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


def main() -> None:
    with mosquitto() as port:
        mqtt_port = port if isinstance(port, int) else None
        print(
            f"{'drives':>6} {'faces':>12} {'cycle':>9} {'modbus write':>13} {'mqtt cmd':>9} "
            f"{'states/drive/s':>15} {'cycles/s':>9} {'CPU':>6}"
        )
        for count in (1, 31):
            for faces in (False, True):
                figures = asyncio.run(run(count, faces, mqtt_port, 5.0))
                label = "all three" if faces else "modbus only"
                mqtt = f"{figures['mqtt_ms']:.1f}ms" if "mqtt_ms" in figures else "-"
                states = (
                    f"{figures['states_per_drive_s']:.1f}"
                    if "states_per_drive_s" in figures
                    else "-"
                )
                print(
                    f"{count:>6} {label:>12} {figures['cycle_ms']:>7.1f}ms "
                    f"{figures['modbus_ms']:>11.1f}ms {mqtt:>9} {states:>15} "
                    f"{figures['cycles_per_s']:>9.1f} {figures['cpu'] * 100:>5.0f}%"
                )


if __name__ == "__main__":
    main()
