"""Benchmark: start-up of the command line, ``usvid --help`` (target < 0.5 s: the CLI imports
its commands' libraries lazily, and ``import usvid`` loads neither pandas nor numba).

Runs ``python -m usvid --help`` five times in fresh processes and prints the median and the
fastest wall time [s].

Run: ``.venv/bin/python benchmarks/bench_cli_help.py``
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time


def main() -> None:
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "usvid", "--help"], check=True,
                       capture_output=True)
        times.append(time.perf_counter() - t0)
    print(f"usvid --help: median {statistics.median(times):.3f} s, fastest {min(times):.3f} s "
          "(target < 0.5 s)")


if __name__ == "__main__":
    main()
