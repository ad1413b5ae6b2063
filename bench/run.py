"""Run every benchmark under bench/ (files named bench_*.py, each with a ``main()``), then print
the figures that have goals in one table (docs/bench.md says how to read it).

``python bench/run.py master scan`` runs only the ones named; ``--quick`` asks those that
have a quick mode for it (shorter windows: ``USS_BENCH_QUICK=1``).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import time
from pathlib import Path


def main() -> int:
    here = Path(__file__).resolve().parent
    sys.path.insert(0, str(here))
    from common import Figure, table

    if "--quick" in sys.argv:
        os.environ["USS_BENCH_QUICK"] = "1"
    only = set(sys.argv[1:]) - {"--quick"}
    figures: list[Figure] = []
    began = time.monotonic()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    for path in sorted(here.glob("bench_*.py")):
        if only and path.stem.removeprefix("bench_") not in only:
            continue
        spec = importlib.util.spec_from_file_location(path.stem, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # as an import would: dataclasses look their module up
        spec.loader.exec_module(module)
        print(f"== {path.stem.removeprefix('bench_')}", flush=True)
        figures += module.main() or []
    took = time.monotonic() - began
    print()
    print(f"== figures and goals ({took:.0f} s; {os.cpu_count()} cores", end="")
    print(f", load average {load:.1f} at the start)" if load is not None else ")")
    print(table(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
