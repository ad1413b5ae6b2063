"""What a face does with a line besides the points of its drives, so that no face imports
the master: find the drives on it (`scan`, the probe of ``uss scan``), put the demo's
simulated drives on a virtual bus (`simulated_drives`), and the drive handle's type
(`Drive`), which `pyuss.commission`'s backups, comparisons and restores take
(`pyuss.points.DrivePoints.drive`), with the type of its process data (`DriveStatus`).
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import AbstractAsyncContextManager
from typing import TYPE_CHECKING, Any

from pyuss.master.drive import Drive
from pyuss.master.process import DriveStatus
from pyuss.master.scan import Found, scan
from pyuss.protocol.layout import Layout

if TYPE_CHECKING:
    from pyuss.bus import VirtualBus

__all__ = ["Drive", "DriveStatus", "Found", "scan", "simulated_drives"]


def simulated_drives(
    bus: VirtualBus, drives: Sequence[tuple[int, str, Layout | None]], *, one_station: bool = True
) -> AbstractAsyncContextManager[dict[int, Any]]:
    """Serve ``drives`` - ``(address, profile name, layout or None)`` - on ``bus`` while the
    block runs (`pyuss.master.testing.simulated_drives`); yields the engines by address. By
    default one station answers every address, as ``uss simulate`` does: one receiver of the
    line for all drives."""
    from pyuss.master.testing import simulated_drives as serve

    return serve(bus, drives, one_station=one_station)
