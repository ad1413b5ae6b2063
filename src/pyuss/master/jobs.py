"""The parameter channel of one slave, master side (C 4.2.1.1, C 4.2.1.2), without I/O.

The scheduler asks `ParameterChannel.request` for the PKW area of every telegram it sends to
the slave and hands every answer to `ParameterChannel.answer`. Time is passed in.

Rules (C 4.2.1.1):

- At most one open job per slave. Jobs queue in order; the open one is repeated in every
  telegram to the slave until the answer that belongs to it arrives (`pyuss.master.profile.answers`:
  the response ID of C Table 4.3, the PNU and, for indexed jobs, IND), or until its time is up
  (`JobTimeout`). Without a job the master sends "no job".
- Response ID 7 ends the job with `DriveRefusal` (error number and meaning, the profile's
  meanings for device numbers), ID 8 with `NoWriteAuthority`.
- An old answer is never taken for a new one. A slave repeats the answer to the previous job
  until it has processed the next one ("Übergangsphase zwischen Alt-Auftrag und Neu-Auftrag"),
  and some jobs share their answer's signature: "write P52 = 5" and then "read P52" are both
  answered with ID 1, PNU 52. So before a job starts, the master looks at the slave's latest
  answer (spontaneous messages aside): if that answer would be accepted as the answer to the
  new job - or nothing is known about it (first contact, after a job timed out) - the master
  sends "no job" until the slave answers "no response" (which answers no job but "no job"),
  and only then the new job. Two jobs in a row whose answers cannot be confused follow each
  other directly.
- A job's time starts when it is due: when it is submitted to an idle channel, or when the
  job before it ends. The time held back by the guard counts, so a slave that never answers
  "no response" times the job out, and a job never lasts longer than its timeout plus the
  one exchange that is on the line at its deadline. No telegram carries a job after its
  deadline. A `JobTimeout` says whether the job was ever sent (`JobOutcome.NOT_SENT`: the
  drive did not get it) or not answered (`JobOutcome.UNKNOWN`: a change may have been
  carried out) and how long it took (``elapsed``, on the clock passed in).
- Spontaneous messages (IDs 9..12, C 4.2.1.2) interrupt the job: a message is new when its
  toggle bit (PKE bit 11) differs from the master's, which then takes the slave's value - the
  master changes its own bit 11, acknowledging it - and hands the message on once. Repeats
  (same bit) are ignored; the interrupted job goes on being sent. The master's bit starts at
  the value of the slave's first answer, so a bit left over from an earlier session is not
  taken for a message; a first answer that is a spontaneous message is delivered.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from pyuss.errors import DriveRefusal, UssError
from pyuss.master.errors import (
    NOT_SENDING_HINT,
    JobOutcome,
    JobTimeout,
    NoWriteAuthority,
    job_changes,
)
from pyuss.master.profile import Profile, answers
from pyuss.master.stats import JobStats, Samples
from pyuss.protocol.pkw import SPONTANEOUS_IDS, Pkw, RequestId, ResponseId

__all__ = ["Job", "ParameterChannel", "SpontaneousMessage", "describe_job"]

_NO_JOB = RequestId.NO_JOB


@dataclass(frozen=True, slots=True)
class SpontaneousMessage:
    """A spontaneous message (C 4.2.1.2): a parameter changed through another interface."""

    address: int
    pnu: int
    response: ResponseId
    index: int | None
    """The array element for IDs 11 and 12 (IND low byte; 255 = the whole array)."""
    values: tuple[int, ...]
    time: float

    @property
    def value(self) -> int | None:
        """The new value: a word for IDs 9 and 11, a double word for 10 and 12; None when the
        message carries no value (a whole array on a fixed-length interface)."""
        if not self.values:
            return None
        pkw = Pkw(self.response, 0, 0, values=self.values)
        double = self.response in (ResponseId.SPONTANEOUS_DWORD, ResponseId.SPONTANEOUS_ARRAY_DWORD)
        if double and len(self.values) == 2:
            return pkw.dword()
        return pkw.word()


def describe_job(request: Pkw, pnu: int, index: int | None, label: str | None = None) -> str:
    """``"read parameter value r0052"`` and the like, for messages (``label``: the parameter as
    the drive's family writes it; without it ``P52``)."""
    where = label or (f"P{pnu}" + ("" if index is None else f".{index}"))
    try:
        what = RequestId(request.id).text
    except ValueError:  # pragma: no cover - Pkw ids are 0..15, all named
        what = f"request {request.id}"
    return f"{what} {where}"


@dataclass(eq=False)
class Job:
    """One parameter job: the PKW area to send and who waits for the answer.

    ``done`` is called once, when ``answer`` or ``error`` is set. ``due``: when its time
    started; ``started``: when it was first sent; ``sent``: telegrams that carried it.
    """

    request: Pkw
    pnu: int
    index: int | None
    timeout: float
    done: Callable[[Job], None]
    answer: Pkw | None = None
    error: BaseException | None = None
    due: float | None = None
    started: float | None = None
    sent: int = 0
    finished: bool = field(default=False)

    @property
    def text(self) -> str:
        return describe_job(self.request, self.pnu, self.index)

    @property
    def deadline(self) -> float | None:
        """When its time is up (None while it is not due yet)."""
        return None if self.due is None else self.due + self.timeout


class ParameterChannel:
    """The master side of one slave's PKW interface; see the module docstring."""

    def __init__(self, address: int, profile: Profile) -> None:
        self.address = address
        self.profile = profile
        self.queue: deque[Job] = deque()
        self.current: Job | None = None
        self.last_answer: Pkw | None = None
        """The slave's latest answer other than a spontaneous message; None: not known."""
        self.toggle = False
        """The master's PKE bit 11 (C 4.2.1.2)."""
        self.synced = False
        self.not_sending = False
        """Set by the scheduler; only used to word timeout messages."""
        self._completed = 0
        self._refused = 0
        self._timed_out = 0
        self._guard = 0
        self._spontaneous = 0
        self._telegrams = Samples()
        self._latency = Samples()

    # -- jobs ------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """True while a job is open or queued."""
        return self.current is not None or bool(self.queue)

    def submit(self, job: Job, now: float | None = None) -> None:
        """Queue ``job``; with ``now`` its time starts at once when nothing is before it
        (else when the job before it ends, or, without ``now``, at the next request)."""
        if now is not None and self.current is None and not self.queue:
            job.due = now
        self.queue.append(job)

    @property
    def deadline(self) -> float | None:
        """The earliest time a job of this channel runs out (None: none is due)."""
        job = self.current if self.current is not None else (self.queue[0] if self.queue else None)
        return None if job is None else job.deadline

    def _next_due(self, now: float) -> None:
        if self.current is None and self.queue and self.queue[0].due is None:
            self.queue[0].due = now

    def cancel(self, job: Job) -> None:
        """Forget ``job`` (its waiter gave up). An open job leaves the slave's answer unknown."""
        if job is self.current:
            self.current = None
            self.last_answer = None
        elif job in self.queue:
            self.queue.remove(job)
        job.finished = True

    def fail_all(self, error: BaseException) -> None:
        """End every job with ``error`` (the master closes)."""
        jobs = ([self.current] if self.current is not None else []) + list(self.queue)
        self.current = None
        self.queue.clear()
        for job in jobs:
            self._finish(job, error=error)

    def request(self, now: float) -> Pkw:
        """The PKW area for the telegram sent at ``now``."""
        self.expire(now)
        if self.current is None and self.queue:
            head = self.queue[0]
            if head.due is None:
                head.due = now
            last = self.last_answer
            if last is None or answers(self.profile, last, head.request):
                self._guard += 1
                return Pkw(_NO_JOB, spm_toggle=self.toggle)
            self.queue.popleft()
            self.current = head
            head.started = now
        job = self.current
        if job is None:
            return Pkw(_NO_JOB, spm_toggle=self.toggle)
        job.sent += 1
        return replace(job.request, spm_toggle=self.toggle)

    def expire(self, now: float) -> None:
        """End the open job, or a queued one still waiting for the slave to clear its old
        answer, once its time is up."""
        job = self.current
        if job is not None:
            if job.due is None:  # pragma: no cover - a job is due before it is sent
                job.due = job.started
            deadline = job.deadline
            if deadline is not None and now > deadline:
                self.current = None
                self.last_answer = None
                self._timed_out += 1
                if not self.not_sending:
                    what = (
                        f"slave {self.address}: no answer to {self._text(job)} within "
                        f"{job.timeout:g} s ({job.sent} telegrams sent; C 4.2.1.1): the drive "
                        "answers, but not this job: allow it more time, or repeat it"
                    )
                elif not self.synced:
                    what = self._silent(job)
                else:
                    what = (
                        f"slave {self.address} has stopped answering: no reply to "
                        f"{self._text(job)} within {job.timeout:g} s ({job.sent} telegrams "
                        "sent): check the wiring, and whether the drive knows this request "
                        "(USS specification A 5.2.1.1: the slave does not send; C 4.2.1.1)"
                    )
                self._finish(job, error=self._timeout(job, now, what))
                self._next_due(now)
        if self.current is None and self.queue:
            head = self.queue[0]
            deadline = head.deadline
            if deadline is not None and now > deadline:
                self.queue.popleft()
                self._timed_out += 1
                if self.not_sending:
                    what = self._silent(head)
                else:
                    what = (
                        f"slave {self.address}: {self._text(head)} not sent within "
                        f"{head.timeout:g} s: "
                        "the slave kept repeating an answer that could be taken for the answer "
                        "to it and did not answer 'no job' with 'no response' (C 4.2.1.1)"
                    )
                self._finish(head, error=self._timeout(head, now, what))
                self._next_due(now)

    def _text(self, job: Job) -> str:
        """The job in words, its parameter as the drive's family writes it."""
        return describe_job(job.request, job.pnu, job.index, self.profile.label(job.pnu, job.index))

    def _silent(self, job: Job) -> str:
        """What a job's end says of a slave that does not answer at all."""
        return (
            f"slave {self.address} does not answer (no reply within {job.timeout:g} s): "
            f"{NOT_SENDING_HINT} (USS specification A 5.2.1.1: the slave does not send)"
        )

    def _timeout(self, job: Job, now: float, message: str) -> JobTimeout:
        outcome = JobOutcome.NOT_SENT if job.sent == 0 else JobOutcome.UNKNOWN
        if job_changes(job.request):
            if outcome is JobOutcome.NOT_SENT:
                message += "; the drive did not get it"
            else:
                message += "; the drive may have carried it out: read the value back to know"
        return JobTimeout(
            message,
            address=self.address,
            pnu=job.pnu,
            index=job.index,
            sent=job.sent,
            outcome=outcome,
            elapsed=None if job.due is None else now - job.due,
            timeout=job.timeout,
            request=job.request,
        )

    # -- answers ---------------------------------------------------------------------------
    def answer(self, pkw: Pkw, now: float) -> SpontaneousMessage | None:
        """Take the PKW area of an answer; returns a new spontaneous message, if it is one."""
        first = not self.synced
        self.synced = True
        if pkw.id in SPONTANEOUS_IDS:
            if not first and pkw.spm_toggle == self.toggle:
                return None  # a repeat of a message already acknowledged
            self.toggle = pkw.spm_toggle
            self._spontaneous += 1
            response = ResponseId(pkw.id)
            indexed = response.is_indexed
            return SpontaneousMessage(
                address=self.address,
                pnu=self.profile.decode_pnu(pkw.pnu, pkw.index),
                response=response,
                index=pkw.subindex if indexed else None,
                values=pkw.values,
                time=now,
            )
        if first:
            self.toggle = pkw.spm_toggle
        self.last_answer = pkw
        job = self.current
        if job is None or not answers(self.profile, pkw, job.request):
            return None
        self.current = None
        self._next_due(now)
        if job.started is not None:
            self._latency.add(now - job.started)
        self._telegrams.add(job.sent)
        if pkw.id == ResponseId.REFUSED:
            self._refused += 1
            number = pkw.error_number
            if number is None:  # cannot happen with a layout's PKW area: PWE1 always travels
                error: UssError = DriveRefusal(
                    0xFFFF, "no error number sent", pnu=job.pnu, index=job.index
                )
            else:
                error = DriveRefusal(
                    number,
                    self.profile.error_meaning(number),
                    pnu=job.pnu,
                    index=job.index,
                    label=self.profile.label(job.pnu, job.index),
                    hint=self.profile.error_hint(number),
                )
            self._finish(job, error=error)
        elif pkw.id == ResponseId.NO_AUTHORITY:
            self._refused += 1
            refusal = NoWriteAuthority(
                address=self.address,
                pnu=job.pnu,
                index=job.index,
                label=self.profile.label(job.pnu, job.index),
                hint=self.profile.no_authority_hint,
            )
            self._finish(job, error=refusal)
        else:
            self._completed += 1
            self._finish(job, answer=pkw)
        return None

    def stats(self) -> JobStats:
        return JobStats(
            completed=self._completed,
            refused=self._refused,
            timed_out=self._timed_out,
            guard_telegrams=self._guard,
            spontaneous=self._spontaneous,
            telegrams=self._telegrams.summary(),
            latency=self._latency.summary(),
        )

    @staticmethod
    def _finish(job: Job, *, answer: Pkw | None = None, error: BaseException | None = None) -> None:
        if job.finished:
            return
        job.finished = True
        job.answer = answer
        job.error = error
        job.done(job)
