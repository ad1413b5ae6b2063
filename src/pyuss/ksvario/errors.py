"""Errors of the KS VARIO part, all in the one tree of `pyuss.errors`."""

from __future__ import annotations

from pyuss.errors import ProtocolError, UssError


class KsVarioError(UssError):
    """Base of the errors raised by `pyuss.ksvario`."""


class ChannelResultError(KsVarioError):
    """The bus coupler ended a parameter-channel job with a result other than 0 (KS VARIO interface
    description 4.2).

    ``result`` is the result number (2 bad address, 3 invalid value, 4 buffer overflow).
    """

    def __init__(self, result: int, meaning: str, what: str = "") -> None:
        self.result = result
        self.meaning = meaning
        super().__init__(
            f"parameter channel{(' ' + what) if what else ''}: result {result}: {meaning}"
        )


class FdlError(ProtocolError):
    """A PROFIBUS FDL telegram that cannot be decoded (delimiter, length, FCS, end delimiter)."""
