"""The sessions of the OPC UA face's server (`pyuss.gateway.opcua`), over asyncua's.

Access is per session (OPC UA Part 4 5.6): every request is served by the session its
authentication token names, so several sessions on one secure channel (as node-opcua opens
them) keep their own users and subscriptions (`SessionProcessor`, which also keeps each
session's Publish requests for its own subscriptions, Part 4 5.13.5); the tokens are random,
so no client can name another's session (`SessionServer`). A Write or Call that waited in
the connection's queue longer than its TimeoutHint is not carried out (BadTimeout, Part 4
7.28). `current_user` is the user of the session whose request is being served; `Users`
signs clients in (``users``, ``anonymous``), `Rules` lets every signed-in client use the
services (the face checks writes and calls).
"""

from __future__ import annotations

import contextvars
import hmac
import logging
import secrets
import time
from collections import deque
from typing import Any

from asyncua import Server, ua
from asyncua.common.utils import ServiceError
from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, User, UserRole
from asyncua.server.binary_server_asyncio import BinaryServer, OPCUAProtocol
from asyncua.server.uaprocessor import PublishRequestData, UaProcessor
from asyncua.server.user_managers import UserManager
from asyncua.ua.ua_binary import struct_from_binary

from pyuss._tasks import cancel_and_wait
from pyuss.gateway.options import OpcuaOptions

__all__ = ["Rules", "SessionProcessor", "SessionServer", "Users", "current_user"]

log = logging.getLogger("pyuss.gateway.opcua")

current_user: contextvars.ContextVar[User | None] = contextvars.ContextVar(
    "pyuss_opcua_user", default=None
)
"""The user of the session whose request is being served (None: no activated session)."""


class Users(UserManager):  # type: ignore[misc]
    def __init__(self, options: OpcuaOptions) -> None:
        self.options = options

    def get_user(
        self,
        iserver: Any,
        username: str | None = None,
        password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        if username is None:
            if self.options.anonymous == "none":
                return None
            return User(role=UserRole.Anonymous)
        expected = self.options.users.get(username)
        if expected is None or password is None:
            return None
        if not hmac.compare_digest(expected.encode(), password.encode()):
            return None
        return User(role=UserRole.User, name=username)


_ANONYMOUS = User(role=UserRole.Anonymous)


class Rules(PermissionRuleset):  # type: ignore[misc]
    """Lets every signed-in client use the services (the face checks writes and calls)."""

    def __init__(self) -> None:
        self._allowed = {ua.NodeId(t) for t in USER_TYPES}

    def check_validity(self, user: User, action_type_id: ua.NodeId, body: Any) -> bool:
        return user.role is UserRole.Admin or action_type_id in self._allowed


_NO_SESSION = {
    ua.NodeId(code)
    for code in (
        ua.ObjectIds.CreateSessionRequest_Encoding_DefaultBinary,
        ua.ObjectIds.FindServersRequest_Encoding_DefaultBinary,
        ua.ObjectIds.GetEndpointsRequest_Encoding_DefaultBinary,
        ua.ObjectIds.RegisterServerRequest_Encoding_DefaultBinary,
        ua.ObjectIds.RegisterServer2Request_Encoding_DefaultBinary,
        ua.ObjectIds.CloseSecureChannelRequest_Encoding_DefaultBinary,
    )
}
_CREATE = ua.NodeId(ua.ObjectIds.CreateSessionRequest_Encoding_DefaultBinary)
_CLOSE = ua.NodeId(ua.ObjectIds.CloseSessionRequest_Encoding_DefaultBinary)
_ACTING = {
    ua.NodeId(ua.ObjectIds.WriteRequest_Encoding_DefaultBinary),
    ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary),
}
"""The services that may change a drive."""
_PUBLISH = ua.NodeId(ua.ObjectIds.PublishRequest_Encoding_DefaultBinary)


