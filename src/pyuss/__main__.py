"""``python -m pyuss``: the ``uss`` command, for a Python whose scripts folder is not on PATH
(a Windows install without the option ticked, an embedded Python)."""

import sys

from pyuss.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
