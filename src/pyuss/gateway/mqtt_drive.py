"""One drive of the MQTT face (`pyuss.gateway.mqtt`): its worker publishes the drive's states
and carries out its commands in order.

- States go out retained whenever a drive's state changes, through the drive's
  `pyuss.gateway.payloads.StateThrottle`: at once when anything but the actual values changed,
  else at most ``max_rate`` a second (the newest one) and only for a move of ``deadband`` or
  more; parameters when they were read. Each state message is built from the parts of the
  state that changed (`pyuss.gateway.payloads.StatePayloads`). A state that needs nothing
  else published is written from the drive model's callback itself, no task woken
  (`DriveWorker.on_state`, through the face's `BusFace.publish_now`).
- Commands of one drive are carried out one after the other, in order, by a task of that
  drive (`pyuss.gateway.mqtt_commands.carry_out`), so the message loop never waits for a
  drive; at most `QUEUE` wait.
"""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any, Protocol

from pyuss.gateway.homeassistant import discovery
from pyuss.gateway.mqtt_commands import carry_out
from pyuss.gateway.options import MqttOptions
from pyuss.gateway.payloads import StatePayloads, StateThrottle, param_payload
from pyuss.gateway.topics import Command, DriveTopics
from pyuss.points.drive import DrivePoints
from pyuss.points.plant import BusPoints
from pyuss.points.state import DriveState, ParamValue

__all__ = ["QUEUE", "BusFace", "DriveWorker"]

log = logging.getLogger("pyuss.gateway.mqtt")

QUEUE = 100
"""Commands waiting per drive; more are answered with a refusal."""


class BusFace(Protocol):
    """What a drive's worker uses of its bus's MQTT client (`pyuss.gateway.mqtt.MqttBusFace`)."""

    bus: BusPoints
    options: MqttOptions
    connected: asyncio.Event
    """Set while the client is connected."""

    def publish_now(self, topic: str, payload: bytes | str) -> bool:
        """A retained QoS 0 message written in this turn of the loop; False: not sent."""
        ...

    async def publish(
        self, topic: str, payload: bytes | str, *, qos: int = 1, retain: bool = False
    ) -> bool:
        """Publish if connected; False if it could not be sent."""
        ...

    async def reply(self, command: Command, reply: dict[str, Any], default: str) -> None:
        """Send the reply to ``command`` (to its reply topic, else ``default``)."""
        ...

    def remember(self, command: Command, reply: dict[str, Any]) -> None:
        """Keep the reply to a command with an id, for its repeats."""
        ...


_Due = tuple[str | None, list[tuple[str, ParamValue]], tuple[object, object] | None]
"""What a state needs published beside its state message (`DriveWorker._due`)."""


