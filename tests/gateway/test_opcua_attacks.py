"""What the OPC UA face does with requests it must not follow, with real clients (asyncua's
and node-opcua's) against simulated drives: rights are per session, however many sessions
share a secure channel (OPC UA Part 4 5.6); the access levels a session reads say what that
session may do (Part 3 5.6.2); wrong types, argument counts and non-finite values are refused
with Part 4's status codes; a read-only face refuses every change. Each test watches the line:
no telegram that would move a drive goes out for a refused request, and a well-behaved client
is served afterwards."""

from __future__ import annotations

import asyncio
import json
import math
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from asyncua import Client, ua

from gateway.harness import OpcuaClient, simulated_gateway
from pyuss.gateway.run import Gateway
from support.line import LineRecord

NODE_OPCUA = "node-opcua-client@2.182.2"


class LineWatch(LineRecord):
    """The telegrams the gateway sent one simulated drive, from now on: the process data of
    each and the parameter jobs that change something."""

    async def nothing_moved(self) -> None:
        """Some telegrams went out since the watch began (refused requests had their chance
        to show), all with the process data of the first and no changing parameter job."""
        await self.telegrams()
        assert set(self.pzd) == {self.pzd[0]}, "a refused request changed the process data"
        assert self.changes == [], "a refused request sent a parameter change"


def node(client: Client, ns: int, path: str, address: int = 5) -> Any:
    return client.get_node(ua.NodeId(f"bus.drive{address}{path}", ns))


async def write_status(
    target: Any, variant: ua.Variant, index_range: str | None = None, status: int = 0
) -> int:
    """The status code of one Write of ``variant`` (with ``status``) to ``target``'s value."""
    item = ua.WriteValue(
        NodeId=target.nodeid,
        AttributeId=ua.AttributeIds.Value,
        Value=ua.DataValue(variant, StatusCode=ua.StatusCode(status)),
        IndexRange=index_range,
    )
    (result,) = await target.session.write(ua.WriteParameters(NodesToWrite=[item]))
    code: int = result.value
    return code


async def call_result(client: Client, ns: int, method: str, *args: Any, on: int = 5) -> Any:
    """The CallMethodResult of drive 5's ``method`` called on drive ``on``'s object."""
    request = ua.CallMethodRequest(
        ObjectId=ua.NodeId(f"bus.drive{on}", ns),
        MethodId=ua.NodeId(f"bus.drive5.{method}", ns),
        InputArguments=list(args),
    )
    (result,) = await client.uaclient.call([request])
    return result


async def access(target: Any) -> tuple[int, int]:
    """AccessLevel and UserAccessLevel of ``target`` for the session that reads them."""
    level = (await target.read_attribute(ua.AttributeIds.AccessLevel)).Value.Value
    user = (await target.read_attribute(ua.AttributeIds.UserAccessLevel)).Value.Value
    return level, user


async def executable(target: Any) -> tuple[bool, bool]:
    level = (await target.read_attribute(ua.AttributeIds.Executable)).Value.Value
    user = (await target.read_attribute(ua.AttributeIds.UserExecutable)).Value.Value
    return level, user


READ = ua.AccessLevel.CurrentRead.mask
READ_WRITE = READ | ua.AccessLevel.CurrentWrite.mask
SETPOINT_25 = ua.Variant(25.0, ua.VariantType.Double)


def url(gateway: Gateway) -> str:
    options = gateway.config.opcua
    assert options is not None
    return f"opc.tcp://127.0.0.1:{options.endpoint.port}"


