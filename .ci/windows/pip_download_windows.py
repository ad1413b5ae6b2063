"""pip download, with environment markers evaluated for Windows CPython 3.13 on amd64.

pip's --platform and --python-version choose the wheels, but pip still evaluates the
markers of requirements (``uvloop; sys_platform != 'win32'``, ``colorama; platform_system ==
'Windows'``) for the Python it runs on: on Linux it would want Linux-only packages and miss
Windows-only ones. This runs pip with the marker environment of the Windows Python the lane
installs into, so that the wheels downloaded are the ones pip on Windows asks for (the
lane's install there runs with --no-index: anything missing fails it).

    python pip_download_windows.py ARGS...   # the arguments of pip download
"""

from __future__ import annotations

import sys

from pip._internal.cli.main import main
from pip._vendor.packaging import markers

WINDOWS = {
    "implementation_name": "cpython",
    "implementation_version": "3.13.2",
    "os_name": "nt",
    "platform_machine": "AMD64",
    "platform_release": "10",
    "platform_system": "Windows",
    "platform_version": "10.0.19045",
    "python_full_version": "3.13.2",
    "platform_python_implementation": "CPython",
    "python_version": "3.13",
    "sys_platform": "win32",
}

markers.default_environment = lambda: dict(WINDOWS)  # type: ignore[assignment,return-value]

if __name__ == "__main__":
    sys.exit(main(["download", *sys.argv[1:]]))
