"""The MQTT client of the MQTT face (`pyuss.gateway.mqtt`) and what it takes of aiomqtt and
paho-mqtt below their public calls:

- `make_client`: an MQTT 5 client with a clean start and no session kept (the broker keeps
  nothing for it while it is away), TLS and user/password from `MqttOptions`;
- `send_at_once`: its socket sends each packet at once (no Nagle delay behind the broker's
  acknowledgement of the packet before);
- `publish_head`, `publish_packet`: the PUBLISH packet of a QoS 0 message (MQTT 5.0 3.3),
  which the face writes to the socket itself once paho has taken its topic;
- `queued`: the messages the client has received and nobody has taken yet;
- `not_granted`, `lost_reason`: a subscription the broker refused, and what became of the
  broker when the connection failed (for the log line);
- `INSTANCE`, `instance_of`, `generation_of`: the token of a gateway in its gateway message,
  and `TakenOver`, raised when a gateway of the same bus started after this one publishes.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import ssl

import aiomqtt
from aiomqtt.exceptions import MqttConnectError
from paho.mqtt.reasoncodes import ReasonCode
from paho.mqtt.subscribeoptions import SubscribeOptions

from pyuss.errors import UssError
from pyuss.gateway.options import MqttOptions
from pyuss.gateway.topics import show

__all__ = [
    "INSTANCE",
    "SUBSCRIBE",
    "TakenOver",
    "generation_of",
    "instance_of",
    "lost_reason",
    "make_client",
    "not_granted",
    "publish_head",
    "publish_packet",
    "queued",
    "send_at_once",
]

client_log = logging.getLogger("pyuss.gateway.mqtt.client")
"""The MQTT client's own messages; its "pending publish calls" notes are normal when many
drives change at once (each drive waits for its own publish), so only errors are shown."""
client_log.setLevel(logging.ERROR)

SUBSCRIBE = SubscribeOptions(qos=1, noLocal=True, retainAsPublished=True)
"""Command subscriptions: QoS 1; what the face publishes never comes back to it; a retained
command keeps its retain flag whenever it is delivered."""


def _tls(options: MqttOptions) -> ssl.SSLContext | None:
    if not options.tls:
        return None
    context = ssl.create_default_context(cafile=options.ca)
    if options.cert is not None:
        context.load_cert_chain(options.cert, options.key)
    if options.insecure:
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
    return context


def make_client(
    options: MqttOptions, identifier: str, will: aiomqtt.Will | None = None
) -> aiomqtt.Client:
    """An MQTT 5 client for ``options`` (broker, user, password, TLS, keep-alive) with a clean
    start and no session expiry: the broker keeps nothing for it while it is away."""
    return aiomqtt.Client(
        options.endpoint.host,
        options.endpoint.port,
        username=options.username,
        password=options.password,
        identifier=identifier,
        protocol=aiomqtt.ProtocolVersion.V5,
        clean_start=True,  # and no session expiry: nothing is kept while away
        keepalive=options.keepalive,
        will=will,
        tls_context=_tls(options),
        timeout=10,
        logger=client_log,
    )


def send_at_once(client: aiomqtt.Client) -> None:
    """Turn Nagle's algorithm off on a connected client's TCP socket (``TCP_NODELAY``): a
    state, command or reply goes out when it is made, not held until the broker acknowledged
    the one before (with the peer's delayed acknowledgement, some 40 ms each time). A socket
    that is no TCP socket (websockets) is left as it is."""
    paho = getattr(client, "_client", None)  # aiomqtt's paho client
    sock = paho.socket() if paho is not None else None
    if isinstance(sock, socket.socket) and sock.family in (socket.AF_INET, socket.AF_INET6):
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class TakenOver(UssError):
    """Another gateway of the same bus (prefix and bus name) publishes on the broker."""


INSTANCE = "pyuss-gateway"
"""The MQTT 5 user property of the gateway message that tells one gateway's from another's
and the newer from the older (`MqttBusFace.instance`)."""


def instance_of(message: aiomqtt.Message) -> str | None:
    """The token of the gateway that published ``message`` (None: none said)."""
    for name, value in getattr(message.properties, "UserProperty", None) or ():
        if name == INSTANCE:
            return str(value)
    return None


def generation_of(instance: str) -> int:
    """The generation of a gateway's `INSTANCE` token (0: none that can be read)."""
    digits = instance.partition("-")[0]
    if len(digits) != 20 or not (digits.isascii() and digits.isdigit()):
        return 0
    return min(int(digits), 10**20 - 2)  # (one more must still be 20 digits)


def queued(client: aiomqtt.Client) -> list[aiomqtt.Message]:
    """The messages ``client`` has received and nobody has taken yet (aiomqtt's queue)."""
    queue = getattr(client, "_queue", None)
    taken: list[aiomqtt.Message] = []
    while isinstance(queue, asyncio.Queue):
        try:
            taken.append(queue.get_nowait())
        except asyncio.QueueEmpty:
            break
    return taken


def publish_head(topic: str, retain: bool) -> tuple[int, bytes]:
    """The first byte of an MQTT 5 PUBLISH packet of QoS 0 (MQTT 5.0 3.3.1), and what follows
    its remaining length up to the payload: the topic name and no properties (3.3.2)."""
    name = topic.encode()
    return 0x30 | retain, len(name).to_bytes(2, "big") + name + b"\x00"


def publish_packet(head: tuple[int, bytes], payload: bytes) -> bytes:
    """A PUBLISH packet of `publish_head` and ``payload``: the remaining length is a
    variable byte integer (MQTT 5.0 1.5.5)."""
    first, rest = head
    length = len(rest) + len(payload)
    size = bytearray([first])
    while True:
        length, byte = divmod(length, 128)
        size.append(byte | 0x80 if length else byte)
        if not length:
            return bytes(size) + rest + payload


def not_granted(code: int | ReasonCode) -> bool:
    """A subscription the broker did not grant (MQTT 5 reason code 80h and above)."""
    return (code.value if isinstance(code, ReasonCode) else code) >= 0x80


def lost_reason(exc: Exception, *, connected: bool) -> str:
    """What became of the broker, for the log line: it refused the connection (the login, the
    client id: the CONNACK's reason), or it is lost or unreachable, and why."""
    if isinstance(exc, MqttConnectError):
        return f"refused the connection ({exc})"
    return f"{'lost' if connected else 'unreachable'}: {show(exc, 200)}"
