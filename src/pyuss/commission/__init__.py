"""Commissioning on top of the master: parameter sets backed up, compared and restored, and
one look at a drive's state.

- `pyuss.commission.backup`: `take` a `Backup` of a drive (every parameter its book knows,
  ``scan`` for the others), `save` it (TOML, JSON, CSV export; atomically), `load` it back
  (refusing cut-short or broken files).
- `pyuss.commission.compare`: `compare` two sets (settings;
  `changed_values`: the read-only values apart); `another_drive` says whether a file is
  another drive's; `plan` and `restore` write a set back.
- `pyuss.commission.status`: `look` at a drive: state, status word, actual values with
  units, fault and warning numbers with texts, and whether it follows USS.
- `pyuss.commission.sources`: `check` whether a drive takes its control word and setpoint
  from USS (Siemens P0700, P1000 = 5) and what to set where not; `uss run` refuses before it
  sends anything when it does not.
- `pyuss.commission.survey`: a line surveyed: who each drive a scan found is (family,
  profile, firmware), the line description ``uss.toml`` of what was found, and what to check
  when nothing answered (``uss scan``).

The commands ``uss backup``, ``uss diff``, ``uss restore``, ``uss status`` and ``uss scan``
are thin layers over these. See docs/commissioning.md and docs/lines.md.
"""

from pyuss.commission.backup import Backup, Entry, load, save, take
from pyuss.commission.compare import (
    Difference,
    Outcome,
    Skip,
    Write,
    another_drive,
    changed_values,
    compare,
    plan,
    restore,
)
from pyuss.commission.status import Look, look

__all__ = [
    "Backup",
    "Difference",
    "Entry",
    "Look",
    "Outcome",
    "Skip",
    "Write",
    "another_drive",
    "changed_values",
    "compare",
    "load",
    "look",
    "plan",
    "restore",
    "save",
    "take",
]
