"""Helpers for transport tests: collect what a transport delivers until a condition holds."""

from __future__ import annotations

from pyuss.transport.base import Chunk, Transport

#: Generous: real ptys and sockets on a loaded machine.
WAIT = 5.0


async def read_bytes(transport: Transport, n: int, timeout: float = WAIT) -> list[Chunk]:
    """Read chunks until ``n`` bytes came (or ``timeout`` per read passes)."""
    chunks: list[Chunk] = []
    got = 0
    while got < n:
        chunk = await transport.read(timeout)
        if chunk is None:
            break
        chunks.append(chunk)
        got += len(chunk.data)
    return chunks


def joined(chunks: list[Chunk]) -> bytes:
    return b"".join(c.data for c in chunks)