async def test_an_anonymous_session_keeps_its_rights_beside_an_operator_one_on_its_channel() -> (
    None
):
    async with simulated_gateway(opcua=True) as (gateway, engines):
        client = Client(url(gateway), timeout=10)
        await client.connect()  # an anonymous session
        try:
            ns = await client.get_namespace_index("urn:pyuss:gateway")
            session = client.uaclient.session
            anonymous = session.authentication_token
            await client.create_session()  # a second session on the same secure channel
            await client.activate_session(username="operator", password="secret")
            operator = session.authentication_token
            assert operator != anonymous
            watch = LineWatch(engines[5])
            session.restore_authentication_token(anonymous)
            setpoint = node(client, ns, ".Setpoint.main")
            assert await write_status(setpoint, SETPOINT_25) == ua.StatusCodes.BadUserAccessDenied
            off2 = await call_result(client, ns, "Off2")
            assert off2.StatusCode.value == ua.StatusCodes.BadUserAccessDenied
            assert await access(setpoint) == (READ_WRITE, READ)
            assert await executable(node(client, ns, ".Off2")) == (True, False)
            await watch.nothing_moved()
            assert engines[5].drive.value(3) == 0
            # the operator's session, on the same channel, has its own rights
            session.restore_authentication_token(operator)
            assert await access(setpoint) == (READ_WRITE, READ_WRITE)
            assert await executable(node(client, ns, ".Off2")) == (True, True)
            assert (await call_result(client, ns, "On")).StatusCode.is_good()
            assert await write_status(setpoint, SETPOINT_25) == ua.StatusCodes.Good
            assert engines[5].drive.value(3) == 2500
            # a token of no session of this channel is served by none
            session.restore_authentication_token(ua.NodeId(123456789))
            with pytest.raises(ua.UaStatusCodeError):
                await setpoint.read_value()
            session.restore_authentication_token(operator)
        finally:
            await client.disconnect()


def next_token(token: ua.NodeId) -> ua.NodeId:
    """The token after ``token`` if tokens were counted (as asyncua counts them)."""
    if isinstance(token.Identifier, bytes):
        number = int.from_bytes(token.Identifier, "big") + 1
        return ua.NodeId(number.to_bytes(len(token.Identifier), "big"), token.NamespaceIndex)
    return ua.NodeId(token.Identifier + 1, token.NamespaceIndex)


async def test_a_client_cannot_take_over_the_next_clients_session_by_guessing_its_token() -> None:
    async with simulated_gateway(opcua=True) as (gateway, engines):
        attacker = Client(url(gateway), timeout=10)
        await attacker.connect()  # anonymous, on its own channel
        try:
            mine = attacker.uaclient.session.authentication_token
            async with OpcuaClient(gateway) as operator:  # the next session
                attacker.uaclient.session.restore_authentication_token(next_token(mine))
                with pytest.raises(ua.UaStatusCodeError):
                    await attacker.activate_session()  # anonymous, on the guessed session
                # the operator's session is still the operator's
                await operator.switch_on(5)
                await operator.set_setpoint(5, 25.0)
                assert engines[5].drive.value(3) == 2500
            attacker.uaclient.session.restore_authentication_token(mine)
        finally:
            await attacker.disconnect()


async def test_a_write_that_waited_longer_than_its_client_waits_is_not_carried_out() -> None:
    async with (
        simulated_gateway(opcua=True) as (gateway, engines),
        OpcuaClient(gateway) as operator,
    ):
        protocol = operator.client.uaclient.protocol

        def write(address: int, timeout: float) -> Any:
            request = ua.WriteRequest()
            request.Parameters.NodesToWrite = [
                ua.WriteValue(
                    NodeId=operator.node(address, ".Setpoint.main").nodeid,
                    AttributeId=ua.AttributeIds.Value,
                    Value=ua.DataValue(SETPOINT_25),
                )
            ]
            # TimeoutHint: how long the client waits (in ms)
            return asyncio.ensure_future(protocol.send_request(request, timeout=timeout))

        watch = LineWatch(engines[5])
        first = write(6, 10.0)  # served at the next bus cycle
        await asyncio.sleep(0)
        behind = write(5, 0.001)  # queued behind it, its client gone after 1 ms
        with pytest.raises(asyncio.TimeoutError):
            await behind
        await first
        assert await operator.node(5, ".Address").read_value() == 5  # served after both
        await watch.nothing_moved()
        assert engines[5].drive.value(3) == 0
        # a request that did not wait longer than its client is carried out
        await operator.switch_on(5)
        await operator.set_setpoint(5, 25.0)
        assert engines[5].drive.value(3) == 2500


