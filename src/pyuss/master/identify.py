"""Identifying a drive's family through the master: `pyuss.profiles.identify` with reads of a
`pyuss.master.drive.Drive`.

The reads use the ``micromaster4`` parameter numbering (pages in IND bits 12..15 for numbers of
2000 and above; numbers below 2000 travel as everywhere), since the parameters the families
show their identity in are read from drives whose family is not known yet. A refused read (any
error number) counts as "not there"; a read that gets no answer in time ends the
identification with `pyuss.errors.UssTimeout`, as any job does.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Callable, Sequence
from typing import Any

from pyuss.errors import DriveRefusal, UssError, UssTimeout
from pyuss.master.drive import Drive
from pyuss.master.scan import Found
from pyuss.master.scheduler import ACYCLIC, Master
from pyuss.profiles import get_profile
from pyuss.profiles.identify import Identity, identify
from pyuss.protocol.layout import PKW_VARIABLE, Layout
from pyuss.transport.base import Transport

__all__ = [
    "AUTO_LAYOUTS",
    "KIND_ONLY",
    "UNKNOWN_FAMILY",
    "auto_master",
    "identify_drive",
    "identify_family",
    "identify_found",
    "identify_on",
]

AUTO_LAYOUTS = (Layout(PKW_VARIABLE, 2), Layout(4, 2))
"""Layouts `auto_master` tries when none is given: the Siemens families' variable PKW area and
the NORD SK 500E's PPO 1."""

UNKNOWN_FAMILY = (
    "address {address}: the drive shows no family known here; it is taken as one of unknown"
    " kind (its parameters as words; --profile NAME gives a family's)"
)
"""What `auto_master` tells of a drive that answers but shows no family."""

KIND_ONLY = (
    "address {address}: {what}: its family is not known here; its parameters, units and "
    "limits are taken from the {profile} profile's file, not from the drive (--profile NAME "
    "gives its family's)"
)
"""What `auto_master` tells of a drive that shows its kind (a Siemens drive of the
MICROMASTER 4 kind) but no family known here: the kind's profile file is a guess."""

IDENTIFY_PROFILE = "micromaster4"
"""The numbering the identification reads with."""


async def identify_drive(drive: Drive, *, timeout: float | None = None) -> Identity:
    """The family of ``drive`` (its handle must use a layout with a PKW area)."""

    async def read(pnu: int, index: int | None) -> float | None:
        try:
            words = await drive.read_raw(pnu, index, timeout=timeout)
        except DriveRefusal:
            return None
        # the number as sent (an unsigned word or double word): the rules compare raw values
        return words[0] if len(words) == 1 else (words[0] << 16) | words[1]

    return await identify(read)


async def identify_on(
    master: Master, address: int, layout: Layout, *, timeout: float | None = None
) -> Identity | None:
    """`identify_drive` for the slave at ``address`` that answers with ``layout`` (as
    `pyuss.master.scan.scan` found it); None when the layout has no PKW area."""
    if not layout.pkw:
        return None
    drive = master.drive(address, layout=layout, profile=get_profile(IDENTIFY_PROFILE), poll=False)
    return await identify_drive(drive, timeout=timeout)


async def identify_found(
    transport: Callable[[int], Transport], found: Sequence[Found], *, timeout: float = 1.0
) -> dict[int, tuple[str, str]]:
    """Identify the slaves a scan found: address -> (what it is, the profile to use). A slave
    without a parameter area, or that stops answering, is left out."""
    result: dict[int, tuple[str, str]] = {}
    for baud in sorted({f.baud for f in found}):
        here = [f for f in found if f.baud == baud and f.layout.pkw]
        if not here:
            continue
        async with Master(
            transport(baud), profile=IDENTIFY_PROFILE, mode=ACYCLIC, job_timeout=timeout
        ) as master:
            for f in here:
                try:
                    identity = await identify_on(master, f.address, f.layout, timeout=timeout)
                except UssError:
                    continue
                if identity is not None and identity.profile is not None:
                    result[f.address] = (identity.text, identity.profile)
    return result


@contextlib.asynccontextmanager
async def auto_master(
    transport: Callable[[], Transport],
    address: int,
    *,
    layout: Layout | None = None,
    job_timeout: float = 2.0,
    unknown: Callable[[str], None] | None = None,
    **options: Any,
) -> AsyncIterator[Master]:
    """A started `Master` whose profile is the family of the drive at ``address``
    (``--profile auto``): `identify_family` finds it; then the master is opened with the
    family's profile (and the layout the drive answered). A drive that answers but shows no
    family is taken as one of unknown kind (the master has no profile: its parameters travel
    as words), and ``unknown`` is told so in one sentence (`UNKNOWN_FAMILY`); so is one that
    shows only its kind, whose kind's profile is then used (`KIND_ONLY`)."""
    identity, answered = await _identify(transport, address, layout, job_timeout=job_timeout)
    profile = identity.profile
    _tell(unknown, address, identity)
    async with Master(
        transport(), profile=profile, layout=answered, job_timeout=job_timeout, **options
    ) as master:
        yield master


async def identify_family(
    transport: Callable[[], Transport],
    address: int,
    layout: Layout | None = None,
    *,
    job_timeout: float = 2.0,
    unknown: Callable[[str], None] | None = None,
) -> tuple[str | None, Layout]:
    """The profile of the drive at ``address`` and the layout it answered with: a master on
    ``transport()`` identifies it, with ``layout`` or each of `AUTO_LAYOUTS` in turn. A drive
    that answers but shows no family known here has the profile None (a drive of unknown
    kind: nothing is assumed of it that it did not say); one that answers in no layout is a
    `UssTimeout` naming the address. ``unknown`` is told, as by `auto_master`, of a drive of
    unknown kind (`UNKNOWN_FAMILY`) and of one that shows only its kind (`KIND_ONLY`)."""
    identity, answered = await _identify(transport, address, layout, job_timeout=job_timeout)
    _tell(unknown, address, identity)
    return identity.profile, answered


def _tell(unknown: Callable[[str], None] | None, address: int, identity: Identity) -> None:
    """Tell ``unknown`` what of a drive's family is a guess or not known, if anything."""
    if unknown is None:
        return
    if identity.profile is None:
        unknown(UNKNOWN_FAMILY.format(address=address))
    elif identity.family is None:
        unknown(KIND_ONLY.format(address=address, what=identity.text, profile=identity.profile))


async def _identify(
    transport: Callable[[], Transport],
    address: int,
    layout: Layout | None,
    *,
    job_timeout: float,
) -> tuple[Identity, Layout]:
    """`identify_family` with the whole `Identity`."""
    found = None
    for candidate in (layout,) if layout is not None else AUTO_LAYOUTS:
        async with Master(
            transport(), profile=IDENTIFY_PROFILE, mode=ACYCLIC, job_timeout=job_timeout
        ) as probe:
            try:
                identity = await identify_on(probe, address, candidate, timeout=job_timeout)
            except UssTimeout:
                continue
        if identity is not None:
            found = (identity, candidate)
            break
    if found is None:
        raise UssTimeout(f"address {address}: no answer to identify the drive's family")
    return found
