"""A virtual RS-485 segment with true character timing, collisions and fault injection.

- `VirtualBus` (`pyuss.bus.virtual`): the segment; `attach` stations in-process, `serve_pty` /
  `serve_tcp` for stations in other processes. `Segment` (`pyuss.bus.core`): the segment
  alone, its timeline and its in-process stations, which the servers of `pyuss.bus.serve` use.
- `FaultPlan`, `Fault`, `parse_fault`: seeded, reproducible faults (`pyuss.bus.faults`).
- `Recorder`, `load_recording`, `replay`: every character as JSON lines (`pyuss.bus.recorder`).
- `BusClientTransport`: a ``bus://`` station in another process (`pyuss.bus.client`).
"""

from typing import TYPE_CHECKING

from pyuss._lazy import lazy_exports

if TYPE_CHECKING:
    from pyuss.bus.client import BusClientTransport
    from pyuss.bus.core import BusStats, Segment, Station
    from pyuss.bus.faults import Fault, FaultKind, FaultPlan, parse_fault
    from pyuss.bus.line import WireChar
    from pyuss.bus.recorder import Record, Recorder, Recording, load_recording, replay
    from pyuss.bus.virtual import VirtualBus

__all__ = [
    "BusClientTransport",
    "BusStats",
    "Fault",
    "FaultKind",
    "FaultPlan",
    "Record",
    "Recorder",
    "Recording",
    "Segment",
    "Station",
    "VirtualBus",
    "WireChar",
    "load_recording",
    "parse_fault",
    "replay",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "pyuss.bus.client": ("BusClientTransport",),
        "pyuss.bus.core": (
            "BusStats",
            "Segment",
            "Station",
        ),
        "pyuss.bus.faults": (
            "Fault",
            "FaultKind",
            "FaultPlan",
            "parse_fault",
        ),
        "pyuss.bus.line": ("WireChar",),
        "pyuss.bus.recorder": (
            "Record",
            "Recorder",
            "Recording",
            "load_recording",
            "replay",
        ),
        "pyuss.bus.virtual": ("VirtualBus",),
    },
)
