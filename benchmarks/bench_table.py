"""Tabular reader benchmark: a one-hour 50 Hz CSV log (180,000 rows, 8 columns, header) read by
``usvid.io.read_trial`` (format spec, units, rejection counts, assembly) against
``pandas.read_csv`` of the same file (C parser, no conversion). Target: within 2x of pandas.
"""

from __future__ import annotations

import os
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


if __name__ == "__main__":
    main()
