"""One parameter job, executed: request PKW in, response PKW out (C 4.2.1.1, C 4.2.2, C 7).

`ParameterChannel.execute` carries out a job on the drive's parameters (or on the slave's
diagnostic parameters, `pyuss.slave.diagnostic`) and builds the answer; `ParameterChannel.current`
rebuilds the answer to a job already carried out with the values of now, for the repetitions of
an answer (C 4.2.1.1: "bei der Wiederholung der Antworttelegramme immer mit dem aktuellen Wert").
Which job is new and when its answer is ready is the engine's business (`pyuss.slave.engine`).

Request IDs and their answers (C Tables 4.1..4.3, 4.8, 4.9, 4.10, 4.11):

=====  =================================  ===============================================
ID     job                                answer
=====  =================================  ===============================================
0      no job                             0 no response (all zero)
1      read value                         1 (word) or 2 (double word); a string travels
                                          as its words with ID 1 (variable length only)
2, 14  write word (14: and store)         1 with the value now held
3, 13  write double word (13: and store)  2
4      read description element IND       3; IND 255: the whole description (variable
                                          length only)
5      write description element          refused: 7 (element not changeable)
6      read array element IND             4 (word) or 5 (double word); IND 255: all
                                          elements (variable length only)
7, 12  write array element (word)         4; IND 255: every element (variable only)
8, 11  write array element (double word)  5; IND 255: every element (variable only)
9      read array length                  6
10     reserved                           7 with the profile's ``unsupported_error``
15     text: IND bits 0..7 = element y,   15 with the 16 characters of the element; IND as
       bit 8 = write, bit 9 = second      requested. Variable length only (C 4.2.2)
       field (values of an array)
=====  =================================  ===============================================

Refusals: a `pyuss.drive.ParameterFault` of the drive becomes response 7 with its number; a
change job without write authority becomes response 8 (C 4.2.1.1, checked before anything else:
such jobs are "not processed"). A job whose answer does not fit the PKW area - a double word in
3 words, a whole array, a whole description or a text under a fixed length (C 4.2.2 "Index
Low-Byte 255", C 7) - is answered with 7 and the profile's ``too_large_error``. Request IDs a
profile does not know (Baumueller: 0..4 only) get its ``unsupported_error``. An EEPROM write
(IDs 11..14) whose store file cannot be written (the disk is full, the folder is gone) is not
carried out: it is answered with 7 and error 1 "parameter not changeable", the reason is logged
as a warning, and the slave goes on serving (the project's choice; a real drive whose EEPROM
fails answers a refusal too).

Word placement: with PKW 4 a word travels in PWE2, with PKW 3 and the variable length in PWE1
(C 4.2.3 "Hinweis", reading 6) - for the answer `pyuss.protocol.layout.Layout.pack` does it, for
the request `request_word` reads it.

IND of the answers: the request's IND (subindex, text bits, device bits such as the
MICROMASTER 4 page), or always 0 for profiles that say so (6SE21). PNU: the request's PKE bits;
the parameter addressed is the profile's `decode_pnu` of them and IND.
"""

from __future__ import annotations

import logging
from dataclasses import replace

from pyuss.drive.database import Parameter
from pyuss.drive.faults import NoWriteAuthority, ParameterFault
from pyuss.drive.memory import ParameterMemory
from pyuss.drive.store import StoreError
from pyuss.profiles.base import Profile
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import INDEX_ALL, ErrorNumber, Pkw, RequestId, ResponseId, TextIndex
from pyuss.slave.diagnostic import DiagnosticParameters

__all__ = ["ALL_REQUESTS", "ParameterChannel", "TooLarge", "request_word"]

log = logging.getLogger("pyuss.slave")

R = RequestId
A = ResponseId

ALL_REQUESTS = frozenset(r for r in RequestId if r is not RequestId.RESERVED_10)
"""The request IDs of C Table 4.1 (all but the reserved 10)."""

