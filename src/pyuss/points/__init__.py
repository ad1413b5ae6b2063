"""The data points of a plant's drives, the one model every face shows alike.

- `pyuss.points.config`: buses, drives and the points to expose (TOML tables or flags).
- `pyuss.points.model`: the configuration resolved against the parameter model (`resolve`).
- `pyuss.points.state`: `DriveState`, a drive's points at one moment (JSON with units).
- `pyuss.points.plant`: `Plant`: one master per bus, `DrivePoints` per drive, live, with
  change notification and the writes the faces ask for.
- `pyuss.points.errors`: what went wrong, in classes every face maps to its own errors.
- `pyuss.points.endpoint`: the addresses faces listen on or connect to.

The faces (`pyuss.gateway`, `pyuss.web`) sit on top. See docs/gateway.md.
"""

from pyuss.points.config import (
    BusConfig,
    DriveConfig,
    ParameterConfig,
    PlantConfig,
    ProcessConfig,
    parse_plant,
    plant_from_flags,
)
from pyuss.points.endpoint import Endpoint, parse_endpoint
from pyuss.points.errors import Failure, ReadOnly, UnknownPoint, classify, error_dict
from pyuss.points.model import COMMANDS, STATUS_BIT_NAMES, DriveModel, PlantModel, resolve
from pyuss.points.parameters import ParameterModel, ParamMeta
from pyuss.points.plant import BusPoints, DrivePoints, Plant
from pyuss.points.state import DriveState, Health, ParamValue, ProcessValue

__all__ = [
    "COMMANDS",
    "STATUS_BIT_NAMES",
    "BusConfig",
    "BusPoints",
    "DriveConfig",
    "DriveModel",
    "DrivePoints",
    "DriveState",
    "Endpoint",
    "Failure",
    "Health",
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
    "UnknownPoint",
    "classify",
    "error_dict",
    "parse_endpoint",
    "parse_plant",
    "plant_from_flags",
    "resolve",
]
