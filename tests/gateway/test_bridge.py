"""The area broker's bridge of docs/gateway.md ("Sizing a plant"), run as written between two
real mosquittos: the gateway publishes to the area broker, a client of the central broker sees
its states and commands the drive through the bridge, and a command published centrally while
the bridge is cut never acts when it comes back."""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from gateway.harness import Broker, mosquitto_pub, simulated_gateway, subscribed
from support.network import free_port
from support.paths import ROOT
from support.waiting import eventually

DRIVE = "uss/line1/drive5"


def bridge_lines() -> list[str]:
    """The area broker's configuration as docs/gateway.md prints it."""
    text = (ROOT / "docs" / "gateway.md").read_text(encoding="utf-8")
    body = text.split("\n## Sizing a plant\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```text\n(# mosquitto\.conf.*?)```", body, re.S)
    assert len(blocks) == 1, "one mosquitto.conf block in 'Sizing a plant'"
    return [line for line in blocks[0].splitlines() if line and not line.startswith("#")]


class Link:
    """A TCP relay between the area broker's bridge and the central broker that can be cut
    (every connection dropped, none taken) and mended, as a network between two halls."""

    def __init__(self, target: int) -> None:
        self.target = target
        self.port = free_port()
        self.server: asyncio.Server | None = None
        self.writers: set[asyncio.StreamWriter] = set()

    async def mend(self) -> None:
        self.server = await asyncio.start_server(self._relay, "127.0.0.1", self.port)

    async def cut(self) -> None:
        server, self.server = self.server, None
        if server is not None:
            server.close()  # no new connections
        for writer in self.writers:
            writer.transport.abort()  # no goodbye: a link that breaks
        self.writers.clear()
        if server is not None:
            # after the aborts: from Python 3.12.1 on, wait_closed waits for every connection
            await server.wait_closed()

    async def _relay(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target)
        self.writers |= {writer, up_writer}

        async def pump(source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
            with contextlib.suppress(ConnectionError):
                while data := await source.read(65536):
                    sink.write(data)
                    await sink.drain()
            sink.transport.abort()

        await asyncio.gather(pump(reader, up_writer), pump(up_reader, writer))


@contextlib.asynccontextmanager
async def plant(tmp_path: Path) -> AsyncIterator[tuple[Broker, Link, list[tuple[str, Any]]]]:
    """Central broker, the link, the area broker bridged as documented, the gateway on the
    area broker; yields the central broker, the link and what a central client sees."""
    (tmp_path / "central").mkdir()
    (tmp_path / "area").mkdir()
    central = Broker(tmp_path / "central")
    area = Broker(tmp_path / "area")
    link = Link(central.port)
    lines = [
        f"address 127.0.0.1:{link.port}" if line.startswith("address ") else line
        for line in bridge_lines()
        if not line.startswith("listener ")  # the area broker's listener is the harness's
    ]
    area.config.write_text(
        area.config.read_text(encoding="utf-8") + "\n".join([*lines, "restart_timeout 1"]) + "\n",
        encoding="utf-8",
    )
    seen: list[tuple[str, Any]] = []

    def on(topic: str, payload: bytes) -> None:
        text = payload.decode()
        seen.append((topic, json.loads(text) if text.startswith("{") else text))

    central.start()
    try:
        await link.mend()
        area.start()
        try:
            async with (
                subscribed(central, "uss/#", "areas/#", on=on),
                simulated_gateway(mqtt=area.url, bus_name="line1", addresses=(5,)),
            ):
                yield central, link, seen
        finally:
            area.stop()
            await link.cut()
    finally:
        central.stop()


def replies(seen: list[tuple[str, Any]]) -> dict[str, dict[str, Any]]:
    return {p["id"]: p for t, p in seen if t == f"{DRIVE}/reply" and isinstance(p, dict)}


async def test_states_go_up_and_commands_come_down_the_documented_bridge(tmp_path: Path) -> None:
    async with plant(tmp_path) as (central, _link, seen):
        await eventually(lambda: any(t == f"{DRIVE}/state" for t, _ in seen), what="a state")
        await eventually(lambda: ("areas/hall1/bridge", "1") in seen)
        command = json.dumps({"id": "up", "value": 40.0})
        await mosquitto_pub(central, f"{DRIVE}/cmd/setpoint_percent", command)
        await eventually(lambda: "up" in replies(seen), what="the reply at the central broker")
        reply = replies(seen)["up"]
        assert reply["ok"], reply
        assert reply["result"]["setpoint"]["main"]["percent"] == 40.0
        # a retained command crosses the bridge retained: it never acts
        await mosquitto_pub(
            central,
            f"{DRIVE}/cmd/setpoint_percent",
            json.dumps({"id": "kept", "value": 90.0}),
            retain=True,
        )
        await eventually(lambda: "kept" in replies(seen), what="the refusal of a retained command")
        refused = replies(seen)["kept"]
        assert not refused["ok"] and refused["error"]["type"] == "Retained", refused
        await mosquitto_pub(central, f"{DRIVE}/cmd/setpoint_percent", b"", retain=True)


async def test_a_command_sent_while_the_bridge_is_cut_never_acts(tmp_path: Path) -> None:
    async with plant(tmp_path) as (central, link, seen):
        await eventually(lambda: ("areas/hall1/bridge", "1") in seen)
        await link.cut()
        # the central broker publishes the bridge's will: the area is cut off
        await eventually(lambda: ("areas/hall1/bridge", "0") in seen, what="the bridge's 0")
        late = json.dumps({"id": "late", "value": 80.0})
        await mosquitto_pub(central, f"{DRIVE}/cmd/setpoint_percent", late)
        del seen[:]
        await link.mend()
        await eventually(lambda: ("areas/hall1/bridge", "1") in seen, what="the bridge back")
        now = json.dumps({"id": "now", "value": 60.0})
        await mosquitto_pub(central, f"{DRIVE}/cmd/setpoint_percent", now)
        # a command waiting in the bridge's session would have come down before this one
        await eventually(lambda: "now" in replies(seen), what="the reply to the new command")
        assert "late" not in replies(seen)
        assert replies(seen)["now"]["result"]["setpoint"]["main"]["percent"] == 60.0
