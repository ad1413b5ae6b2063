"""Let Wireshark decode the captures of uss monitor: install or locate the USS dissector.

    uss wireshark path                 # where the shipped uss.lua is
    uss wireshark install              # copy it into Wireshark's personal Lua plugins folder
    uss wireshark install --dir DIR    # ... or into DIR

An earlier copy of the dissector is replaced; a uss.lua that is not pyuss's is left alone
(exit code 1) unless --force. A --dir that is a file is a usage error (exit code 2).

After installing, Wireshark and tshark decode captures written by
``uss monitor --write FILE.pcapng``. Without installing:
``wireshark -X lua_script:$(uss wireshark path) FILE.pcapng``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from pyuss.cli._help import actions, subcommand
from pyuss.cli._output import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from pyuss.errors import ConfigError
from pyuss.monitor.dissector import dissector_source, install, plugin_dir

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    parser = subcommand(
        subparsers,
        "wireshark",
        "install or locate the Wireshark dissector for monitor captures",
        __doc__,
    )
    sub = actions(parser, "action")
    sub.add_parser("path", help="print where the dissector (uss.lua) shipped with pyuss is")
    setup = sub.add_parser(
        "install", help="copy the dissector into Wireshark's personal Lua plugins folder"
    )
    setup.add_argument(
        "--dir",
        type=Path,
        metavar="DIR",
        help=f"copy it into DIR instead (default: {plugin_dir()})",
    )
    setup.add_argument(
        "--force",
        action="store_true",
        help="replace a uss.lua there even if it is not pyuss's dissector",
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        if args.action == "path":
            print(dissector_source())
            return EXIT_OK
        if args.dir is not None and args.dir.exists() and not args.dir.is_dir():
            print(f"uss wireshark: --dir {args.dir}: not a folder", file=sys.stderr)
            return EXIT_USAGE
        target, status = install(args.dir, force=args.force)
    except ConfigError as exc:
        print(f"uss wireshark: {exc}", file=sys.stderr)
        return EXIT_FAILED
    print(target)
    if status == "up to date":
        print("uss wireshark: already up to date", file=sys.stderr)
    else:
        print(f"uss wireshark: {status}; restart Wireshark to load it", file=sys.stderr)
    return EXIT_OK
