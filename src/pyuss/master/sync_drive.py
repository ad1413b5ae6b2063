"""`Drive`, one slave for scripts without asyncio: the handle `pyuss.master.sync.Master.drive`
makes.

Each method is the method of `pyuss.master.Drive` of the same name without ``await``: it hands
its call to the master's background loop and waits for the result, so the logic exists once.
The rules of `pyuss.master.sync` hold (which thread runs the callbacks, ``call_timeout``, the
exceptions); import `Drive` from there.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine, Sequence
from pathlib import Path
from typing import Any, Protocol, TypeVar

from pyuss.drive.database import ParameterDatabase
from pyuss.drive.datatypes import Value
from pyuss.master import scheduler
from pyuss.master.description import Description
from pyuss.master.drive import Drive as AsyncDrive
from pyuss.master.jobs import SpontaneousMessage
from pyuss.master.process import DriveStatus
from pyuss.master.profile import Profile
from pyuss.master.stats import SlaveCounts, SlaveDiagnostics
from pyuss.params.book import ParamBook
from pyuss.params.model import ParamInfo, Reading
from pyuss.protocol.layout import Layout
from pyuss.protocol.pkw import Pkw

__all__ = ["Drive"]

T = TypeVar("T")


class _Loop(Protocol):
    """What a `Drive` hands its calls to: its `pyuss.master.sync.Master`, which runs them on
    the background loop and waits for the result."""

    def _call(self, coro: Coroutine[Any, Any, T]) -> T: ...

    def _run(self, func: Callable[[], T]) -> T: ...


class Drive:
    """One slave, synchronously: the methods of `pyuss.master.Drive` without ``await``."""

    def __init__(self, bus: _Loop, drive: AsyncDrive) -> None:
        self._bus = bus
        self._drive = drive

    def __repr__(self) -> str:
        return repr(self._drive).replace("<Drive", "<sync Drive", 1)

    @property
    def core(self) -> AsyncDrive:
        """The asyncio handle (use it only on the background loop)."""
        return self._drive

    @property
    def address(self) -> int:
        return self._drive.address

    @property
    def layout(self) -> Layout:
        return self._drive.layout

    @property
    def profile(self) -> Profile:
        return self._drive.profile

    @property
    def profile_named(self) -> bool:
        return self._drive.profile_named

    @property
    def response_delay(self) -> float:
        return self._drive.response_delay

    @property
    def not_sending(self) -> bool:
        return self._drive.not_sending

    @property
    def status(self) -> DriveStatus | None:
        return self._drive.status

    @property
    def control(self) -> int:
        return self._drive.control

    @property
    def setpoints(self) -> tuple[int, ...]:
        return self._drive.setpoints

    def running_elsewhere(self) -> str | None:
        return self._drive.running_elsewhere()

    def diagnostics(self) -> SlaveDiagnostics:
        return self._bus._run(self._drive.diagnostics)

    def counts(self) -> SlaveCounts:
        return self._bus._run(self._drive.counts)

    def mirror(self) -> scheduler.MirrorResult:
        return self._bus._call(self._drive.mirror())

    # parameters
    def job(
        self,
        request: Pkw,
        *,
        pnu: int | None = None,
        index: int | None = None,
        timeout: float | None = None,
    ) -> Pkw:
        return self._bus._call(self._drive.job(request, pnu=pnu, index=index, timeout=timeout))

    @property
    def params(self) -> ParamBook:
        """What is known of the drive's parameters (`pyuss.params.ParamBook`)."""
        return self._drive.params

    def use_params(self, source: str | Path | ParameterDatabase) -> None:
        self._bus._run(lambda: self._drive.use_params(source))

    def info(self, pnu: int, *, timeout: float | None = None) -> ParamInfo | None:
        return self._bus._call(self._drive.info(pnu, timeout=timeout))

    def read_raw(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> tuple[int, ...]:
        return self._bus._call(self._drive.read_raw(pnu, index, timeout=timeout))

    def read_param(
        self,
        pnu: int,
        index: int | None = None,
        *,
        progress: Callable[[int, int], object] | None = None,
        timeout: float | None = None,
    ) -> Reading:
        return self._bus._call(
            self._drive.read_param(pnu, index, progress=progress, timeout=timeout)
        )

    def read(
        self, pnu: int, index: int | None = None, *, timeout: float | None = None
    ) -> Value | list[Value]:
        return self._bus._call(self._drive.read(pnu, index, timeout=timeout))

    def write_raw(
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
        return self._bus._call(
            self._drive.write_raw(
                pnu, words, index, eeprom=eeprom, dword=dword, timeout=timeout, verify=verify
            )
        )

    def write_param(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
        verify: bool = False,
    ) -> Reading:
        return self._bus._call(
            self._drive.write_param(
                pnu, value, index, eeprom=eeprom, timeout=timeout, verify=verify
            )
        )

    def write(
        self,
        pnu: int,
        value: object,
        index: int | None = None,
        *,
        eeprom: bool = False,
        timeout: float | None = None,
        verify: bool = False,
    ) -> Value | list[Value]:
        return self._bus._call(
            self._drive.write(pnu, value, index, eeprom=eeprom, timeout=timeout, verify=verify)
        )

    def array_length(self, pnu: int, *, timeout: float | None = None) -> int:
        return self._bus._call(self._drive.array_length(pnu, timeout=timeout))

    def read_array(
        self,
        pnu: int,
        *,
        progress: Callable[[int, int], object] | None = None,
        timeout: float | None = None,
    ) -> list[Value]:
        return self._bus._call(self._drive.read_array(pnu, progress=progress, timeout=timeout))

    def read_description(
        self, pnu: int, element: int | None = None, *, timeout: float | None = None
    ) -> Description:
        return self._bus._call(self._drive.read_description(pnu, element, timeout=timeout))

    def read_text(
        self, pnu: int, index: int, *, value_texts: bool = False, timeout: float | None = None
    ) -> str:
        return self._bus._call(
            self._drive.read_text(pnu, index, value_texts=value_texts, timeout=timeout)
        )

    def write_text(
        self,
        pnu: int,
        index: int,
        text: str,
        *,
        value_texts: bool = False,
        timeout: float | None = None,
    ) -> str:
        return self._bus._call(
            self._drive.write_text(pnu, index, text, value_texts=value_texts, timeout=timeout)
        )

    # process data
    def set_control(self, word: int) -> None:
        self._bus._run(lambda: self._drive.set_control(word))

    def set_pzd(self, number: int, value: int) -> None:
        self._bus._run(lambda: self._drive.set_pzd(number, value))

    def control_word(self, word: int, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.control_word(word, timeout=timeout))

    def setpoint(
        self,
        percent: float | None = None,
        *,
        raw: int | None = None,
        pzd: int = 2,
        dword: bool = False,
        timeout: float | None = None,
    ) -> DriveStatus:
        return self._bus._call(
            self._drive.setpoint(percent, raw=raw, pzd=pzd, dword=dword, timeout=timeout)
        )

    def on(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.on(timeout=timeout))

    def off1(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.off1(timeout=timeout))

    def off2(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.off2(timeout=timeout))

    def off3(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.off3(timeout=timeout))

    def enable(self, enabled: bool = True, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.enable(enabled, timeout=timeout))

    def acknowledge(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.acknowledge(timeout=timeout))

    def jog(self, which: int | None, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.jog(which, timeout=timeout))

    def next_update(self, *, timeout: float | None = None) -> DriveStatus:
        return self._bus._call(self._drive.next_update(timeout=timeout))

    def wait_until(
        self,
        condition: Callable[[DriveStatus], bool],
        *,
        timeout: float = 10.0,
        what: str = "the state waited for",
    ) -> DriveStatus:
        return self._bus._call(self._drive.wait_until(condition, timeout=timeout, what=what))

    def on_update(self, callback: Callable[[DriveStatus], object]) -> Callable[[], None]:
        return self._bus._run(lambda: self._drive.on_update(callback))

    @property
    def missed(self) -> int:
        return self._drive.missed

    def on_missed(self, callback: Callable[[int], object]) -> Callable[[], None]:
        return self._bus._run(lambda: self._drive.on_missed(callback))

    def on_spontaneous(
        self, callback: Callable[[SpontaneousMessage], object]
    ) -> Callable[[], None]:
        return self._bus._run(lambda: self._drive.on_spontaneous(callback))
