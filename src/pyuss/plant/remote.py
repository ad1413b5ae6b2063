"""The plant as the gateways publish it on one MQTT broker (see the package text).

`RemotePlant` is one aiomqtt client (MQTT 5, clean start, no session kept, a client id of its
own drawn at random at every start: ``pyuss-web-XXXXXXXX``). It subscribes to

- ``uss/+/gateway``: each gateway's retained gateway message (bus, version, read-only,
  keep-alive, drives with their process values), which makes its drives known;
- ``uss/+/availability`` (the gateway, ``offline`` its last will) and
  ``uss/+/+/availability`` (each drive);
- ``uss/+/+/state``: each drive's state, which is the drive view, its trend and its status;
- ``uss/+/+/reply/CLIENT``: the replies to its own requests (``reply_to``, under each
  drive's reply namespace, where the gateway allows replies: `pyuss.gateway.topics`).

A request (`RemotePlant.request`) is one command of the contract, published with QoS 1 and
never retained, with an ``id`` unique to this client and run (``CLIENT-N``) and ``reply_to``
the client's reply topic; it waits for the reply with that id for `REPLY_TIMEOUT` seconds, and
then fails with ``gateway line2 did not answer within 5 s``. A reply that comes retained, or
whose id is not one this client waits for (another run's, a repeated one, a made-up one),
answers nothing and is dropped: a page that starts again never takes an old reply for a new
command, and the gateway carries out each id once. Nothing is sent to a gateway that is
offline, nor a change to a read-only one.

Every message is read within bounds (`MAX_MESSAGE` bytes, `MAX_DEPTH` levels of JSON), and a
message of a contract version this client does not read (``v``) is dropped with one log line
naming the versions it reads; none ends the client.

A gateway that goes away (its last will, or ``offline`` when it stops) makes each of its drives
offline: their values are no longer live (`RemoteDrive.live`), and commands to them are refused
with a text naming the gateway. After a lost connection to the broker the client connects
again (1 s, doubling up to 30 s) and gets every retained message anew.

Latency (`Latency`), per bus: the round trip of each request (published to reply arrived) and
the age of each state as it arrives (the state's ``time``, set by the gateway as the drive
answered, to its arrival here; the two clocks are assumed to agree).

`RemoteParams` offers the parameter jobs `pyuss.commission` uses (``read_param``,
``write_param``, with ``params``, ``profile``, ``layout`` and ``address``) over ``cmd/read``
and ``cmd/write``: a backup, a comparison and a restore run over the broker as over a line.
The gateway carries numbers only: a parameter whose value is no number is refused, and a
value comes rounded to its resolution (`pyuss.gateway.payloads.param_value`).
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import itertools
import json
import logging
import secrets
import statistics
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import aiomqtt
from paho.mqtt.subscribeoptions import SubscribeOptions

from pyuss._tasks import cancel_and_wait
from pyuss.drive.datatypes import encode as encode_raw
from pyuss.errors import ConfigError, DriveRefusal, UssError, UssTimeout
from pyuss.gateway.mqtt_client import make_client, send_at_once
from pyuss.gateway.options import MqttOptions
from pyuss.gateway.topics import CONTRACT_VERSION
from pyuss.params import ParamBook, ParamInfo
from pyuss.params.model import Reading
from pyuss.params.values import raw_of
from pyuss.points import Sample
from pyuss.profiles import UNKNOWN_KIND, get_profile, profile_names
from pyuss.profiles.base import Profile
from pyuss.protocol.layout import Layout
from pyuss.userfile import parse_message as read_message

__all__ = [
    "REPLY_TIMEOUT",
    "GatewayRefusal",
    "Latency",
    "RemoteBus",
    "RemoteDrive",
    "RemoteParams",
    "RemotePlant",
]

log = logging.getLogger("pyuss.plant")

REPLY_TIMEOUT = 5.0
"""Seconds a request waits for its reply."""
MAX_MESSAGE = 256 * 1024
"""Bytes a message read from the broker may have (a state has about two thousand)."""
MAX_DEPTH = 8
"""JSON nesting a message may have (a state nests five levels)."""
READS = (1,)
"""The contract versions this client reads (``v``)."""
SAMPLES = 2000
"""Samples kept per drive between two takes."""
LATENCIES = 100
"""Round trips and value ages kept per bus for the median."""
RECONNECT_MAX = 30.0
REPLIES = SubscribeOptions(qos=1, retainAsPublished=True)
"""The reply subscription: QoS 1, and a reply published retained is seen as such even when it
is delivered live (else the broker clears the flag), so that it never counts."""


class GatewayRefusal(UssError):
    """A gateway refused a request, or cannot take it (offline, read-only): ``error`` is the
    reply's error (`pyuss.points.errors.error_dict`) or one made here alike."""

    def __init__(self, message: str, error: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.error = error or {"type": "GatewayRefusal", "message": message, "class": "refused"}


@dataclass
class Latency:
    """The last `LATENCIES` round trips of requests and ages of values of one bus (seconds)."""

    commands: deque[float] = field(default_factory=lambda: deque(maxlen=LATENCIES))
    values: deque[float] = field(default_factory=lambda: deque(maxlen=LATENCIES))

    @staticmethod
    def _shown(times: deque[float]) -> dict[str, Any]:
        if not times:
            return {"last_ms": None, "median_ms": None, "count": 0}
        return {
            "last_ms": round(times[-1] * 1000, 1),
            "median_ms": round(statistics.median(times) * 1000, 1),
            "count": len(times),
        }

    def to_dict(self) -> dict[str, Any]:
        """``command``: request to reply; ``value``: the drive's answer (state time) to here."""
        return {"command": self._shown(self.commands), "value": self._shown(self.values)}


@dataclass
class RemoteBus:
    """One gateway's bus as its messages tell it."""

    name: str
    gateway: dict[str, Any] | None = None
    """The gateway message (None: not seen yet)."""
    online: bool = False
    """``uss/BUS/availability`` is ``online``."""
    latency: Latency = field(default_factory=Latency)

    @property
    def read_only(self) -> bool:
        return bool(self.gateway and self.gateway.get("read_only"))


@dataclass
class RemoteDrive:
    """One drive of a gateway: what its gateway message says and its last state."""

    bus: str
    name: str
    address: int
    profile: str
    layout: str
    unit: str
    setpoints: tuple[tuple[str, int, bool], ...]
    actual: tuple[tuple[str, int, bool], ...]
    state: dict[str, Any] | None = None
    available: bool = False
    """``uss/BUS/DRIVE/availability`` is ``online`` (the drive answers)."""
    samples: deque[Sample] = field(default_factory=lambda: deque(maxlen=SAMPLES))

    @property
    def key(self) -> str:
        """How the page names it: ``BUS.ADDRESS``."""
        return f"{self.bus}.{self.address}"

    def actual_row(self, state: dict[str, Any]) -> tuple[float, ...]:
        """The actual values of ``state`` in the order of the gateway message, each in its
        unit (percent while the reference is not known)."""
        row = []
        for key, _pzd, _dword in self.actual:
            item = state.get("actual", {}).get(key)
            if not isinstance(item, dict):
                row.append(float("nan"))
                continue
            value = item.get("value")
            number = value if isinstance(value, int | float) else item.get("percent")
            row.append(float(number) if isinstance(number, int | float) else float("nan"))
        return tuple(row)


def _text(value: object, what: str) -> str:
    if not isinstance(value, str) or not value or len(value) > 64:
        raise ConfigError(f"{what}: expected a name, not {value!r:.40}")
    return value


def _points(value: object, what: str) -> tuple[tuple[str, int, bool], ...]:
    if not isinstance(value, list):
        raise ConfigError(f"{what}: expected a list")
    out = []
    for item in value:
        if not isinstance(item, dict):
            raise ConfigError(f"{what}: expected objects")
        pzd, dword = item.get("pzd"), item.get("dword")
        if isinstance(pzd, bool) or not isinstance(pzd, int) or not isinstance(dword, bool):
            raise ConfigError(f"{what}: pzd and dword")
        out.append((_text(item.get("key"), what), pzd, dword))
    return tuple(out)


def drives_of(message: dict[str, Any]) -> list[RemoteDrive]:
    """The drives a gateway message names; `ConfigError` for a message that breaks the
    contract (schema ``gateway.json``)."""
    bus = _text(message.get("bus"), "bus")
    drives = message.get("drives")
    if not isinstance(drives, list):
        raise ConfigError("drives: expected a list")
    out = []
    for n, item in enumerate(drives):
        where = f"drives[{n}]"
        if not isinstance(item, dict):
            raise ConfigError(f"{where}: expected an object")
        address = item.get("address")
        if isinstance(address, bool) or not isinstance(address, int) or not 0 <= address <= 31:
            raise ConfigError(f"{where}.address: expected 0..31")
        profile = item.get("profile")
        if profile not in profile_names():
            # a drive of unknown kind, or a family this version does not know: no family's
            # facts apply to it, its parameters travel as the gateway gives them
            profile = UNKNOWN_KIND
        layout, unit = item.get("layout"), item.get("unit")
        if not isinstance(layout, str) or not isinstance(unit, str):
            raise ConfigError(f"{where}: layout and unit are texts")
        out.append(
            RemoteDrive(
                bus,
                _text(item.get("name"), f"{where}.name"),
                address,
                str(profile),
                layout,
                unit,
                _points(item.get("setpoints"), f"{where}.setpoints"),
                _points(item.get("actual"), f"{where}.actual"),
            )
        )
    return out


def parse_message(payload: bytes) -> dict[str, Any]:
    """A JSON object of the contract read within bounds (`pyuss.userfile.parse_message`: no
    NaN or Infinity, which would make the page's own answers unreadable for the browser), in
    a version this client reads; `ConfigError` naming what is wrong."""
    data = read_message(payload, "the message", max_depth=MAX_DEPTH, max_bytes=MAX_MESSAGE)
    if not isinstance(data, dict):
        raise ConfigError("not a JSON object")
    if data.get("v") not in READS:
        reads = ", ".join(str(v) for v in READS)
        raise ConfigError(f"contract version {data.get('v')!r:.20}: this page reads {reads}")
    return data


def _seconds(stamp: object) -> float | None:
    """A state's ISO 8601 time as Unix seconds (None: none, or not a time)."""
    if not isinstance(stamp, str) or len(stamp) > 40:
        return None
    try:
        return datetime.datetime.fromisoformat(stamp.replace("Z", "+00:00")).timestamp()
    except ValueError:
        return None


class RemotePlant:
    """The gateways on one broker (see the module text). ``options``: the broker, user,
    password, TLS and topic prefix, as the gateway takes them (`pyuss.gateway.config`)."""

    def __init__(self, options: MqttOptions, *, timeout: float = REPLY_TIMEOUT) -> None:
        self.options = options
        self.prefix = options.prefix
        self.timeout = timeout
        self.client_id = f"pyuss-web-{secrets.token_hex(4)}"
        self.buses: dict[str, RemoteBus] = {}
        self.drives: dict[str, RemoteDrive] = {}
        """By `RemoteDrive.key` (``BUS.ADDRESS``)."""
        self._names: dict[tuple[str, str], str] = {}
        self._early: dict[tuple[str, str], tuple[str, bytes]] = {}
        self._pending: dict[str, tuple[asyncio.Future[dict[str, Any]], RemoteDrive]] = {}
        self._ids = itertools.count(1)
        self._client: aiomqtt.Client | None = None
        self.connected = asyncio.Event()
        self._stop = asyncio.Event()
        self._runner: asyncio.Task[None] | None = None
        self.dropped = 0
        """Messages dropped: out of bounds, of another version, replies that answer nothing."""

    @property
    def broker(self) -> str:
        return str(self.options.endpoint)

    # -- life cycle ---------------------------------------------------------------------------
    async def start(self, wait: float = 10.0) -> None:
        """Connect; `ConfigError` naming the broker if it cannot be reached within ``wait``."""
        self._runner = asyncio.create_task(self._run(), name="plant mqtt")
        try:
            async with asyncio.timeout(wait):
                await self.connected.wait()
        except TimeoutError:
            await self.close()
            raise ConfigError(
                f"cannot reach the MQTT broker {self.broker} within {wait:g} s"
            ) from None

    async def close(self) -> None:
        self._stop.set()
        runner, self._runner = self._runner, None
        if runner is not None:
            await cancel_and_wait(runner, ignore=(aiomqtt.MqttError,))
        for future, _ in self._pending.values():
            if not future.done():
                future.cancel()

    async def _run(self) -> None:
        wait = 1.0
        while not self._stop.is_set():
            try:
                async with make_client(self.options, self.client_id) as client:
                    send_at_once(client)  # a command goes out when it is made
                    p = self.prefix
                    for topic in (
                        f"{p}/+/gateway",
                        f"{p}/+/availability",
                        f"{p}/+/+/availability",
                        f"{p}/+/+/state",
                    ):
                        await client.subscribe(topic, qos=1)
                    # a message published retained keeps its flag however it comes
                    await client.subscribe(f"{p}/+/+/reply/{self.client_id}", options=REPLIES)
                    self._client = client
                    self.connected.set()
                    wait = 1.0
                    log.info("connected to MQTT broker %s as %s", self.broker, self.client_id)
                    async for message in client.messages:
                        payload = message.payload
                        data = payload if isinstance(payload, bytes) else str(payload).encode()
                        try:
                            self.receive(message.topic.value, data, retained=bool(message.retain))
                        except Exception as exc:  # one message never ends the client
                            self.dropped += 1
                            log.warning("message on %.120s dropped: %s", message.topic.value, exc)
            except aiomqtt.MqttError as exc:
                if self._stop.is_set():
                    break
                log.warning("MQTT broker %s: %s; trying again after %g s", self.broker, exc, wait)
            finally:
                self.connected.clear()
                self._client = None
            if not self._stop.is_set():
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(wait):
                        await self._stop.wait()
                wait = min(wait * 2, RECONNECT_MAX)

    # -- receiving ----------------------------------------------------------------------------
    def receive(self, topic: str, payload: bytes, *, retained: bool = False) -> None:
        """One message from the broker (public for the tests of what is dropped)."""
        head = f"{self.prefix}/"
        if not topic.startswith(head):
            return
        levels = topic[len(head) :].split("/")
        bus = levels[0]
        if levels[1:] == ["gateway"]:
            self._gateway(bus, payload)
        elif levels[1:] == ["availability"]:
            if payload or bus in self.buses:  # an empty one clears a retained message
                self._bus(bus).online = payload == b"online"
        elif len(levels) == 3 and levels[2] in ("availability", "state"):
            key = self._names.get((bus, levels[1]))
            if key is None:
                if not payload:
                    return
                # before its gateway message (the retained ones come in any order)
                self._early[(bus, levels[1])] = (levels[2], payload)
                while len(self._early) > 1000:
                    del self._early[next(iter(self._early))]
                return
            drive = self.drives[key]
            if levels[2] == "availability":
                drive.available = payload == b"online"
            else:
                self._state(drive, payload, retained=retained)
        elif len(levels) == 4 and levels[2] == "reply" and levels[3] == self.client_id:
            self._reply(payload, retained=retained)

    def _bus(self, name: str) -> RemoteBus:
        bus = self.buses.get(name)
        if bus is None:
            bus = self.buses[name] = RemoteBus(name)
        return bus

    def _gateway(self, name: str, payload: bytes) -> None:
        if not payload:  # the retained message cleared: the gateway is gone for good
            self._forget(name)
            return
        message = parse_message(payload)
        if message.get("bus") != name:
            raise ConfigError(f"the gateway message of bus {name} names bus {message.get('bus')!r}")
        drives = drives_of(message)
        old = {d.name: d for d in self.drives.values() if d.bus == name}
        self._forget(name, keep_bus=True)
        bus = self._bus(name)
        bus.gateway = message
        for drive in drives:
            before = old.get(drive.name)
            if before is not None and before.address == drive.address:
                drive.state, drive.available = before.state, before.available
            self.drives[drive.key] = drive
            self._names[(name, drive.name)] = drive.key
            early = self._early.pop((name, drive.name), None)
            if early is not None:
                self.receive(f"{self.prefix}/{name}/{drive.name}/{early[0]}", early[1])

    def _forget(self, bus: str, *, keep_bus: bool = False) -> None:
        for key in [k for k, d in self.drives.items() if d.bus == bus]:
            del self.drives[key]
        for name in [n for n in self._names if n[0] == bus]:
            del self._names[name]
        if not keep_bus:
            self.buses.pop(bus, None)

    def _state(self, drive: RemoteDrive, payload: bytes, *, retained: bool) -> None:
        state = parse_message(payload)
        arrived = time.time()
        drive.state = state
        stamp = _seconds(state.get("time"))
        status = state.get("status_word")
        if stamp is None or not isinstance(status, int):
            return
        if not retained:  # a retained state is as old as it is: no measure of the path
            self._bus(drive.bus).latency.values.append(max(arrived - stamp, 0.0))
        drive.samples.append(Sample(stamp, status, drive.actual_row(state)))

    def _reply(self, payload: bytes, *, retained: bool) -> None:
        if retained:
            self.dropped += 1
            log.warning("a retained message on the reply topic answers nothing: dropped")
            return
        reply = parse_message(payload)
        ident = reply.get("id")
        waiting = self._pending.get(ident) if isinstance(ident, str) else None
        if waiting is None:
            self.dropped += 1
            log.info("a reply with id %.40r answers no request of this page: dropped", ident)
            return
        future, drive = waiting
        if reply.get("drive") != drive.name:
            self.dropped += 1
            shown = reply.get("drive")
            log.warning("a reply for drive %.40r came for %s: dropped", shown, drive.key)
            return
        if not future.done():
            future.set_result(reply)

    # -- drives and requests ------------------------------------------------------------------
    def drive(self, key: str) -> RemoteDrive:
        """The drive ``BUS.ADDRESS``; `ConfigError` if no gateway names it."""
        try:
            return self.drives[key]
        except KeyError:
            raise ConfigError(f"drive {key!r:.40} is not on the page") from None

    def live(self, drive: RemoteDrive) -> bool:
        """Its gateway and the drive are online: its values are live."""
        return self.why_not_live(drive) is None

    def why_not_live(self, drive: RemoteDrive) -> str | None:
        """Why the values of ``drive`` are not live (None: they are): the broker not
        connected (nothing is known of a gateway then, "offline" least of all), its gateway
        offline, the drive not answering its gateway."""
        if not self.connected.is_set():
            return f"the MQTT broker {self.broker} is not connected"
        bus = self.buses.get(drive.bus)
        if bus is None or not bus.online:
            return f"gateway {drive.bus} offline"
        if not drive.available:
            return "the drive does not answer its gateway"
        return None

    def why_not(self, drive: RemoteDrive, *, change: bool) -> str | None:
        """Why a request to ``drive`` is not sent (None: it is): the broker, its gateway
        offline, and for a ``change`` a read-only gateway."""
        bus = self._bus(drive.bus)
        if not self.connected.is_set():
            return f"the MQTT broker {self.broker} is not connected: nothing sent"
        if not bus.online:
            return f"gateway {drive.bus} is offline: nothing sent to drive {drive.key}"
        if change and bus.read_only:
            return f"gateway {drive.bus} is read-only (its MQTT face takes reads only)"
        return None

    async def request(
        self, drive: RemoteDrive, command: str, fields: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """Send ``command`` (a name of the contract: ``on``, ``setpoint``, ``read``...) with
        ``fields`` to ``drive`` and wait for its reply: the reply's result; `GatewayRefusal`
        (or `DriveRefusal` with the drive's error number) for a refusal, `UssTimeout` when no
        reply comes in time. Nothing is sent to a gateway that is offline or, for a change,
        read-only."""
        refusal = self.why_not(drive, change=command != "read")
        client = self._client
        if refusal is not None or client is None:
            raise GatewayRefusal(refusal or f"the MQTT broker {self.broker} is not connected")
        ident = f"{self.client_id}-{next(self._ids)}"
        reply_to = f"{self.prefix}/{drive.bus}/{drive.name}/reply/{self.client_id}"
        payload = {"v": CONTRACT_VERSION, "id": ident, "reply_to": reply_to, **(fields or {})}
        future: asyncio.Future[dict[str, Any]] = asyncio.get_running_loop().create_future()
        self._pending[ident] = (future, drive)
        sent = time.monotonic()
        try:
            topic = f"{self.prefix}/{drive.bus}/{drive.name}/cmd/{command}"
            await client.publish(topic, json.dumps(payload), qos=1, retain=False)
            async with asyncio.timeout(self.timeout):
                reply = await future
        except TimeoutError:
            raise UssTimeout(
                f"gateway {drive.bus} did not answer within {self.timeout:g} s "
                f"({command} for drive {drive.key})"
            ) from None
        except aiomqtt.MqttError as exc:
            raise GatewayRefusal(f"the MQTT broker {self.broker}: {exc}") from None
        finally:
            self._pending.pop(ident, None)
        self._bus(drive.bus).latency.commands.append(time.monotonic() - sent)
        if reply.get("ok") is True and isinstance(reply.get("result"), dict):
            result: dict[str, Any] = reply["result"]
            return result
        error = reply.get("error") if isinstance(reply.get("error"), dict) else {}
        assert isinstance(error, dict)
        message = str(error.get("message", "refused"))[:300]
        number = error.get("number")
        if isinstance(number, int) and not isinstance(number, bool):
            raise DriveRefusal(number, str(error.get("meaning", "")))
        if error.get("class") == "no_answer":
            raise UssTimeout(f"drive {drive.key}: {message}")
        if error.get("class") in ("bad_value", "not_found"):
            raise ConfigError(f"gateway {drive.bus}: {message}")
        raise GatewayRefusal(f"gateway {drive.bus} refused {command}: {message}", error)


class RemoteParams:
    """The parameter jobs of one remote drive for `pyuss.commission` (see the module text):
    its parameter book (the profile's file), profile, layout and address, and
    ``read_param`` / ``write_param`` carried by ``cmd/read`` and ``cmd/write``."""

    def __init__(self, plant: RemotePlant, drive: RemoteDrive) -> None:
        self.plant = plant
        self.remote = drive
        self.profile_named = drive.profile in profile_names()
        """Whether the gateway names the drive's family: its facts apply. A drive of unknown
        kind gets the USS specification's rules only, no parameter facts."""
        self.profile: Profile = get_profile(drive.profile if self.profile_named else "generic")
        self.params = (
            ParamBook.for_profile(self.profile)
            if self.profile_named
            else ParamBook(index_base=self.profile.database().profile.index_base)
        )
        self.layout = Layout.parse(drive.layout)
        self.address = drive.address

    @property
    def kind(self) -> str:
        """The profile's name, or `UNKNOWN_KIND`, as a backup's header keeps it."""
        return self.profile.name if self.profile_named else UNKNOWN_KIND

    @property
    def named_profile(self) -> Profile | None:
        """The profile where the gateway names one, None for a drive of unknown kind."""
        return self.profile if self.profile_named else None

    async def read_param(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Reading:
        info = self.params.get(pnu)
        if index is None and info is not None and info.array is not None:
            elements = [await self._read(pnu, i, info) for i in self.params.indices(info)]
            words = tuple(w for e in elements for w in e.words)
            return Reading(pnu, None, info, words, [e.value for e in elements])  # type: ignore[misc]
        return await self._read(pnu, index, info)

    async def _read(self, pnu: int, index: int | None, info: ParamInfo | None) -> Reading:
        fields: dict[str, Any] = {"pnu": pnu}
        if index is not None:
            fields["index"] = index
        try:
            result = await self.plant.request(self.remote, "read", fields)
        except ConfigError as exc:  # the gateway cannot read it: that parameter's error
            raise GatewayRefusal(str(exc)) from None
        return self._reading(pnu, index, info, result)

    def _reading(
        self, pnu: int, index: int | None, info: ParamInfo | None, result: dict[str, Any]
    ) -> Reading:
        value = result.get("value")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise GatewayRefusal(f"{self.params.label(pnu, index)}: the gateway gave no number")
        if info is not None and info.dtype.is_integer and float(value).is_integer():
            value = int(value) if info.scaling in (None, 1) else value
        try:  # the words that carry it, as the drive holds it (a display beyond its limits)
            raw = raw_of(info, value, index) if info is not None else None
            words = () if info is None or raw is None else encode_raw(info.dtype, raw, info.length)
        except (UssError, ValueError, OverflowError, TypeError):
            words = ()
        return Reading(pnu, index, info, tuple(words), value)

    async def write_param(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
    ) -> Reading:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(
                f"{self.params.label(pnu, index)}: the gateway writes numbers only, "
                f"not {value!r:.40}"
            )
        fields: dict[str, Any] = {"pnu": pnu, "value": value, "eeprom": eeprom}
        if index is not None:
            fields["index"] = index
        result = await self.plant.request(self.remote, "write", fields)
        return self._reading(pnu, index, self.params.get(pnu), result)

    async def write_raw(
        self, pnu: int, raw: object, index: int | None = None, *, eeprom: bool = False
    ) -> tuple[int, ...]:
        raise ConfigError(
            f"{self.params.label(pnu, index)}: nothing is known of it, and the gateway "
            "writes values in their unit only"
        )
