"""The OPC UA face with the asyncua client: browsing, engineering units, subscriptions at the
bus cycle, methods, anonymous clients read-only."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from asyncua import ua

from gateway.harness import OpcuaClient, simulated_gateway
from support.limits import limit_writes
from support.waiting import eventually


async def test_a_client_browses_the_drives_and_reads_units() -> None:
    async with simulated_gateway(opcua=True) as (gateway, _), OpcuaClient(gateway) as client:
        uss = client.client.get_node(ua.NodeId("USS", client.ns))
        (bus,) = await uss.get_children()
        drives = sorted([(await d.read_browse_name()).Name for d in await bus.get_children()])
        assert drives == ["drive5", "drive6"]
        children = set()
        for child in await client.node(5).get_children():
            children.add((await child.read_browse_name()).Name)
        assert {
            "StatusWord",
            "Status",
            "Actual",
            "Setpoint",
            "ControlWord",
            "Parameters",
        } <= children
        assert {
            "On",
            "Off1",
            "Off2",
            "Off3",
            "Acknowledge",
            "ReadParameter",
            "WriteParameter",
        } <= children
        actual = client.node(5, ".Actual.main")
        units = await actual.get_child(ua.QualifiedName("EngineeringUnits", 0))
        eu = await units.read_value()
        assert eu.DisplayName.Text == "Hz"
        assert eu.UnitId == (ord("H") << 16 | ord("T") << 8 | ord("Z"))  # UNECE HTZ
        assert await client.node(5, ".Address").read_value() == 5
        # the words as a person reads them (pyuss.params.words), beside the numbers
        assert {"StatusText", "ControlText"} <= children
        text = client.node(5, ".StatusText")
        shown = ""
        async with asyncio.timeout(15):  # the drive's first answer (a bound, not a timing)
            while not (shown := await text.read_value()):
                await asyncio.sleep(0.01)
        word = await client.node(5, ".StatusWord").read_value()  # a drive at rest
        assert shown.startswith(f"{word:04X}h  switch-on inhibited"), shown
        control = await client.node(5, ".ControlText").read_value()
        assert control.startswith(f"{await client.node(5, '.ControlWord').read_value():04X}h  ")


async def test_a_subscription_delivers_the_actual_value_as_the_drive_ramps() -> None:
    async with simulated_gateway(opcua=True) as (gateway, engines), OpcuaClient(gateway) as client:
        seen: list[float] = []

        class Handler:
            def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
                seen.append(value)

        subscription = await client.client.create_subscription(50, Handler())
        await subscription.subscribe_data_change(client.node(5, ".Actual.main"))
        await client.set_setpoint(5, 10.0)
        await client.switch_on(5)
        await eventually(lambda: any(v > 0 for v in seen if v == v))
        await eventually(lambda: len({v for v in seen if v == v}) >= 3)  # several steps of the ramp
        await subscription.delete()
    assert engines[5].drive.value(3) == 1000


async def test_values_no_client_monitors_are_read_as_the_drive_answers() -> None:
    # Values nobody monitors are stored at once as states come, those a client monitors go
    # through the server to its subscription: both read what the drive last answered.
    async with simulated_gateway(opcua=True) as (gateway, _), OpcuaClient(gateway) as client:
        # while the drive ramps (to its full speed: seconds) every answer is a new state
        answers = client.node(6, ".Health.Answers")
        actual = client.node(6, ".Actual.main")
        await client.set_setpoint(6, 50.0)
        await client.switch_on(6)
        await _reads_above(actual, 0.0)
        await _reads_above(answers, await answers.read_value() + 3)
        seen: list[float] = []

        class Handler:
            def datachange_notification(self, node: Any, value: Any, data: Any) -> None:
                seen.append(value)

        subscription = await client.client.create_subscription(50, Handler())
        await subscription.subscribe_data_change(answers)
        await eventually(lambda: len(set(seen)) >= 3)
        await subscription.delete()
        await _reads_above(answers, max(seen) + 3)


async def _reads_above(node: Any, value: float) -> None:
    """Read ``node`` until it is above ``value`` (bounded as `eventually` is)."""
    async with asyncio.timeout(15.0):
        while not await node.read_value() > value:
            await asyncio.sleep(0.01)


async def _status(node: Any) -> str:
    value = await node.read_data_value(raise_on_bad_status=False)
    name: str = value.StatusCode.name
    return name


async def _status_becomes(node: Any, name: str) -> None:
    """Read ``node`` until its StatusCode is ``name`` (bounded as `eventually` is)."""
    async with asyncio.timeout(15.0):
        while await _status(node) != name:
            await asyncio.sleep(0.01)


async def test_a_drive_that_stops_answering_shows_its_values_as_bad_then_good_again() -> None:
    # OPC UA Part 4 7.39: a drive offline (several answers missed in a row) shows its values
    # BadNoCommunication (a client must not take a silent drive's last status word or speed
    # for now), one not known yet BadWaitingForInitialData; what the gateway sends, and the
    # health, stay Good, Health.Online says so
    async with simulated_gateway(opcua=True) as (gateway, engines), OpcuaClient(gateway) as client:
        await client.set_setpoint(5, 10.0)
        await client.switch_on(5)
        await _reads_above(client.node(5, ".Actual.main"), 1.0)
        drives = [".StatusWord", ".State", ".Status.operation_enabled", ".Actual.main",
                  ".ActualPercent.main"]  # fmt: skip
        ours = [".ControlWord", ".Setpoint.main", ".SetpointPercent.main", ".Health.NotSending"]
        for path in drives + ours:  # (a loaded machine may miss an answer: then Uncertain)
            await _status_becomes(client.node(5, path), "Good")
        assert await _status(client.node(5, ".Parameters.P107")) == "BadWaitingForInitialData"
        assert await client.node(5, ".Health.Online").read_value() is True
        engines[5].address = 31  # drive 5 answers no more
        await _status_becomes(client.node(5, ".StatusWord"), "BadNoCommunication")
        assert await client.node(5, ".Health.NotSending").read_value() is True
        assert await client.node(5, ".Health.Online").read_value() is False
        for path in drives:
            assert await _status(client.node(5, path)) == "BadNoCommunication", path
        for path in ours:
            assert await _status(client.node(5, path)) == "Good", path
        await _status_becomes(client.node(6, ".StatusWord"), "Good")  # the other one answers
        engines[5].address = 5  # it answers again
        for path in drives:
            await _status_becomes(client.node(5, path), "Good")
        assert await client.node(5, ".Health.Online").read_value() is True


async def test_anonymous_clients_read_but_may_not_write_or_command() -> None:
    async with simulated_gateway(opcua=True) as (gateway, engines):
        async with OpcuaClient(gateway, user=None) as anonymous:
            assert await anonymous.node(5, ".StatusWord").read_value() != 0
            value, unit = await anonymous.read_parameter(5, 107)  # reading a parameter is fine
            assert (value, unit) == (50.0, "Hz")
            node = anonymous.node(5, ".Setpoint.main")
            with pytest.raises(ua.UaStatusCodeError) as error:
                await node.write_value(ua.DataValue(ua.Variant(25.0, ua.VariantType.Double)))
            assert error.value.code == ua.StatusCodes.BadUserAccessDenied
            with pytest.raises(ua.UaStatusCodeError) as error:
                await anonymous.node(5).call_method(ua.QualifiedName("On", anonymous.ns))
            assert error.value.code == ua.StatusCodes.BadUserAccessDenied
        assert engines[5].drive.value(3) == 0
        assert not engines[5].drive.status_word() & 4


async def test_a_wrong_password_is_refused() -> None:
    async with simulated_gateway(opcua=True) as (gateway, _):
        client = OpcuaClient(gateway)
        client.client.set_password("wrong")
        with pytest.raises((ua.UaError, asyncio.TimeoutError, OSError)):
            async with client:
                pass


async def test_a_stop_answers_the_write_being_carried_out_and_takes_no_new_one() -> None:
    # the drive takes 1 s to answer a parameter job: the gateway stopped meanwhile waits for
    # the answer and gives it to the client (it said "Connection is closed", the write going
    # out on the line all the same); a write that comes during the stop gets BadShutdown
    from asyncua import ua

    from pyuss.slave import JobLatency

    async with (
        simulated_gateway(opcua=True) as (gateway, engines),
        OpcuaClient(gateway) as client,
        OpcuaClient(gateway) as late,
    ):
        engines[5].latency = JobLatency(seconds=1.0)
        write = asyncio.create_task(client.write_parameter(5, 107, 55.0))
        face = next(f for f in gateway._started if hasattr(f, "acting"))
        await eventually(lambda: face._acting > 0, what="the write under way")
        closing = asyncio.create_task(face.close())
        await eventually(lambda: face.stopping, what="the stop begun")
        with pytest.raises(ua.UaStatusCodeError) as refused:
            await late.node(5, ".Setpoint.main").write_value(
                ua.DataValue(ua.Variant(10.0, ua.VariantType.Double))
            )
        assert type(refused.value).__name__ == "BadShutdown"
        assert await write == pytest.approx(55.0)
        await closing
    assert engines[5].drive.value(107) == 55


async def test_a_write_parameter_the_drive_answers_with_another_value_is_clamped() -> None:
    # A drive limits or rounds a value: WriteParameter returns what the drive holds, with
    # GoodClamped (OPC UA Part 4 7.39), not Good, where that is not the value written.
    async with (
        simulated_gateway(opcua=True, parameters=("18",)) as (gateway, engines),
        OpcuaClient(gateway) as op,
    ):
        limit_writes(engines[5].drive, 18, 1000)
        results = []
        for value in (5000.0, 700.0):
            request = ua.CallMethodRequest(
                ObjectId=ua.NodeId("bus.drive5", op.ns),
                MethodId=ua.NodeId("bus.drive5.WriteParameter", op.ns),
                InputArguments=[
                    ua.Variant(18, ua.VariantType.UInt16),
                    ua.Variant(-1, ua.VariantType.Int16),
                    ua.Variant(value, ua.VariantType.Double),
                ],
            )
            (result,) = await op.client.uaclient.call([request])
            results.append((result.StatusCode.value, result.OutputArguments[0].Value))
        # so is a write to the parameter's variable (P18 is one of the configured)
        node = op.node(5, ".Parameters.P18")
        written = []
        for value in (6000.0, 800.0):
            item = ua.WriteValue(
                NodeId=node.nodeid,
                AttributeId=ua.AttributeIds.Value,
                Value=ua.DataValue(ua.Variant(value, ua.VariantType.Double)),
            )
            (status,) = await op.client.uaclient.write(ua.WriteParameters(NodesToWrite=[item]))
            written.append((status.value, engines[5].drive.value(18)))
    assert results == [(ua.StatusCodes.GoodClamped, 1000.0), (ua.StatusCodes.Good, 700.0)]
    assert written == [(ua.StatusCodes.GoodClamped, 1000), (ua.StatusCodes.Good, 800)]
