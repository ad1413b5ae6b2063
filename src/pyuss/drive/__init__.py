"""The simulated drive: parameter database, values, descriptions, EEPROM, state machine.

- `pyuss.drive.database`: what the declarative parameter file (TOML) describes
  (`ParameterDatabase`, `Parameter`, `ProfileInfo` ...).
- `pyuss.drive.loader`: reads parameter files (`load_profile`, `load_database`,
  `parse_database`): built-in profiles, ``extends``, editions; `pyuss.drive.fields` and
  `pyuss.drive.tables` read and check their fields and tables.
- `pyuss.drive.datatypes`: data types and their PKW words (C 6).
- `pyuss.drive.description`: the parameter description elements (C 4.2.2, C 6; Baumueller manual).
- `pyuss.drive.memory`: values and the rules of reading and changing them (`ParameterMemory`).
- `pyuss.drive.store`: the EEPROM store file (atomic, checksummed).
- `pyuss.drive.states`, `pyuss.drive.ramp`: the drive profile's state machine (C 5.2.1) and
  its ramp-function generator.
- `pyuss.drive.simulated`: `SimulatedDrive`, everything bundled for a slave engine.

See docs/drive.md.
"""

from typing import TYPE_CHECKING

from pyuss._lazy import lazy_exports

if TYPE_CHECKING:
    from pyuss.drive.database import (
        Access,
        Commissioning,
        DescriptionStyle,
        Parameter,
        ParameterDatabase,
        ParamRef,
        WordBits,
    )
    from pyuss.drive.datatypes import DataType, Value
    from pyuss.drive.description import DescriptionElement
    from pyuss.drive.faults import DriveErrorNumber, NoWriteAuthority, ParameterFault
    from pyuss.drive.loader import builtin_profiles, load_database, load_profile, parse_database
    from pyuss.drive.memory import LOCAL, WHOLE_ARRAY, ParameterChange, ParameterMemory
    from pyuss.drive.simulated import SimulatedDrive
    from pyuss.drive.states import DriveState, DriveStateMachine, Motion
    from pyuss.drive.store import ParameterStore, StoreError

__all__ = [
    "LOCAL",
    "WHOLE_ARRAY",
    "Access",
    "Commissioning",
    "DataType",
    "DescriptionElement",
    "DescriptionStyle",
    "DriveErrorNumber",
    "DriveState",
    "DriveStateMachine",
    "Motion",
    "NoWriteAuthority",
    "ParamRef",
    "Parameter",
    "ParameterChange",
    "ParameterDatabase",
    "ParameterFault",
    "ParameterMemory",
    "ParameterStore",
    "SimulatedDrive",
    "StoreError",
    "Value",
    "WordBits",
    "builtin_profiles",
    "load_database",
    "load_profile",
    "parse_database",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "pyuss.drive.database": (
            "Access",
            "Commissioning",
            "DescriptionStyle",
            "Parameter",
            "ParameterDatabase",
            "ParamRef",
            "WordBits",
        ),
        "pyuss.drive.datatypes": (
            "DataType",
            "Value",
        ),
        "pyuss.drive.description": ("DescriptionElement",),
        "pyuss.drive.faults": (
            "DriveErrorNumber",
            "NoWriteAuthority",
            "ParameterFault",
        ),
        "pyuss.drive.loader": (
            "builtin_profiles",
            "load_database",
            "load_profile",
            "parse_database",
        ),
        "pyuss.drive.memory": (
            "LOCAL",
            "WHOLE_ARRAY",
            "ParameterChange",
            "ParameterMemory",
        ),
        "pyuss.drive.simulated": ("SimulatedDrive",),
        "pyuss.drive.states": (
            "DriveState",
            "DriveStateMachine",
            "Motion",
        ),
        "pyuss.drive.store": (
            "ParameterStore",
            "StoreError",
        ),
    },
)
