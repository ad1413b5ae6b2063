"""Byte pipes. Every transport implements `pyuss.transport.base.Transport`."""

from pyuss.transport.base import Chunk, LineError, Transport

__all__ = ["Chunk", "LineError", "Transport"]
