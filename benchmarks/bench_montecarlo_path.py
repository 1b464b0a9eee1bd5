"""Monte-Carlo: ``usvid montecarlo`` against the in-process library path, CPU side by side.

The same 100,000 Nomoto zig-zag 10/10 runs (K, T drawn from normals, 60 s at dt = 0.02 s,
chunks of 8192) two ways, each in a fresh process and measured in this run (the CPU of the
process and its children, ``resource.RUSAGE_CHILDREN``): the command (``usvid montecarlo ...
--out F.parquet``: start-up, its path choice, the Parquet file) and a script calling
:func:`usvid.scale.montecarlo.run_montecarlo` in process (imports, the runs, the same Parquet
file). Then the command on a local Dask cluster (``--workers`` above the cores), for the
record. ``USVID_BENCH_MC_RUNS`` sets the number of runs. The acceptance: the command within
1.1x the CPU of the library path on a 2-core machine.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RUNS = int(os.environ.get("USVID_BENCH_MC_RUNS", "100000"))
CHUNK = 8192

LIBRARY = """
import sys
import pandas as pd
from usvid.io.modelfile import load_model, model_to_dict
from usvid.scale.montecarlo import MonteCarlo, Vary, run_montecarlo
mc = MonteCarlo(model_to_dict(load_model(sys.argv[1])), "zigzag", {{"t_end": 60.0, "dt": 0.02}},
                vary=(Vary("K", "normal", 0.2, 0.02), Vary("T", "normal", 5.0, 0.5)), seed=1)
df = run_montecarlo(mc, {runs}, chunk={chunk})
df.to_parquet(sys.argv[2], index=False)
"""


def _cpu(argv: list[str]) -> tuple[float, float]:
    """(CPU [s] of the process and its children, wall [s]) of ``argv`` run to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime), wall


def main() -> None:
    usvid = str(Path(sys.executable).with_name("usvid"))
    with tempfile.TemporaryDirectory() as tmp:
        model = Path(tmp) / "m.json"
        from usvid.io.modelfile import save_model
        from usvid.models import Nomoto1, VesselModel, mu2018_servo
        from usvid.trial import Vessel

        save_model(VesselModel(Nomoto1(K=0.2, T=5.0), servo=mu2018_servo(),
                               vessel=Vessel(length=7.0, speed=3.0)), model)
        cmd = [usvid, "montecarlo", str(model), "--manoeuvre", "zigzag", "--runs", str(RUNS),
               "--chunk", str(CHUNK), "--t-end", "60", "--dt", "0.02", "--vary",
               "K=normal:0.2,0.02", "--vary", "T=normal:5.0,0.5", "--seed", "1", "--json"]
        lib = [sys.executable, "-c", LIBRARY.format(runs=RUNS, chunk=CHUNK), str(model),
               str(Path(tmp) / "lib.parquet")]
        _cpu(cmd + ["--out", str(Path(tmp) / "warm.parquet")])  # numba cache, file cache
        rows = []
        for _ in range(2):  # alternated, twice: the machine's load moves
            rows.append(("usvid montecarlo (in process)",
                         *_cpu(cmd + ["--out", str(Path(tmp) / "cli.parquet")])))
            rows.append(("library run_montecarlo", *_cpu(lib)))
        cores = len(os.sched_getaffinity(0))
        dask = _cpu(cmd + ["--out", str(Path(tmp) / "dask.parquet"), "--workers",
                           str(cores + 1)])
        out = json.loads(subprocess.run(cmd + ["--out", str(Path(tmp) / "x.parquet")],
                                        capture_output=True, text=True).stdout)
    best = {}
    for name, cpu, wall in rows:
        best[name] = min(best.get(name, (1e9, 0))[0], cpu), wall
    c, lb = best["usvid montecarlo (in process)"][0], best["library run_montecarlo"][0]
    print(f"bench_montecarlo_path: {RUNS} Nomoto zig-zags (60 s, dt 0.02 s), chunks of {CHUNK}, "
          f"{cores} cores, load average {os.getloadavg()[0]:.1f}; CPU of process + children, "
          "best of 2, fresh processes")
    for name, cpu, wall in rows:
        print(f"  {name:32s} CPU {cpu:6.2f} s  wall {wall:6.2f} s")
    print(f"  usvid montecarlo on Dask ({cores + 1} workers) CPU {dask[0]:6.2f} s  wall "
          f"{dask[1]:6.2f} s")
    print(f"  command / library CPU: {c / lb:.3f} (acceptance <= 1.1); the command chose "
          f"backend {out.get('backend')!r} with {out.get('workers')} thread(s)")


if __name__ == "__main__":
    main()
