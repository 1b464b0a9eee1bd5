"""Monte-Carlo benchmark: Nomoto zig-zag 10/10 runs (K, T drawn from normals) on a local Dask
cluster of 2 single-threaded workers, 60 s at dt = 0.02 s per run, in chunks of 8192 runs.

``USVID_BENCH_MC_RUNS`` sets the number of runs (default 200,000; the issue's figure is
1,000,000). Printed: wall time, runs per second, throughput per core (ns CPU per RK4 step, from
the workers' CPU time), peak RSS per worker process (flat in N: each task holds one chunk).
"""

from __future__ import annotations

import logging
import os
import resource
import tempfile
import time
from pathlib import Path

import pandas as pd
from distributed import Client, LocalCluster

from usvid.io.modelfile import model_to_dict
from usvid.models import Nomoto1, VesselModel, mu2018_servo
from usvid.scale.montecarlo import MonteCarlo, Vary, run_chunk, run_montecarlo
from usvid.trial import Vessel

RUNS = int(os.environ.get("USVID_BENCH_MC_RUNS", "200000"))
CHUNK, T_END, DT = 8192, 60.0, 0.02


def _usage() -> tuple[float, float]:
    """(CPU seconds, max RSS [MiB]) of this worker process."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime, r.ru_maxrss / 1024


def main() -> None:
    vm = VesselModel(Nomoto1(K=0.2, T=5.0), servo=mu2018_servo(),
                     vessel=Vessel(length=7.0, speed=3.0))
    mc = MonteCarlo(model_to_dict(vm), "zigzag", {"t_end": T_END, "dt": DT},
                    vary=(Vary("K", "normal", 0.2, 0.02), Vary("T", "normal", 5.0, 0.5)), seed=1)
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        client.run(run_chunk, mc, 0, 64, 1)  # compile / load the kernel on every worker
        cpu0 = sum(c for c, _ in client.run(_usage).values())
        w0 = time.perf_counter()
        df = run_montecarlo(mc, RUNS, chunk=CHUNK, client=client, progress=False)
        wall = time.perf_counter() - w0
        usage = client.run(_usage)
    finally:
        client.close()
        cluster.close()
    cpu = sum(c for c, _ in usage.values()) - cpu0
    steps = RUNS * T_END / DT
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mc.parquet"
        df.to_parquet(path, index=False)
        size = path.stat().st_size
    print(f"bench_montecarlo: {RUNS} Nomoto zig-zag 10/10 runs ({T_END:.0f} s at dt={DT} s), "
          f"2 workers x 1 thread, chunks of {CHUNK} (load average {os.getloadavg()[0]:.1f})")
    print(f"  wall {wall:.1f} s, {RUNS / wall:,.0f} runs/s; workers' CPU {cpu:.1f} s = "
          f"{cpu / steps * 1e9:.1f} ns CPU per RK4 step, {RUNS / cpu:,.0f} runs per CPU-second")
    print("  peak RSS per worker: " + ", ".join(f"{rss:.0f} MiB" for _, rss in usage.values())
          + " (one chunk in memory per task: flat in the number of runs)")
    print(f"  {df['success'].mean() * 100:.1f} % runs completed; overshoot_1_deg median "
          f"{df['overshoot_1_deg'].median():.3f}; Parquet {size / 2**20:.1f} MiB; "
          f"{len(pd.unique(df['run']))} distinct runs")


if __name__ == "__main__":
    main()
