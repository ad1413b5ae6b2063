"""The MQTT contract for the tests: the JSON Schema files shipped in the package
(``pyuss/gateway/schemas``, read with importlib.resources as another program would find
them), checked with jsonschema, and `Recorder`, a client that keeps every message the
gateway publishes on a broker so that the `broker` fixture checks each against the schema
of its topic."""

from __future__ import annotations

import functools
import json
import threading
from importlib import resources
from typing import Any

import paho.mqtt.client as paho
from jsonschema import Draft202012Validator
from referencing import Registry, Resource

from pyuss.gateway.topics import COMMAND_NAMES

SCHEMAS = resources.files("pyuss.gateway") / "schemas"
KINDS = ("availability", "gateway", "state", "param", "reply", "command", "param_set")
"""The schema of each kind of message; ``common`` holds what they share."""


def load(name: str) -> dict[str, Any]:
    """The schema ``NAME.json`` as shipped."""
    data: dict[str, Any] = json.loads((SCHEMAS / f"{name}.json").read_text(encoding="utf-8"))
    return data


def _registry() -> Registry:
    names = [entry.name for entry in SCHEMAS.iterdir() if entry.name.endswith(".json")]
    return Registry().with_resources(
        (name, Resource.from_contents(load(name.removesuffix(".json")))) for name in names
    )


REGISTRY = _registry()


@functools.cache
def validator(name: str) -> Draft202012Validator:
    """The validator of ``NAME`` (``state``) or of a definition (``command#/$defs/run``);
    references resolve to the other files by name, as they do beside each other on disk."""
    file, _, pointer = name.partition("#")
    schema: dict[str, Any] = {"$ref": f"{file}.json#{pointer}"} if pointer else load(file)
    return Draft202012Validator(schema, registry=REGISTRY)


def problems(name: str, instance: object) -> list[str]:
    """What breaks the schema ``name`` (empty: valid)."""
    return [
        f"{'/'.join(map(str, error.absolute_path)) or '(payload)'}: {error.message}"
        for error in validator(name).iter_errors(instance)
    ]


def schema_of(topic: str, prefix: str = "uss") -> str | None:
    """The schema of a message on ``topic`` of the contract (None: not a topic of it)."""
    levels = topic.split("/")
    if levels[0] != prefix or len(levels) < 3:
        return None
    rest = levels[2:]
    if rest == ["availability"] or rest[1:] == ["availability"]:
        return "availability"
    if rest == ["gateway"]:
        return "gateway"
    if len(rest) < 2:
        return None
    if rest[1:] == ["state"]:
        return "state"
    if rest[1] == "reply":
        return "reply"
    if rest[1] == "cmd" and len(rest) == 3:
        return f"command#/$defs/{rest[2]}"
    if rest[1] == "param" and len(rest) == 3:
        return "param"
    if rest[1] == "param" and len(rest) == 4 and rest[3] in ("set", "get"):
        return "param_set" if rest[3] == "set" else "command#/$defs/param_get"
    return None


def payload_value(payload: bytes, schema: str) -> object:
    """A payload as the schema sees it: availability is plain text; a command is the JSON
    value it parses to, else its text (an empty payload: null); what the gateway publishes
    otherwise is JSON."""
    text = payload.decode("utf-8")
    if schema == "availability":
        return text
    if schema.startswith(("command", "param_set")):
        text = text.strip()
        if not text:
            return None
        try:
            return json.loads(text)
        except json.JSONDecodeError:
            return text
    return json.loads(text)


def check(topic: str, payload: bytes) -> list[str]:
    """What breaks the schema of ``topic`` in ``payload`` (empty: valid or not a topic of
    the contract)."""
    schema = schema_of(topic)
    if schema is None:
        return []
    if schema.startswith("command#/$defs/") and topic.split("/")[-2] == "cmd":
        name = schema.rsplit("/", 1)[1]
        if name not in COMMAND_NAMES:
            return [f"{topic}: {name} is no command of the contract"]
    try:
        value = payload_value(payload, schema)
    except ValueError as exc:  # not UTF-8, not JSON
        return [f"{topic}: {exc}"]
    return [f"{topic}: {problem}" for problem in problems(schema, value)]


OUTPUTS = ("availability", "gateway", "state", "param", "reply")
"""The kinds of message the gateway publishes (the others it receives)."""


class Recorder:
    """A paho client subscribed to ``uss/#`` on a broker (again after every reconnection,
    as the broker may be restarted) that keeps what the gateway publishes: every message
    on a topic whose schema is one of `OUTPUTS`."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.messages: list[tuple[str, bytes]] = []
        self.subscribed = threading.Event()
        client = paho.Client(paho.CallbackAPIVersion.VERSION2)
        client.on_connect = self._on_connect
        client.on_subscribe = lambda *_: self.subscribed.set()
        client.on_message = self._on_message
        client.reconnect_delay_set(0.05, 0.5)
        self.client = client

    def _on_connect(self, client: paho.Client, *_: object) -> None:
        client.subscribe("uss/#", qos=1)

    def _on_message(self, _client: paho.Client, _data: object, message: paho.MQTTMessage) -> None:
        schema = schema_of(message.topic)
        if schema is not None and schema.split("#")[0] in OUTPUTS:
            self.messages.append((message.topic, bytes(message.payload)))

    def start(self) -> None:
        self.client.connect("127.0.0.1", self.port)
        self.client.loop_start()
        if not self.subscribed.wait(10):
            raise RuntimeError("the recording client did not subscribe")

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()

    def problems(self) -> list[str]:
        """What breaks the contract among the recorded messages."""
        return [problem for topic, payload in self.messages for problem in check(topic, payload)]
