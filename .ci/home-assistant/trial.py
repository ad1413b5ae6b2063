"""A trial of ``uss gateway`` with a real Home Assistant, as a plant engineer would run one:
mosquitto, ``uss simulate`` (two MICROMASTER 440 drives), a lossy TCP proxy between the line
and the gateway (tests/support/lossy.py), ``uss gateway`` with MQTT and discovery, and Home
Assistant (a config folder of its own, onboarded and given the MQTT integration through its
REST API), every part a process of its own. For ``--minutes`` (default 30) the faults of the
soak test go round: single answers and bursts below ``offline_after_missed`` lost, a burst of
``offline_after_missed``, the line cut and back, the simulator killed and started again, the
broker restarted, the gateway killed (SIGKILL) and started again. Then Home Assistant is asked:

- the entities of the discovery messages exist, with the device class, state class and unit
  the messages give; the energy counters (r0039) are energy / total_increasing / kWh and the
  energy dashboard takes them (they are saved as its devices, and ``energy/validate`` finds
  nothing wrong with them);
- home-assistant.log holds no "Template variable" line, no ERROR and no WARNING of the MQTT
  integration or naming our topics or entities;
- the recorder's history shows no entity unavailable during the single losses, nor outside
  the faults, and every entity unavailable during each fault that takes its drive away.

Run it with the Python of Home Assistant's venv (it needs aiohttp and paho-mqtt, which that
venv has); the pyuss processes run with ``--pyuss`` (default: the repository's .venv). See
README.md beside this file. Exit code 0 when every check holds, 1 otherwise; the figures go
to stdout and, with ``--json FILE``, to a file."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
import urllib.request
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import aiohttp
import paho.mqtt.client as paho

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "tests"))
from support.lossy import LossyProxy  # noqa: E402

BUS = "line1"
DRIVES = {5: "conveyor", 6: "pump"}
PROFILE = "micromaster440"
MISSED = 3
BAUD = "38400"
CLIENT_ID = "http://127.0.0.1/"
TEMPLATE = re.compile(r"Template variable (error|warning)", re.IGNORECASE)
LOG_LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d+ (\w+) \(([^)]*)\) \[([^\]]+)\] (.*)$")


def log(text: str) -> None:
    print(f"{datetime.now(UTC):%H:%M:%S} {text}", flush=True)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def wait_port(port: int, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 1):
            return
        time.sleep(0.1)
    raise RuntimeError(f"{what} does not listen on {port}")


def until(check: Any, what: str, timeout: float = 60.0, step: float = 0.2) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = check()
        if found:
            return found
        time.sleep(step)
    raise RuntimeError(f"timed out waiting for {what}")


def kill(process: subprocess.Popen[Any] | None, how: int = signal.SIGKILL) -> None:
    if process is not None and process.poll() is None:
        process.send_signal(how)
        try:
            process.wait(30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(10)


class Broker:
    """mosquitto on a free loopback port, its retained messages kept over a restart."""

    def __init__(self, directory: Path) -> None:
        if shutil.which("mosquitto") is None:
            raise SystemExit("mosquitto is not installed (apt-get install mosquitto)")
        self.port = free_port()
        self.config = directory / "mosquitto.conf"
        root = hasattr(os, "geteuid") and os.geteuid() == 0
        self.config.write_text(
            f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence true\n"
            f"persistence_location {directory}/\nautosave_interval 1\n"
            + ("user root\n" if root else ""),
            encoding="utf-8",
        )
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.process = subprocess.Popen(
            ["mosquitto", "-c", str(self.config)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        wait_port(self.port, 10, "mosquitto")

    def stop(self) -> None:
        kill(self.process, signal.SIGTERM)
        self.process = None


class Recorder:
    """A paho client recording what the gateway publishes (for the figures and to tell a
    drive the gateway itself called offline from one Home Assistant made unavailable)."""

    def __init__(self, port: int) -> None:
        self.lock = threading.Lock()
        self.messages: list[tuple[float, str, bytes]] = []
        self.discovery: dict[str, dict[str, Any]] = {}
        client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="trial-recorder")
        client.on_connect = lambda c, *_: c.subscribe([("uss/#", 1), ("homeassistant/#", 1)])
        client.on_message = self._message
        client.reconnect_delay_set(0.2, 2)
        client.connect("127.0.0.1", port)
        client.loop_start()
        self.client = client

    def _message(self, _c: object, _d: object, message: paho.MQTTMessage) -> None:
        payload = bytes(message.payload)
        with self.lock:
            self.messages.append((time.time(), message.topic, payload))
            if message.topic.startswith("homeassistant/") and message.topic.endswith("/config"):
                if payload:
                    self.discovery[message.topic] = json.loads(payload)
                else:
                    self.discovery.pop(message.topic, None)

    def command(self, drive: str, name: str, value: Any) -> None:
        topic = f"uss/{BUS}/{drive}/cmd/{name}"
        self.client.publish(topic, json.dumps({"value": value}), qos=1)

    def availability(self, drive: str, start: float, end: float) -> list[str]:
        topic = f"uss/{BUS}/{drive}/availability"
        with self.lock:
            return [p.decode() for t, top, p in self.messages if top == topic and start <= t <= end]

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


class HomeAssistant:
    """Home Assistant in ``config`` on a free port: started, onboarded, given the MQTT
    integration, and asked through its REST and websocket APIs."""

    def __init__(self, hass: str, config: Path) -> None:
        self.hass = hass
        self.config = config
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.refresh = ""
        self.token = ""
        self.token_until = 0.0
        self.process: subprocess.Popen[bytes] | None = None
        config.mkdir(parents=True, exist_ok=True)
        (config / "configuration.yaml").write_text(
            "homeassistant:\n  name: pyuss trial\n  latitude: 52.5\n  longitude: 13.4\n"
            "  elevation: 30\n  unit_system: metric\n  time_zone: UTC\n  country: DE\n"
            "  currency: EUR\n"
            f"http:\n  server_host: 127.0.0.1\n  server_port: {self.port}\n"
            "api:\nwebsocket_api:\nonboarding:\nconfig:\nhistory:\nenergy:\n"
            "recorder:\n  commit_interval: 2\n  purge_keep_days: 2\n"
            "logger:\n  default: warning\n",
            encoding="utf-8",
        )

    @property
    def log_file(self) -> Path:
        return self.config / "home-assistant.log"

    def start(self) -> None:
        with (self.config / "hass.out").open("ab") as out:
            self.process = subprocess.Popen(
                [self.hass, "-c", str(self.config), "--log-file", str(self.log_file)],
                stdout=out,
                stderr=out,
            )
        until(lambda: self._get_plain("/api/onboarding") is not None, "Home Assistant", 300, 1)

    def stop(self) -> None:
        kill(self.process, signal.SIGTERM)

    def version(self) -> str:
        return str(self.get("/api/config")["version"])

    def _get_plain(self, path: str) -> Any:
        try:
            with urllib.request.urlopen(self.url + path, timeout=5) as answer:
                return json.load(answer)
        except OSError:
            return None

    def _post(self, path: str, body: Any, *, form: bool = False, auth: bool = True) -> Any:
        data = (urllib.parse.urlencode(body) if form else json.dumps(body)).encode()
        headers = {
            "Content-Type": "application/x-www-form-urlencoded" if form else "application/json"
        }
        if auth:
            headers["Authorization"] = f"Bearer {self.access()}"
        request = urllib.request.Request(self.url + path, data, headers, method="POST")
        with urllib.request.urlopen(request, timeout=30) as answer:
            return json.load(answer)

    def get(self, path: str) -> Any:
        request = urllib.request.Request(
            self.url + path, headers={"Authorization": f"Bearer {self.access()}"}
        )
        with urllib.request.urlopen(request, timeout=120) as answer:
            return json.load(answer)

    def onboard(self) -> None:
        code = self._post(
            "/api/onboarding/users",
            {
                "client_id": CLIENT_ID,
                "name": "Plant",
                "username": "plant",
                "password": "plant-trial",
                "language": "en",
            },
            auth=False,
        )["auth_code"]
        tokens = self._post(
            "/auth/token",
            {"grant_type": "authorization_code", "code": code, "client_id": CLIENT_ID},
            form=True,
            auth=False,
        )
        self.refresh = tokens["refresh_token"]
        self.token, self.token_until = tokens["access_token"], time.time() + 600

    def access(self) -> str:
        if time.time() > self.token_until:
            tokens = self._post(
                "/auth/token",
                {
                    "grant_type": "refresh_token",
                    "refresh_token": self.refresh,
                    "client_id": CLIENT_ID,
                },
                form=True,
                auth=False,
            )
            self.token, self.token_until = tokens["access_token"], time.time() + 600
        return self.token

    def add_mqtt(self, port: int) -> None:
        flow = self._post("/api/config/config_entries/flow", {"handler": "mqtt"})
        if flow.get("step_id") != "broker":
            raise RuntimeError(f"the MQTT config flow asks for {flow}")
        done = self._post(
            f"/api/config/config_entries/flow/{flow['flow_id']}",
            {"broker": "127.0.0.1", "port": port},
        )
        if done.get("type") != "create_entry":
            raise RuntimeError(f"the MQTT config flow ended with {done}")

    def ws(self, *commands: dict[str, Any]) -> list[Any]:
        """The results of websocket ``commands``, sent in order on one connection."""

        async def run() -> list[Any]:
            url = self.url + "/api/websocket"
            async with (
                aiohttp.ClientSession() as session,
                session.ws_connect(url, max_msg_size=0) as ws,
            ):
                await ws.receive_json()
                await ws.send_json({"type": "auth", "access_token": self.access()})
                ok = await ws.receive_json()
                if ok.get("type") != "auth_ok":
                    raise RuntimeError(f"websocket auth: {ok}")
                results = []
                for number, command in enumerate(commands, 1):
                    await ws.send_json({"id": number, **command})
                    while True:
                        answer = await ws.receive_json(timeout=120)
                        if answer.get("id") == number and answer["type"] == "result":
                            break
                    if not answer["success"]:
                        raise RuntimeError(f"{command['type']}: {answer.get('error')}")
                    results.append(answer["result"])
                return results

        return asyncio.run(run())


@dataclass
class Phase:
    kind: str
    start: float
    end: float = 0.0
    away: tuple[str, ...] = ()
    """The drives whose entities go unavailable in it (every entity: the bus is away)."""


@dataclass
class Plant:
    directory: Path
    pyuss: str
    broker: Broker
    line: int = field(default_factory=free_port)
    simulator: subprocess.Popen[str] | None = None
    gateway: subprocess.Popen[str] | None = None
    proxy: LossyProxy | None = None

    def __post_init__(self) -> None:
        self.proxy = LossyProxy(self.line).start()
        drives = "".join(
            f'[[bus.drive]]\naddress = {address}\nname = "{name}"\n'
            "parameters = [{ pnu = 39, poll = 10.0 }]\n"
            for address, name in DRIVES.items()
        )
        self.config = self.directory / "gateway.toml"
        self.config.write_text(
            f'[[bus]]\nname = "{BUS}"\nport = "tcp://127.0.0.1:{self.proxy.port}"\n'
            f'baud = {BAUD}\nprofile = "{PROFILE}"\nlayout = "4,2"\n'
            f"offline_after_missed = {MISSED}\n{drives}"
            f'[mqtt]\nbroker = "mqtt://127.0.0.1:{self.broker.port}"\nreconnect = 0.2\n'
            "keepalive = 5\n",
            encoding="utf-8",
        )
        self.log = self.directory / "gateway.log"

    def uss(self, *args: str) -> list[str]:
        return [self.pyuss, "-m", "pyuss.cli.main", *args]

    def start_simulator(self) -> None:
        addresses = [a for address in DRIVES for a in ("--address", str(address))]
        self.simulator = subprocess.Popen(
            self.uss(
                "simulate",
                "--profile",
                PROFILE,
                *addresses,
                "--layout",
                "4,2",
                "--baud",
                BAUD,
                "--tcp",
                f"127.0.0.1:{self.line}",
            ),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        wait_port(self.line, 30, "uss simulate")

    def start_gateway(self) -> None:
        with self.log.open("a", encoding="utf-8") as stderr:
            self.gateway = subprocess.Popen(
                self.uss("gateway", "--config", str(self.config)),
                stdout=subprocess.PIPE,
                stderr=stderr,
                text=True,
                env={**os.environ, "PYTHONUNBUFFERED": "1"},
            )
        assert self.gateway.stdout is not None
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            line = self.gateway.stdout.readline()
            if not line:
                raise RuntimeError(f"uss gateway ended: {self.log.read_text()[-2000:]}")
            if "ready" in line:
                break
        threading.Thread(target=self._drain, args=(self.gateway,), daemon=True).start()

    @staticmethod
    def _drain(process: subprocess.Popen[str]) -> None:
        assert process.stdout is not None
        for _ in process.stdout:
            pass

    def stop(self) -> None:
        kill(self.gateway, signal.SIGTERM)
        kill(self.simulator, signal.SIGTERM)
        if self.proxy is not None:
            self.proxy.close()

    def gateway_log(self, pattern: str) -> list[str]:
        return [
            line
            for line in self.log.read_text(encoding="utf-8").splitlines()
            if re.search(pattern, line)
        ]


class Trial:
    def __init__(self, args: argparse.Namespace, directory: Path) -> None:
        self.args = args
        self.directory = directory
        self.phases: list[Phase] = []
        self.broker = Broker(directory)
        self.plant = Plant(directory, args.pyuss, self.broker)
        self.ha = HomeAssistant(args.hass, directory / "ha")
        self.recorder: Recorder | None = None
        self.cycles = 0

    @property
    def proxy(self) -> LossyProxy:
        assert self.plant.proxy is not None
        return self.plant.proxy

    def phase(self, kind: str, away: tuple[str, ...] = ()) -> Phase:
        found = Phase(kind, time.time(), away=away)
        self.phases.append(found)
        return found

    def answers_pass(self, count: int) -> None:
        now = dict(self.proxy.passed)
        until(
            lambda: all(self.proxy.passed.get(a, 0) >= now.get(a, 0) + count for a in DRIVES),
            f"{count} more answers of each drive",
        )

    def run_drives(self, percent: float) -> None:
        assert self.recorder is not None
        for name in DRIVES.values():
            self.recorder.command(name, "setpoint_percent", percent)
            self.recorder.command(name, "run", "ON")

    def outage(self, kind: str, lose: Callable[[], object], mend: Callable[[], object]) -> None:
        """A fault that takes every drive away: ``lose`` it, 5 s, ``mend`` it, then until 5
        more answers of each drive have passed and 3 s more."""
        phase = self.phase(kind, tuple(DRIVES.values()))
        lose()
        time.sleep(5)
        mend()
        self.answers_pass(5)
        time.sleep(3)
        phase.end = time.time()

    def quiet(self, seconds: float) -> None:
        phase = self.phase("quiet")
        time.sleep(seconds)
        phase.end = time.time()

    def cycle(self) -> None:
        """One round of the soak's faults, some 2 minutes."""
        self.cycles += 1
        self.run_drives(20.0 + 10 * (self.cycles % 4))
        self.quiet(15)
        singles = self.phase("single losses")
        for burst in [1, 1, 1, 1, 1, MISSED - 1, 1, MISSED - 1]:
            for address in DRIVES:
                self.proxy.drop(address, burst)
            until(lambda: not any(self.proxy.pending(a) for a in DRIVES), "the losses")
            self.answers_pass(5)
        singles.end = time.time()
        self.quiet(10)
        burst = self.phase("a burst of offline_after_missed (conveyor)", ("conveyor",))
        self.proxy.drop(5, MISSED)
        until(lambda: not self.proxy.pending(5), "the burst")
        self.answers_pass(5)
        time.sleep(2)
        burst.end = time.time()
        self.quiet(10)
        self.outage("line cut by the proxy", self.proxy.cut, self.proxy.restore)
        self.quiet(10)
        self.outage(
            "simulator killed and started again",
            lambda: kill(self.plant.simulator),
            self.plant.start_simulator,
        )
        self.run_drives(25.0 + 10 * (self.cycles % 4))  # the drives started again stopped
        self.quiet(10)
        restart = self.phase("broker restarted", ("(Home Assistant's MQTT link)",))
        self.broker.stop()
        time.sleep(2)
        self.broker.start()
        time.sleep(10)
        restart.end = time.time()
        self.quiet(10)
        self.outage(
            "gateway killed and started again",
            lambda: kill(self.plant.gateway),
            self.plant.start_gateway,
        )
        self.quiet(10)

    def ours(self) -> dict[str, dict[str, Any]]:
        """Our entities in Home Assistant's registry, by unique id."""
        (entries,) = self.ha.ws({"type": "config/entity_registry/list"})
        return {
            e["unique_id"]: e
            for e in entries
            if e["platform"] == "mqtt" and e["unique_id"].startswith(f"pyuss_{BUS}_")
        }

    def run(self) -> dict[str, Any]:
        args = self.args
        self.broker.start()
        log(f"mosquitto on {self.broker.port}; starting Home Assistant ({args.hass})")
        self.ha.start()
        self.ha.onboard()
        self.ha.add_mqtt(self.broker.port)
        version = self.ha.version()
        log(f"Home Assistant {version} on {self.ha.port}, MQTT integration added")
        self.recorder = Recorder(self.broker.port)
        self.plant.start_simulator()
        self.plant.start_gateway()
        recorder = self.recorder
        configs = until(
            lambda: len(recorder.discovery) >= 2 and recorder.discovery, "discovery messages"
        )
        time.sleep(3)
        configs = {c["unique_id"]: c for c in recorder.discovery.values()}
        until(lambda: set(configs) <= set(self.ours()), "the entities in Home Assistant", 120, 2)
        entities = self.ours()
        energy = [entities[u]["entity_id"] for u in configs if u.endswith("_param_P39")]
        self.ha.ws(
            {
                "type": "energy/save_prefs",
                "energy_sources": [],
                "device_consumption": [{"stat_consumption": e} for e in energy],
            }
        )
        log(
            f"{len(entities)} entities; energy counters {energy} are the energy dashboard's devices"
        )
        began = time.time()
        self.run_drives(20.0)
        deadline = began + args.minutes * 60
        while time.time() < deadline:
            self.cycle()
            log(f"cycle {self.cycles} done, {max(0, deadline - time.time()) / 60:.1f} min left")
        self.quiet(20)
        ended = time.time()
        (self.directory / "phases.json").write_text(
            json.dumps([(p.kind, p.start, p.end, p.away) for p in self.phases]), encoding="utf-8"
        )
        return self.check(version, configs, began, ended)

    def check(
        self, version: str, configs: dict[str, dict[str, Any]], began: float, ended: float
    ) -> dict[str, Any]:
        problems: list[str] = []
        entities = self.ours()
        ids = {u: entities[u]["entity_id"] for u in configs if u in entities}
        missing = sorted(set(configs) - set(entities))
        if missing:
            problems.append(f"entities missing in Home Assistant: {missing}")
        states = {s["entity_id"]: s for s in self.ha.get("/api/states")}
        wrong = []
        for unique, config in configs.items():
            state = states.get(ids.get(unique, ""))
            if state is None:
                continue
            for key in ("device_class", "state_class", "unit_of_measurement"):
                if config.get(key) != state["attributes"].get(key):
                    wrong.append(
                        f"{ids[unique]} {key}: {state['attributes'].get(key)!r},"
                        f" discovery says {config.get(key)!r}"
                    )
        problems += wrong
        energy = {u: ids[u] for u in configs if u.endswith("_param_P39") and u in ids}
        for entity in energy.values():
            attributes = states[entity]["attributes"]
            got = tuple(
                attributes.get(k) for k in ("device_class", "state_class", "unit_of_measurement")
            )
            if got != ("energy", "total_increasing", "kWh"):
                problems.append(f"{entity}: {got} is no energy counter")
        validation, prefs, statistic_ids, statistics_issues = self.ha.ws(
            {"type": "energy/validate"},
            {"type": "energy/get_prefs"},
            {"type": "recorder/list_statistic_ids", "statistic_type": "sum"},
            {"type": "recorder/validate_statistics"},
        )
        devices = [d["stat_consumption"] for d in prefs.get("device_consumption", [])]
        if sorted(devices) != sorted(energy.values()):
            problems.append(f"the energy dashboard's devices are {devices}")
        energy_issues = [i for issues in validation.get("device_consumption", []) for i in issues]
        energy_issues += [i for issues in validation.get("energy_sources", []) for i in issues]
        if ended - began < 600:  # the recorder compiles statistics every 5 minutes
            energy_issues = [i for i in energy_issues if i["type"] != "statistics_not_defined"]
        if energy_issues:
            problems.append(f"energy/validate: {energy_issues}")
        summed = sorted(
            s["statistic_id"] for s in statistic_ids if s["statistic_id"] in energy.values()
        )
        ours_issues = {k: v for k, v in statistics_issues.items() if k in ids.values()}
        if ours_issues:
            problems.append(f"recorder/validate_statistics: {ours_issues}")

        # the log
        template_lines, error_lines, our_warnings, mqtt_lines, other_lines = [], [], [], [], []
        names = [*ids.values(), f"uss/{BUS}", "pyuss", *(n for n in DRIVES.values())]
        for line in self.ha.log_file.read_text(encoding="utf-8", errors="replace").splitlines():
            match = LOG_LINE.match(line)
            if TEMPLATE.search(line):
                template_lines.append(line)
            if not match:
                continue
            level, _, logger, text = match.groups()
            if level not in ("WARNING", "ERROR", "CRITICAL"):
                continue
            mqtt = logger.startswith("homeassistant.components.mqtt")
            mentions = any(n in text for n in names)
            if level != "WARNING" and (mqtt or mentions):
                error_lines.append(line)
            elif mentions:
                our_warnings.append(line)
            elif mqtt:
                mqtt_lines.append(line)
            else:
                other_lines.append(line)
        if template_lines:
            problems.append(f"{len(template_lines)} template lines in the log")
        if error_lines:
            problems.append(f"{len(error_lines)} ERROR lines of MQTT or ours in the log")
        if our_warnings:
            problems.append(f"{len(our_warnings)} WARNING lines of MQTT or ours in the log")

        # the history: every change to unavailable, by the phase it falls in
        start = datetime.fromtimestamp(began, UTC).isoformat()  # its first rows: the states then
        end = datetime.fromtimestamp(ended, UTC).isoformat()
        history = self.ha.get(
            f"/api/history/period/{urllib.parse.quote(start)}?"
            + urllib.parse.urlencode(
                {
                    "end_time": end,
                    "filter_entity_id": ",".join(ids.values()),
                    "minimal_response": "",
                    "no_attributes": "",
                }
            )
        )
        prefix = f"pyuss_{BUS}_"
        drive_of = {
            ids[u]: c["device"]["identifiers"][0].removeprefix(prefix)
            for u, c in configs.items()
            if u in ids
        }
        flaps: dict[str, Counter[str]] = {}
        changes = 0
        for rows in history:
            entity = rows[0]["entity_id"]
            before = None
            for row in rows:
                changes += 1
                at = datetime.fromisoformat(row["last_changed"]).timestamp()
                if row["state"] == "unavailable" and before not in (None, "unavailable"):
                    kind = self.phase_at(at)
                    flaps.setdefault(kind, Counter())[entity] += 1
                before = row["state"]
        single = flaps.get("single losses", Counter())
        own = (
            {
                name: sum(
                    self.recorder.availability(name, p.start, p.end + 3).count("offline")
                    for p in self.phases
                    if p.kind == "single losses"
                )
                for name in DRIVES.values()
            }
            if self.recorder
            else {}
        )
        if single:
            problems.append(
                f"unavailable during single losses: {dict(single)} (the gateway "
                f"said offline then: {own})"
            )
        for kind in ("quiet", "outside the faults"):
            if flaps.get(kind):
                problems.append(f"unavailable {kind}: {dict(flaps[kind])}")
        for phase in self.phases:
            drives = [d for d in phase.away if d in DRIVES.values()]
            if not drives:
                continue
            for entity, drive in drive_of.items():
                if drive in drives and not self.unavailable_in(history, entity, phase):
                    problems.append(
                        f"{entity} not unavailable in '{phase.kind}' at"
                        f" {datetime.fromtimestamp(phase.start, UTC):%H:%M:%S}"
                    )
        assert self.recorder is not None
        with self.recorder.lock:
            messages = [(t, top) for t, top, _ in self.recorder.messages if began <= t <= ended]
        kinds = Counter(top.rsplit("/", 1)[-1] for _, top in messages if top.startswith("uss/"))
        phases = Counter(p.kind for p in self.phases)
        return {
            "home_assistant": version,
            "minutes": round((ended - began) / 60, 1),
            "cycles": self.cycles,
            "phases": dict(phases),
            "entities": len(ids),
            "entities_by_domain": dict(Counter(e.split(".")[0] for e in ids.values())),
            "energy_counters": {
                e: [
                    states[e]["attributes"].get(k)
                    for k in ("device_class", "state_class", "unit_of_measurement")
                ]
                for e in energy.values()
            },
            "energy_devices": devices,
            "energy_validate_issues": energy_issues,
            "energy_statistics": summed,
            "statistics_issues": ours_issues,
            "messages": len(messages),
            "messages_by_kind": dict(kinds),
            "history_rows": changes,
            "unavailable_by_phase": {k: sum(v.values()) for k, v in flaps.items()},
            "unavailable_entities_by_phase": {k: len(v) for k, v in flaps.items()},
            "gateway_offline_in_single_losses": own,
            "answers_dropped": dict(self.proxy.dropped),
            "template_lines": template_lines,
            "error_lines": error_lines,
            "our_warning_lines": our_warnings,
            "mqtt_warning_lines_naming_none_of_ours": mqtt_lines,
            "other_warning_error_lines": other_lines,
            "timeline": [
                (
                    p.kind,
                    datetime.fromtimestamp(p.start, UTC).strftime("%H:%M:%S.%f")[:-3],
                    datetime.fromtimestamp(p.end, UTC).strftime("%H:%M:%S.%f")[:-3],
                )
                for p in self.phases
            ],
            "gateway_warnings": Counter(
                re.sub(r"^\S+ \S+ WARNING \S+ ", "", re.sub(r"[\d.]+ s", "N s", line))[:90]
                for line in self.plant.gateway_log(r" WARNING ")
            ).most_common(),
            "problems": problems,
        }

    def phase_at(self, at: float) -> str:
        """The fault an instant falls in: a fault's own window, then 15 s after it for what
        it leaves behind (a drive's reconnection, Home Assistant's)."""
        for phase in self.phases:
            if phase.kind != "quiet" and phase.start - 0.5 <= at <= (phase.end or at) + 0.5:
                return phase.kind
        for phase in self.phases:
            if phase.kind != "quiet" and phase.start <= at <= (phase.end or at) + 15:
                return phase.kind
        for phase in self.phases:
            if phase.kind == "quiet" and phase.start <= at <= (phase.end or at):
                return "quiet"
        return "outside the faults"

    @staticmethod
    def unavailable_in(history: list[list[dict[str, Any]]], entity: str, phase: Phase) -> bool:
        for rows in history:
            if rows and rows[0]["entity_id"] == entity:
                return any(
                    row["state"] == "unavailable"
                    and phase.start - 0.5
                    <= datetime.fromisoformat(row["last_changed"]).timestamp()
                    <= phase.end + 0.5
                    for row in rows
                )
        return False

    def close(self) -> None:
        if self.recorder is not None:
            self.recorder.stop()
        self.plant.stop()
        self.ha.stop()
        self.broker.stop()


def main() -> int:
    default_pyuss = REPO / ".venv" / "bin" / "python"
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="how long the faults go on")
    parser.add_argument(
        "--hass",
        default=str(Path(sys.executable).with_name("hass")),
        help="Home Assistant's hass (default: beside this Python)",
    )
    parser.add_argument(
        "--pyuss",
        default=str(default_pyuss if default_pyuss.exists() else sys.executable),
        help="the Python that has pyuss (default: the repository's .venv)",
    )
    parser.add_argument("--keep", type=Path, help="a folder to run in and keep (logs, config)")
    parser.add_argument("--json", type=Path, help="write the figures to this file")
    args = parser.parse_args()
    directory = args.keep or Path(tempfile.mkdtemp(prefix="pyuss-ha-trial-"))
    directory.mkdir(parents=True, exist_ok=True)
    log(f"trial in {directory}, {args.minutes} min of faults")
    trial = Trial(args, directory)
    try:
        figures = trial.run()
    finally:
        trial.close()
    text = json.dumps(figures, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text + "\n", encoding="utf-8")
    if figures["problems"]:
        log("FAILED: " + "; ".join(figures["problems"]))
        return 1
    log("every check holds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
