"""Tabular reader benchmark: ``usvid.io.read_trial`` (format spec, units, rejection counts,
assembly) against ``pandas.read_csv`` of the same file (C parser, no conversion), interleaved:

- a one-hour 50 Hz CSV log (180,000 rows, 8 columns, header, 14 MiB): best wall time of 7
  (target: within 2x of pandas);
- a 1e6 x 12 CSV (131 MB, ``%.6f`` cells): CPU time (``time.process_time``), fastest and
  median of 5 (target: within 1.2x of pandas).

Run: ``.venv/bin/python benchmarks/bench_table.py`` (needs ~0.5 GB of temporary disk space).
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from usvid.io import read_trial

SPEC = """reader: table
delimiter: ","
header: true
columns:
  t:     {col: time_s, unit: s}
  x:     {col: x_m, unit: m}
  y:     {col: y_m, unit: m}
  psi:   {col: heading_deg, unit: deg}
  r:     {col: yaw_rate_deg_s, unit: deg/s}
  u:     {col: u_m_s, unit: m/s}
  delta: {col: rudder_deg, unit: deg}
  n:     {col: rpm, unit: rpm}
"""


def _best_pair(fa, fb, repeat: int = 7) -> tuple[float, float]:
    """Best wall times [s] of ``fa`` and ``fb`` over ``repeat`` interleaved runs (a shared
    machine's load then weighs on both alike)."""
    ta, tb = float("inf"), float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fa()
        t1 = time.perf_counter()
        fb()
        t2 = time.perf_counter()
        ta, tb = min(ta, t1 - t0), min(tb, t2 - t1)
    return ta, tb


BIG_SPEC = """reader: table
delimiter: ","
header: true
columns:
  t: {col: time_s, unit: s}
""" + "".join(f"  {c}: {{col: c{k}, unit: {u}}}\n" for k, (c, u) in enumerate(
    [("x", "m"), ("y", "m"), ("psi", "deg"), ("r", "deg/s"), ("u", "m/s"), ("v", "m/s"),
     ("delta", "deg"), ("n", "rpm"), ("U", "m/s"), ("n_port", "rpm"), ("n_stbd", "rpm")]))


def _cpu_pair(fa, fb, repeat: int = 5) -> tuple[list[float], list[float]]:
    """CPU times [s] of ``fa`` and ``fb`` over ``repeat`` interleaved runs."""
    ta, tb = [], []
    for _ in range(repeat):
        t0 = time.process_time()
        fa()
        t1 = time.process_time()
        fb()
        t2 = time.process_time()
        ta.append(t1 - t0)
        tb.append(t2 - t1)
    return ta, tb


def big_table() -> None:
    """The 1e6 x 12 CSV (131 MB): CPU of read_trial against pandas.read_csv."""
    n = 1_000_000
    rng = np.random.default_rng(0)
    cols = {"time_s": np.arange(n) / 50.0}
    for k in range(11):
        cols[f"c{k}"] = rng.normal(0, 100, n)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        pd.DataFrame(cols).to_csv(path, index=False, float_format="%.6f")
        spec = Path(tmp) / "big.yaml"
        spec.write_text(BIG_SPEC)
        size = path.stat().st_size
        tr = read_trial(path, spec)  # (warm: imports, the file in the page cache)
        load0 = os.getloadavg()[0]
        t_pd, t_us = _cpu_pair(lambda: pd.read_csv(path), lambda: read_trial(path, spec))
        load1 = os.getloadavg()[0]
    print(f"bench_table: 1e6 x 12 CSV ({size / 1e6:.0f} MB), CPU time, 5 runs interleaved "
          f"(load average {load0:.1f} at the start, {load1:.1f} at the end)")
    print(f"  pandas.read_csv: fastest {min(t_pd):.2f} s, median {statistics.median(t_pd):.2f} s;"
          f" usvid read_trial: fastest {min(t_us):.2f} s, median "
          f"{statistics.median(t_us):.2f} s; ratio {min(t_us) / min(t_pd):.2f}x fastest, "
          f"{statistics.median(t_us) / statistics.median(t_pd):.2f}x median [target <= 1.2x]; "
          f"{len(tr)} records")


def main() -> None:
    n = 3600 * 50
    rng = np.random.default_rng(0)
    t = np.arange(n) / 50.0
    df = pd.DataFrame({"time_s": t, "x_m": rng.normal(0, 100, n), "y_m": rng.normal(0, 100, n),
                       "heading_deg": rng.uniform(0, 360, n),
                       "yaw_rate_deg_s": rng.normal(0, 3, n), "u_m_s": rng.normal(3, 0.1, n),
                       "rudder_deg": rng.uniform(-35, 35, n), "rpm": rng.normal(900, 10, n)})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.csv"
        df.to_csv(path, index=False, float_format="%.6f")
        spec = Path(tmp) / "spec.yaml"
        spec.write_text(SPEC)
        size = path.stat().st_size
        tr = read_trial(path, spec)
        t_pd, t_us = _best_pair(lambda: pd.read_csv(path), lambda: read_trial(path, spec))
    print(f"bench_table: one-hour 50 Hz CSV ({n} rows, 8 columns, {size / 2**20:.0f} MiB), "
          f"best of 7 interleaved (load average {os.getloadavg()[0]:.1f})")
    print(f"  pandas.read_csv: {t_pd:.2f} s; usvid read_trial: {t_us:.2f} s "
          f"({t_us / t_pd:.1f}x pandas) [target <= 2x]; {len(tr)} records")
    big_table()


if __name__ == "__main__":
    main()