async def test_the_access_levels_an_anonymous_session_reads_say_it_may_only_read() -> None:
    async with simulated_gateway(opcua=True) as (gateway, _engines):
        async with OpcuaClient(gateway, user=None) as anonymous:
            for path in (".Setpoint.main", ".SetpointPercent.main", ".ControlWord"):
                assert await access(anonymous.node(5, path)) == (READ_WRITE, READ), path
            assert await access(anonymous.node(5, ".Parameters.P107")) == (READ_WRITE, READ)
            assert await access(anonymous.node(5, ".StatusWord")) == (READ, READ)
            for method in ("On", "Off1", "Off2", "Off3", "Acknowledge", "WriteParameter"):
                assert await executable(anonymous.node(5, f".{method}")) == (True, False), method
            assert await executable(anonymous.node(5, ".ReadParameter")) == (True, True)
        async with OpcuaClient(gateway) as operator:
            assert await access(operator.node(5, ".Setpoint.main")) == (READ_WRITE, READ_WRITE)
            assert await executable(operator.node(5, ".On")) == (True, True)


async def test_wrong_types_and_argument_counts_get_part_4_status_codes_and_change_nothing() -> None:
    async with (
        simulated_gateway(opcua=True) as (gateway, engines),
        OpcuaClient(gateway) as operator,
    ):
        client, ns = operator.client, operator.ns
        watch = LineWatch(engines[5])
        setpoint = operator.node(5, ".Setpoint.main")
        mismatch = ua.StatusCodes.BadTypeMismatch
        assert await write_status(setpoint, ua.Variant("25", ua.VariantType.String)) == mismatch
        assert await write_status(setpoint, ua.Variant(25.0, ua.VariantType.Float)) == mismatch
        assert await write_status(setpoint, ua.Variant([25.0, 1.0])) == mismatch
        assert await write_status(setpoint, ua.Variant()) == mismatch
        control = operator.node(5, ".ControlWord")
        assert await write_status(control, ua.Variant(0x047F, ua.VariantType.Int64)) == mismatch
        index_range = await write_status(setpoint, SETPOINT_25, index_range="0")
        assert index_range == ua.StatusCodes.BadWriteNotSupported
        status_word = operator.node(5, ".StatusWord")
        not_writable = ua.StatusCodes.BadNotWritable
        assert await write_status(status_word, ua.Variant(0, ua.VariantType.UInt16)) == not_writable
        # a value its writer marks bad is no request to act on
        stale = await write_status(setpoint, SETPOINT_25, status=ua.StatusCodes.BadNoCommunication)
        assert stale == ua.StatusCodes.BadWriteNotSupported

        pnu = ua.Variant(107, ua.VariantType.UInt16)
        index = ua.Variant(-1, ua.VariantType.Int16)
        value = ua.Variant(60.0, ua.VariantType.Double)
        few = await call_result(client, ns, "WriteParameter", pnu, index)
        assert few.StatusCode.value == ua.StatusCodes.BadArgumentsMissing
        many = await call_result(client, ns, "WriteParameter", pnu, index, value, value)
        assert many.StatusCode.value == ua.StatusCodes.BadTooManyArguments
        on = await call_result(client, ns, "On", value)
        assert on.StatusCode.value == ua.StatusCodes.BadTooManyArguments
        text = ua.Variant("60", ua.VariantType.String)
        wrong = await call_result(client, ns, "WriteParameter", pnu, index, text)
        assert wrong.StatusCode.value == ua.StatusCodes.BadInvalidArgument
        assert [r.value for r in wrong.InputArgumentResults] == [0, 0, mismatch]
        # a drive's method called on another drive's object
        other = await call_result(client, ns, "On", on=6)
        assert other.StatusCode.value == ua.StatusCodes.BadMethodInvalid

        await watch.nothing_moved()
        assert engines[5].drive.value(107) == 50.0
        assert engines[6].drive.status_word() & 4 == 0
        # the same client is served afterwards
        assert await operator.write_parameter(5, 107, 60.0) == 60.0
        await operator.switch_on(5)
        await operator.set_setpoint(5, 25.0)
        assert engines[5].drive.value(3) == 2500


