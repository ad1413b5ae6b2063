"""One suite of attacks over every face alike: the gateway's Modbus TCP, MQTT and OPC UA faces
and the web page's HTTP API (`attacks.faces` has one adapter per face). A valid request acts; a
refused one - a setpoint out of range, an unknown command, a write of a read-only parameter, any
change through a read-only face - changes nothing on the line; malformed, oversize, nested,
wrongly typed, huge and non-finite input gets the face's error and moves nothing; retained,
stale and replayed requests never act; a flood of bad input leaves a well-behaved client
served. After every refused request the suite checks what the simulated drive took from the
line since the case began: the same process data, no parameter change job, and the same
control word, setpoint and parameter in the drive."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import pytest

from attacks.faces import KINDS, NOTIONS, Face, Meaningless
from gateway.harness import Refused
from pyuss.slave import SlaveEngine
from support.line import LineRecord
from support.waiting import eventually

pytestmark = pytest.mark.asyncio(loop_scope="module")

PNU = 107  # Mot.rated freq.: 8..600 Hz, 50 Hz in the simulated drives
READ_ONLY_PNU = 2  # Actual freq. (read-only)
RUNNING = 0x0004  # status word bit 2: operation enabled


class Watch:
    """What the simulated drive behind a face takes from the line while the block runs."""

    def __init__(self, engine: SlaveEngine) -> None:
        self.engine = engine
        self.before: tuple[object, ...] = ()
        self.baseline: tuple[int, ...] = ()

    def state(self) -> tuple[object, ...]:
        drive = self.engine.drive
        return drive.machine.control, drive.machine.setpoint, drive.value(3), drive.value(PNU)

    async def __aenter__(self) -> Watch:
        self.line = LineRecord(self.engine)
        await self.line.telegrams()  # what went out before the case is in force
        self.baseline = self.line.pzd[-1]
        self.line.pzd.clear()
        self.line.changes.clear()
        self.before = self.state()
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.line.close()

    async def unmoved(self) -> None:
        """Telegrams went out since the case began (a refused request had its chance to
        show), all with the process data of the last one before it, no parameter change; the
        drive's control word, setpoint (P3) and tested parameter as before."""
        await self.line.telegrams()
        changed = set(self.line.pzd) - {self.baseline}
        assert not changed, f"a refused request changed the process data: {changed}"
        assert self.line.changes == [], "a refused request sent a parameter change"
        assert self.state() == self.before


async def refused(request: Awaitable[object]) -> Refused:
    with pytest.raises(Refused) as caught:
        await request
    return caught.value


def faces_error(face: Face, refusal: Refused) -> None:
    """The refusal is one of the face's own errors for a bad request."""
    assert refusal.code in face.errors, (face.name, refusal.code)


async def applies(request: Callable[[], Awaitable[object]]) -> None:
    """Run ``request``, or skip the case where it has no meaning on this face."""
    try:
        await request()
    except Meaningless as exc:
        pytest.skip(str(exc))


async def test_a_valid_request_acts(face: Face) -> None:
    drive = face.engine.drive
    try:  # P107 is written at standstill (a running drive refuses it: error 17)
        assert await face.write_parameter(PNU, 60.0) == 60.0
        assert drive.value(PNU) == 60.0
        assert await face.read_parameter(PNU) == 60.0
    finally:  # as the other cases expect the drive
        await face.write_parameter(PNU, 50.0)
    try:
        await face.command("on")
        await eventually(lambda: drive.status_word() & RUNNING)
        await face.set_setpoint(25.0)
        await eventually(lambda: drive.value(3) == 2500)  # 25 Hz in 0.01 Hz
    finally:
        await face.set_setpoint(0.0)
        await face.command("off1")
    await eventually(lambda: not drive.status_word() & RUNNING and drive.value(3) == 0)


REFUSED: dict[str, Callable[[Face], Awaitable[object]]] = {
    "setpoint-out-of-range": lambda face: face.set_setpoint(1000.0),  # 20 x the reference
    "unknown-command": lambda face: face.command("jump"),
    "read-only-parameter": lambda face: face.write_parameter(READ_ONLY_PNU, 10.0),
    "parameter-out-of-range": lambda face: face.write_parameter(PNU, 1000.0),  # 8..600 Hz
    "parameter-not-finite": lambda face: face.write_parameter(PNU, float("nan")),
}


@pytest.mark.parametrize("case", list(REFUSED))
async def test_a_refused_request_changes_nothing_on_the_line(face: Face, case: str) -> None:
    async with Watch(face.engine) as watch:
        faces_error(face, await refused(REFUSED[case](face)))
        await watch.unmoved()
    await face.served()


async def test_a_read_only_face_refuses_every_change_and_reads(face: Face) -> None:
    async with face.read_only() as read_only, Watch(read_only.engine) as watch:
        await refused(read_only.command("on"))
        await refused(read_only.command("off2"))
        await refused(read_only.set_setpoint(25.0))
        await refused(read_only.write_parameter(PNU, 60.0))
        await watch.unmoved()
        assert await read_only.read_parameter(PNU) == 50.0


@pytest.mark.parametrize("kind", KINDS)
async def test_malformed_input_gets_the_faces_error_and_moves_nothing(
    face: Face, kind: str
) -> None:
    async with Watch(face.engine) as watch:
        with pytest.raises(Refused) as caught:
            await applies(lambda: face.malformed(kind))
        faces_error(face, caught.value)
        await watch.unmoved()
    await face.served()


@pytest.mark.parametrize("notion", NOTIONS)
async def test_retained_stale_and_replayed_requests_never_act(face: Face, notion: str) -> None:
    async with Watch(face.engine) as watch:
        with pytest.raises(Refused):
            await applies(lambda: face.outdated(notion))
        await watch.unmoved()
    await face.served()


async def test_a_flood_of_bad_input_leaves_a_client_served(face: Face) -> None:
    kinds = []
    for kind in KINDS:
        try:
            await face.malformed(kind)
        except Meaningless:
            continue
        except Refused:
            kinds.append(kind)
    async with Watch(face.engine) as watch:
        for _ in range(5):
            for kind in kinds:
                await refused(face.malformed(kind))
            await refused(face.set_setpoint(1000.0))
            await refused(face.command("jump"))
        await face.served()
        await watch.unmoved()
