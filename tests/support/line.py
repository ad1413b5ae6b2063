"""What a simulated drive takes from the line: the process data of every telegram addressed
to it and the parameter jobs that change something, recorded as the drive's engine handles
them (the drive itself still takes them)."""

from __future__ import annotations

from typing import Any

from pyuss.protocol.pkw import RequestId
from pyuss.protocol.telegram import AddressMode, Telegram
from pyuss.slave import SlaveEngine
from support.waiting import eventually


class LineRecord:
    """The telegrams ``engine`` takes from now on until `close`."""

    def __init__(self, engine: SlaveEngine) -> None:
        self.engine = engine
        self.pzd: list[tuple[int, ...]] = []
        self.changes: list[Any] = []
        handle = engine.handle

        def recording(telegram: Telegram, now: float) -> Telegram | None:
            if telegram.address == engine.address and telegram.mode is AddressMode.NORMAL:
                net = engine.layout.unpack(telegram.data)
                self.pzd.append(net.pzd)
                if net.pkw is not None and RequestId(net.pkw.id).is_change:
                    self.changes.append(net.pkw)
            return handle(telegram, now)

        engine.handle = recording  # type: ignore[method-assign]

    def close(self) -> None:
        """Stop recording: the engine's own method again."""
        del self.engine.handle

    async def telegrams(self, count: int = 3) -> None:
        """Wait until the drive took ``count`` more telegrams (the master's cycle went on)."""
        seen = len(self.pzd)
        await eventually(lambda: len(self.pzd) >= seen + count)
