"""`VirtualBus`: the virtual RS-485 segment (`pyuss.bus.core.Segment`: stations, the wire
timeline, collisions and delivery) that also takes stations in other processes, over ptys and
TCP connections (`pyuss.bus.serve`)."""

from __future__ import annotations

from collections.abc import Collection

from pyuss.bus.core import Segment
from pyuss.bus.serve import serve_pty, serve_tcp

__all__ = ["VirtualBus"]


class VirtualBus(Segment):
    """One RS-485 segment in software (`pyuss.bus.core`), with `serve_pty` and `serve_tcp`."""

    async def serve_pty(self, n: int, *, echo: bool | Collection[str] = False) -> list[str]:
        """Open ``n`` pty stations; their device paths (see `pyuss.bus.serve`)."""
        return await serve_pty(self, n, echo=echo)

    async def serve_tcp(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        framed: bool = False,
        echo: bool | Collection[str] = False,
    ) -> tuple[str, int]:
        """Accept stations over TCP; the address bound (see `pyuss.bus.serve`)."""
        return await serve_tcp(self, host, port, framed=framed, echo=echo)
