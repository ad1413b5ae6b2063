"""The bus monitor: passive listening, decoding, statistics and capture files.

- `Monitor` (`pyuss.monitor.core`): sans-io core; bytes or frames in, `Exchange`s out.
- `LayoutBook` (`pyuss.monitor.infer`): given layouts and layout inference.
- `Summary` (`pyuss.monitor.stats`): A 5.2.3 counters, error rates, response times.
- `exchange_line`, `summary_table` (`pyuss.monitor.render`): text output (JSON: the command).
- `open_writer`, `read_capture` (`pyuss.monitor.capture`): pcapng and JSON-lines captures;
  `CaptureRecord`, `CaptureFlag` (`pyuss.monitor.records`): what they hold of each frame.
- `watch`, `replay` (`pyuss.monitor.live`): run a monitor on transports or a capture;
  `Listener`: a transport with no way to send.
- `dissector_source`, `install` (`pyuss.monitor.dissector`): the Wireshark Lua dissector.
"""

from pyuss.monitor.capture import open_writer, read_capture
from pyuss.monitor.core import Monitor, default_gap
from pyuss.monitor.dissector import dissector_source, install, plugin_dir
from pyuss.monitor.infer import LayoutBook, LayoutChoice
from pyuss.monitor.live import Listener, replay, watch
from pyuss.monitor.model import Direction, Exchange, Frame, Issue, LayoutSource, Problem
from pyuss.monitor.records import Capture, CaptureFlag, CaptureRecord, CaptureWriter
from pyuss.monitor.render import exchange_line, summary_table
from pyuss.monitor.stats import AddressStats, Summary

__all__ = [
    "AddressStats",
    "Capture",
    "CaptureFlag",
    "CaptureRecord",
    "CaptureWriter",
    "Direction",
    "Exchange",
    "Frame",
    "Issue",
    "LayoutBook",
    "LayoutChoice",
    "LayoutSource",
    "Listener",
    "Monitor",
    "Problem",
    "Summary",
    "default_gap",
    "dissector_source",
    "exchange_line",
    "install",
    "open_writer",
    "plugin_dir",
    "read_capture",
    "replay",
    "summary_table",
    "watch",
]
