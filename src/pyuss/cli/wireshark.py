"""``uss wireshark``: the Wireshark dissector for the monitor's pcapng captures.

    uss wireshark path                 # where the shipped uss.lua is
    uss wireshark install              # copy it into Wireshark's personal Lua plugins folder
    uss wireshark install --dir DIR    # ... or into DIR

After installing, Wireshark and tshark decode captures written by
``uss monitor --write FILE.pcapng``. Without installing:
``wireshark -X lua_script:$(uss wireshark path) FILE.pcapng``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from pyuss.errors import ConfigError
from pyuss.monitor.dissector import dissector_source, install, plugin_dir

__all__ = ["register", "run"]

EXIT_OK = 0
EXIT_FAILED = 1


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "wireshark",
        help="install or locate the Wireshark dissector for monitor captures",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    actions.add_parser("path", help="print the path of the shipped uss.lua")
    setup = actions.add_parser("install", help="copy uss.lua into the Lua plugins folder")
    setup.add_argument(
        "--dir",
        type=Path,
        metavar="DIR",
        help=f"plugins folder (default: {plugin_dir()})",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        if args.action == "path":
            print(dissector_source())
            return EXIT_OK
        target, written = install(args.dir)
    except ConfigError as exc:
        print(f"uss wireshark: {exc}", file=sys.stderr)
        return EXIT_FAILED
    print(target)
    note = "installed" if written else "already up to date"
    print(f"uss wireshark: {note}; restart Wireshark to load it", file=sys.stderr)
    return EXIT_OK