_DWORD_WRITES = frozenset(
    {R.WRITE_DWORD, R.WRITE_DWORD_EEPROM, R.WRITE_ARRAY_DWORD, R.WRITE_ARRAY_DWORD_EEPROM}
)
_WORD_WRITES = frozenset(
    {R.WRITE_WORD, R.WRITE_WORD_EEPROM, R.WRITE_ARRAY_WORD, R.WRITE_ARRAY_WORD_EEPROM}
)
_WRITES = _WORD_WRITES | _DWORD_WRITES
_ARRAY_WRITES = frozenset(
    {R.WRITE_ARRAY_WORD, R.WRITE_ARRAY_DWORD, R.WRITE_ARRAY_WORD_EEPROM, R.WRITE_ARRAY_DWORD_EEPROM}
)
_EEPROM = frozenset(
    {
        R.WRITE_WORD_EEPROM,
        R.WRITE_DWORD_EEPROM,
        R.WRITE_ARRAY_WORD_EEPROM,
        R.WRITE_ARRAY_DWORD_EEPROM,
    }
)
_WHOLE = frozenset({R.READ_PBE_ELEMENT, R.WRITE_PBE_ELEMENT, R.READ_ARRAY, *_ARRAY_WRITES})
"""Jobs for which IND low byte 255 means "everything" (C 4.2.2)."""
_VALUE_ANSWERS = frozenset(
    {
        A.VALUE_WORD,
        A.VALUE_DWORD,
        A.PBE_ELEMENT,
        A.ARRAY_WORD,
        A.ARRAY_DWORD,
        A.ARRAY_COUNT,
        A.TEXT,
    }
)


class TooLarge(Exception):
    """The answer would not fit the PKW area (C 7)."""


def request_word(job: Pkw, layout: Layout) -> int:
    """The 16-bit value of a write job: PWE2 with PKW 4, else PWE1 (C 4.2.3, reading 6)."""
    if not job.values:
        raise ParameterFault(ErrorNumber.WRONG_TYPE, "the job carries no value")
    return job.values[1] if layout.pkw == 4 and len(job.values) > 1 else job.values[0]


_CHANGES = frozenset(r for r in RequestId if r.is_change)


def _changes(job: Pkw) -> bool:
    if job.id == RequestId.TEXT:
        return bool(job.index & TextIndex.WRITE)
    return job.id in _CHANGES


