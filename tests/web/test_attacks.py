"""The page's server under attack, over real sockets against the demo's simulated drives:
oversize and deeply nested bodies, wrong types, huge numbers, NaN and infinity, unknown
drives, replayed and stale confirmations, a setpoint beyond the word's range. Each bad
request gets one clear 4xx JSON error, nothing that moves a drive goes out, and a
well-behaved client is served as before: the server and the drives' workers run on."""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import AsyncIterator
from typing import Any

import aiohttp

from pyuss.web.backend import Backend
from pyuss.web.bodies import MAX_BODY, MAX_DEPTH, MAX_JSON
from support.web import serve

WRITE = {"X-Pyuss": "1"}
JSON = {**WRITE, "Content-Type": "application/json"}


def moving(backend: Backend) -> dict[int, tuple[int, tuple[int, ...]]]:
    """What the master sends every drive: the control word and the setpoints."""
    return {
        a: (backend.points(a).drive.control, backend.points(a).drive.setpoints)
        for a in backend.addresses()
    }


async def post(http: aiohttp.ClientSession, url: str, body: Any) -> tuple[int, Any]:
    data = body if isinstance(body, bytes | str) else json.dumps(body)
    async with http.post(url, data=data, headers=JSON) as reply:
        return reply.status, await reply.json()


async def still_served(backend: Backend, http: aiohttp.ClientSession, base: str) -> None:
    """A well-behaved client is served, and every drive's worker still runs (it answers)."""
    async with http.get(base + "/api/bus") as reply:
        assert reply.status == 200
        assert [d["address"] for d in (await reply.json())["drives"]] == [1, 4, 7, 9]
    answers = {a: backend.points(a).drive.diagnostics().answers for a in backend.addresses()}
    async with asyncio.timeout(20):
        while any(backend.points(a).drive.diagnostics().answers <= n for a, n in answers.items()):
            await asyncio.sleep(0.05)
    status, read = await post(http, base + "/api/drive/1/params/read", {"ids": ["462"]})
    assert (status, read[0]["value"]) == (200, "10.0 s")


