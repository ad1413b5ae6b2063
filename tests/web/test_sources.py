"""``GET /api/drive/N/sources`` over a real socket: whether the drive follows the control word
and setpoint of USS (P0700, P1000), read from the drive at each request - the check ``uss
run`` makes first."""

from __future__ import annotations

import aiohttp

from pyuss.web.backend import Backend
from support.web import serve


async def test_the_page_says_whether_a_drive_follows_uss(backend: Backend) -> None:
    server = await serve(backend)
    url = f"http://127.0.0.1:{server.port}/api/drive"
    try:
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{url}/9/sources") as reply:  # the demo's V20: ready for USS
                assert reply.status == 200
                ready = await reply.json()
            assert ready["known"] and ready["follows"]
            assert ready["line"] == (
                "the drive follows USS: P0700.0 = 5 (USS/MODBUS 485), P1000.0 = 5 (USS/MODBUS 485)"
            )
            backend.engines[9].drive.write(700, 1, 0)  # on the drive's own panel: BOP
            async with http.get(f"{url}/9/sources") as reply:
                panel = await reply.json()
            assert not panel["follows"]
            assert panel["line"] == (
                "the drive ignores the control word: P0700.0 = 1 (operator panel), "
                "set P0700.0 = 5 for USS"
            )
            command, setpoint = panel["sources"]
            assert (command["parameter"], command["value"], command["follows"]) == (
                "P0700.0",
                1,
                False,
            )
            assert (setpoint["parameter"], setpoint["follows"]) == ("P1000.0", True)
            async with http.get(f"{url}/1/sources") as reply:  # generic: nothing to check
                generic = await reply.json()
            assert generic == {"known": False, "follows": True, "line": "", "sources": []}
    finally:
        await server.close()
