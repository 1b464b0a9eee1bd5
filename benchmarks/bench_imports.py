"""Start-up benchmark: the CPU time of a fresh Python process that imports usvid's simulation
library, or runs ``usvid --help``, against its peer measured in the same run:

- ``import usvid.sim`` against ``import numba, numpy`` (what a simulation cannot do without;
  target: at most 1.5x),
- ``python -m usvid --help`` against ``import typer`` (the command-line layer; target: at most
  1.2x).

Each command runs ``--repeat`` times (default 9) in fresh processes, the commands interleaved
so that the load of the shared machine weighs on all alike. The figure is the child's CPU time
(user + system, from ``os.wait4``; what ``time.process_time`` reads at its exit), interpreter
start-up included for both sides; Python's bytecode is written as for any installed package
(``PYTHONDONTWRITEBYTECODE`` is dropped for the children: the warm-up run writes usvid's, pip
wrote the peers' at install). Prints the fastest and the median of each, their ratios and the
load average.

Run: ``.venv/bin/python benchmarks/bench_imports.py [--repeat N]``; ``python -X importtime -c
"import usvid.sim"`` shows where the time goes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

PY = sys.executable

#: (label, argv, peer label, peer argv, target ratio)
PAIRS = [
    ("import usvid.sim", [PY, "-c", "import usvid.sim"],
     "import numba, numpy", [PY, "-c", "import numba, numpy"], 1.5),
    ("usvid --help", [PY, "-m", "usvid", "--help"],
     "import typer", [PY, "-c", "import typer"], 1.2),
]


#: The children's environment: Python writes the bytecode of what they import, as for any
#: installed package (pip compiles the peers' at install; a shell with PYTHONDONTWRITEBYTECODE
#: set would otherwise measure the compilation of usvid's sources at every start).
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def run_child(argv: list[str]) -> tuple[float, str]:
    """(CPU time [s] (user + system), standard output) of one run of ``argv`` in a fresh
    process."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(argv, stdout=out, stderr=err, env=ENV)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if proc.returncode != 0:
            raise SystemExit(f"{' '.join(argv)}: exit {proc.returncode}: "
                             f"{err.read().decode(errors='replace')[-400:]}")
        return usage.ru_utime + usage.ru_stime, out.read().decode(errors="replace")


def cpu_seconds(argv: list[str]) -> float:
    """CPU time [s] (user + system) of one run of ``argv`` in a fresh process."""
    return run_child(argv)[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args()
    for argv in {tuple(a) for p in PAIRS for a in (p[1], p[3])}:  # warm the file cache
        cpu_seconds(list(argv))
    load0 = os.getloadavg()[0]
    times: dict[str, list[float]] = {}
    for _ in range(args.repeat):
        for label, argv, peer, peer_argv, _target in PAIRS:
            times.setdefault(label, []).append(cpu_seconds(argv))
            times.setdefault(peer, []).append(cpu_seconds(peer_argv))
    load1 = os.getloadavg()[0]
    print(f"bench_imports: CPU time of a fresh process, {args.repeat} runs each, interleaved "
          f"(load average {load0:.1f} at the start, {load1:.1f} at the end)")
    for label, _argv, peer, _peer_argv, target in PAIRS:
        a, b = times[label], times[peer]
        print(f"  {label}: fastest {min(a):.3f} s, median {statistics.median(a):.3f} s; "
              f"{peer}: fastest {min(b):.3f} s, median {statistics.median(b):.3f} s; ratio "
              f"{min(a) / min(b):.2f}x fastest, {statistics.median(a) / statistics.median(b):.2f}x "
              f"median [target <= {target}x]")


if __name__ == "__main__":
    main()
