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


def flat_errors(chunks: list[Chunk]) -> list[tuple[int, object]]:
    """Line errors of ``chunks`` with positions in the joined data."""
    out: list[tuple[int, object]] = []
    offset = 0
    for chunk in chunks:
        out += [(offset + pos, flag) for pos, flag in chunk.errors]
        offset += len(chunk.data)
    return out


def byte_ends(chunks: list[Chunk], baud: int) -> list[float]:
    """The end time of every byte, from the chunk stamps (bytes in a chunk are contiguous)."""
    tc = 11 / baud
    out: list[float] = []
    for chunk in chunks:
        n = len(chunk.data)
        out += [chunk.timestamp - (n - 1 - i) * tc for i in range(n)]
    return out