async def test_malformed_values_are_refused_and_a_good_client_is_served_afterwards() -> None:
    async with simulated_gateway(opcua=True) as (gateway, engines):
        async with OpcuaClient(gateway) as operator:
            client, ns = operator.client, operator.ns
            watch = LineWatch(engines[5])
            out_of_range = ua.StatusCodes.BadOutOfRange
            for path in (".Setpoint.main", ".SetpointPercent.main", ".Parameters.P107"):
                target = operator.node(5, path)
                for bad in (math.nan, math.inf, -math.inf, 1e300, -1e300):
                    variant = ua.Variant(bad, ua.VariantType.Double)
                    assert await write_status(target, variant) == out_of_range, (path, bad)
            pnu = ua.Variant(107, ua.VariantType.UInt16)
            index = ua.Variant(-1, ua.VariantType.Int16)
            for bad in (math.nan, math.inf, -math.inf):
                value = ua.Variant(bad, ua.VariantType.Double)
                result = await call_result(client, ns, "WriteParameter", pnu, index, value)
                assert result.StatusCode.value == ua.StatusCodes.BadInvalidArgument
                assert [r.value for r in result.InputArgumentResults] == [0, 0, out_of_range]
            huge = ua.Variant(1e300, ua.VariantType.Double)  # beyond P107's 8..600 Hz
            result = await call_result(client, ns, "WriteParameter", pnu, index, huge)
            assert result.StatusCode.value == out_of_range
            # an element number below -1 is no element, not "the simple parameter"
            below = ua.Variant(-5, ua.VariantType.Int16)
            value = ua.Variant(60.0, ua.VariantType.Double)
            result = await call_result(client, ns, "WriteParameter", pnu, below, value)
            assert result.StatusCode.value == out_of_range
            await watch.nothing_moved()
            assert engines[5].drive.value(107) == 50.0
            assert engines[5].drive.value(3) == 0
        async with OpcuaClient(gateway) as good:
            await good.switch_on(5)
            await good.set_setpoint(5, 25.0)
            assert engines[5].drive.value(3) == 2500
            assert engines[5].drive.status_word() & 4


async def test_a_read_only_face_refuses_every_change_and_says_so() -> None:
    async with (
        simulated_gateway(opcua=True, read_only=True) as (gateway, engines),
        OpcuaClient(gateway) as operator,
    ):
        client, ns = operator.client, operator.ns
        watch = LineWatch(engines[5])
        denied = ua.StatusCodes.BadUserAccessDenied
        for path in (".Setpoint.main", ".SetpointPercent.main", ".Parameters.P107"):
            target = operator.node(5, path)
            assert await access(target) == (READ, READ), path
            assert await write_status(target, SETPOINT_25) == denied, path
        control = operator.node(5, ".ControlWord")
        assert await write_status(control, ua.Variant(0x047F, ua.VariantType.UInt16)) == denied
        for method in ("On", "Off1", "Off2", "Off3", "Acknowledge"):
            assert await executable(operator.node(5, f".{method}")) == (False, False)
            assert (await call_result(client, ns, method)).StatusCode.value == denied
        args = [
            ua.Variant(107, ua.VariantType.UInt16),
            ua.Variant(-1, ua.VariantType.Int16),
            ua.Variant(60.0, ua.VariantType.Double),
        ]
        result = await call_result(client, ns, "WriteParameter", *args)
        assert result.StatusCode.value == denied
        await watch.nothing_moved()
        assert engines[5].drive.value(107) == 50.0
        assert not engines[5].drive.status_word() & 4
        # reading stays possible
        assert await executable(operator.node(5, ".ReadParameter")) == (True, True)
        assert await operator.read_parameter(5, 107) == (50.0, "Hz")


