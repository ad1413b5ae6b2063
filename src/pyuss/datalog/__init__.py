"""Logging drive values to CSV files for spreadsheets: ``uss log`` (see docs/web.md).

- `pyuss.datalog.values`: the VALUES a log records (status, state, actual, bits, parameters).
- `pyuss.datalog.csvfile`: the file: whole rows, safe append, rotation by size.
- `pyuss.datalog.logger`: `DataLogger`, the sampling loop on a cyclic master; a drive that
  stops answering is written as such, never with stale values.
"""

from pyuss.datalog.csvfile import CsvLog, LogWriteError, parse_size
from pyuss.datalog.logger import COMM_OK, NO_ANSWER, DataLogger, LogResult
from pyuss.datalog.values import Kind, Quantity, parse_values

__all__ = [
    "COMM_OK",
    "NO_ANSWER",
    "CsvLog",
    "DataLogger",
    "Kind",
    "LogResult",
    "LogWriteError",
    "Quantity",
    "parse_size",
    "parse_values",
]
