"""The data points of a plant's drives, the one model every face shows alike.

- `pyuss.points.config`: buses, drives and the points to expose (TOML tables or flags).
- `pyuss.points.model`: the configuration resolved against the parameter model (`resolve`).
- `pyuss.points.state`: `DriveState`, a drive's points at one moment (JSON with units).
- `pyuss.points.plant`: `Plant`: one master per bus (`BusPoints`), a `DrivePoints` per drive.
- `pyuss.points.drive`: `DrivePoints`: a drive's points, live, with change notification and
  the writes the faces ask for - the one place where a face's wish becomes process data or a
  parameter job, checked whole first (its docstring has the rules).
- `pyuss.points.checks`: the pure checks of a face's request (`checked_setpoint`, commands,
  process words, the takeover rule), made before anything goes out.
- `pyuss.points.access`: a drive's parameters and reference (`ParameterAccess`), held by its
  `DrivePoints`: typed reads and writes, checked first.
- `pyuss.points.line`: the scan, the demo's simulated drives, the drive handle's type.
- `pyuss.points.errors`: what went wrong, in classes every face maps to its own errors.
- `pyuss.points.endpoint`: the addresses faces listen on or connect to.

The faces (`pyuss.gateway`, `pyuss.web`) sit on top and never import the master.
See docs/architecture.md and docs/gateway.md.
"""

from pyuss.points.checks import checked_setpoint
from pyuss.points.config import (
    BusConfig,
    DriveConfig,
    ParameterConfig,
    PlantConfig,
    ProcessConfig,
    parse_plant,
    plant_from_flags,
)
from pyuss.points.drive import DrivePoints
from pyuss.points.endpoint import Endpoint, parse_endpoint
from pyuss.points.errors import (
    Failure,
    NotInControl,
    NoWriteAuthority,
    ReadOnly,
    UnknownPoint,
    classify,
    error_dict,
)
from pyuss.points.line import Drive, DriveStatus, Found, scan, simulated_drives
from pyuss.points.model import (
    COMMAND_TABLE,
    COMMANDS,
    MOVES,
    STATUS_BIT_NAMES,
    Command,
    DriveModel,
    PlantModel,
    line_model,
    resolve,
)
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.plant import BusPoints, Plant
from pyuss.points.state import DriveState, Health, ParamValue, ProcessValue, Sample, state_name

__all__ = [
    "COMMANDS",
    "COMMAND_TABLE",
    "MOVES",
    "STATUS_BIT_NAMES",
    "BusConfig",
    "BusPoints",
    "Command",
    "Drive",
    "DriveConfig",
    "DriveModel",
    "DrivePoints",
    "DriveState",
    "DriveStatus",
    "Endpoint",
    "Failure",
    "Found",
    "Health",
    "NoWriteAuthority",
    "NotInControl",
    "ParamMeta",
    "ParamValue",
    "ParameterConfig",
    "ParameterModel",
    "Plant",
    "PlantConfig",
    "PlantModel",
    "ProcessConfig",
    "ProcessValue",
    "ReadOnly",
    "Sample",
    "UnknownPoint",
    "checked_setpoint",
    "classify",
    "error_dict",
    "line_model",
    "parse_endpoint",
    "parse_plant",
    "plant_from_flags",
    "resolve",
    "scan",
    "simulated_drives",
    "state_name",
]