async def test_values_with_units_are_analog_items_with_their_range() -> None:
    async with (
        simulated_gateway(opcua=True) as (gateway, _engines),
        OpcuaClient(gateway, user=None) as client,
    ):
        analog = ua.NodeId(ua.ObjectIds.AnalogItemType)

        async def described(path: str) -> tuple[str, float, float]:
            target = client.node(5, path)
            assert await target.read_type_definition() == analog, path
            units = await target.get_child(ua.QualifiedName("EngineeringUnits", 0))
            eu_range = await target.get_child(ua.QualifiedName("EURange", 0))
            span = await eu_range.read_value()
            return (await units.read_value()).DisplayName.Text, span.Low, span.High

        high = 32767 * 100 / 16384
        for path in (".ActualPercent.main", ".SetpointPercent.main"):
            assert await described(path) == ("%", -200.0, high)
        # in Hz once the reference (P352 = 50.00 Hz) was read
        for path in (".Actual.main", ".Setpoint.main"):
            assert await described(path) == ("Hz", -100.0, high / 2)
        assert await described(".Parameters.P107") == ("Hz", 8.0, 600.0)
        status = client.node(5, ".StatusWord")
        base = ua.NodeId(ua.ObjectIds.BaseDataVariableType)
        assert await status.read_type_definition() == base


# -- node-opcua: a client of another stack, two sessions on one channel --------------------

SCRIPT = r"""
const {OPCUAClient, UserTokenType, DataType, AttributeIds, MessageSecurityMode, SecurityPolicy}
    = require("node-opcua-client");
(async () => {
  const [url, ns] = [process.argv[2], Number(process.argv[3])];
  const client = OPCUAClient.create({endpointMustExist: false, connectionStrategy: {maxRetry: 0},
    securityMode: MessageSecurityMode.None, securityPolicy: SecurityPolicy.None});
  await client.connect(url);
  const anonymous = await client.createSession();
  const operator = await client.createSession(
    {type: UserTokenType.UserName, userName: "operator", password: "secret"});
  const id = (path) => `ns=${ns};s=bus.drive5${path}`;
  const write = async (session) => (await session.write({nodeId: id(".Setpoint.main"),
    attributeId: AttributeIds.Value,
    value: {value: {dataType: DataType.Double, value: 25.0}}})).name;
  const call = async (session) => (await session.call({objectId: id(""),
    methodId: id(".Off2"), inputArguments: []})).statusCode.name;
  const level = async (session) => (await session.read({nodeId: id(".Setpoint.main"),
    attributeId: AttributeIds.UserAccessLevel})).value.value;
  const result = {
    anonymous: {write: await write(anonymous), call: await call(anonymous),
                level: await level(anonymous)},
    operator: {level: await level(operator)},
  };
  result.operator.write = await write(operator);
  await anonymous.close();
  await operator.close();
  await client.disconnect();
  console.log("RESULT " + JSON.stringify(result));
})().catch((e) => { console.error(e); process.exit(1); });
"""


SUBSCRIPTIONS = r"""
const {OPCUAClient, UserTokenType, AttributeIds, MessageSecurityMode, SecurityPolicy,
       ClientSubscription, ClientMonitoredItem, TimestampsToReturn} = require("node-opcua-client");
(async () => {
  const [url, ns] = [process.argv[2], Number(process.argv[3])];
  const client = OPCUAClient.create({endpointMustExist: false, connectionStrategy: {maxRetry: 0},
    securityMode: MessageSecurityMode.None, securityPolicy: SecurityPolicy.None});
  await client.connect(url);
  const sessions = {
    anonymous: [await client.createSession(), 5],
    operator: [await client.createSession(
      {type: UserTokenType.UserName, userName: "operator", password: "secret"}), 6],
  };
  const seen = {anonymous: [], operator: []};
  for (const [name, [session, address]] of Object.entries(sessions)) {
    const subscription = ClientSubscription.create(session, {requestedPublishingInterval: 50,
      requestedMaxKeepAliveCount: 10, publishingEnabled: true});
    const item = ClientMonitoredItem.create(subscription,
      {nodeId: `ns=${ns};s=bus.drive${address}.Address`, attributeId: AttributeIds.Value},
      {samplingInterval: 50, queueSize: 1, discardOldest: true}, TimestampsToReturn.Both);
    item.on("changed", (value) => seen[name].push(value.value.value));
  }
  for (let i = 0; i < 400 && (!seen.anonymous.length || !seen.operator.length); i++) {
    await new Promise((r) => setTimeout(r, 25));  // until each has its first notification
  }
  for (const [session] of Object.values(sessions)) { await session.close(); }
  await client.disconnect();
  console.log("RESULT " + JSON.stringify(seen));
})().catch((e) => { console.error(e); process.exit(1); });
"""


