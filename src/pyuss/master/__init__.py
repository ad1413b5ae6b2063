"""The USS bus master: scheduler, parameter jobs, drive handles, sync facade.

- `Master`: one bus (poll list, cyclic or acyclic traffic, timing, broadcast, mirror,
  diagnostics); ``async with Master(url_or_transport, baud=...) as bus``.
- `Drive`: one slave (`Master.drive`): parameters, process data, status.
- `pyuss.master.sync`: the same for scripts without asyncio (a background thread).
- `pyuss.master.scan`: find slaves, their baud rate and telegram layout.
- `pyuss.master.testing`: simulated drives on a virtual bus, to try a master.

See docs/master.md.
"""

from typing import TYPE_CHECKING

from pyuss._lazy import lazy_exports

if TYPE_CHECKING:
    from pyuss.master.description import Description, DescriptionElement
    from pyuss.master.drive import Drive
    from pyuss.master.errors import (
        DriveFault,
        JobOutcome,
        JobTimeout,
        MasterClosed,
        MirrorMismatch,
        NotInControl,
        NotSending,
        NoWriteAuthority,
        StatusTimeout,
        ValueDiffers,
    )
    from pyuss.master.jobs import SpontaneousMessage
    from pyuss.master.process import OPERATE, DriveStatus
    from pyuss.master.profile import resolve_profile
    from pyuss.master.scheduler import ACYCLIC, CYCLIC, Master, MirrorResult, Mode, Reply
    from pyuss.master.stats import (
        BusDiagnostics,
        CycleStats,
        JobStats,
        SampleSummary,
        SlaveDiagnostics,
    )

__all__ = [
    "ACYCLIC",
    "CYCLIC",
    "OPERATE",
    "BusDiagnostics",
    "CycleStats",
    "Description",
    "DescriptionElement",
    "Drive",
    "DriveFault",
    "DriveStatus",
    "JobOutcome",
    "JobStats",
    "JobTimeout",
    "Master",
    "MasterClosed",
    "MirrorMismatch",
    "MirrorResult",
    "Mode",
    "NoWriteAuthority",
    "NotInControl",
    "NotSending",
    "Reply",
    "SampleSummary",
    "SlaveDiagnostics",
    "SpontaneousMessage",
    "StatusTimeout",
    "ValueDiffers",
    "resolve_profile",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "pyuss.master.description": (
            "Description",
            "DescriptionElement",
        ),
        "pyuss.master.drive": ("Drive",),
        "pyuss.master.errors": (
            "DriveFault",
            "JobOutcome",
            "JobTimeout",
            "MasterClosed",
            "MirrorMismatch",
            "NotInControl",
            "NotSending",
            "NoWriteAuthority",
            "StatusTimeout",
            "ValueDiffers",
        ),
        "pyuss.master.jobs": ("SpontaneousMessage",),
        "pyuss.master.process": (
            "OPERATE",
            "DriveStatus",
        ),
        "pyuss.master.profile": ("resolve_profile",),
        "pyuss.master.scheduler": (
            "ACYCLIC",
            "CYCLIC",
            "Master",
            "MirrorResult",
            "Mode",
            "Reply",
        ),
        "pyuss.master.stats": (
            "BusDiagnostics",
            "CycleStats",
            "JobStats",
            "SampleSummary",
            "SlaveDiagnostics",
        ),
    },
)
