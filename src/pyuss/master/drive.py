"""`Drive`: the handle of one slave on a `Master` bus - parameters and process data.

Parameters (C 4) go through the slave's parameter channel (`pyuss.master.jobs`): every method
is one or more jobs, queued behind the jobs of other tasks; errors are typed: `DriveRefusal`
(response 7 with error number and meaning), `NoWriteAuthority` (response 8), `JobTimeout`,
`ConfigError` for requests the layout cannot carry (C 7).

- Values: `read` / `write` take the parameter number (``pnu``; numbers from 2000 on where the
  profile extends them through IND bits) and, for array parameters, the element ``index``
  (C 4.2.2: read with request 6, write with 7/8, or 11/12 with ``eeprom=True``). Without an
  index: request 1, and 2/3 (14/13 with ``eeprom``). Values are typed through what is known of
  the drive's parameters (`params`, a `pyuss.params.ParamBook`: the user's parameter file, the
  drive's own descriptions, the profile's file): a float is a float, a signed type signed, a
  scaled value comes out scaled, an array without index is read whole. A written value is
  checked against the parameter's type and limits before anything is sent. A drive of no named
  profile (`Master` without one) starts with an empty book: no family's facts are applied to
  it, a parameter no file of the user's knows travels as words, and the drive alone refuses
  what it does not take.
- Descriptions (request 4, C 6) are asked for where the book's policy says
  (`pyuss.params.Describe`: by default only where the profile says the drive has them). A
  drive that refuses one (other than with error 0, "no such parameter") or does not answer it
  though it answers other telegrams is a drive without descriptions: the value travels as
  words at once and no description is asked of it again. `read_param` /
  `write_param` return a `pyuss.params.Reading` (words, value and what is known); `read_raw` /
  `write_raw` take and give the PWE words as they travel.
- `info` (what is known of a parameter, reading its description where needed),
  `array_length` (request 9), `read_array` (IND 255 in one telegram with the variable layout,
  element by element otherwise, counting from the drive's first index).
- `read_description`: one element (request 4, IND = element), or the whole description (IND
  255 with the variable layout; element by element with a fixed one, where elements too long
  for the PKW area are left out), decoded by `pyuss.master.description`.
- `read_text` / `write_text` (request 15, variable layout only, C 4.2.2 Tables 4.5/4.6).

Process data (C 5): `Drive` is composed from `pyuss.master.control.DriveControl`, the mixin
of its process data commands (`on`, `off1`..`off3`, `enable`, `acknowledge`, `jog`,
`setpoint`, `control_word`, `status`, `next_update`, `wait_until`, `on_update`); their rules
are that module's. Parameter jobs never touch the process data.

The words of a value as the master sends and takes them (the value's words in an answer, an
array's elements, a value nothing is known of) are the functions of `pyuss.master.values`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from pyuss import _callbacks
from pyuss.drive.database import TEXT_LENGTH, DescriptionStyle, ParameterDatabase
from pyuss.drive.datatypes import Value
from pyuss.errors import ConfigError, DriveRefusal, TelegramError
from pyuss.master.control import ControlBus, DriveControl
from pyuss.master.description import (
    BAUMUELLER_ELEMENTS,
    PROFIBUS_ELEMENTS,
    Description,
    DescriptionElement,
    decode_description,
    decode_element,
    element_size,
)
from pyuss.master.errors import JobTimeout
from pyuss.master.jobs import SpontaneousMessage
from pyuss.master.profile import Profile, description_style, index_base
from pyuss.master.stats import SlaveCounts, SlaveDiagnostics
from pyuss.master.values import (
    DOUBLE_ANSWERS,
    answer_words,
    element_index,
    negative,
    split_elements,
    untyped,
    untyped_float,
    untyped_words,
)
from pyuss.master.verify import read_back
from pyuss.params.book import ParamBook
from pyuss.params.model import ParamInfo, Reading
from pyuss.params.values import ValueRefused, decode, encode
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import (
    INDEX_ALL,
    ErrorNumber,
    Pkw,
    RequestId,
    TextIndex,
    pwe_text,
    words_to_text,
)

if TYPE_CHECKING:
    from pyuss.master.core import MirrorResult, Slave


class Bus(ControlBus, Protocol):
    """What a `Drive` asks of its master (`pyuss.master.Master`): its public calls only; those
    of the process data commands are `ControlBus`'s."""

    async def parameter_job(
        self, slave: Slave, request: Pkw, pnu: int, index: int | None, timeout: float | None
    ) -> Pkw: ...
    async def mirror(self, address: int, data: bytes | None = None) -> MirrorResult: ...


