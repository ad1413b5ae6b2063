"""BASS, Baumueller's ASCII service protocol over RS-232 (Baumueller manual part 1).

- `pyuss.bass.codec`: the line codec (pure) and the streaming `BassLineReader`.
- `pyuss.bass.errors`: `BassError` and its subclasses, the error numbers of table 1.3.
- `pyuss.bass.master`: `BassMaster` (async) and `SyncBassMaster`: read/write one element.
- `pyuss.bass.ring`: simulated drives on a closed RS-232 loop (Baumueller manual 1.4.2).
"""

from pyuss.bass.codec import (
    BassAnswer,
    BassCommand,
    BassFault,
    BassLine,
    BassLineReader,
    BassRequest,
    BassStatus,
    checksum,
)
from pyuss.bass.errors import (
    BassEchoError,
    BassError,
    BassErrorNumber,
    BassProtocolError,
    BassRefusal,
    BassTelegramError,
    BassTimeout,
    FaultKind,
)
from pyuss.bass.master import BassMaster, SyncBassMaster
from pyuss.bass.ring import BassRing, BassStation, DictOperatingData, Element, OperatingData

__all__ = [
    "BassAnswer",
    "BassCommand",
    "BassEchoError",
    "BassError",
    "BassErrorNumber",
    "BassFault",
    "BassLine",
    "BassLineReader",
    "BassMaster",
    "BassProtocolError",
    "BassRefusal",
    "BassRequest",
    "BassRing",
    "BassStation",
    "BassStatus",
    "BassTelegramError",
    "BassTimeout",
    "DictOperatingData",
    "Element",
    "FaultKind",
    "OperatingData",
    "SyncBassMaster",
    "checksum",
]