class DriveWorker:
    """Publishes one drive's states and carries out its commands in order.

    Each new state goes through the drive's `StateThrottle` (``max_rate``, ``deadband`` of
    `MqttOptions`): published at once when a status bit, a fault, what was sent, a parameter
    or the availability changed; when only actual values changed, at most ``max_rate`` a
    second, the newest one held until its time comes (`on_state`, `_release`). A state to
    publish that changes nothing but the state message - most of them, while a drive runs -
    is written at once from the drive model's callback (`send`), no task woken; the rest
    (availability, a parameter, discovery; a state while not connected or while the task
    publishes) is left to the task (`states`), which publishes the newest."""

    def __init__(self, face: BusFace, drive: DrivePoints) -> None:
        self.face = face
        self.drive = drive
        self.topics = DriveTopics(face.options.prefix, drive.model.bus, drive.name)
        self.queue: asyncio.Queue[Command] = asyncio.Queue(QUEUE)
        self.published: dict[str, Any] = {}
        self.discovery_key: object = None
        self.payloads = StatePayloads()
        self.idle = asyncio.Event()
        """Set while no command is being carried out (and its reply sent)."""
        self.idle.set()
        self.latest: DriveState | None = None
        """The newest state the task is to publish (`on_state`)."""
        self.wake = asyncio.Event()
        self.publishing = False
        options = face.options
        self.throttle = StateThrottle(
            1.0 / options.max_rate if options.max_rate else 0.0, options.deadband
        )
        self.held: DriveState | None = None
        """The newest state the throttle holds back until `timer` publishes it."""
        self.timer: asyncio.TimerHandle | None = None
        self.connect_state: DriveState | None = None
        """The state published at the connection (`pyuss.gateway.mqtt.MqttBusFace._connected`)."""

    def on_state(self, state: DriveState) -> None:
        """The drive model's subscriber (see the class docstring)."""
        loop = asyncio.get_running_loop()
        now = loop.time()
        wait = self.throttle.offer(state, now)
        if wait is None:  # no newer than what was published: nothing to publish
            self.drop_held()
        elif wait > 0:
            self.held = state
            if self.timer is None:
                self.timer = loop.call_at(now + wait, self._release)
        else:
            self.drop_held()
            self.send(state, now)

    def drop_held(self) -> None:
        """Forget the state held back, and its timer."""
        self.held = None
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None

    def _release(self) -> None:
        """The held state's time has come."""
        self.timer = None
        state, self.held = self.held, None
        if state is not None:
            self.send(state, asyncio.get_running_loop().time())

    def send(self, state: DriveState, now: float) -> None:
        """Publish ``state`` now (see the class docstring)."""
        self.throttle.sent(state, now)
        if (
            self.publishing
            or self.wake.is_set()
            or self._due(state) is not None
            or not self.face.publish_now(self.topics.state, self.payloads.payload(state))
        ):
            self.latest = state
            self.wake.set()

    def _due(self, state: DriveState) -> _Due | None:
        """What ``state`` needs published beside its state message, of what was not
        published yet: its availability, parameter readings, discovery signature (where
        discovery is on). None: nothing."""
        published = self.published
        online = "online" if state.online else "offline"
        availability = None if published.get("availability") == online else online
        parameters = []
        for key, reading in state.parameters.items():  # (a loop: no comprehension to call)
            if reading.time is not None and published.get(key) != (reading.value, reading.time):
                parameters.append((key, reading))
        signature: tuple[object, object] | None = (state.reference, state.model.unit)
        if not self.face.options.discovery or signature == self.discovery_key:
            signature = None
        if availability is None and not parameters and signature is None:
            return None
        return availability, parameters, signature

    async def publish_state(self, state: DriveState) -> None:
        """``state`` and what it needs published beside (`_due`); its message only if it is
        not the one published at the connection already
        (`pyuss.gateway.mqtt.MqttBusFace._connected`)."""
        face = self.face
        if state is not self.connect_state:
            await face.publish(self.topics.state, self.payloads.payload(state), qos=0, retain=True)
        due = self._due(state)
        if due is None:
            return
        online, parameters, signature = due
        if online is not None and await face.publish(
            self.topics.availability, online, qos=1, retain=True
        ):
            self.published["availability"] = online
        for key, reading in parameters:
            if await face.publish(self.topics.param(key), param_payload(reading), retain=True):
                self.published[key] = (reading.value, reading.time)
        if signature is not None and await self.publish_discovery(state):
            self.discovery_key = signature

    def discovery(self, state: DriveState) -> list[tuple[str, dict[str, Any]]]:
        """The drive's discovery messages (`pyuss.gateway.homeassistant.discovery`)."""
        options = self.face.options
        return discovery(
            self.drive.model,
            state,
            prefix=options.prefix,
            discovery_prefix=options.discovery_prefix,
            read_only=options.read_only,
        )

    async def publish_discovery(self, state: DriveState) -> bool:
        """Publish the drive's discovery messages, all at once (one round trip to the broker,
        not one per entity)."""
        sent = await asyncio.gather(
            *(
                self.face.publish(topic, json.dumps(config), qos=1, retain=True)
                for topic, config in self.discovery(state)
            )
        )
        return all(sent)

    async def states(self) -> None:
        while True:
            await self.wake.wait()
            await self.face.connected.wait()
            self.wake.clear()
            state, self.latest = self.latest, None
            if state is None:
                continue
            self.publishing = True
            try:
                await self.publish_state(state)
            finally:
                self.publishing = False

    async def commands(self) -> None:
        while True:
            self.idle.set()
            command = await self.queue.get()
            self.idle.clear()
            reply = await carry_out(
                self.drive, command, read_only=self.face.options.read_only, bus=self.face.bus.name
            )
            self.face.remember(command, reply)
            try:
                await self.face.reply(command, reply, self.topics.reply)
            except Exception as exc:  # the drive's next command is served
                log.error("%s: reply to %s failed: %r", self.drive.key, command.name, exc)