async def test_bad_bodies_get_a_clear_error_and_change_nothing(backend: Backend) -> None:
    server = await serve(backend)
    base = f"http://127.0.0.1:{server.port}"
    before = moving(backend)
    try:
        async with aiohttp.ClientSession() as http:
            command = base + "/api/drive/1/command"
            nested = "[" * 200_000
            cases: list[tuple[str, Any, int, str]] = [
                # too large: a command's body, and a backup file beyond the upload limit
                (command, {"name": "on", "value": "x" * MAX_JSON}, 400, "larger than"),
                (base + "/api/drive/1/compare?name=big.toml", b"x" * (MAX_BODY + 1), 413,
                 "larger than"),
                # nesting deeper than the parser is ever given (the standard library's
                # recurses), within the size limit and beyond it
                (command, nested, 400, "larger than"),
                (command, nested[:60_000], 400, f"deeper than {MAX_DEPTH}"),
                (command, '{"name": "on", "value": ' + "[" * 50 + "]" * 50 + "}", 400,
                 "deeper"),
                (command, b"\xff\xfe{}", 400, "not UTF-8 text"),
                (command, "[]", 400, "JSON object"),
                # wrong types
                (command, {"name": 5}, 400, "command name"),
                (command, {"name": ["on"]}, 400, "command name"),
                (command, {"name": "on", "check": "yes"}, 400, "true or false"),
                (command, {"name": "on", "speed": 1}, 400, "unknown key 'speed'"),
                (command, {"name": "setpoint", "value": [40]}, 400, "finite number"),
                (command, {"name": "setpoint", "value": {"value": 40, "unit": 3}}, 400,
                 "setpoint unit"),
                (command, {"name": "setpoint", "value": None}, 400, "finite number"),
                (command, {"name": "setpoint", "value": True}, 400, "finite number"),
                (base + "/api/drive/1/params/write", {"id": {"x": 1}, "value": "1"}, 400,
                 "not a parameter"),
                (base + "/api/drive/1/params/write", {"id": "462", "value": [1]}, 400,
                 "value as text"),
                (base + "/api/drive/1/params/write", {"id": "462", "value": "5",
                 "eeprom": "no"}, 400, "eeprom must be true or false"),
                (base + "/api/drive/1/params/read", {"ids": "462"}, 400, "list"),
                (base + "/api/scan", {"addresses": ["0-31"]}, 400, "short text"),
                (base + "/api/scan", {"profile": {"x": 1}}, 400, "is not one of"),
                # huge numbers
                (command, '{"name": "setpoint", "value": 1' + "0" * 400 + "}", 400,
                 "Enter a value within -200 %"),
                (command, {"name": "setpoint", "value": {"value": "9" * 400, "unit": "Hz"}},
                 400, "not a number"),
                (command, {"name": "setpoint", "value": {"value": 10**400, "unit": "Hz"}},
                 400, "not sent: it is beyond"),
                (base + "/api/drive/" + "1" * 400 + "/command", {"name": "on"}, 400,
                 "not on the page"),
                (base + "/api/drive/1/params/read", {"ids": ["1" * 400]}, 400,
                 "not a parameter"),
                (base + "/api/drive/1/params/read", {"ids": [10**400]}, 400,
                 "not a parameter"),
                # NaN and infinity, as JSON's foreign constants and as numbers or text
                (command, '{"name": "setpoint", "value": NaN}', 400, "NaN is no JSON number"),
                (command, '{"name": "setpoint", "value": Infinity}', 400, "no JSON number"),
                (command, '{"name": "setpoint", "value": -Infinity}', 400, "no JSON number"),
                (command, '{"name": "setpoint", "value": 1e999}', 400, "finite number"),
                (command, {"name": "setpoint", "value": "nan"}, 400, "finite number"),
                (command, {"name": "setpoint", "value": {"value": "-inf", "unit": "%"}}, 400,
                 "finite number"),
                # unknown drive, unknown command
                (base + "/api/drive/12/command", {"name": "on"}, 400, "not on the page"),
                (base + "/api/drive/12/params/read", {"ids": ["462"]}, 400, "not on the page"),
                (command, {"name": "reverse"}, 400, "unknown command 'reverse'"),
                # a setpoint beyond the word's range is refused before anything is sent
                (command, {"name": "setpoint", "value": 500}, 400, "Enter a value within -200 %"),
                (command, {"name": "setpoint", "value": 500, "check": True}, 400,
                 "setpoint 500 % not sent: it is beyond what the drive's setpoint word"),
                (command, {"name": "setpoint", "value": {"value": 250, "unit": "Hz"}}, 400,
                 "setpoint 250 Hz not sent"),
                (base + "/api/nothing", {}, 404, "Not Found"),
            ]  # fmt: skip
            for url, body, code, words in cases:
                status, reply = await post(http, url, body)
                assert status == code, (url, str(body)[:80], reply)
                assert words in reply["error"], (str(body)[:80], reply)
                assert len(reply["error"]) < 300  # one line, not the request echoed back
            # a WebSocket message nested deep or malformed is ignored; the page is served on
            async with http.ws_connect(base + "/ws") as ws:
                assert (await ws.receive_json(timeout=10))["type"] == "bus"
                await ws.send_str("[" * 4000)
                await ws.send_str('{"monitor": NaN}')
                await ws.send_str(json.dumps({"monitor": True}))
                async with asyncio.timeout(10):
                    while (await ws.receive_json())["type"] != "telegrams":
                        pass
            assert moving(backend) == before  # nothing that moves a drive went out
            await still_served(backend, http, base)
            # and a valid command still acts
            status, _ = await post(http, base + "/api/drive/1/command",
                                   {"name": "setpoint", "value": 10})  # fmt: skip
            assert status == 200
            assert backend.points(1).drive.setpoints == (round(0x4000 * 0.1),)
    finally:
        await server.close()


