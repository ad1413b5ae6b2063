"""`DriveControl`: the process data commands of a `pyuss.master.Drive` (C 5), a mixin.

`pyuss.master.drive.Drive` is composed from this class (``class Drive(DriveControl)``): what
is here is the half of a drive's handle that sends the control word and setpoints and reads
the status; the parameters are `pyuss.master.drive`'s. Import `Drive` from there; this class
is never made on its own. Its rules: it reads and changes only the process data of its
`Slave` (``_link``), and asks its master only the calls of `ControlBus` (the process-data part
of `pyuss.master.drive.Bus`), never a parameter job.

The control word and setpoints are sent in every telegram to the slave from the moment they
are set. The commands return once a telegram carrying them was answered, with the status of
that answer: `on` (047Eh then 047Fh), `off1` (047Eh), `off2` (047Ch), `off3` (047Ah), and,
changing the current word, `enable` (bit 3), `acknowledge` (a rising edge of bit 7: set, then
cleared), `jog` (bits 8, 9) - refused (`NotInControl`) on a drive that is switched on while
this master has sent no control word, since they would start from OFF1; `setpoint` (percent
with 4000h = 100 %, or raw; 16 or 32 bits), `control_word`. `status` is the latest answer's
process data, `next_update` waits for the next, `on_update` registers a callback. Parameter
jobs never touch the process data: reading a parameter leaves the control word as the user
set it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from pyuss import _callbacks
from pyuss.errors import ConfigError, UssTimeout
from pyuss.master.errors import NotInControl, NotSending, StatusTimeout
from pyuss.master.process import OPERATE, DriveStatus
from pyuss.protocol.pzd import (
    ControlWord,
    StatusWord,
    percent_to_raw16,
    percent_to_raw32,
    split_dword,
)

if TYPE_CHECKING:
    from pyuss.master.core import Slave

__all__ = ["ControlBus", "DriveControl"]


class ControlBus(Protocol):
    """What the process data commands ask of the master: its public calls only."""

    def ensure_usable(self, *, line: bool = True) -> None: ...
    def clock(self) -> float: ...
    def set_process_data(
        self, slave: Slave, control: int | None = None, setpoints: dict[int, int] | None = None
    ) -> int: ...
    async def delivered(self, slave: Slave, version: int, timeout: float | None) -> DriveStatus: ...
    async def next_update(self, slave: Slave, timeout: float | None = None) -> DriveStatus: ...


class DriveControl:
    """The process data commands of a `pyuss.master.Drive`; see the module docstring."""

    _master: ControlBus
    _link: Slave

    @property
    def status(self) -> DriveStatus | None:
        """The process data of the latest answer (None before the first)."""
        return self._link.status

    @property
    def control(self) -> int:
        """The control word sent in every telegram."""
        return self._link.control

    @property
    def setpoints(self) -> tuple[int, ...]:
        """PZD2... as sent."""
        return tuple(self._link.setpoints)

    def _need_pzd(self, words: int = 1) -> None:
        if self._link.layout.pzd < words:
            raise ConfigError(
                f"slave {self._link.address} has layout {self._link.layout}: {words} PZD words "
                "needed (C 5)"
            )

    def set_control(self, word: int) -> None:
        """Send ``word`` as control word from the next telegram on (no waiting)."""
        self._need_pzd()
        if isinstance(word, bool) or not isinstance(word, int) or not 0 <= word <= 0xFFFF:
            raise ConfigError(f"control word must be 0..FFFFh, got {word!r}")
        self._master.set_process_data(self._link, control=word)

    def set_pzd(self, number: int, value: int) -> None:
        """Set PZD word ``number`` (2..16; 1 is the control word) to a raw 16-bit value."""
        if number == 1:
            self.set_control(value)
            return
        self._need_pzd(number if isinstance(number, int) else 2)
        if isinstance(number, bool) or not isinstance(number, int) or number < 2:
            raise ConfigError(f"PZD number must be 1..{self._link.layout.pzd}, got {number!r}")
        if isinstance(value, bool) or not isinstance(value, int) or not -0x8000 <= value <= 0xFFFF:
            raise ConfigError(f"PZD{number} must be a 16-bit value, got {value!r}")
        self._master.set_process_data(self._link, setpoints={number: value & 0xFFFF})

    async def _send(
        self,
        control: int | None,
        setpoints: dict[int, int] | None = None,
        timeout: float | None = None,
    ) -> DriveStatus:
        self._master.ensure_usable()  # refused at once (the line down): nothing is changed
        version = self._master.set_process_data(self._link, control=control, setpoints=setpoints)
        return await self._master.delivered(self._link, version, timeout)

    async def control_word(self, word: int, *, timeout: float | None = None) -> DriveStatus:
        """Send ``word`` as control word; returns the status of the answer to it."""
        self._master.ensure_usable()  # refused at once (the line down): nothing is changed
        self.set_control(word)
        return await self._master.delivered(self._link, self._link.version, timeout)

    async def setpoint(
        self,
        percent: float | None = None,
        *,
        raw: int | None = None,
        pzd: int = 2,
        dword: bool = False,
        timeout: float | None = None,
    ) -> DriveStatus:
        """Set the main setpoint (PZD2, or PZD ``pzd``): ``percent`` with 4000h = 100 %
        (4000 0000h with ``dword``, sent high word first in PZD ``pzd`` and ``pzd + 1``), or a
        ``raw`` value. Returns the status of the answer to the first telegram carrying it."""
        if (percent is None) == (raw is None):
            raise ConfigError("give either a percentage or a raw value")
        words = 2 if dword else 1
        if isinstance(pzd, bool) or not isinstance(pzd, int) or pzd < 2:
            raise ConfigError(f"setpoints are PZD2 and up, got PZD{pzd!r}")
        self._need_pzd(pzd + words - 1)
        values: dict[int, int]
        if dword:
            value = percent_to_raw32(percent) if percent is not None else raw
            if (
                isinstance(value, bool)
                or not isinstance(value, int)
                or not -0x8000_0000 <= value <= 0xFFFF_FFFF
            ):
                raise ConfigError(f"raw 32-bit setpoint must be a 32-bit value, got {raw!r}")
            high, low = split_dword(value & 0xFFFF_FFFF)
            values = {pzd: high, pzd + 1: low}
        else:
            value = percent_to_raw16(percent) if percent is not None else raw
            if (
                isinstance(value, bool)
                or not isinstance(value, int)
                or not -0x8000 <= value <= 0xFFFF
            ):
                raise ConfigError(f"raw setpoint must be a 16-bit value, got {raw!r}")
            values = {pzd: value & 0xFFFF}
        return await self._send(None, values, timeout)

    def running_elsewhere(self) -> str | None:
        """Why a command that takes control would change what the drive does, while this
        master has sent it no control word (0000h: the drive keeps the process data it had):
        its last answer says it is switched on (READY or operation enabled, no fault), or it
        has not answered yet; None if neither (it is off, or in fault)."""
        status = self._link.status  # the last answer, also of a drive that does not send now
        if status is None:
            return "has not answered yet, so whether it runs is not known"
        if status.word & (StatusWord.READY | StatusWord.OPERATION_ENABLED) and not (
            status.word & StatusWord.FAULT
        ):
            return f"is switched on ({status.state})"
        return None

    def _base(self, what: str) -> int:
        """The control word in force, for a command (``what``) that changes bits of it; 047Eh
        (OFF1) where this master has sent none yet (0000h: no control by the interface).
        There, on a drive switched on (by another master, or one started again) or not
        answered yet, the command would stop it: `NotInControl`, nothing sent."""
        word = self._link.control
        if word & ControlWord.CONTROL_BY_PLC:
            return word
        why = self.running_elsewhere()
        if why is None:
            return int(OPERATE)
        raise NotInControl(
            f"slave {self._link.address}: {what} refused: the drive {why}, and this master has "
            f"sent it no control word yet, so {what} would take control with OFF1 (047Eh) and "
            "stop it; send on or off1 first"
        )

    async def on(self, *, timeout: float | None = None) -> DriveStatus:
        """Switch on: 047Eh (OFF1 with every enable: leaves "switch-on inhibited"), then 047Fh
        (C Tables 5.2..5.5). Returns the status of the answer to the ON telegram."""
        self._need_pzd()
        keep = self._link.control & (ControlWord.JOG1 | ControlWord.JOG2)
        await self._send(int(OPERATE) | keep, timeout=timeout)
        return await self._send(int(OPERATE | ControlWord.ON) | keep, timeout=timeout)

    async def off1(self, *, timeout: float | None = None) -> DriveStatus:
        """OFF1: ramp down and switch off (control bit 0 = 0)."""
        self._need_pzd()
        return await self._send(int(OPERATE), timeout=timeout)

    async def off2(self, *, timeout: float | None = None) -> DriveStatus:
        """OFF2: pulses off at once, the motor coasts (control bit 1 = 0)."""
        self._need_pzd()
        return await self._send(int(OPERATE) & ~int(ControlWord.NO_OFF2), timeout=timeout)

    async def off3(self, *, timeout: float | None = None) -> DriveStatus:
        """OFF3: quick stop (control bit 2 = 0)."""
        self._need_pzd()
        return await self._send(int(OPERATE) & ~int(ControlWord.NO_OFF3), timeout=timeout)

    async def enable(self, enabled: bool = True, *, timeout: float | None = None) -> DriveStatus:
        """Enable (or inhibit) operation: control bit 3."""
        self._need_pzd()
        word = self._base("enable" if enabled else "inhibit")
        word = (
            word | ControlWord.ENABLE_OPERATION
            if enabled
            else word & ~int(ControlWord.ENABLE_OPERATION)
        )
        return await self._send(word, timeout=timeout)

    async def acknowledge(self, *, timeout: float | None = None) -> DriveStatus:
        """Acknowledge a fault: a rising edge of control bit 7 (set, answered, cleared)."""
        self._need_pzd()
        word = self._base("acknowledge") & ~int(ControlWord.ACKNOWLEDGE_FAULT)
        await self._send(word | ControlWord.ACKNOWLEDGE_FAULT, timeout=timeout)
        return await self._send(word, timeout=timeout)

    async def jog(self, which: int | None, *, timeout: float | None = None) -> DriveStatus:
        """Jog 1 or 2 on (control bit 8 or 9), or off with None or 0."""
        self._need_pzd()
        if which not in (None, 0, 1, 2):
            raise ConfigError(f"jog takes 1, 2 or None, got {which!r}")
        word = self._base("jog") & ~int(ControlWord.JOG1 | ControlWord.JOG2)
        if which == 1:
            word |= ControlWord.JOG1
        elif which == 2:
            word |= ControlWord.JOG2
        return await self._send(word, timeout=timeout)

    async def next_update(self, *, timeout: float | None = None) -> DriveStatus:
        """The process data of the next answer from the slave."""
        return await self._master.next_update(self._link, timeout)

    async def wait_until(
        self,
        condition: Callable[[DriveStatus], bool],
        *,
        timeout: float = 10.0,
        what: str = "the state waited for",
    ) -> DriveStatus:
        """Wait for an answer whose status meets ``condition`` (e.g. ``lambda s: s.running``).

        Raises `StatusTimeout` (with the last status; ``what`` names the condition in its
        message) when the drive answers but its status does not meet the condition within
        ``timeout`` seconds, `NotSending` when it stopped answering."""
        clock = self._master.clock
        end = clock() + timeout
        status = self.status
        while status is None or not condition(status):
            left = end - clock()
            if left <= 0:
                raise StatusTimeout(self._link.address, timeout, self.status, what)
            try:
                status = await self.next_update(timeout=left)
            except NotSending:
                raise
            except UssTimeout:  # the time ran out between two answers: not a silent drive
                raise StatusTimeout(self._link.address, timeout, self.status, what) from None
        return status

    def on_update(self, callback: Callable[[DriveStatus], object]) -> Callable[[], None]:
        """Call ``callback`` with the process data of every answer; returns a function that
        removes it. Callbacks run in the master's task, before the tasks waiting for the
        update and before the next telegram: they must not block, and what takes time is
        better left to the loop's next turn (``loop.call_soon``), when the next telegram is
        on its way (`pyuss.points` does so)."""
        return _callbacks.add(self._link.update_callbacks, callback)
