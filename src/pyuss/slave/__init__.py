"""The USS slave: a protocol engine without I/O and a server that runs engines on a line.

- `SlaveEngine` (`pyuss.slave.engine`): one slave address serving a `pyuss.drive.SimulatedDrive`
  as a `pyuss.profiles.Profile` says; ``handle(telegram, now) -> answer or None``.
- `SlaveServer` (`pyuss.slave.server`): engines on one `pyuss.transport.Transport`, with the
  receiver of the protocol core, the start pause and the profile's response delay.
- `ParameterChannel` (`pyuss.slave.channel`): one parameter job executed (C 4.2).
- `DiagnosticParameters` (`pyuss.slave.diagnostic`): the diagnostic parameters of A 5.2.3.
- `InterfaceParameters` (`pyuss.slave.interface`): the interface parameters of C 3 (baud rate,
  failure time ...) read and shown through the parameter file's ``[interface]`` table.
- `pyuss.slave.process`: process data mappings and broadcasts.
- `pyuss.slave.simulation`: simulated drives on a line, as ``uss simulate`` builds them.

See docs/slave.md.
"""

from pyuss.slave.channel import ParameterChannel
from pyuss.slave.diagnostic import DiagnosticParameters
from pyuss.slave.engine import JobLatency, SlaveEngine, SpecialHandler
from pyuss.slave.interface import InterfaceParameters
from pyuss.slave.server import ServerStats, SlaveServer, describe, serve

__all__ = [
    "DiagnosticParameters",
    "InterfaceParameters",
    "JobLatency",
    "ParameterChannel",
    "ServerStats",
    "SlaveEngine",
    "SlaveServer",
    "SpecialHandler",
    "describe",
    "serve",
]