async def test_a_confirmation_acts_once_fresh_and_for_the_command_checked(
    backend: Backend,
) -> None:
    server = await serve(backend)
    stale = await serve(backend, confirm_age=0.0)
    try:
        async with aiohttp.ClientSession() as http:
            url = f"http://127.0.0.1:{server.port}/api/drive/1/command"
            ten = {"name": "setpoint", "value": {"value": "10", "unit": "Hz"}}
            status, check = await post(http, url, {**ten, "check": True})
            assert status == 200
            assert check["text"] == "set the setpoint to 10 Hz (20 % of the reference)"
            assert check["setpoint"]["raw"] == round(0x4000 * 0.2)
            assert backend.points(1).drive.setpoints == (0,)  # a check sends nothing
            # the yes of another command (or another value) does not carry this one
            other = {"name": "setpoint", "value": {"value": "40", "unit": "Hz"}}
            status, reply = await post(http, url, {**other, "confirm": check["confirm"]})
            assert (status, "not the one confirmed" in reply["error"]) == (409, True)
            assert backend.points(1).drive.setpoints == (0,)
            # a yes is used up by its refusal too: check again, then it acts once
            status, check = await post(http, url, {**ten, "check": True})
            status, _ = await post(http, url, {**ten, "confirm": check["confirm"]})
            assert status == 200
            assert backend.points(1).drive.setpoints == (round(0x4000 * 0.2),)
            await post(http, url, {"name": "setpoint", "value": 0})
            # replayed: refused, nothing sent
            status, reply = await post(http, url, {**ten, "confirm": check["confirm"]})
            assert (status, "confirmed before" in reply["error"]) == (409, True)
            status, reply = await post(http, url, {**ten, "confirm": "made-up"})
            assert status == 409
            assert backend.points(1).drive.setpoints == (0,)
            # the reference changed between the question and the yes: 10 Hz is 10 % now
            # (an expert's write of P352, access level 3, C Table 4.3 error 12 otherwise)
            status, check = await post(http, url, {**ten, "check": True})
            await backend.write(1, 51, None, "EXPERT")
            await backend.write(1, 352, None, "100")
            try:
                assert backend.points(1).reference == 100.0  # read anew after the write
                status, reply = await post(http, url, {**ten, "confirm": check["confirm"]})
                assert (status, "another setpoint now" in reply["error"]) == (409, True)
                assert backend.points(1).drive.setpoints == (0,)
            finally:
                await backend.write(1, 352, None, "50")
                await backend.write(1, 51, None, "STANDARD")
            # stale: a yes older than the server takes
            url = f"http://127.0.0.1:{stale.port}/api/drive/1/command"
            on = {"name": "on"}
            status, check = await post(http, url, {**on, "check": True})
            assert (status, check["text"]) == (200, "on")
            status, reply = await post(http, url, {**on, "confirm": check["confirm"]})
            assert (status, "older than" in reply["error"]) == (409, True)
            assert backend.points(1).drive.control == 0
            await still_served(backend, http, f"http://127.0.0.1:{server.port}")
    finally:
        await stale.close()
        await server.close()


@contextlib.asynccontextmanager
async def attacked(backend: Backend) -> AsyncIterator[tuple[aiohttp.ClientSession, str]]:
    """A client and the address of a server for ``backend``; when the attack is over,
    nothing that moves a drive went out and a well-behaved client is served as before."""
    server = await serve(backend)
    before = moving(backend)
    try:
        async with aiohttp.ClientSession() as http:
            base = f"http://127.0.0.1:{server.port}"
            yield http, base
            assert moving(backend) == before
            await still_served(backend, http, base)
    finally:
        await server.close()


async def test_a_command_that_takes_no_value_refuses_one(backend: Backend) -> None:
    # "on" with a setpoint beside it: the drive would start at whatever setpoint is in
    # force, not at the one the request names; refused whole, checked or not
    async with attacked(backend) as (http, base):
        for body in (
            {"name": "on", "value": 40},
            {"name": "on", "value": 40, "check": True},
            {"name": "jog1", "value": {"value": "10", "unit": "Hz"}},
            {"name": "off1", "value": None},
        ):
            status, reply = await post(http, base + "/api/drive/1/command", body)
            assert status == 400, (body, reply)
            assert reply["error"].startswith(f"{body['name']} takes no value"), reply


