"""A plant of gateways for the page over the broker (``uss web --mqtt``): a real mosquitto,
and per bus a ``uss simulate --bus-tcp`` process (its simulated drives on a virtual bus of its
own) with a ``uss gateway`` process over it, publishing on the broker; and the page itself
(`pyuss.web.plant.PlantBackend` and its server) on a thread of its own."""

from __future__ import annotations

import json
import signal
import subprocess
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any, TypeVar

from pyuss.gateway.config import mqtt_options
from pyuss.plant.remote import RemotePlant
from pyuss.points.config import Where
from pyuss.web.plant import PlantBackend
from pyuss.web.server import WebServer
from support.processes import first_line, start_uss, stop_uss
from support.web import LoopThread

T = TypeVar("T")
BAUD = 38400
KEEPALIVE = 5
"""The gateways' MQTT keep-alive (the least the configuration takes): the broker publishes
a gateway's last will within 1.5 of them after losing it."""


class Line:
    """One bus: simulated drives 5 and 6 (generic, layout 4,2) and a gateway over them."""

    def __init__(self, name: str, broker: str, folder: Path) -> None:
        self.name = name
        self.broker = broker
        self.folder = folder
        self.simulator = start_uss(
            "simulate", "--baud", str(BAUD), "--layout", "4,2", "--address", "5",
            "--address", "6", "--bus-tcp", "127.0.0.1:0",
        )  # fmt: skip
        self.url = first_line(self.simulator, "bus://")
        self.gateway: subprocess.Popen[str] | None = None

    def config(self, *, read_only: bool) -> Path:
        path = self.folder / f"{self.name}.toml"
        path.write_text(
            f'[[bus]]\nname = "{self.name}"\nport = "{self.url}"\nbaud = {BAUD}\n'
            'layout = "4,2"\nprofile = "generic"\n'
            "[[bus.drive]]\naddress = 5\n[[bus.drive]]\naddress = 6\n"
            f'[mqtt]\nbroker = "{self.broker}"\nkeepalive = {KEEPALIVE}\n'
            f"read_only = {'true' if read_only else 'false'}\n",
            encoding="utf-8",
        )
        return path

    def start_gateway(self, *, read_only: bool = False) -> None:
        self.gateway = start_uss("gateway", "--config", str(self.config(read_only=read_only)))
        first_line(self.gateway, "ready")

    def kill_gateway(self) -> None:
        """As a power cut: no goodbye, the broker's last will says offline."""
        if self.gateway is not None:
            stop_uss(self.gateway, signal.SIGKILL)
            self.gateway = None

    def stop(self) -> None:
        if self.gateway is not None:
            stop_uss(self.gateway)
        stop_uss(self.simulator, signal.SIGINT)


class Page(LoopThread):
    """The page over the broker, on a thread of its own (its own event loop)."""

    def __init__(self, broker: str, *, timeout: float = 10.0) -> None:
        super().__init__()
        options = mqtt_options({"broker": broker}, Where("web"))
        self.plant = RemotePlant(options, timeout=timeout)
        self.backend = PlantBackend(self.plant)
        self.call(self.backend.start())
        self.server = WebServer(self.backend, port=0)
        self.url = self.call(self.server.start())

    def api(self, path: str, body: object = None, *, raw: bytes | None = None) -> Any:
        """A request as the page makes it: GET, or POST with a JSON body (or ``raw``
        bytes); returns (status, parsed JSON or text)."""
        data = raw if raw is not None else None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(
            self.url.rstrip("/") + path,
            data=data,
            method="GET" if data is None else "POST",
            headers={"X-Pyuss": "1", "Content-Type": "application/json"},
        )
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                status, text = response.status, response.read().decode()
        except urllib.error.HTTPError as error:
            status, text = error.code, error.read().decode()
        try:
            return status, json.loads(text)
        except ValueError:
            return status, text
