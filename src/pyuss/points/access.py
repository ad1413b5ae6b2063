"""A drive's parameters through its points: typed reads and writes, the reference, the polled
parameters, and the words of an answer as the values of the parameters they carry.

`ParameterAccess` is held by `pyuss.points.drive.DrivePoints` (one per drive), which offers its
reads and writes as its own. The rules:

- A parameter value is checked against its type, limits and access before the job goes out
  (`write_parameter` for a number in the parameter's unit, through `ParameterModel`;
  `write_value` for a value as a person types it, through `pyuss.params.parse`): a refused
  value raises (`ConfigError`, `ValueRefused`) and nothing is sent.
- A refusal of the drive is raised to the caller (`pyuss.errors.DriveRefusal` with the
  drive's error number, `NoWriteAuthority`) and kept as the drive's last refusal
  (`last_refusal`, shown in its health).
- The reference (the physical value of 100 %) is read from the profile's parameter once it
  can (again every `RETRY_PERIOD` until it is), and anew when a face writes that parameter;
  only a positive finite number is taken. A fixed reference of the configuration stays.
- The configured parameters are kept with their last reading, the polled ones read when due;
  a failed poll keeps the value with its error.
- The words PZD3... of an answer are the values of the parameters the profile maps them to
  (`actual_items`, `actual_row`), PZD2 the main actual value in the reference's unit.
- Every job goes through the drive handle, so everything queues in the master and nothing
  interleaves on the line.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from pyuss.drive.datatypes import Value
from pyuss.errors import ConfigError, DriveRefusal, UssError
from pyuss.master.drive import Drive
from pyuss.master.errors import NoWriteAuthority
from pyuss.params import ParamInfo, ValueRefused, decode, parse
from pyuss.params.model import Reading, param_label
from pyuss.params.values import parse_unknown
from pyuss.points.checks import MAX_TEXT
from pyuss.points.errors import error_dict
from pyuss.points.model import DriveModel
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.state import ParamValue, now, process_value

__all__ = ["RETRY_PERIOD", "ParameterAccess"]

log = logging.getLogger("pyuss.points")

RETRY_PERIOD = 5.0
"""How long to wait before reading the reference again after a failure (seconds)."""


class ParameterAccess:
    """The parameters of one drive (see the module docstring); ``changed`` is called when
    something its points show changed (a kept reading, the reference, a refusal)."""

    def __init__(self, model: DriveModel, drive: Drive, changed: Callable[[], None]) -> None:
        self.model = model
        self.drive = drive
        self.parameter_model = ParameterModel(model.profile)
        self.reference: float | None = (
            model.reference if isinstance(model.reference, float) else None
        )
        """The physical value of 100 % (None until known)."""
        self.params: dict[str, ParamValue] = {p.key: ParamValue(p.meta) for p in model.parameters}
        """The configured parameters' last readings, by key."""
        self.last_refusal: dict[str, object] | None = None
        """The drive's last refusal of a job (`error_dict`)."""
        self._changed = changed

    @contextlib.contextmanager
    def _refusal_kept(self) -> Iterator[None]:
        """A refusal of the drive raised in the block is kept as its last (and raised on)."""
        try:
            yield
        except (DriveRefusal, NoWriteAuthority) as exc:
            self.last_refusal = error_dict(exc)
            self._changed()
            raise

    def _kept(self, meta: ParamMeta, value: float) -> ParamValue:
        """``value`` read or written now, kept (and shown) where ``meta`` is a configured
        parameter."""
        reading = ParamValue(meta, value, now())
        if meta.key in self.params:
            self.params[meta.key] = reading
            self._changed()
        return reading

    # -- process data as the parameters' values ----------------------------------------------
    def process_parameter(self, number: int) -> ParamInfo | None:
        """The parameter the profile maps to actual value PZD``number`` (3 and up; None for a
        drive of unknown kind)."""
        if not self.drive.profile_named:
            return None
        pnus = self.drive.profile.database().process_actuals
        pnu = pnus[number - 3] if 0 <= number - 3 < len(pnus) else 0
        return self.drive.params.get(pnu) if pnu else None

    def actual_columns(self) -> list[dict[str, Any]]:
        """Name and unit of every actual value of `actual_row`: PZD2 the main one (in the
        reference's unit or %), PZD3... as the profile's parameters for them."""
        columns: list[dict[str, Any]] = []
        for number in range(2, self.model.layout.pzd + 1):
            if number == 2:
                unit = self.model.unit if self.reference is not None else "%"
                columns.append({"pzd": 2, "name": "Main actual value", "unit": unit})
                continue
            info = self.process_parameter(number)
            if info is not None:
                columns.append({"pzd": number, "name": info.name, "unit": info.unit})
            else:
                columns.append({"pzd": number, "name": f"PZD{number}", "unit": ""})
        return columns

    def actual_items(self, words: Sequence[int]) -> list[tuple[Value, ParamInfo | None]]:
        """The actual values of an answer's PZD2... as values, each with the parameter that
        types it: PZD2 in the reference's unit (or %, no parameter), PZD3... decoded by the
        parameters the profile maps them to (the word as it came, without a parameter, where
        none is known or it does not decode)."""
        out: list[tuple[Value, ParamInfo | None]] = []
        for number, word in enumerate(words, start=2):
            if number == 2:
                main = process_value(
                    "main", 2, False, tuple(words), self.reference, self.model.unit
                )
                assert main is not None
                out.append((main.percent if main.value is None else main.value, None))
                continue
            info = self.process_parameter(number)
            value: Value = word
            typed: ParamInfo | None = None
            if info is not None and info.words == 1:
                with contextlib.suppress(UssError):
                    value, typed = decode(info, (word,)), info
            out.append((value, typed))
        return out

    def actual_row(self, words: Sequence[int]) -> tuple[float, ...]:
        """The actual values of an answer's PZD2... as numbers, in the units
        `actual_columns` names (`actual_items`)."""
        return tuple(
            float(value) if isinstance(value, int | float) else float(word)
            for (value, _), word in zip(self.actual_items(words), words, strict=True)
        )

    # -- parameters --------------------------------------------------------------------------
    def meta(self, pnu: int, index: int | None = None) -> ParamMeta:
        """What is known of P``pnu`` (the configured point's, else the parameter model's)."""
        key = f"P{pnu}" if index is None else f"P{pnu}.{index}"
        point = self.model.parameter(key)
        if point is not None:
            return point.meta
        return self.parameter_model.meta(pnu, index)

    async def read_parameter(self, pnu: int, index: int | None = None) -> ParamValue:
        """Read P``pnu`` (element ``index``) now, any parameter; a configured one's value is
        kept and published."""
        meta = self.meta(pnu, index)
        with self._refusal_kept():
            value = await self.parameter_model.read(self.drive, meta)
        return self._kept(meta, value)

    async def write_parameter(
        self, pnu: int, value: float, index: int | None = None, *, eeprom: bool = False
    ) -> ParamValue:
        """Write ``value`` (in the parameter's unit) as a parameter job; returns what the
        drive answered, with ``written`` where it answered another value (it limits or
        rounds)."""
        meta = self.meta(pnu, index)
        with self._refusal_kept():
            answered, differs = await self.parameter_model.write(
                self.drive, meta, value, eeprom=eeprom
            )
        reading = self._kept(meta, answered)
        if self.is_reference(pnu, index):
            self._take_reference(answered)
        if differs:
            return dataclasses.replace(reading, written=value)
        return reading

    async def read_value(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Reading:
        """Read any parameter, typed by the drive's parameter book (`pyuss.params`): numbers,
        texts, value texts, array elements - what the page's expert list shows."""
        with self._refusal_kept():
            return await self.drive.read_param(pnu, index, timeout=timeout)

    async def write_value(
        self,
        pnu: int,
        index: int | None,
        text: str,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
    ) -> Reading:
        """Write a value as a person types it (``2.5``, ``2.5 s``, ``0x7000``, a value text):
        parsed and checked against the parameter's type, limits and access before anything
        is sent (`pyuss.params.parse`; refusals as `ValueRefused`); the drive's refusal
        raises `DriveRefusal`. A write of the reference parameter reads the reference anew. On
        a drive of unknown kind a parameter nothing is known of takes what ``uss write`` takes
        then (`pyuss.params.values.parse_unknown`: an integer, sent as a word or double word,
        or a float), and what the device does not take the device refuses."""
        if not isinstance(text, str) or len(text) > 4 * MAX_TEXT:
            raise ConfigError(f"{param_label(pnu, index)}: the value must be a short text")
        info = await self.drive.info(pnu, timeout=timeout)
        value: object
        if info is None and not self.drive.profile_named:
            value = parse_unknown(text.strip())
        elif info is None:
            raise ConfigError(
                f"{param_label(pnu, index)}: nothing is known of it (no parameter file has "
                "it, the drive gives no description), so its value cannot be checked: write "
                "its words with uss write --raw"
            )
        elif info.read_only:
            raise ValueRefused(f"{param_label(pnu, index)} ({info.name}) is read-only")
        else:
            value = parse(info, text, index)
        with self._refusal_kept():
            reading = await self.drive.write_param(
                pnu, value, index, eeprom=eeprom, timeout=timeout
            )
        if self.is_reference(pnu, index):
            with contextlib.suppress(UssError):
                await self.read_reference()
        return reading

    # -- the reference -----------------------------------------------------------------------
    def is_reference(self, pnu: int, index: int | None = None) -> bool:
        """Whether P``pnu`` (element ``index``) is the parameter the reference is read from."""
        reference = self.model.reference
        return isinstance(reference, ParamMeta) and (reference.pnu, reference.index) == (
            pnu,
            index if reference.index is not None else None,
        )

    def _take_reference(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if not math.isfinite(value) or value <= 0:
            return False
        if float(value) != self.reference:
            self.reference = float(value)
            self._changed()
        return True

    async def read_reference(self) -> float | None:
        """Read the reference parameter now (the physical value of 100 %); returns the
        reference (None: the drive has no reference parameter, or its value is no positive
        number). A fixed reference of the configuration is returned as it is."""
        reference = self.model.reference
        if not isinstance(reference, ParamMeta):
            return self.reference
        value = await self.parameter_model.read(self.drive, reference)
        if not self._take_reference(value):
            log.warning("%s: reference %s is %r", self.model.key, reference.key, value)
        return self.reference

    # -- background reads --------------------------------------------------------------------
    async def run(self) -> None:
        """Read the reference, then the polled parameters when due, until cancelled."""
        reference = self.model.reference
        if isinstance(reference, ParamMeta):
            while self.reference is None:
                try:
                    await self.read_reference()
                except UssError as exc:
                    log.info("%s: reference %s not read: %s", self.model.key, reference.key, exc)
                if self.reference is None:
                    await asyncio.sleep(RETRY_PERIOD)
        polled = [p for p in self.model.parameters if p.poll is not None]
        if not polled:
            return
        loop = asyncio.get_running_loop()
        due = {p.key: loop.time() for p in polled}
        while True:
            point = min(polled, key=lambda p: due[p.key])
            wait = due[point.key] - loop.time()
            if wait > 0:
                await asyncio.sleep(wait)
            assert point.poll is not None
            due[point.key] = loop.time() + point.poll
            try:
                await self.read_parameter(point.meta.pnu, point.meta.index)
            except UssError as exc:
                old = self.params[point.key]
                self.params[point.key] = ParamValue(old.meta, old.value, old.time, error_dict(exc))
                self._changed()