@pytest.fixture(scope="session")
def node_opcua(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Path]:
    """A folder with node-opcua-client installed from the npm registry (kept in pytest's
    cache between runs where there is one); the test is skipped without node/npm or the
    registry."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip("node and npm are needed for the node-opcua client")
    cache = getattr(request.config, "cache", None)
    if cache is not None:
        folder = Path(cache.mkdir("node-opcua"))
    else:
        folder = tmp_path_factory.mktemp("node-opcua")
    # `make test` runs the tests in several processes: one installs, the others wait for it
    # (a folder that npm is still filling must not be taken for an installed client)
    import fcntl

    with (folder / "install.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        installed = folder / "installed"
        if not installed.is_file() or installed.read_text(encoding="utf-8") != NODE_OPCUA:
            result = subprocess.run(
                ["npm", "install", "--no-audit", "--no-fund", "--prefix", str(folder), NODE_OPCUA],
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
            )
            if result.returncode != 0:
                pytest.skip(f"npm could not install {NODE_OPCUA}: {result.stderr[-500:]}")
            installed.write_text(NODE_OPCUA, encoding="utf-8")
    yield folder


async def run_node(gateway: Gateway, folder: Path, name: str, script: str) -> dict[str, Any]:
    """Run the node-opcua ``script`` (its arguments: the endpoint and the gateway's namespace
    index) without blocking the loop, the gateway serving it meanwhile; the JSON of its
    standard output's line ``RESULT ...``."""
    async with OpcuaClient(gateway, user=None) as probe:
        ns = probe.ns
    path = folder / name
    path.write_text(script, encoding="utf-8")
    process = await asyncio.create_subprocess_exec(
        *["node", str(path), url(gateway), str(ns)],
        cwd=folder,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    async with asyncio.timeout(60):
        out, err = await process.communicate()
    assert process.returncode == 0, err.decode(errors="replace")[-2000:]
    (line,) = [x for x in out.decode().splitlines() if x.startswith("RESULT ")]
    result: dict[str, Any] = json.loads(line.removeprefix("RESULT "))
    return result


@pytest.mark.posix("the node-opcua install is shared through fcntl.flock")
async def test_node_opcua_sessions_on_one_channel_keep_their_own_rights(
    node_opcua: Path,
) -> None:
    async with simulated_gateway(opcua=True) as (gateway, engines):
        watch = LineWatch(engines[5])
        process = await run_node(gateway, node_opcua, "sessions.js", SCRIPT)
        assert process["anonymous"] == {
            "write": "BadUserAccessDenied",
            "call": "BadUserAccessDenied",
            "level": READ,
        }
        assert process["operator"] == {"level": READ_WRITE, "write": "Good"}
        # the one change on the line is the operator's setpoint (50 % of 50 Hz)
        assert len({pzd[0] for pzd in watch.pzd}) == 1  # no Off2 in the control word
        assert {pzd[1] for pzd in watch.pzd} == {0, 0x2000}
        assert watch.changes == []
        assert not engines[5].drive.status_word() & 4


@pytest.mark.posix("the node-opcua install is shared through fcntl.flock")
async def test_node_opcua_sessions_on_one_channel_get_their_own_subscriptions(
    node_opcua: Path,
) -> None:
    async with simulated_gateway(opcua=True) as (gateway, _engines):
        seen = await run_node(gateway, node_opcua, "subscriptions.js", SUBSCRIPTIONS)
        # each session's notification answered that session's Publish, none the other's
        assert seen == {"anonymous": [5], "operator": [6]}
