"""Run every ``benchmarks/bench_*.py`` in its own process and print its output (``make bench``).

Benchmarks print numbers; nothing here asserts timings. Exit code 1 if any benchmark failed.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> int:
    failed = []
    files = sorted(HERE.glob("bench_*.py"))
    if not files:
        print("no benchmarks/bench_*.py found")
        return 0
    for path in files:
        print(f"=== {path.name} " + "=" * max(0, 70 - len(path.name)), flush=True)
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, str(path)], cwd=HERE.parent, text=True,
                              capture_output=True)
        sys.stdout.write(proc.stdout)
        if proc.returncode != 0:
            sys.stdout.write(proc.stderr)
            failed.append(path.name)
        print(f"--- {path.name}: exit {proc.returncode}, {time.perf_counter() - t0:.1f} s wall "
              "(including start-up and compilation)", flush=True)
    if failed:
        print(f"FAILED: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
