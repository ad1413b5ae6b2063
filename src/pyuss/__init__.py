"""pyuss: the USS protocol toolkit (master, slave, drive simulator, virtual bus, monitor)."""

from pyuss.errors import (
    ConfigError,
    DriveRefusal,
    ProtocolError,
    TelegramError,
    TransportError,
    UssError,
    UssTimeout,
)

__version__ = "0.1.0"

__all__ = [
    "ConfigError",
    "DriveRefusal",
    "ProtocolError",
    "TelegramError",
    "TransportError",
    "UssError",
    "UssTimeout",
    "__version__",
]