class SessionProcessor(UaProcessor):  # type: ignore[misc]
    """asyncua's processor of one connection, with each request served by the session its
    authentication token names (Part 4 5.6): asyncua's own keeps one session per connection,
    so a second session on the same secure channel (as node-opcua opens them) would lend its
    user to the first. A token of no session of this channel is served by none (refused),
    except ActivateSession, which may move a live session here (Part 4 5.6.3).

    A Write or Call that waited in the connection's queue longer than its TimeoutHint is
    not carried out (BadTimeout, Part 4 7.28): its client has given up on it.

    Publish requests are kept per session too: a subscription's notifications answer a
    Publish of the session that owns it (Part 4 5.13.5), where asyncua's would answer any
    session's on the channel, which the other session's client drops."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.sessions: dict[ua.NodeId, Any] = {}
        self.arrived: float | None = None
        """When the message being served arrived (`_Protocol`)."""

    def stale(self, requesthdr: Any) -> bool:
        hint = requesthdr.TimeoutHint
        waited = 0.0 if self.arrived is None else time.monotonic() - self.arrived
        return bool(hint) and waited > hint / 1000

    async def _process_message(self, typeid: Any, requesthdr: Any, seqhdr: Any, body: Any) -> Any:
        if typeid in _ACTING and self.stale(requesthdr):
            log.info("a request waited longer than its client waits for it: not carried out")
            raise ServiceError(ua.StatusCodes.BadTimeout)
        if typeid not in _NO_SESSION:
            self.session = self.sessions.get(requesthdr.AuthenticationToken)
        session: Any = self.session if typeid != _CREATE else None
        active = session is not None and session.is_activated()
        current_user.set(session.user if active else None)
        try:
            if typeid == _PUBLISH and active:
                await self._publish(session, requesthdr, seqhdr, body)
                return True
            return await super()._process_message(typeid, requesthdr, seqhdr, body)
        finally:
            if self.session is not None:
                if typeid == _CLOSE:
                    self.sessions.pop(self.session.auth_token, None)
                else:
                    self.sessions[self.session.auth_token] = self.session
            current_user.set(None)

    def _owned(self, session: Any) -> dict[int, Any]:
        """The subscriptions of ``session`` by id."""
        subscriptions = self.iserver.subscription_service.subscriptions
        return {i: s for i, s in subscriptions.items() if s.session_id == session.session_id}

    def _owner(self, subscription_id: int) -> ua.NodeId | None:
        """The token of the session of this channel that owns the subscription."""
        sub = self.iserver.subscription_service.subscriptions.get(subscription_id)
        for token, session in self.sessions.items():
            if sub is not None and session.session_id == sub.session_id:
                return token
        return None

    async def _publish(self, session: Any, requesthdr: Any, seqhdr: Any, body: Any) -> None:
        """A Publish request of ``session``, as asyncua serves one, for its own subscriptions
        only."""
        self.session_last_activity = time.monotonic()
        session.touch()
        params = struct_from_binary(ua.PublishParameters, body)
        owned = self._owned(session)
        if not owned:
            raise ServiceError(ua.StatusCodes.BadNoSubscription)
        results: list[ua.StatusCode] = []
        for ack in params.SubscriptionAcknowledgements or []:
            sub = owned.get(ack.SubscriptionId)
            if sub is None:
                results.append(ua.StatusCode(ua.StatusCodes.BadSubscriptionIdInvalid))
            else:
                sub.publish([ack.SequenceNumber])
                results.append(ua.StatusCode())
        data = PublishRequestData(requesthdr=requesthdr, seqhdr=seqhdr, results=results)
        token = requesthdr.AuthenticationToken
        for subscription_id in [i for i in self._publish_results_subs if i in owned]:
            del self._publish_results_subs[subscription_id]
            if await owned[subscription_id].publish_results(data):
                return  # answered at once with what was waiting
        mine = [d for d in self._publish_requests if d.requesthdr.AuthenticationToken == token]
        if len(mine) >= self.publish_request_limit(len(owned)):
            self._publish_requests.remove(mine[0])
            fault = ua.ServiceFault()
            fault.ResponseHeader.ServiceResult = ua.StatusCode(
                ua.StatusCodes.BadTooManyPublishRequests
            )
            self.send_response(mine[0].requesthdr.RequestHandle, mine[0].seqhdr, fault)
        self._publish_requests.append(data)

    def get_publish_request(self, subscription_id: int) -> Any:
        """The oldest Publish request of the subscription's session still waited for; None
        (the subscription waits for the next) without one."""
        owner = self._owner(subscription_id)
        now = time.monotonic()
        for data in list(self._publish_requests):
            if data.requesthdr.AuthenticationToken != owner:
                continue
            self._publish_requests.remove(data)
            if not data.has_timed_out(now):
                return data
            self._send_publish_request_timeout(data)
        self._publish_results_subs[subscription_id] = True
        return None

    async def close(self) -> None:
        others = [s for s in self.sessions.values() if s is not self.session]
        await super().close()
        for session in others:
            self.session = session
            if self._should_close_session_on_transport_loss():
                await session.close_session(True)


class _Protocol(OPCUAProtocol):  # type: ignore[misc]
    """asyncua's connection, serving with `SessionProcessor` and telling it when each
    message arrived."""

    processor: Any

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.arrivals: deque[float] = deque()

    def data_received(self, data: bytes) -> None:
        now = time.monotonic()
        queued = self.messages.qsize()
        super().data_received(data)
        self.arrivals.extend([now] * (self.messages.qsize() - queued))

    async def _process_one_msg(self, header: Any, buf: Any) -> bool:
        if self.arrivals and self.processor is not None:
            self.processor.arrived = self.arrivals.popleft()
        done: bool = await super()._process_one_msg(header, buf)
        return done

    def connection_made(self, transport: Any) -> None:
        super().connection_made(transport)
        if self.processor is not None:
            processor = SessionProcessor(self.iserver, self.transport, self.limits)
            processor.set_policies(self.policies)
            self.processor = processor


class _Listener(BinaryServer):  # type: ignore[misc]
    def _make_protocol(self) -> _Protocol:
        return _Protocol(
            iserver=self.iserver,
            policies=self._policies,
            clients=self.clients,
            closing_tasks=self.closing_tasks,
            limits=self.limits,
        )


class SessionServer(Server):  # type: ignore[misc]
    """asyncua's server listening with `SessionProcessor` (as ``Server.start`` does), its
    clients' sessions named by random authentication tokens: asyncua numbers them one after
    the other, so a client could name the next client's session in an ActivateSession on its
    own channel and take it over (Part 4 5.6.2: the token is a secret)."""

    async def start(self) -> None:
        iserver = self.iserver
        create = iserver.create_session

        def create_session(name: str, user: User = _ANONYMOUS, external: bool = False) -> Any:
            session = create(name, user=user, external=external)
            if external:
                iserver.unregister_external_session(session)
                session.auth_token = ua.NodeId(secrets.token_bytes(32), 0, ua.NodeIdType.ByteString)
                iserver.register_external_session(session)
            return session

        iserver.create_session = create_session
        await self._setup_server_nodes()
        await self.iserver.start()
        host, port = self._get_bind_socket_info()
        self.bserver = _Listener(self.iserver, host, port, self.limits)
        self.bserver.set_policies(self._policies)
        try:
            await self.bserver.start()
        except Exception:
            await self.iserver.stop()
            raise

    async def stop(self) -> None:
        # The server's clock writes CurrentTime once a second, and asyncua's stop waits for
        # its next tick: up to a second more for every stop of the face. It ends at once.
        clock = self.iserver.time_task
        if clock is not None:
            await cancel_and_wait(clock)
            self.iserver.time_task = None
        await super().stop()
