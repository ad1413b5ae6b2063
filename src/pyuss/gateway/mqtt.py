"""The MQTT face: one aiomqtt client per bus, publishing its drives and taking commands.

Topics and commands are `pyuss.gateway.topics`, the messages published
`pyuss.gateway.payloads`, Home Assistant discovery `pyuss.gateway.homeassistant` (pure, tested
without a broker); this module is the client's session around them (the client itself, and
what the face takes of aiomqtt and paho below their public calls: `pyuss.gateway.mqtt_client`):

- It speaks MQTT 5 and connects with a clean start and no session kept (a fixed client id per
  bus, ``pyuss-BUS``) and a last will that sets ``uss/BUS/availability`` to ``offline``; it
  subscribes to the command topics with QoS 1, "no local" (what it publishes itself never
  comes back to it) and "retain as published" (a command published retained is seen as
  such however it arrives). So only commands sent while it is connected reach it: the broker
  keeps none for it while it is away, and none is delivered again after a reconnection;
  those that wait for their drive when the connection is lost are refused, not carried out
  while the gateway is away or once it is back.
- A retained command never acts, nor one whose reply topic could act (`check_reply_to`);
  every message is parsed within bounds (`pyuss.gateway.topics.MAX_PAYLOAD` and the rest).
  Such a message gets an error reply and one log line; nothing a message holds ends the
  message loop or a drive's task.
- After every (re)connection it subscribes again, publishes the gateway message
  (`pyuss.gateway.announce`: its version, read-only or not, keep-alive, drives), every
  drive's state and availability of now, then ``online`` (so that no reader takes a state
  retained from before for a current one once the bus is online); then each drive's task
  publishes its parameters and discovery messages, and beside the message loop the face
  clears (an empty retained message) each discovery topic of its drives it found retained and
  no longer publishes (`MqttBusFace._clear_discovery`) and sends the replies it could not
  send. An unreachable broker is tried again after 1 s, then twice as long each time up to
  `RECONNECT_MAX`; losing it and getting it back are one log line each.
- Each drive has its worker (`pyuss.gateway.mqtt_drive`): it publishes the drive's states
  (at once, or as its ``max_rate`` and ``deadband`` let it) and carries out its commands in
  order (`pyuss.gateway.mqtt_commands`). A state (QoS 0) is handed to the socket in the turn
  of the loop that made it, without aiomqtt's wait for it to be written
  (`MqttBusFace._publish_now`): that wait cost more CPU than the rest of the face. Once paho
  has taken a topic, the face writes the next QoS 0 messages to it itself, the packet's head
  made once per topic (`MqttBusFace._write_now`).
- A command with an id is carried out once (`pyuss.gateway.topics`), its reply kept for
  repeats (the last 1000 ids per bus).
- Its socket sends each packet at once (`pyuss.gateway.mqtt_client.send_at_once`: no Nagle
  delay behind the broker's acknowledgement of the packet before).
- On stop it refuses the commands that wait or come, lets each drive's command being
  carried out finish and reply (`MqttBusFace._finish`), publishes ``offline`` itself and
  disconnects.
- One gateway per bus on a broker: its gateway message carries its generation (the user
  property `pyuss.gateway.mqtt_client.INSTANCE`): one more than that of the gateway message
  of its bus it finds retained when it first connects, so a gateway started later has the
  greater one, whatever the machines' clocks say; a face that sees the message of a gateway
  of its bus of a greater generation stops connecting (`TakenOver`), so two gateways never
  both take a bus's commands nor take the session from each other in turn.

Why aiomqtt: the asyncio client over paho-mqtt (the reference MQTT client for Python); it
brings sessions, QoS 1, last will, TLS and user/password.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import logging
import secrets
import socket
from collections import OrderedDict, deque
from collections.abc import Callable
from typing import Any

import aiomqtt
from paho.mqtt import client as mqtt
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from paho.mqtt.reasoncodes import ReasonCode
from paho.mqtt.subscribeoptions import SubscribeOptions

from pyuss.errors import ConfigError
from pyuss.gateway.announce import gateway_payload, gateway_topic
from pyuss.gateway.homeassistant import discovery_node, of_bus
from pyuss.gateway.mqtt_client import (
    INSTANCE,
    SUBSCRIBE,
    TakenOver,
    generation_of,
    instance_of,
    lost_reason,
    make_client,
    not_granted,
    publish_head,
    publish_packet,
    queued,
    send_at_once,
)
from pyuss.gateway.mqtt_commands import log_refused, lost_link, refusal, stopping
from pyuss.gateway.mqtt_drive import QUEUE, DriveWorker
from pyuss.gateway.options import RECONNECT_MAX, STOP_WAIT, MqttOptions
from pyuss.gateway.payloads import (
    reply_payload,
    state_payload,
)
from pyuss.gateway.topics import (
    Command,
    CommandError,
    check_reply_to,
    drive_of,
    parse_command,
    show,
    subscriptions,
    under,
)
from pyuss.points.errors import error_dict
from pyuss.points.plant import BusPoints, Plant
from pyuss.points.state import DriveState

__all__ = ["MqttBusFace", "MqttFace"]

log = logging.getLogger("pyuss.gateway.mqtt")
KEEP_IDS = 1000
"""Replies kept per bus for commands repeated with the same id."""
OUTBOX = 1000
"""Replies kept while the broker cannot be reached (the oldest are dropped first)."""


@dataclasses.dataclass(frozen=True, slots=True)
class _Connected:
    """What `MqttBusFace._connected` leaves to `MqttBusFace._publish_rest`: each drive's state
    published at the connection, the retained discovery messages found of its drives."""

    states: list[tuple[DriveWorker, DriveState]]
    discovery: list[aiomqtt.Message]


class MqttBusFace:
    """The MQTT client of one bus (see the module docstring)."""

    def __init__(self, bus: BusPoints, options: MqttOptions) -> None:
        self.bus = bus
        self.options = options
        self.client_id = options.client_id.format(bus=bus.name)
        self.availability = f"{options.prefix}/{bus.name}/availability"
        self.workers = {drive.name: DriveWorker(self, drive) for drive in bus.drives.values()}
        self.connected = asyncio.Event()
        self._client: aiomqtt.Client | None = None
        self._done: OrderedDict[tuple[str, str], dict[str, Any]] = OrderedDict()
        self._pending: set[tuple[str, str]] = set()
        self._outbox: deque[tuple[str, bytes]] = deque(maxlen=OUTBOX)
        self._heads: dict[tuple[str, bool], tuple[int, bytes]] = {}
        self._tasks: list[asyncio.Task[None]] = []
        self._removers: list[Callable[[], None]] = []
        self._stop = asyncio.Event()
        self._runner: asyncio.Task[None] | None = None
        self.connections = 0
        """How many times the client connected (1 + reconnections)."""
        self.attempts = 0
        """Failed tries to reach the broker since it was last connected."""
        self._lost = False
        self._closing = False
        self.taken_over: str | None = None
        """Why the face stopped connecting: another gateway of its bus (`TakenOver`)."""
        self.instance = ""
        """This face's token in its gateway messages (`INSTANCE`), set when it first
        connects: its generation (one more than the greatest it finds retained then: a later
        gateway's is greater, and a restart of this one finds its own) and a random part
        (two gateways that start at once differ, and the greater keeps the bus)."""
        self.gateway_topic = gateway_topic(options.prefix, bus.name)
        self._early: list[aiomqtt.Message] = []

    # -- publishing ----------------------------------------------------------------------------
    def _paho_now(self) -> mqtt.Client | None:
        """aiomqtt's paho client, if connected and nothing waits to be written: a QoS 0
        message may then be written in this turn of the loop (`_write_now`,
        `_publish_now`)."""
        client = self._client
        if client is None or not self.connected.is_set():
            return None
        paho = getattr(client, "_client", None)
        if not isinstance(paho, mqtt.Client) or paho.want_write():
            return None
        return paho

    def publish_now(self, topic: str, payload: bytes | str) -> bool:
        """A retained QoS 0 message written in this turn of the loop (`_paho_now`); False:
        not sent (`publish` it)."""
        paho = self._paho_now()
        return paho is not None and (
            self._write_now(paho, topic, payload, True)
            or self._publish_now(paho, topic, payload, True)
        )

    async def publish(
        self, topic: str, payload: bytes | str, *, qos: int = 1, retain: bool = False
    ) -> bool:
        """Publish if connected; False if it could not be sent."""
        client = self._client
        if client is None or not self.connected.is_set():
            return False
        if qos == 0 and (paho := self._paho_now()) is not None:
            return self._write_now(paho, topic, payload, retain) or self._publish_now(
                paho, topic, payload, retain
            )
        try:
            await client.publish(topic, payload, qos=qos, retain=retain)
        except aiomqtt.MqttError as exc:
            log.info("%s: publish to %s failed: %s", self.bus.name, topic, exc)
            return False
        return True

    def _write_now(self, paho: mqtt.Client, topic: str, payload: bytes | str, retain: bool) -> bool:
        """A QoS 0 message written to a plain TCP socket by the face itself, the packet's
        head made once per topic (`publish_head`): paho builds MQTT 5 reason-code and
        property objects for every message it has written, some hundred microseconds of
        CPU per state. Only while nothing else waits to be written; what the socket does
        not take at once is handed to paho to write next, as paho does with its own. False:
        nothing was written (not a plain socket, a topic not yet published through paho,
        a full socket), for `_publish_now`."""
        head = self._heads.get((topic, retain))
        sock = paho.socket()
        if head is None or type(sock) is not socket.socket:
            return False
        data = payload.encode() if isinstance(payload, str) else payload
        packet = publish_packet(head, data)
        try:
            sent = sock.send(packet)
        except BlockingIOError:
            return False
        except OSError:  # a broken connection: paho's to find and report (on_disconnect)
            return False
        if sent < len(packet):
            rest = packet[sent:]
            paho._packet_queue(mqtt.PUBLISH, rest, 0, 0, mqtt.MQTTMessageInfo(0))
        return True

    def _publish_now(
        self, paho: mqtt.Client, topic: str, payload: bytes | str, retain: bool
    ) -> bool:
        """A QoS 0 message written to the socket now, in this turn of the loop. Through
        aiomqtt a message takes a task, a timer and three more turns of the loop (paho asks
        for the socket to be watched for writing, from any thread; the loop watches it, writes,
        stops watching): most of the gateway's CPU per state. With no watch to ask for, paho
        writes at once; what the socket could not take is left to the watch as before. Only
        while nothing waits to be written: a watch asked for earlier and not yet set up would
        otherwise be set up after this write, with nothing left to write, and never removed
        (the loop would call it at every turn)."""
        register = paho.on_socket_register_write
        paho.on_socket_register_write = None
        try:
            code = paho.publish(topic, payload, 0, retain).rc
        except Exception as exc:  # a broken connection is paho's to report (on_disconnect)
            log.info("%s: publish to %s failed: %s", self.bus.name, topic, exc)
            return False
        finally:
            paho.on_socket_register_write = register
            sock = paho.socket()
            if register is not None and sock is not None and paho.want_write():
                register(paho, paho.user_data_get(), sock)
        if code != mqtt.MQTT_ERR_SUCCESS:
            log.info("%s: publish to %s failed: %s", self.bus.name, topic, mqtt.error_string(code))
            return False
        # paho took the topic (valid, no wildcards): the face may write the next itself
        self._heads[(topic, retain)] = publish_head(topic, retain)
        return True

    async def reply(self, command: Command, reply: dict[str, Any], default: str) -> None:
        topic = command.reply_to or default
        payload = json.dumps(reply).encode()
        if not await self.publish(topic, payload, qos=1):
            self._outbox.append((topic, payload))

    def remember(self, command: Command, reply: dict[str, Any]) -> None:
        if command.id is None:
            return
        key = (command.drive, command.id)
        self._pending.discard(key)
        self._done[key] = reply
        while len(self._done) > KEEP_IDS:
            self._done.popitem(last=False)

    # -- receiving -----------------------------------------------------------------------------
    async def _refuse(
        self, command: Command, error: dict[str, Any], topic: str, what: str | None = None
    ) -> None:
        """Refuse ``command`` (one log line) with an error reply to ``topic``."""
        log_refused(self.bus.name, what or f"{command.name} for {command.drive}", error["message"])
        await self.reply(command, reply_payload(command, error=error), topic)

    async def _message(self, topic: str, payload: bytes, *, retained: bool = False) -> None:
        log.debug("%s: %s %r", self.bus.name, show(topic, 200), payload[:200])
        options = self.options
        try:
            command = parse_command(topic, payload, options.prefix, self.bus.name)
        except ConfigError as exc:
            drive_name = drive_of(topic, options.prefix, self.bus.name)
            if drive_name not in self.workers:
                log.info("%s: ignored %s: %s", self.bus.name, show(topic, 200), exc)
                return
            ident = exc.id if isinstance(exc, CommandError) else None
            bad = Command(drive=drive_name, name="?", id=ident)
            reply_topic = self.workers[drive_name].topics.reply
            await self._refuse(
                bad, error_dict(exc), reply_topic, f"a message on {show(topic, 120)}"
            )
            return
        worker = self.workers.get(command.drive)
        if worker is None:
            log.info("%s: command for unknown drive %s", self.bus.name, show(command.drive))
            return
        if command.reply_to is not None:
            try:
                check_reply_to(command.reply_to, worker.topics, options.discovery_prefix)
            except ConfigError as exc:
                bare = dataclasses.replace(command, reply_to=None)
                await self._refuse(bare, error_dict(exc), worker.topics.reply)
                return
        if retained:
            message = "a retained message never acts: publish commands without the retain flag"
            await self._refuse(command, refusal("Retained", message), worker.topics.reply)
            return
        if self._closing:
            await self._refuse(command, stopping(), worker.topics.reply)
            return
        if command.id is not None:
            key = (command.drive, command.id)
            if key in self._done:
                again = dict(self._done[key], duplicate=True)
                await self.reply(command, again, worker.topics.reply)
                return
            if key in self._pending:
                return  # the first one is still being carried out; it will reply
            self._pending.add(key)
        try:
            worker.queue.put_nowait(command)
        except asyncio.QueueFull:
            if command.id is not None:
                self._pending.discard((command.drive, command.id))
            busy = refusal("Busy", f"{QUEUE} commands wait already", "busy")
            await self._refuse(command, busy, worker.topics.reply)

    # -- the connection ------------------------------------------------------------------------
    def _make_client(self) -> aiomqtt.Client:
        will = aiomqtt.Will(self.availability, "offline", qos=1, retain=True)
        return make_client(self.options, self.client_id, will)

    def _other_gateway(self, message: aiomqtt.Message) -> None:
        """`TakenOver` if ``message``, on the gateway topic, comes from a gateway of this bus
        of a greater generation (retained or live): one started after this one. One of an
        earlier generation, or a retained message of an earlier run, is left to find this
        one's message: the newest gateway keeps the bus, the others stop, whatever order
        their messages come in."""
        instance = instance_of(message)
        if instance is None or instance <= self.instance:
            return
        raise TakenOver(
            f"another gateway of bus {self.bus.name!r}, started after this one, publishes on "
            f"this broker under the prefix {self.options.prefix!r}"
        )

    async def _connected(self, client: aiomqtt.Client) -> _Connected:
        self._client = client
        send_at_once(client)
        # the gateway topic first: its retained message is in before the other subscriptions
        # are granted, so another gateway is found before this one publishes anything
        watch = SubscribeOptions(qos=1, noLocal=False, retainAsPublished=True)
        granted = await client.subscribe(self.gateway_topic, options=watch)
        if any(not_granted(code) for code in granted):
            raise aiomqtt.MqttError(f"the broker refused the subscription to {self.gateway_topic}")
        # in one request: the commands, and the discovery topics of this gateway's drives
        # (their retained messages, to clear those no longer published: `_clear_discovery`)
        commands = subscriptions(self.options.prefix, self.bus.name)
        nodes = self._discovery_filters()
        codes: list[int | ReasonCode] = list(
            await client.subscribe(
                [(topic, SUBSCRIBE) for topic in commands] + [(topic, watch) for topic in nodes]
            )
        )
        for topic, code in zip(commands, codes, strict=False):
            if not_granted(code):
                raise aiomqtt.MqttError(f"the broker refused the subscription to {topic}")
        if any(not_granted(code) for code in codes[len(commands) :]):
            log.warning(
                "%s: the broker refused the subscription to the discovery topics: the "
                "entities of parameters or commands no longer published are not removed",
                self.bus.name,
            )
            nodes = []
        # the gateway topic's retained message is in: granted after it
        early = queued(client)
        gateways = [m for m in early if m.topic.value == self.gateway_topic]
        if not self.instance:  # the first connection: one generation after the newest found
            found = [i for i in map(instance_of, gateways) if i is not None]
            generation = 1 + max(map(generation_of, found), default=0)
            self.instance = f"{generation:020d}-{secrets.token_hex(4)}"
        for message in gateways:
            self._other_gateway(message)
        # the gateway message (its drives: a reader knows them before their messages come),
        # then each drive's state and availability of now, and only then the bus online: a
        # state retained from an earlier run (a crash, a power cut) is never current
        properties = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
        properties.UserProperty = [(INSTANCE, self.instance)]
        await client.publish(
            self.gateway_topic,
            gateway_payload(
                self.bus.name,
                [worker.drive.model for worker in self.workers.values()],
                read_only=self.options.read_only,
                keepalive=self.options.keepalive,
            ),
            qos=1,
            retain=True,
            properties=properties,
        )
        if nodes:  # the retained discovery messages are in once this is granted
            await client.unsubscribe(nodes)
            early += queued(client)
        retained = [m for m in early if under(m.topic.value, self.options.discovery_prefix)]
        # the rest for `_consume`, the gateway messages found here having been looked at
        self._early = [
            m for m in early if m.topic.value != self.gateway_topic and m not in retained
        ]
        now = asyncio.get_running_loop().time()
        states: list[tuple[DriveWorker, DriveState]] = []
        sends = []
        for worker in self.workers.values():
            state = worker.drive.snapshot()
            worker.drop_held()
            worker.connect_state = state
            worker.throttle.sent(state, now)
            worker.published.clear()
            worker.discovery_key = None
            online = "online" if state.online else "offline"
            payload = worker.payloads.payload(state)
            sends.append(client.publish(worker.topics.state, payload, qos=1, retain=True))
            sends.append(client.publish(worker.topics.availability, online, qos=1, retain=True))
            worker.published["availability"] = online
            states.append((worker, state))
        await asyncio.gather(*sends)
        await client.publish(self.availability, "online", qos=1, retain=True)
        self.connected.set()
        self.connections += 1
        for worker, state in states:
            # its parameters and discovery, by its task: the one that publishes what a state
            # needs beside its message, in the order of the states (one that came while
            # connecting and is newer keeps its place)
            pending = worker.latest
            if pending is None or pending.time < state.time:
                worker.latest = state
            worker.wake.set()
        return _Connected(states, retained)

    async def _publish_rest(self, client: aiomqtt.Client, connected: _Connected) -> None:
        """What a connection publishes once the bus is online, beside the message loop (a
        connection lost meanwhile is found by it at once): the discovery messages no longer
        published cleared, the replies that could not be sent."""
        await self._clear_discovery(connected)
        while self._outbox:
            topic, payload = self._outbox[0]
            await client.publish(topic, payload, qos=1)
            self._outbox.popleft()

    def _discovery_filters(self) -> list[str]:
        """The discovery topics of this gateway's drives' devices; none where discovery is off
        (the broker may not let this gateway near Home Assistant's topics)."""
        if not self.options.discovery:
            return []
        return [
            f"{self.options.discovery_prefix}/+/{discovery_node(worker.drive.model)}/+/config"
            for worker in self.workers.values()
        ]

    async def _clear_discovery(self, connected: _Connected) -> None:
        """Clear (an empty retained message: Home Assistant removes the entity) the
        discovery messages found of this gateway's drives that it no longer publishes: a
        parameter taken out of the configuration, the commands of a face now read-only.
        Only messages of this gateway: those whose entities are available through this
        bus's availability topic."""
        published = {
            topic
            for worker, state in connected.states
            for topic, _config in worker.discovery(state)
        }
        for message in connected.discovery:
            topic = message.topic.value
            if topic in published or not of_bus(message.payload, self.availability):
                continue
            if await self.publish(topic, b"", qos=1, retain=True):
                log.info("%s: removed the discovery message %s", self.bus.name, topic)

    async def _consume(self, client: aiomqtt.Client) -> None:
        early, self._early = self._early, []
        for message in early:
            await self._receive(message)
        async for message in client.messages:
            await self._receive(message)

    async def _receive(self, message: aiomqtt.Message) -> None:
        if message.topic.value == self.gateway_topic:
            self._other_gateway(message)  # `TakenOver` ends the session
            return
        if under(message.topic.value, self.options.discovery_prefix):
            return  # a discovery message come after `_connected`: no command
        try:
            payload = message.payload
            data = payload if isinstance(payload, bytes) else str(payload).encode()
            await self._message(message.topic.value, data, retained=bool(message.retain))
        except aiomqtt.MqttError:
            raise  # the connection is lost: `run` reconnects
        except Exception as exc:  # one message never ends the face
            log.error(
                "%s: message on %s: %s",
                self.bus.name,
                show(message.topic.value, 200),
                show(exc, 200),
            )

    async def _session(self) -> None:
        """One connection, from connecting until it is lost (`aiomqtt.MqttError`) or `close`."""
        client = self._make_client()  # a fresh client per connection
        consume: asyncio.Task[None] | None = None
        rest: asyncio.Task[None] | None = None
        try:
            async with client:
                connected = await self._connected(client)
                rest = asyncio.create_task(self._publish_rest(client, connected))
                rest.add_done_callback(_retrieve)
                if self._lost:
                    log.warning(
                        "%s: MQTT broker %s is back (after %d tries)",
                        self.bus.name,
                        self.options.endpoint,
                        self.attempts,
                    )
                else:
                    log.info(
                        "%s: connected to MQTT broker %s", self.bus.name, self.options.endpoint
                    )
                self._lost = False
                self.attempts = 0
                consume = asyncio.create_task(self._consume(client))
                consume.add_done_callback(_retrieve)
                stop = asyncio.create_task(self._stop.wait())
                try:
                    await asyncio.wait({consume, stop}, return_when=asyncio.FIRST_COMPLETED)
                finally:
                    stop.cancel()
                if consume.done():
                    consume.result()  # the connection was lost (MqttError), or `TakenOver`
                # stopping: leaving the block disconnects cleanly
        finally:
            self.connected.clear()
            self._client = None
            for task in (consume, rest):
                if task is not None and not task.done():
                    task.cancel()
            if not self._closing:
                # its sender saw offline (the last will) and may have done otherwise since:
                # a command that waited must not act while, or after, the gateway was away
                await self._refuse_waiting(lost_link())

    async def run(self) -> None:
        """Stay connected until `close`: after a loss, try again after `MqttOptions.reconnect`
        seconds, doubling the wait up to `RECONNECT_MAX`; one log line when the broker is lost,
        one when it is back."""
        wait = self.options.reconnect
        while not self._stop.is_set():
            connections = self.connections
            try:
                await self._session()
            except TakenOver as exc:
                # taking it back would take it from the other, which takes it back in turn:
                # each command would act on whichever gateway holds the session at that
                # moment, a drive of the one or of the other
                self.taken_over = str(exc)
                log.error(
                    "%s: %s: this gateway takes no more commands over MQTT and does not "
                    "connect again until it is restarted",
                    self.bus.name,
                    exc,
                )
                break
            except Exception as exc:  # MqttError, or a broker speaking nonsense
                if self._stop.is_set():
                    break
                if self.connections != connections:
                    wait = self.options.reconnect  # it was connected: start again at 1 s
                self.attempts += 1
                if not self._lost:
                    self._lost = True
                    log.warning(
                        "%s: MQTT broker %s %s; trying again after %g s, then up to every %g s",
                        self.bus.name,
                        self.options.endpoint,
                        lost_reason(exc, connected=self.connections > 0),
                        wait,
                        RECONNECT_MAX,
                    )
                else:
                    log.debug("%s: MQTT broker still unreachable: %s", self.bus.name, exc)
            if not self._stop.is_set():
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(wait):
                        await self._stop.wait()
                wait = min(wait * 2, RECONNECT_MAX)

    async def start(self) -> None:
        for worker in self.workers.values():
            self._removers.append(worker.drive.subscribe(worker.on_state))
            self._tasks.append(asyncio.create_task(worker.states()))
            self._tasks.append(asyncio.create_task(worker.commands()))
        self._runner = asyncio.create_task(self.run(), name=f"mqtt {self.bus.name}")

    async def _refuse_waiting(self, error: dict[str, Any]) -> None:
        """Refuse the commands that wait for their drive, each with a reply (sent, or kept
        for the next connection)."""
        for worker in self.workers.values():
            while not worker.queue.empty():
                command = worker.queue.get_nowait()
                reply = reply_payload(command, error=error)
                self.remember(command, reply)
                await self.reply(command, reply, worker.topics.reply)

    async def _finish(self) -> None:
        """Take no more commands, refuse those waiting and let the one being carried out of
        each drive finish and reply (bounded by `STOP_WAIT`): a client is answered for every
        command, and none is cut off between its check and its telegram."""
        self._closing = True
        await self._refuse_waiting(stopping())
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(STOP_WAIT):
                for worker in self.workers.values():
                    await worker.idle.wait()

    async def close(self) -> None:
        """Finish the commands (`_finish`), stop publishing, publish each drive's last state
        and ``offline``, disconnect."""
        await self._finish()
        for remove in self._removers:
            remove()
        self._removers.clear()
        for worker in self.workers.values():
            worker.drop_held()
        for task in self._tasks:
            task.cancel()
        if self._tasks:
            # bounded: a task inside the MQTT client may take its time to end
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(3):
                    await asyncio.gather(*self._tasks, return_exceptions=True)
        self._tasks.clear()
        client = self._client
        if client is not None and self.connected.is_set():
            with contextlib.suppress(aiomqtt.MqttError, asyncio.TimeoutError):
                async with asyncio.timeout(2):
                    # the retained state is the drive's last one, even when a change came
                    # after the last state the publishing task got out
                    for worker in self.workers.values():
                        state = state_payload(worker.drive.snapshot())
                        await client.publish(worker.topics.state, state, qos=1, retain=True)
                    await client.publish(self.availability, "offline", qos=1, retain=True)
                    for worker in self.workers.values():
                        await client.publish(
                            worker.topics.availability, "offline", qos=1, retain=True
                        )
        self._stop.set()
        runner, self._runner = self._runner, None
        if runner is not None:
            try:
                async with asyncio.timeout(5):
                    await runner
            except (TimeoutError, aiomqtt.MqttError):
                runner.cancel()


def _retrieve(task: asyncio.Task[None]) -> None:
    """Mark the outcome of a finished task as seen (a lost connection is handled by `run`)."""
    if not task.cancelled():
        task.exception()


class MqttFace:
    """The MQTT face of a plant: one `MqttBusFace` per bus."""

    def __init__(self, plant: Plant, options: MqttOptions) -> None:
        self.options = options
        self.buses = {name: MqttBusFace(bus, options) for name, bus in plant.buses.items()}
        ids = [face.client_id for face in self.buses.values()]
        if len(set(ids)) != len(ids):
            raise ConfigError("mqtt.client_id: must contain {bus}, one session per bus")

    async def start(self) -> None:
        for face in self.buses.values():
            await face.start()

    async def close(self) -> None:
        for face in self.buses.values():
            await face.close()
