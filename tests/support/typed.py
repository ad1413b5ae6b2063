"""A simulated drive with a parameter of every data type, served on TCP in its own process."""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path

from support.processes import start_simulator, stop_simulator

TYPES_TOML = """\
[profile]
extends = "generic"
name = "typed"

[[parameter]]
pnu = 800
name = "Int8 value"
type = "int8"
min = -100
max = 100
default = -7

[[parameter]]
pnu = 801
name = "Uint8 value"
type = "uint8"
default = 200

[[parameter]]
pnu = 802
name = "Signed torque"
type = "int16"
unit = "%"
scaling = 0.1
min = -1500
max = 1500
default = -125

[[parameter]]
pnu = 803
name = "Counter"
type = "uint32"
default = 3000000000

[[parameter]]
pnu = 804
name = "Position"
type = "int32"
unit = "mm"
scaling = 0.001
default = -123456

[[parameter]]
pnu = 805
name = "Speed limit"
type = "float"
unit = "rpm"
min = 0.0
max = 3000.0
default = 1500.5

[[parameter]]
pnu = 806
name = "Plant name"
type = "string"
length = 12
default = "PUMP 3"

[[parameter]]
pnu = 807
name = "Serial bytes"
type = "octets"
length = 4
default = "01 A0 FF 10"

[[parameter]]
pnu = 808
name = "Option bits"
type = "V2"
default = 0x0005

[[parameter]]
pnu = 809
name = "Fixed speeds"
type = "float"
array = 3
unit = "Hz"
min = -650.0
max = 650.0
default = [10.0, 20.0, -30.0]

[[parameter]]
pnu = 810
name = "Mode"
type = "uint16"
max = 2
default = 1
texts = { 0 = "OFF", 1 = "LOCAL", 2 = "REMOTE" }

[[parameter]]
pnu = 811
name = "Act. speed"
type = "float"
unit = "rpm"
access = "ro"
"""


@dataclass
class Simulator:
    path: str
    """The port to open: ``tcp://127.0.0.1:PORT``."""
    params: Path
    process: subprocess.Popen[str]


def start(params: Path, *options: str) -> Simulator:
    process, path = start_simulator(
        "--params", str(params), "--address", "5", "--baud", "38400", *options
    )
    return Simulator(path, params, process)


def stop(sim: Simulator) -> None:
    stop_simulator(sim.process)