class ParameterChannel:
    """Executes parameter jobs for one slave interface on a drive's parameters.

    ``memory`` holds the drive's parameters, ``diagnostics`` the slave's own (read-only, routed
    by number), ``interface`` names this interface for write authority and change reports,
    ``requests`` are the request IDs the device knows.
    """

    def __init__(
        self,
        memory: ParameterMemory,
        layout: Layout,
        profile: Profile,
        *,
        interface: str,
        diagnostics: DiagnosticParameters | None = None,
        requests: frozenset[int] = ALL_REQUESTS,
    ) -> None:
        self.memory = memory
        self.layout = layout
        self.profile = profile
        self.interface = interface
        self.diagnostics = diagnostics
        self.requests = requests

    # -- answers ----------------------------------------------------------------------------

    def _answer(self, job: Pkw, response: int, values: tuple[int, ...], index: int) -> Pkw:
        if len(values) > self.layout.max_pwe:
            raise TooLarge
        if self.profile.answer_index_zero:
            index = 0
        return Pkw(response, job.pnu, index, False, values)

    def refused(self, job: Pkw, number: int) -> Pkw:
        """Response 7 with error ``number`` to ``job``."""
        index = 0 if self.profile.answer_index_zero else job.index
        return Pkw(ResponseId.REFUSED, job.pnu, index, False, (number & 0xFFFF,))

    def _no_authority(self, job: Pkw) -> Pkw:
        index = 0 if self.profile.answer_index_zero else job.index
        return Pkw(ResponseId.NO_AUTHORITY, job.pnu, index, False, (0,))

    # -- execution --------------------------------------------------------------------------

    def execute(self, job: Pkw, now: float) -> Pkw:
        """Carry out ``job`` (its toggle bit is ignored) and return the answer."""
        if job.id == RequestId.NO_JOB:
            return Pkw(ResponseId.NO_RESPONSE)
        if job.id not in self.requests:
            return self.refused(job, self.profile.unsupported_error)
        pnu = self.profile.decode_pnu(job.pnu, job.index)
        memory = self._memory(pnu, now)
        try:
            if _changes(job) and not self._may_change(pnu):
                return self._no_authority(job)
            return self._run(job, pnu, memory)
        except NoWriteAuthority:
            return self._no_authority(job)
        except ParameterFault as fault:
            if _changes(job):  # why a change was refused (`uss -v simulate` shows it)
                log.info("change refused: %s", fault)
            return self.refused(job, fault.number)
        except TooLarge:
            return self.refused(job, self.profile.too_large_error)
        except StoreError as exc:
            log.warning("P%d: EEPROM write not carried out: %s", pnu, exc)
            return self.refused(job, ErrorNumber.NOT_CHANGEABLE)

    def current(self, job: Pkw, answer: Pkw, now: float) -> Pkw:
        """The answer to ``job`` (carried out before, answered with ``answer``) with the values
        of now: value answers are read again, refusals repeat as they were."""
        if answer.id not in _VALUE_ANSWERS or job.id == RequestId.NO_JOB:
            return answer
        req = RequestId(job.id)
        if req in _WRITES:
            read = RequestId.READ_ARRAY if req in _ARRAY_WRITES else RequestId.READ_VALUE
            job = replace(job, id=read)
        elif req is RequestId.TEXT:
            job = replace(job, index=job.index & ~TextIndex.WRITE)
        pnu = self.profile.decode_pnu(job.pnu, job.index)
        try:
            fresh = self._run(job, pnu, self._memory(pnu, now))
        except (ParameterFault, TooLarge):
            return answer
        return fresh if fresh.index == answer.index else replace(fresh, index=answer.index)

    def _may_change(self, pnu: int) -> bool:
        """Write authority for a change job: the drive's, also for the slave's diagnostic
        parameters. The profile's write-enable parameter is left to the drive, which keeps it
        writable (else nobody could give authority back)."""
        enable = self.memory.db.profile.write_enable
        if enable is not None and enable.pnu == pnu:
            return True
        return self.memory.has_write_authority(self.interface)

    def _memory(self, pnu: int, now: float) -> ParameterMemory:
        if self.diagnostics is not None and pnu in self.diagnostics:
            return self.diagnostics.refresh(now)
        return self.memory

    def _run(self, job: Pkw, pnu: int, memory: ParameterMemory) -> Pkw:
        req = RequestId(job.id)
        layout = self.layout
        sub = job.index & 0xFF
        index = job.index
        whole = sub == INDEX_ALL and req in _WHOLE
        if whole and not layout.variable:
            raise TooLarge  # IND 255 needs the variable length (C 4.2.2)
        if req is RequestId.TEXT and not layout.variable:
            raise TooLarge  # texts need the variable length (C 4.2.2)
        if req in _DWORD_WRITES and layout.pkw == 3:
            raise TooLarge  # a double word does not fit 3 words (C 7)
        if req is RequestId.READ_VALUE:
            words = memory.read_words(pnu)
            return self._answer(job, _value_id(memory.parameter(pnu)), words, index)
        if req in (RequestId.WRITE_WORD, RequestId.WRITE_WORD_EEPROM):
            param = memory.parameter(pnu)
            count = param.word_count
            if _double(param):
                raise ParameterFault(ErrorNumber.WRONG_TYPE, "a word job for a double word")
            if count > layout.max_pwe:
                raise TooLarge
            values = (request_word(job, layout),) if count == 1 else job.values[:count]
            eeprom = req in _EEPROM
            words = memory.write_words(pnu, values, interface=self.interface, eeprom=eeprom)
            return self._answer(job, ResponseId.VALUE_WORD, words, index)
        if req in (RequestId.WRITE_DWORD, RequestId.WRITE_DWORD_EEPROM):
            param = memory.parameter(pnu)
            if not _double(param):
                raise ParameterFault(ErrorNumber.WRONG_TYPE, "a double word job for a word")
            eeprom = req in _EEPROM
            words = memory.write_words(pnu, job.values[:2], interface=self.interface, eeprom=eeprom)
            return self._answer(job, ResponseId.VALUE_DWORD, words, index)
        if req is RequestId.READ_PBE_ELEMENT:
            if whole:
                words = memory.description_words(pnu)
            else:
                words = memory.description_element(pnu, sub).words
            return self._answer(job, ResponseId.PBE_ELEMENT, words, index)
        if req is RequestId.WRITE_PBE_ELEMENT:
            memory.write_description_element(pnu, sub, interface=self.interface)
            raise AssertionError("unreachable: a description is never changed")  # pragma: no cover
        if req is RequestId.READ_ARRAY:
            param = memory.parameter(pnu)
            words = memory.read_array_words(pnu) if whole else memory.read_words(pnu, sub)
            return self._answer(job, _array_id(param), words, index)
        if req in _ARRAY_WRITES:
            return self._write_array(job, req, pnu, memory, sub, whole)
        if req is RequestId.READ_ARRAY_COUNT:
            count = memory.array_length(pnu)
            return self._answer(job, ResponseId.ARRAY_COUNT, (count,), index)
        if req is RequestId.TEXT:
            return self._text(job, pnu, memory, sub)
        raise AssertionError(f"request {req!r} not dispatched")  # pragma: no cover

    def _write_array(
        self,
        job: Pkw,
        req: RequestId,
        pnu: int,
        memory: ParameterMemory,
        sub: int,
        whole: bool,
    ) -> Pkw:
        param = memory.parameter(pnu)
        double = req in _DWORD_WRITES
        if _double(param) != double:
            what = "double word" if double else "word"
            raise ParameterFault(ErrorNumber.WRONG_TYPE, f"a {what} job for this parameter")
        eeprom = req in _EEPROM
        response = ResponseId.ARRAY_DWORD if double else ResponseId.ARRAY_WORD
        if whole:
            words = memory.write_array_words(
                pnu, job.values, interface=self.interface, eeprom=eeprom
            )
        else:
            values = job.values[:2] if double else (request_word(job, self.layout),)
            words = memory.write_words(pnu, values, sub, interface=self.interface, eeprom=eeprom)
        return self._answer(job, response, words, job.index)

    def _text(self, job: Pkw, pnu: int, memory: ParameterMemory, y: int) -> Pkw:
        if y == INDEX_ALL:
            raise ParameterFault(ErrorNumber.BAD_INDEX, "IND 255 has no meaning for texts")
        second = bool(job.index & TextIndex.VALUE_TEXTS)
        if job.index & TextIndex.WRITE:
            words = memory.write_text_words(
                pnu, y, job.values, second=second, interface=self.interface
            )
        else:
            words = memory.text_words(pnu, y, second=second)
        return self._answer(job, ResponseId.TEXT, words, job.index)


def _double(param: Parameter) -> bool:
    """A 32-bit value (strings travel as words, whatever their length)."""
    return not param.dtype.is_string and param.word_count == 2


def _value_id(param: Parameter) -> ResponseId:
    return ResponseId.VALUE_DWORD if _double(param) else ResponseId.VALUE_WORD


def _array_id(param: Parameter) -> ResponseId:
    return ResponseId.ARRAY_DWORD if _double(param) else ResponseId.ARRAY_WORD
