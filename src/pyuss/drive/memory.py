"""Parameter values of a simulated drive: reads, checked writes, texts, descriptions, EEPROM.

`ParameterMemory` holds the values of every parameter of a `ParameterDatabase` and applies the
rules of the parameter channel (C 4.2) that belong to the drive rather than to the telegram:

- reads of values, array elements, whole arrays, array lengths, description elements (C 4.2.2,
  C 6), texts (request ID 15: IND bit 9 picks the text field, bit 8 writes, C Tables 4.5, 4.6);
- writes refused with typed `ParameterFault`s: wrong PNU (0), read-only (1), limits or allowed
  values (2), index (3), scalar addressed as array (4), wrong word count for the type (5),
  reset-only (6), description elements (7), no write authority of the interface (11, answered
  with response ID 8), keyword missing for protected parameters (12), no text field (15), not in
  this operating state (17);
- writes with the EEPROM request IDs persist in the store file (`pyuss.drive.store`);
- change notification: a change of an ACTIVE parameter calls every subscriber except the
  interface that made it (C 4.2.1.2; the slave engine reports it as a spontaneous message);
  `watch` calls back after any change of one parameter, whoever made it (the slave engine
  follows its interface parameters that way);
- `add_write_rule`: a further condition on the writes of one element (the slave engine refuses
  a baud rate change that would never take effect).

Interfaces are named by strings; `LOCAL` is the drive itself (operator panel, internal updates).
Write authority is granted to every interface until `set_write_authority` takes it away; a
profile may also make it depend on a bit of a parameter (``write_enable``, Baumueller 126).

Texts (C 4.2.2, after the PROFIBUS profile): text elements are 16 characters, blank-padded. The
first text field (IND bit 9 = 0) holds, for an array, the texts naming its elements (element y is
array position y - 1); for an unsigned parameter the value texts (y = value + 1, C 8 example 7);
for a V2 parameter the bit texts (y = 2 x bit + state + 1). The second field (bit 9 = 1) exists
for arrays and holds the value texts of their elements (y = value + 1, C Table 4.6). Texts are
changed only where the profile allows it (``text_write``, C Table 4.1 note 3), else error 7; a
changed text lives until the drive restarts.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from pyuss import _callbacks
from pyuss.drive.database import (
    TEXT_LENGTH,
    Access,
    ParameterDatabase,
    ParamRef,
)
from pyuss.drive.database import (
    Parameter as ParameterSpec,
)
from pyuss.drive.datatypes import DataType, Value, decode, encode, is_visible
from pyuss.drive.description import DescriptionElement, description, element
from pyuss.drive.faults import DriveErrorNumber, NoWriteAuthority, ParameterFault
from pyuss.drive.store import Key, ParameterStore, StoreError
from pyuss.protocol.pkw import INDEX_ALL, ErrorNumber

LOCAL = "local"
"""The interface name of the drive itself (its own updates, an operator panel)."""

_PHASES = {"C": "commissioning", "U": "operation", "T": "ready to run"}

WHOLE_ARRAY = INDEX_ALL
"""The IND low byte (255) that addresses a whole array or the whole description."""

log = logging.getLogger("pyuss.drive")


@dataclass(frozen=True, slots=True)
class ParameterChange:
    """A changed parameter value, as a spontaneous message reports it (C 4.2.1.2).

    ``index`` is the IND of the changed element, None for a scalar and `WHOLE_ARRAY` when every
    element of an array was written at once; ``words`` are the new value(s) as PKW words (all
    elements for a whole array); ``double`` says whether one value is double-word size (response
    IDs 10 and 12 instead of 9 and 11); ``source`` is the interface that made the change.
    """

    pnu: int
    index: int | None
    words: tuple[int, ...]
    double: bool
    source: str


Listener = Callable[[ParameterChange], None]

WriteRule = Callable[[Value, bool], None]
"""A further condition on writes of one parameter element through an interface: called with
the checked value and whether it is an EEPROM write; raises `ParameterFault` to refuse."""

Watcher = Callable[[int], None]
"""Called with the PNU after any change of its value, whoever made it."""


class ParameterMemory:
    """The values of one drive's parameters and the rules of changing them."""

    def __init__(
        self,
        db: ParameterDatabase,
        *,
        store: str | Path | None = None,
        running: Callable[[], bool] = lambda: False,
    ) -> None:
        self.db = db
        self._values: dict[int, list[Value]] = {p.pnu: list(p.default) for p in db}
        self._texts: dict[tuple[int, bool, int], str] = {}
        self._listeners: dict[str, list[Listener]] = {}
        self._rules: dict[tuple[int, int | None], list[WriteRule]] = {}  # by (PNU, IND)
        self._watchers: dict[int, list[Watcher]] = {}
        self._denied: set[str] = set()
        self._running = running
        self._store = None if store is None else ParameterStore(store, db.profile.name)
        self._stored: dict[Key, tuple[int, ...]] = {}
        if self._store is not None:
            self._load_store(self._store)

    # ---------------------------------------------------------------- store

    @property
    def store_path(self) -> Path | None:
        return None if self._store is None else self._store.path

    def _load_store(self, store: ParameterStore) -> None:
        stored = store.load()
        pending: list[tuple[ParameterSpec, int, Value]] = []
        for (pnu, index), words in stored.items():
            try:
                param = self.db.parameter(pnu)
                position = self.db.position(param, index)
                value = param.from_words(words)
                if param.writable:
                    value = param.check_write(value)
            except ParameterFault as exc:
                where = ParamRef(pnu, index)
                raise StoreError(
                    f"{store.path}: stored value of {where} does not fit profile "
                    f"{self.db.profile.name!r} ({exc.meaning}: {exc.detail}); "
                    "the store is not loaded (restore or delete it)"
                ) from None
            pending.append((param, position, value))
        for param, position, value in pending:
            self._values[param.pnu][position] = value
        self._stored = dict(stored)
        if stored:
            log.info("%s: %d stored value(s) loaded", store.path, len(stored))

    def stored(self) -> dict[Key, tuple[int, ...]]:
        """The values in the simulated EEPROM, as (PNU, IND) -> words."""
        return dict(self._stored)

    # ---------------------------------------------------------------- subscribers, authority

    def subscribe(self, interface: str, listener: Listener) -> Callable[[], None]:
        """Call ``listener`` for every change of an active parameter not made by ``interface``.

        Returns a function that ends the subscription.
        """
        return _callbacks.add(self._listeners.setdefault(interface, []), listener)

    def add_write_rule(self, ref: ParamRef, rule: WriteRule) -> Callable[[], None]:
        """Apply ``rule`` to every write of the element ``ref`` through an interface (not to
        the drive's own `update`). Returns a function that removes it."""
        return _callbacks.add(self._rules.setdefault((ref.pnu, ref.index), []), rule)

    def watch(self, pnu: int, watcher: Watcher) -> Callable[[], None]:
        """Call ``watcher(pnu)`` after every change of a value of ``pnu`` (any interface, the
        drive itself, any parameter, active or not). Returns a function that ends it."""
        return _callbacks.add(self._watchers.setdefault(pnu, []), watcher)

    def set_write_authority(self, interface: str, allowed: bool) -> None:
        """Grant or withdraw the parameter write authority of an interface (C 4.2.1.1)."""
        if allowed:
            self._denied.discard(interface)
        else:
            self._denied.add(interface)

    def has_write_authority(self, interface: str) -> bool:
        """Whether ``interface`` may change parameters now: not withdrawn, and for any
        interface but `LOCAL` the profile's write-enable bit (if it has one) is set."""
        if interface in self._denied:
            return False
        enable = self.db.profile.write_enable
        if enable is None or interface == LOCAL:
            return True
        value = self.ref_value(enable)
        assert isinstance(value, int)
        return bool(value >> self.db.profile.write_enable_bit & 1)

    def _notify(self, change: ParameterChange) -> None:
        for interface, listeners in list(self._listeners.items()):
            if interface == change.source:
                continue
            for listener in list(listeners):
                listener(change)

    # ---------------------------------------------------------------- reads

    def parameter(self, pnu: int) -> ParameterSpec:
        """The database entry of ``pnu`` (error 0 if there is none)."""
        return self.db.parameter(pnu)

    def value(self, pnu: int, index: int | None = None) -> Value:
        """The value of a scalar (``index`` None) or of the array element at IND ``index``."""
        param = self.db.parameter(pnu)
        return self._values[pnu][self._position(param, index)]

    def values(self, pnu: int) -> tuple[Value, ...]:
        """Every element of a parameter (one for a scalar)."""
        return tuple(self._values[self.db.parameter(pnu).pnu])

    def ref_value(self, ref: ParamRef) -> Value:
        return self.value(ref.pnu, ref.index)

    def read_words(self, pnu: int, index: int | None = None) -> tuple[int, ...]:
        """PKW words of one value (``index``: IND of an array element)."""
        param = self.db.parameter(pnu)
        return param.to_words(self._values[pnu][self._position(param, index)])

    def read_array_words(self, pnu: int) -> tuple[int, ...]:
        """PKW words of every element of an array, in index order (IND 255, C 4.2.2)."""
        param = self._array(pnu, WHOLE_ARRAY)
        return tuple(word for value in self._values[pnu] for word in param.to_words(value))

    def array_length(self, pnu: int) -> int:
        """Number of elements of an array (request ID 9); error 4 for a scalar."""
        param = self._array(pnu, None)
        assert param.array is not None
        return param.array

    def changed(self, pnu: int) -> bool:
        """Whether any element differs from the factory value (identifier bit 12)."""
        param = self.db.parameter(pnu)
        return tuple(self._values[pnu]) != param.default

    def description_element(self, pnu: int, number: int) -> DescriptionElement:
        """Element ``number`` (IND low byte) of the parameter description."""
        param = self.db.parameter(pnu)
        style = self.db.profile.description
        return element(param, number, style, changed=self.changed(pnu))

    def description(self, pnu: int) -> tuple[DescriptionElement, ...]:
        """The whole parameter description (IND 255)."""
        param = self.db.parameter(pnu)
        return description(param, self.db.profile.description, changed=self.changed(pnu))

    def description_words(self, pnu: int) -> tuple[int, ...]:
        """The whole description as PKW words, elements in order."""
        return tuple(word for item in self.description(pnu) for word in item.words)

    def text(self, pnu: int, y: int, *, second: bool = False) -> str:
        """Text element ``y`` (1..254), 16 characters; ``second``: IND bit 9 (value texts of an
        array's elements)."""
        param = self.db.parameter(pnu)
        self._text_slot(param, y, second)
        override = self._texts.get((pnu, second, y))
        text = override if override is not None else self._stock_text(param, y, second)
        return text.ljust(TEXT_LENGTH)

    def text_words(self, pnu: int, y: int, *, second: bool = False) -> tuple[int, ...]:
        """Text element ``y`` as the 8 PKW words that carry it."""
        return encode(DataType.VISIBLE_STRING, self.text(pnu, y, second=second), TEXT_LENGTH)

    def _text_slot(self, param: ParameterSpec, y: int, second: bool) -> None:
        if not 1 <= y <= 254:
            raise ParameterFault(
                ErrorNumber.BAD_INDEX, f"text element {y} outside 1..254", pnu=param.pnu, index=y
            )
        if second:
            present = param.is_array and bool(param.texts)
        else:
            present = bool(param.index_texts if param.is_array else param.texts or param.bit_texts)
        if not present:
            field = "second (value) text field" if second else "text field"
            raise ParameterFault(
                DriveErrorNumber.NO_TEXT_ARRAY, f"parameter has no {field}", pnu=param.pnu, index=y
            )

    def _stock_text(self, param: ParameterSpec, y: int, second: bool) -> str:
        text: str | None
        if param.is_array and not second:
            text = param.index_texts[y - 1] if y <= len(param.index_texts) else None
        elif param.bit_texts:
            pair = param.bit_texts.get((y - 1) // 2)
            text = None if pair is None else pair[(y - 1) % 2]
        else:
            text = param.texts.get(y - 1)
        if text is None:
            raise ParameterFault(
                ErrorNumber.BAD_INDEX, f"there is no text element {y}", pnu=param.pnu, index=y
            )
        return text

    # ---------------------------------------------------------------- writes

    def write(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        interface: str = LOCAL,
        eeprom: bool = False,
    ) -> Value:
        """Change a value as an interface does: every rule applies. Returns the value now held."""
        return self._write_one(pnu, index, interface, eeprom, lambda param: value)[1]

    def write_words(
        self,
        pnu: int,
        words: Sequence[int],
        index: int | None = None,
        *,
        interface: str = LOCAL,
        eeprom: bool = False,
    ) -> tuple[int, ...]:
        """Change a value from PKW words (one word for 8/16 bit, two for 32 bit and float);
        returns the words now held, for the answer."""
        param, checked = self._write_one(
            pnu, index, interface, eeprom, lambda param: self._decoded(param, words, index)
        )
        return param.to_words(checked)

    def _write_one(
        self,
        pnu: int,
        index: int | None,
        interface: str,
        eeprom: bool,
        value_of: Callable[[ParameterSpec], object],
    ) -> tuple[ParameterSpec, Value]:
        """A write of one value through an interface, in this order: the interface's authority,
        the parameter and element, whether it may be written, the value ``value_of`` gives for
        the parameter, checked, the write rules, the change, `_written`. Returns the parameter
        and the value now held."""
        self._authority(interface, pnu, index)
        param = self.db.parameter(pnu)
        position = self._position(param, index)
        self._may_write(param, index, eeprom)
        checked = self._checked(param, value_of(param), index)
        self._apply_rules(param, index, checked, eeprom)
        self._commit(param, [(position, index, checked)], interface, eeprom, whole=False)
        self._written(pnu)
        return param, checked

    def write_array_words(
        self,
        pnu: int,
        words: Sequence[int],
        *,
        interface: str = LOCAL,
        eeprom: bool = False,
    ) -> tuple[int, ...]:
        """Change every element of an array at once (IND 255); all or nothing."""
        self._authority(interface, pnu, WHOLE_ARRAY)
        param = self._array(pnu, WHOLE_ARRAY)
        assert param.array is not None
        self._may_write(param, WHOLE_ARRAY, eeprom)
        size = param.word_count
        if len(words) != size * param.array:
            raise ParameterFault(
                ErrorNumber.WRONG_TYPE,
                f"the whole array takes {size * param.array} words, the job carries {len(words)}",
                pnu=pnu,
                index=WHOLE_ARRAY,
            )
        base = self.db.profile.index_base
        updates = []
        for position in range(param.array):
            chunk = words[position * size : (position + 1) * size]
            index = base + position
            value = self._checked(param, self._decoded(param, chunk, index), index)
            updates.append((position, index, value))
        for _, index, value in updates:
            self._apply_rules(param, index, value, eeprom)
        self._commit(param, updates, interface, eeprom, whole=True)
        words_held = self.read_array_words(pnu)
        self._written(pnu)
        return words_held

    def write_text(
        self,
        pnu: int,
        y: int,
        text: str,
        *,
        second: bool = False,
        interface: str = LOCAL,
    ) -> str:
        """Change text element ``y`` (request ID 15 with IND bit 8); returns the stored text."""
        self._authority(interface, pnu, y)
        param = self.db.parameter(pnu)
        self._text_slot(param, y, second)
        self._stock_text_or_slot(param, y, second)
        if not self.db.profile.text_write:
            raise ParameterFault(
                ErrorNumber.DESCRIPTION_NOT_CHANGEABLE,
                f"profile {self.db.profile.name!r} does not change texts",
                pnu=pnu,
                index=y,
            )
        clean = text.rstrip(" ")
        if len(clean) > TEXT_LENGTH or not is_visible(clean):
            raise ParameterFault(
                ErrorNumber.LIMIT_EXCEEDED,
                f"a text is at most {TEXT_LENGTH} visible ASCII characters",
                pnu=pnu,
                index=y,
            )
        self._texts[(pnu, second, y)] = clean
        return clean.ljust(TEXT_LENGTH)

    def write_text_words(
        self,
        pnu: int,
        y: int,
        words: Sequence[int],
        *,
        second: bool = False,
        interface: str = LOCAL,
    ) -> tuple[int, ...]:
        """`write_text` from the 8 PKW words of a text element."""
        text = decode(DataType.VISIBLE_STRING, words, TEXT_LENGTH)
        assert isinstance(text, str)
        stored = self.write_text(pnu, y, text, second=second, interface=interface)
        return encode(DataType.VISIBLE_STRING, stored, TEXT_LENGTH)

    def write_description_element(self, pnu: int, number: int, *, interface: str = LOCAL) -> None:
        """Request ID 5: the description is fixed in the simulated drive (error 7)."""
        self._authority(interface, pnu, number)
        self.description_element(pnu, number)  # an unknown PNU or element is reported as such
        raise ParameterFault(
            ErrorNumber.DESCRIPTION_NOT_CHANGEABLE,
            "the parameter description cannot be changed",
            pnu=pnu,
            index=number,
        )

    def update(self, pnu: int, value: object, index: int | None = None) -> bool:
        """The drive's own change of a value (a display, a counter): no access or limit rules,
        only the type's range. Reports the change if the parameter is active. Returns whether
        the value changed."""
        param = self.db.parameter(pnu)
        position = self._position(param, index)
        try:
            checked = param.coerce(value)
        except ParameterFault as exc:
            raise ParameterFault(exc.number, exc.detail, pnu=pnu, index=index) from None
        if self._values[pnu][position] == checked:
            return False
        self._commit(param, [(position, index, checked)], LOCAL, False, whole=False)
        return True

    # ---------------------------------------------------------------- rules

    def _position(self, param: ParameterSpec, index: int | None) -> int:
        return self.db.position(param, index)

    def _array(self, pnu: int, index: int | None) -> ParameterSpec:
        param = self.db.parameter(pnu)
        if param.array is None:
            raise ParameterFault(
                ErrorNumber.NOT_ARRAY, "parameter is not an array", pnu=pnu, index=index
            )
        return param

    def _authority(self, interface: str, pnu: int, index: int | None) -> None:
        """Without write authority no change job is processed at all (C 4.2.1.1). The
        write-enable parameter itself stays writable, or nobody could give authority back."""
        enable = self.db.profile.write_enable
        if enable is not None and pnu == enable.pnu and interface not in self._denied:
            return
        if not self.has_write_authority(interface):
            raise NoWriteAuthority(interface, pnu=pnu, index=index)

    def _may_write(self, param: ParameterSpec, index: int | None, eeprom: bool) -> None:
        pnu = param.pnu
        if param.access is Access.RO:
            raise ParameterFault(ErrorNumber.NOT_CHANGEABLE, "read-only", pnu=pnu, index=index)
        if eeprom and not param.store:
            raise ParameterFault(
                ErrorNumber.NOT_CHANGEABLE, "not storable in EEPROM", pnu=pnu, index=index
            )
        if param.access is Access.PROTECTED and not self._unlocked():
            level = self.db.profile.access_level
            raise ParameterFault(
                DriveErrorNumber.KEYWORD_MISSING,
                f"protected: needs {level} >= {self.db.profile.protected_level}",
                pnu=pnu,
                index=index,
            )
        if param.stopped_only and self._running():
            raise ParameterFault(
                DriveErrorNumber.WRONG_STATE,
                "changeable only while the drive does not run",
                pnu=pnu,
                index=index,
            )
        if param.changeable is not None:
            phase = self.phase()
            if phase not in param.changeable:
                raise ParameterFault(
                    DriveErrorNumber.WRONG_STATE,
                    f"changeable in {'/'.join(_PHASES[c] for c in param.changeable)} only, "
                    f"not {_PHASES[phase]}",
                    pnu=pnu,
                    index=index,
                )

    def commissioning_active(self) -> bool:
        """Whether the drive is in commissioning: the ``[commissioning]`` parameter is not 0."""
        rule = self.db.commissioning
        return rule is not None and self._values[rule.parameter][0] != 0

    def phase(self) -> str:
        """The letter of `pyuss.drive.database.CHANGEABLE_LETTERS` the drive is in now: C in
        commissioning, U while it runs, T while it is ready and does not run."""
        if self.commissioning_active():
            return "C"
        return "U" if self._running() else "T"

    def set_own(self, pnu: int, value: object, index: int | None = None) -> None:
        """The drive's own change of a setting (the end of commissioning, a factory reset):
        like `update`, and a value held in the EEPROM store is changed there too, so the
        drive powers up with it."""
        param = self.db.parameter(pnu)
        self.update(pnu, value, index)
        key = (pnu, index)
        if key in self._stored and self._store is not None:
            stored = dict(self._stored)
            stored[key] = param.to_words(self.value(pnu, index))
            self._store.save(stored)
            self._stored = stored

    def restore_factory(self, keep: Iterable[int] = ()) -> None:
        """Every parameter but read-only ones and those in ``keep`` back to its factory value,
        and out of the EEPROM store."""
        kept = set(keep)
        base = self.db.profile.index_base
        for param in self.db:
            if not param.writable or param.pnu in kept:
                continue
            for position, value in enumerate(param.default):
                index = None if param.array is None else base + position
                self.update(param.pnu, value, index)
        stored = {k: v for k, v in self._stored.items() if k[0] in kept or not self._writable(k[0])}
        if stored != self._stored:
            if self._store is not None:
                self._store.save(stored)
            self._stored = stored

    def _writable(self, pnu: int) -> bool:
        return pnu in self.db and self.db.parameter(pnu).writable

    def _apply_rules(
        self, param: ParameterSpec, index: int | None, value: Value, eeprom: bool
    ) -> None:
        for rule in self._rules.get((param.pnu, index), ()):
            try:
                rule(value, eeprom)
            except ParameterFault as exc:
                raise ParameterFault(exc.number, exc.detail, pnu=param.pnu, index=index) from None

    def _unlocked(self) -> bool:
        ref = self.db.profile.access_level
        if ref is None:
            return True
        level = self.ref_value(ref)
        assert isinstance(level, int | float)
        return level >= self.db.profile.protected_level

    def _decoded(self, param: ParameterSpec, words: Sequence[int], index: int | None) -> Value:
        try:
            return param.from_words(words)
        except ParameterFault as exc:
            raise ParameterFault(exc.number, exc.detail, pnu=param.pnu, index=index) from None

    def _checked(self, param: ParameterSpec, value: object, index: int | None) -> Value:
        try:
            return param.check_write(value)
        except ParameterFault as exc:
            raise ParameterFault(exc.number, exc.detail, pnu=param.pnu, index=index) from None

    def _commit(
        self,
        param: ParameterSpec,
        updates: Iterable[tuple[int, int | None, Value]],
        interface: str,
        eeprom: bool,
        *,
        whole: bool,
    ) -> None:
        updates = list(updates)
        if eeprom:
            if self._store is None:
                log.debug("P%d: EEPROM write without a store file: kept in RAM only", param.pnu)
            else:
                stored = dict(self._stored)
                for _, index, value in updates:
                    stored[(param.pnu, index)] = param.to_words(value)
                self._store.save(stored)  # first the file: a failed save changes nothing
                self._stored = stored
        values = self._values[param.pnu]
        changed = False
        for position, _, value in updates:
            changed |= values[position] != value
            values[position] = value
        if changed:
            self._changed(param.pnu)
            for watcher in list(self._watchers.get(param.pnu, ())):
                watcher(param.pnu)
        if not (param.active and changed):
            return
        if whole:
            words = tuple(w for value in values for w in param.to_words(value))
            change = ParameterChange(
                param.pnu, WHOLE_ARRAY, words, param.word_count == 2, interface
            )
            self._notify(change)
            return
        for _, index, value in updates:
            self._notify(
                ParameterChange(
                    param.pnu, index, param.to_words(value), param.word_count == 2, interface
                )
            )

    def _changed(self, pnu: int) -> None:
        """Called after a value of ``pnu`` changed (for subclasses that cache settings)."""

    def _written(self, pnu: int) -> None:
        """Called after an interface wrote ``pnu`` (for subclasses with rules that act on a
        write, such as the end of commissioning); the answer carries the value written."""

    def _stock_text_or_slot(self, param: ParameterSpec, y: int, second: bool) -> None:
        """A text may be changed where a text element exists or could exist (an index of the
        array, a value of the type, a bit state)."""
        if (param.pnu, second, y) in self._texts:
            return
        try:
            self._stock_text(param, y, second)
        except ParameterFault:
            if param.is_array and not second:
                assert param.array is not None
                if y <= param.array:
                    return
            elif param.bit_texts:
                if y <= 32:
                    return
            else:
                low, high = param.dtype.type_range
                if low <= y - 1 <= high:
                    return
            raise
