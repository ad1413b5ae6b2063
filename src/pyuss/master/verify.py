"""Telling whether a change job whose answer never came was carried out: read the value back.

A drive carries out a job when a telegram carrying it arrives, and then answers it
(C 4.2.1.1). When the answer is lost on the line the master gives the job up with a
`JobTimeout` whose outcome is `JobOutcome.UNKNOWN` - in a noisy line that is often a job the
drive did carry out. `read_back` asks the drive: it reads the parameter (or array element,
description element, text) the job wrote and compares it with what the job sent, as numbers
(so a word in PWE2 of a 4-word PKW area compares with the same word read back in PWE1).

The drive works through one job at a time, so once it has answered the read, the lost write
is behind it: a value that differs means the write was not carried out, and will not be - or
that the drive holds a value of its own for it (a drive that limits or rounds answers a write
with the value it holds; the message says both).
A value that was already there before the write reads as `JobOutcome.APPLIED` too: either way
the drive holds it.

`Drive.write(..., verify=True)` and ``uss write --verify`` use it.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from pyuss.errors import UssError
from pyuss.master.errors import JobOutcome, JobTimeout, job_changes
from pyuss.master.jobs import describe_job
from pyuss.protocol.pkw import Pkw, RequestId, ResponseId, TextIndex

__all__ = ["RunJob", "read_back", "read_request"]


RunJob = Callable[..., Awaitable[Pkw]]
"""What `read_back` asks the drive with: `pyuss.master.Drive.job` (``job(request, *, pnu,
index, timeout)``), which runs a PKW job and returns the answer that belongs to it."""

_READ_OF = {
    RequestId.WRITE_WORD: RequestId.READ_VALUE,
    RequestId.WRITE_DWORD: RequestId.READ_VALUE,
    RequestId.WRITE_WORD_EEPROM: RequestId.READ_VALUE,
    RequestId.WRITE_DWORD_EEPROM: RequestId.READ_VALUE,
    RequestId.WRITE_ARRAY_WORD: RequestId.READ_ARRAY,
    RequestId.WRITE_ARRAY_DWORD: RequestId.READ_ARRAY,
    RequestId.WRITE_ARRAY_WORD_EEPROM: RequestId.READ_ARRAY,
    RequestId.WRITE_ARRAY_DWORD_EEPROM: RequestId.READ_ARRAY,
    RequestId.WRITE_PBE_ELEMENT: RequestId.READ_PBE_ELEMENT,
    RequestId.TEXT: RequestId.TEXT,
}
_DOUBLE_WRITES = frozenset(
    {
        RequestId.WRITE_DWORD,
        RequestId.WRITE_DWORD_EEPROM,
        RequestId.WRITE_ARRAY_DWORD,
        RequestId.WRITE_ARRAY_DWORD_EEPROM,
    }
)
_DOUBLE_ANSWERS = frozenset({ResponseId.VALUE_DWORD, ResponseId.ARRAY_DWORD})


def read_request(write: Pkw) -> Pkw:
    """The request that reads back what change job ``write`` wrote (same PNU and IND; a text
    write becomes a text read)."""
    rid = RequestId(write.id)
    if not job_changes(write) or rid not in _READ_OF:
        raise ValueError(f"request {rid.name} changes nothing that can be read back")
    index = write.index & ~int(TextIndex.WRITE) if rid is RequestId.TEXT else write.index
    return Pkw(_READ_OF[rid], write.pnu, index)


def _written(write: Pkw) -> int | tuple[int, ...]:
    rid = RequestId(write.id)
    if rid in _DOUBLE_WRITES:
        return write.dword()
    if rid in _READ_OF and _READ_OF[rid] in (RequestId.READ_VALUE, RequestId.READ_ARRAY):
        return write.word()
    return write.values


def _held(write: Pkw, answer: Pkw) -> int | tuple[int, ...]:
    if RequestId(write.id) in (RequestId.TEXT, RequestId.WRITE_PBE_ELEMENT):
        return answer.values
    if answer.id in _DOUBLE_ANSWERS:
        return answer.dword()
    return answer.word()


async def read_back(job: RunJob, error: JobTimeout, *, timeout: float | None = None) -> Pkw:
    """After ``error`` (a change job that timed out with an unknown outcome), read the value
    back with ``job`` (the drive's `Drive.job`). Returns the read's answer when the drive
    holds the value written (the write was carried out; ``error.outcome`` becomes
    `JobOutcome.APPLIED`); raises ``error`` with outcome `JobOutcome.NOT_APPLIED` when it holds
    another, and ``error`` unchanged (`JobOutcome.UNKNOWN`, the read's failure noted) when the
    read fails as well. An error whose outcome is already known (never sent) is raised as it
    is."""
    write = error.request
    if write is None or not error.may_have_applied:
        raise error
    try:
        answer = await job(read_request(write), pnu=error.pnu, index=error.index, timeout=timeout)
        written, held = _written(write), _held(write, answer)
    except UssError as exc:
        error.args = (f"{error.args[0]}; reading it back failed too: {exc}",)
        raise error from exc
    if held == written:
        error.outcome = JobOutcome.APPLIED
        return answer
    error.outcome = JobOutcome.NOT_APPLIED
    shown = f"{held} ({held:X}h)" if isinstance(held, int) else " ".join(f"{w:04X}" for w in held)
    what = describe_job(write, write.pnu if error.pnu is None else error.pnu, error.index)
    error.args = (
        f"slave {error.address}: no answer to {what} within {error.timeout:g} s, and reading "
        f"it back shows {shown}: the drive does not hold the value written: it did not carry "
        "it out (it may be repeated), or it holds a value of its own (it limits or rounds)",
    )
    raise error