async def test_a_malformed_host_or_origin_gets_a_clear_refusal(backend: Backend) -> None:
    async with attacked(backend) as (http, base):
        for headers, words in (
            ({"Host": "[::1"}, "not this machine"),
            ({"Origin": "http://["}, "are not accepted"),
            ({"Origin": "http://127.0.0.1:99999"}, "are not accepted"),
        ):
            for method, path in (("GET", "/api/bus"), ("POST", "/api/drive/1/command")):
                async with http.request(
                    method, base + path, json={"name": "on"}, headers={**JSON, **headers}
                ) as reply:
                    assert reply.status == 403, (method, headers)
                    assert words in (await reply.json())["error"]


async def test_a_confirmation_is_for_its_drive_and_the_drives_of_its_time(
    backend: Backend,
) -> None:
    # the yes a person gave for drive 1 never switches on drive 4, and none given before a
    # scan (the drives of before are gone, another may stand at the same address) acts after
    async with attacked(backend) as (http, base):
        url = base + "/api/drive/{}/command"
        for name in ("on", "jog1"):
            status, check = await post(http, url.format(1), {"name": name, "check": True})
            assert status == 200
            status, reply = await post(
                http, url.format(4), {"name": name, "confirm": check["confirm"]}
            )
            assert (status, "not the one confirmed" in reply["error"]) == (409, True), reply
        ten = {"name": "setpoint", "value": 10}
        status, check = await post(http, url.format(1), {**ten, "check": True})
        status, reply = await post(http, url.format(9), {**ten, "confirm": check["confirm"]})
        assert (status, "not the one confirmed" in reply["error"]) == (409, True), reply
        status, check = await post(http, url.format(1), {"name": "on", "check": True})
        status, scan = await post(http, base + "/api/scan", {"addresses": "1,4,7,9"})
        assert status == 200, scan
        async with asyncio.timeout(20):  # the drives found answer again
            while backend.addresses() != [1, 4, 7, 9] or backend.bus()["drives"][0]["state"] in (
                None,
                "does not send",
            ):
                await asyncio.sleep(0.05)
        status, reply = await post(http, url.format(1), {"name": "on", "confirm": check["confirm"]})
        assert (status, "check it again" in reply["error"]) == (409, True), reply


async def test_a_restore_writes_what_the_person_said_yes_to_or_nothing(
    backend: Backend,
) -> None:
    # the page asks with the writes of the comparison; the drive changed meanwhile (another
    # engineer, another page): the restore would write another list, so it writes nothing
    async with attacked(backend) as (http, base):
        url = base + "/api/drive/1"
        async with http.get(url + "/backup?format=json") as reply:
            body = await reply.read()
        await backend.write(1, 464, None, "3")
        try:
            async with http.post(url + "/compare?name=d1.json", data=body, headers=WRITE) as r:
                compared = await r.json()
            assert [w["change"] for w in compared["writes"]] == [
                "P464 (Ramp-down time): 3.0 s -> 10.0 s"
            ]
            await backend.write(1, 462, None, "4")  # now two writes, one not asked about
            restore = url + "/restore?name=d1.json&confirm=" + compared["confirm"]
            async with http.post(restore, data=body, headers=WRITE) as reply:
                assert reply.status == 409
                assert "not the one confirmed" in (await reply.json())["error"]
            status, read = await post(http, url + "/params/read", {"ids": ["462", "464"]})
            assert status == 200
            assert [r["value"] for r in read] == ["4.0 s", "3.0 s"]  # nothing written
            async with http.post(url + "/compare?name=d1.json", data=body, headers=WRITE) as r:
                compared = await r.json()
            assert len(compared["writes"]) == 2
            restore = url + "/restore?name=d1.json&confirm=" + compared["confirm"]
            async with http.post(restore, data=body, headers=WRITE) as reply:
                assert reply.status == 200
                assert (await reply.json())["message"] == "drive 1: 2 of 2 written"
            await backend.write(1, 464, None, "3")
            async with http.post(restore, data=body, headers=WRITE) as reply:
                assert reply.status == 409  # a yes acts once
        finally:
            await backend.write(1, 462, None, "10")
            await backend.write(1, 464, None, "10")