__all__ = ["Drive"]


class Drive(DriveControl):
    """One slave of a `Master` (made by `Master.drive`); see the module docstring."""

    _master: Bus

    def __init__(self, master: Bus, link: Slave) -> None:
        self._master = master
        self._link = link
        self.params = (
            ParamBook.for_profile(link.profile)
            if link.named
            else ParamBook(index_base=index_base(link.profile))
        )
        """What is known of this drive's parameters (`pyuss.params.ParamBook`): the named
        profile's file, or nothing for a drive of unknown kind."""

    def __repr__(self) -> str:
        return f"<Drive {self.address} layout {self.layout} profile {self.profile.name}>"

    # -- what it is ------------------------------------------------------------------------
    @property
    def address(self) -> int:
        return self._link.address

    @property
    def layout(self) -> Layout:
        return self._link.layout

    @property
    def profile(self) -> Profile:
        return self._link.profile

    @property
    def profile_named(self) -> bool:
        """Whether the profile was named (by the caller, or the drive showed its family): its
        parameter facts, texts and reference apply. False for a drive of unknown kind, whose
        `profile` gives only the USS specification's telegram rules."""
        return self._link.named

    @property
    def response_delay(self) -> float:
        """The response delay limit in seconds (A 5.2.1.1)."""
        return self._link.response_delay

    @property
    def not_sending(self) -> bool:
        """ "Slave x does not send" (A 5.2.1.1): set when it did not answer in time, cleared by
        its next good telegram."""
        return self._link.not_sending

    @property
    def missed(self) -> int:
        """Telegrams in a row it gave no usable answer to (silent, late, garbled); 0 after
        an answer."""
        return self._link.missed

    def on_missed(self, callback: Callable[[int], object]) -> Callable[[], None]:
        """Call ``callback`` with `missed` after each telegram it gave no usable answer to
        (in the master's task: it must not block); returns a function that removes it."""
        return _callbacks.add(self._link.miss_callbacks, callback)

    def diagnostics(self) -> SlaveDiagnostics:
        """A 5.2.3 counters of its answers, response times, jobs."""
        return self._link.snapshot(self._master.clock())

    def counts(self) -> SlaveCounts:
        """The counts of `diagnostics` without response times and jobs (quicker to make)."""
        return self._link.counts(self._master.clock())

    async def mirror(self) -> MirrorResult:
        """A mirror test (A 5.3) with a telegram of the slave's length."""
        return await self._master.mirror(self.address)

    # -- parameter jobs ----------------------------------------------------------------------
    def _ind(self, pnu: int, subindex: int = 0, text: TextIndex | int = 0) -> tuple[int, int]:
        bits, high = self.profile.encode_pnu(pnu)
        return bits, subindex | int(text) | high

    async def job(
        self,
        request: Pkw,
        *,
        pnu: int | None = None,
        index: int | None = None,
        timeout: float | None = None,
    ) -> Pkw:
        """Send any PKW job and return the answer that belongs to it (the raw `Pkw`).
        ``pnu``/``index`` only word error messages (default: from ``request``)."""
        name = self.profile.decode_pnu(request.pnu, request.index) if pnu is None else pnu
        return await self._master.parameter_job(self._link, request, name, index, timeout)

    def on_spontaneous(
        self, callback: Callable[[SpontaneousMessage], object]
    ) -> Callable[[], None]:
        """Call ``callback`` for every new spontaneous message of this slave (C 4.2.1.2);
        the master acknowledges it by itself. Returns a function that removes it."""
        return _callbacks.add(self._link.spontaneous_callbacks, callback)

    # -- what the drive's parameters are ----------------------------------------------------
    def use_params(self, source: str | Path | ParameterDatabase) -> None:
        """Take a parameter file of the user's (the simulator's TOML format, docs/drive.md) as
        the most trusted knowledge of this drive's parameters (`pyuss.params.ParamBook`)."""
        if isinstance(source, ParameterDatabase):
            self.params.use_database(source)
        else:
            self.params.use_file(source)

    async def info(self, pnu: int, *, timeout: float | None = None) -> ParamInfo | None:
        """What is known of ``pnu`` (`pyuss.params.ParamInfo`), or None. Reads the drive's
        description of it first where the book's policy says so (`ParamBook.describe`): by
        default only for a parameter no file knows, of a drive whose profile says it has
        descriptions. A drive that refuses the description or does not answer it is noted as
        one without descriptions (`ParamBook.no_descriptions`) and not asked again; a drive
        that answers nothing at all raises the `JobTimeout`."""
        self.profile.encode_pnu(pnu)
        book = self.params
        if book.needs_description(pnu):
            try:
                description = await self.read_description(pnu, timeout=timeout)
            except DriveRefusal as refusal:
                if refusal.number == ErrorNumber.ILLEGAL_PNU:
                    book.no_description(pnu)  # no such parameter: reading its value says so
                else:
                    book.no_descriptions()
            except JobTimeout as silence:
                if not silence.sent:
                    raise  # it answers nothing at all: the value would wait in vain too
                book.no_descriptions()
            except TelegramError:
                book.no_description(pnu)
            else:
                book.learn(description)
        return book.get(pnu)

    def _check_index(self, info: ParamInfo | None, pnu: int, index: int | None) -> None:
        if info is None or index is None:
            return
        if info.array is None:
            raise ConfigError(f"{info.label()} ({info.name}) is not an array: give no index")
        span = self.params.indices(info)
        if index not in span:
            raise ConfigError(
                f"{info.label()} ({info.name}) has {info.array} element(s): index "
                f"{span.start}..{span.stop - 1}, not {index}"
            )

    # -- values ------------------------------------------------------------------------------
    async def read_raw(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> tuple[int, ...]:
        """The PWE words of ``pnu`` (element ``index`` of an array) as the drive sent them:
        request 1, or 6 for an element (C 4.2.2); ``index=255`` the whole array in one
        telegram (variable layout)."""
        whole = index == INDEX_ALL
        index = None if whole else element_index(index)
        if index is None and not whole:
            bits, ind = self._ind(pnu)
            request = Pkw(RequestId.READ_VALUE, bits, ind)
        else:
            bits, ind = self._ind(pnu, INDEX_ALL if whole else index or 0)
            request = Pkw(RequestId.READ_ARRAY, bits, ind)
        answer = await self.job(
            request, pnu=pnu, index=INDEX_ALL if whole else index, timeout=timeout
        )
        return answer_words(answer, pnu, self.params, self.layout)

    async def read_param(
        self,
        pnu: int,
        index: int | None = None,
        *,
        progress: Callable[[int, int], object] | None = None,
        timeout: float | None = None,
    ) -> Reading:
        """``pnu`` read and converted by what is known of it (`info`): the words, the typed
        value and the `ParamInfo`. An array parameter without ``index`` is read whole
        (`read_array`; ``progress(done, total)`` is called per element read one by one), and
        so is a parameter nothing is known of that the drive will only read with an index
        (error 3, C Table 4.3)."""
        info = await self.info(pnu, timeout=timeout)
        self._check_index(info, pnu, index)
        if info is not None and info.array is not None and index is None:
            words, values = await self._array(pnu, info, progress, timeout)
            return Reading(pnu, None, info, words, values)
        if info is None:
            try:
                words = await self.read_raw(pnu, index, timeout=timeout)
            except DriveRefusal as refusal:
                if index is not None or refusal.number != ErrorNumber.BAD_INDEX:
                    raise
                # it wants an index: an array nothing is known of, read whole
                try:
                    words, values = await self._array(pnu, None, progress, timeout)
                except DriveRefusal:
                    raise refusal from None
                return Reading(pnu, None, None, words, values)
            return Reading(pnu, index, None, words, untyped(words))
        words = await self.read_raw(pnu, index, timeout=timeout)
        return Reading(pnu, index, info, words, decode(info, words, index))

    async def read(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Value | list[Value]:
        """The value of ``pnu`` (element ``index`` of an array; a whole array as a list),
        typed and scaled by what is known of it: a float is a float, a signed type signed, a
        scaled integer its physical value (NORD P102: 2.0 for 200 x 0.01 s), a text a
        `str`. A parameter nothing is known of reads as the unsigned word or double word the
        drive sent. The words themselves: `read_raw`."""
        return (await self.read_param(pnu, index, timeout=timeout)).value

    async def _array(
        self,
        pnu: int,
        info: ParamInfo | None,
        progress: Callable[[int, int], object] | None,
        timeout: float | None,
    ) -> tuple[tuple[int, ...], list[Value]]:
        if self.layout.variable:
            bits, ind = self._ind(pnu, INDEX_ALL)
            try:
                answer = await self.job(
                    Pkw(RequestId.READ_ARRAY, bits, ind), pnu=pnu, index=INDEX_ALL, timeout=timeout
                )
            except DriveRefusal:
                pass  # the drive reads its elements one by one only
            else:
                words = answer_words(answer, pnu, self.params, self.layout)
                size = info.words if info is not None else (2 if answer.id in DOUBLE_ANSWERS else 1)
                chunks = split_elements(words, size, pnu)
                if info is None:
                    return words, [untyped(c) for c in chunks]
                base = self.params.index_base
                return words, [decode(info, c, base + i) for i, c in enumerate(chunks)]
        count = info.array if info is not None and info.array else None
        if count is None:
            count = await self.array_length(pnu, timeout=timeout)
        base = self.params.index_base if info is not None else index_base(self.profile)
        all_words: list[int] = []
        values: list[Value] = []
        for number, element in enumerate(range(base, base + count)):
            words = await self.read_raw(pnu, element, timeout=timeout)
            all_words.extend(words)
            values.append(untyped(words) if info is None else decode(info, words, element))
            if progress is not None:
                progress(number + 1, count)
        return tuple(all_words), values

    async def read_array(
        self,
        pnu: int,
        *,
        progress: Callable[[int, int], object] | None = None,
        timeout: float | None = None,
    ) -> list[Value]:
        """Every element of array parameter ``pnu``, typed as `read` does: one telegram (IND
        255) with the variable layout where the drive allows it, else element by element
        (``progress(done, total)`` after each), counting from the drive's first index."""
        info = await self.info(pnu, timeout=timeout)
        _words, values = await self._array(pnu, info, progress, timeout)
        return values

    async def write_raw(
        self,
        pnu: int,
        words: Sequence[int],
        index: int | None = None,
        *,
        eeprom: bool = False,
        dword: bool | None = None,
        timeout: float | None = None,
        verify: bool = False,
    ) -> tuple[int, ...]:
        """Write the PWE ``words`` to ``pnu`` (element ``index``) as they are: request 2/3 (14/13
        with ``eeprom``), 7/8 (12/11) for an element (C 4.2.2). Two words are a double word
        unless the parameter is known to be a string (``dword`` decides otherwise). Returns the
        words the drive answered with. Nothing is checked against the parameter's type or
        limits: the drive refuses what it does not take.

        ``verify=True``: when the answer never comes, read the value back
        (`pyuss.master.verify`) and return it if the drive holds it; otherwise the
        `JobTimeout` says `JobOutcome.NOT_APPLIED` (or stays ``UNKNOWN`` when the read fails
        too)."""
        index = element_index(index)
        words = tuple(words)
        if not words or any(
            isinstance(w, bool) or not isinstance(w, int) or not 0 <= w <= 0xFFFF for w in words
        ):
            raise ConfigError(f"words must be 1 or more values 0..FFFFh, got {list(words)!r}")
        if dword is None:
            info = self.params.get(pnu)
            dword = len(words) == 2 and (info is None or not info.dtype.is_string)
        if dword and len(words) != 2:
            raise ConfigError(f"a double word is 2 words, not {len(words)}")
        if dword and self.layout.pkw == 3:
            raise ConfigError(
                f"a double word does not fit layout {self.layout}: PKW 3 holds one word, "
                "double words need PKW 4 or the variable layout (C 7)"
            )
        if not self.layout.variable and len(words) > self.layout.pkw - 2:
            raise ConfigError(
                f"{len(words)} words do not fit layout {self.layout} (C 7): use the variable "
                "layout (PKW 127)"
            )
        if index is None:
            rid = (
                (RequestId.WRITE_DWORD_EEPROM if eeprom else RequestId.WRITE_DWORD)
                if dword
                else (RequestId.WRITE_WORD_EEPROM if eeprom else RequestId.WRITE_WORD)
            )
            bits, ind = self._ind(pnu)
        else:
            rid = (
                (RequestId.WRITE_ARRAY_DWORD_EEPROM if eeprom else RequestId.WRITE_ARRAY_DWORD)
                if dword
                else (RequestId.WRITE_ARRAY_WORD_EEPROM if eeprom else RequestId.WRITE_ARRAY_WORD)
            )
            bits, ind = self._ind(pnu, index)
        request = Pkw(rid, bits, ind, values=words)
        answer = await self._write_job(request, pnu, index, timeout, verify)
        return answer_words(answer, pnu, self.params, self.layout)

    async def write_param(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
        verify: bool = False,
    ) -> Reading:
        """Write a typed ``value`` (see `write`); returns the `Reading` of the drive's answer."""
        index = element_index(index)
        info = await self.info(pnu, timeout=timeout)
        self._check_index(info, pnu, index)
        if info is None:
            words = untyped_words(pnu, value)
            answer = await self.write_raw(
                pnu, words, index, eeprom=eeprom, timeout=timeout, verify=verify
            )
            typed: Value = (
                untyped_float(answer)
                if isinstance(value, float)
                else untyped(answer, signed=negative(value))
            )
            return Reading(pnu, index, None, answer, typed, words)
        if info.array is not None and index is None:
            raise ConfigError(
                f"{info.label()} ({info.name}) is an array: give the element's index "
                f"({self.params.index_base}..{self.params.index_base + info.array - 1})"
            )
        if info.read_only:
            raise ValueRefused(f"{info.label()} ({info.name}) is read-only")
        words = encode(info, value, index)
        dword = len(words) == 2 and not info.dtype.is_string
        answer = await self.write_raw(
            pnu, words, index, eeprom=eeprom, dword=dword, timeout=timeout, verify=verify
        )
        return Reading(pnu, index, info, answer, decode(info, answer, index), words)

    async def write(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
        verify: bool = False,
    ) -> Value | list[Value]:
        """Write ``value`` to ``pnu`` (element ``index``) as the parameter's type takes it: a
        number for a float, a signed or unsigned integer, the physical value of a scaled one
        (2.5 for 2.50 s at 0.01 s), `str` for text, `bytes` for an octet string. A value of the
        wrong kind, between two steps of the scaling, outside the limits, or for a read-only
        parameter is refused before anything is sent (`pyuss.params.ValueRefused`, a
        `ConfigError`); bit fields (V2) go through `write_raw`. ``eeprom=True`` stores the
        value in the drive's non-volatile memory as well (requests 11..14). Returns the value
        the drive answered with.

        For a parameter nothing is known of, an integer is a word if it fits -32768..65535 and
        a double word otherwise; a float is an IEEE 754 double word (C 6).

        ``verify=True``: when the answer never comes, read the value back and return it if the
        drive holds it (`write_raw`)."""
        reading = await self.write_param(
            pnu, value, index, eeprom=eeprom, timeout=timeout, verify=verify
        )
        return reading.value

    async def _write_job(
        self, request: Pkw, pnu: int, index: int | None, timeout: float | None, verify: bool
    ) -> Pkw:
        """A change job; with ``verify`` a lost answer is settled by reading the value back."""
        try:
            return await self.job(request, pnu=pnu, index=index, timeout=timeout)
        except JobTimeout as error:
            if not verify:
                raise
            return await read_back(self.job, error, timeout=timeout)

    async def array_length(self, pnu: int, *, timeout: float | None = None) -> int:
        """How many elements array parameter ``pnu`` has (request 9)."""
        bits, ind = self._ind(pnu)
        answer = await self.job(
            Pkw(RequestId.READ_ARRAY_COUNT, bits, ind), pnu=pnu, timeout=timeout
        )
        return answer.word()

    def _elements(self) -> dict[int, str]:
        if description_style(self.profile) is DescriptionStyle.BAUMUELLER:
            return BAUMUELLER_ELEMENTS
        return PROFIBUS_ELEMENTS

    async def _element_words(
        self, pnu: int, element: int, timeout: float | None
    ) -> tuple[int, ...]:
        bits, ind = self._ind(pnu, element)
        answer = await self.job(
            Pkw(RequestId.READ_PBE_ELEMENT, bits, ind), pnu=pnu, index=element, timeout=timeout
        )
        return answer.values

    async def read_description(
        self, pnu: int, element: int | None = None, *, timeout: float | None = None
    ) -> Description:
        """The description of ``pnu`` (C 6): only ``element`` (1..254) if given, else all of it.

        A whole description travels in one telegram (IND 255) with the variable layout only
        (C 4.2.2): so without ``element`` a fixed layout reads the elements one by one and
        leaves out those the drive refuses (too long for the PKW area, C 7) - but not the
        first, the data type, without which there is no description. ``element=255`` asks for
        the whole description in one telegram whatever the layout (a fixed-length drive
        refuses it, C 8 example 3). A drive that answers other telegrams but not this request
        has no descriptions: the `JobTimeout` says so.
        """
        try:
            return await self._description(pnu, element, timeout)
        except JobTimeout as silence:
            if silence.sent:
                within = "" if silence.timeout is None else f" within {silence.timeout:g} s"
                silence.args = (
                    f"slave {self.address} gives no description of {self.params.label(pnu)}: "
                    "it does not answer "
                    f"request 4 (no reply{within} to {silence.sent} telegrams, though it "
                    "answers others): it has no parameter descriptions, as most USS slaves "
                    "(USS specification C 6)",
                )
            raise

    async def _description(
        self, pnu: int, element: int | None, timeout: float | None
    ) -> Description:
        style = description_style(self.profile)
        if element is not None and element != INDEX_ALL:
            if isinstance(element, bool) or not isinstance(element, int) or not 1 <= element <= 254:
                raise ConfigError(f"description element must be 1..255, got {element!r}")
            words = await self._element_words(pnu, element, timeout)
            return Description(pnu, style, {element: decode_element(element, words, style)})
        if element == INDEX_ALL or self.layout.variable:
            bits, ind = self._ind(pnu, INDEX_ALL)
            answer = await self.job(
                Pkw(RequestId.READ_PBE_ELEMENT, bits, ind),
                pnu=pnu,
                index=INDEX_ALL,
                timeout=timeout,
            )
            return decode_description(pnu, answer.values, style)
        elements: dict[int, DescriptionElement] = {}
        type_code: int | None = None
        attribute: int | None = None
        for number in self._elements():
            try:
                words = await self._element_words(pnu, number, timeout)
            except DriveRefusal:
                if not elements and number == 1:
                    raise  # no data type: no description
                continue
            size = element_size(number, style, type_code=type_code, attribute=attribute)
            if size is not None and len(words) > size:
                words = words[-size:]  # a word travels in PWE2 with PKW 4 (C 4.2.3)
            if number == 1 and words:
                attribute = words[-1]
                type_code = words[-1] & 0xFF
            elements[number] = decode_element(
                number, words, style, type_code=type_code, attribute=attribute
            )
        return Description(pnu, style, elements)

    def _text_request(
        self, pnu: int, index: int, write: bool, value_texts: bool
    ) -> tuple[int, int]:
        if not self.layout.variable:
            raise ConfigError(
                f"texts need the variable layout (PKW 127), slave {self.address} uses "
                f"{self.layout} (C 4.2.2)"
            )
        if isinstance(index, bool) or not isinstance(index, int) or not 1 <= index <= 254:
            raise ConfigError(f"text element must be 1..254, got {index!r} (C Table 4.5)")
        text = (TextIndex.WRITE if write else TextIndex.READ) | (
            TextIndex.VALUE_TEXTS if value_texts else TextIndex.READ
        )
        return self._ind(pnu, index, text)

    async def read_text(
        self, pnu: int, index: int, *, value_texts: bool = False, timeout: float | None = None
    ) -> str:
        """Text element ``index`` of ``pnu`` (request 15, C Table 4.5); ``value_texts`` selects
        the second text field of an array parameter (IND bit 9, C Table 4.6)."""
        bits, ind = self._text_request(pnu, index, False, value_texts)
        answer = await self.job(
            Pkw(RequestId.TEXT, bits, ind), pnu=pnu, index=index, timeout=timeout
        )
        return words_to_text(answer.values)

    async def write_text(
        self,
        pnu: int,
        index: int,
        text: str,
        *,
        value_texts: bool = False,
        timeout: float | None = None,
    ) -> str:
        """Write text element ``index`` of ``pnu`` (16 characters, blank padded)."""
        bits, ind = self._text_request(pnu, index, True, value_texts)
        words = pwe_text(text, TEXT_LENGTH)
        answer = await self.job(
            Pkw(RequestId.TEXT, bits, ind, values=words), pnu=pnu, index=index, timeout=timeout
        )
        return words_to_text(answer.values)
