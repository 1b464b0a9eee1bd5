"""Benchmark: read a one-hour NMEA 0183 log (10 Hz GNSS, 50 Hz heading/rudder, ~500k sentences).

Generates the log into a temporary folder (GGA, RMC, VTG, ROT at 10 Hz; HDT, RSA at 50 Hz; ISO
time prefix on every line), then times ``usvid.io.read_nmea0183`` and, when ``usvid.prep`` is
available, ``usvid.prep.prepare(trial, rate_hz=50)`` (NED, uniform 50 Hz grid). Prints sentences,
seconds, sentences/s (target >= 20 000 /s end to end) and the peak resident memory
(``ru_maxrss`` of the process, generation included). Then the CPU of the whole job a user's
script does: the imports, the read and the preparation (``usvid.prep`` loads ``scipy.signal``
at its first use, inside the first ``prepare``, not at import: versions compare only with the
imports included).

Run: ``.venv/bin/python benchmarks/bench_nmea.py [--minutes 60] [--engine fast|pynmeagps]``
"""

from __future__ import annotations

import time

_CPU0 = time.process_time()  # noqa: E402 - the imports' CPU is part of the job

import argparse  # noqa: E402
import resource  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from usvid import Trial  # noqa: E402
from usvid.io import read_nmea0183  # noqa: E402
from usvid.io.nmea0183 import nmea0183_lines  # noqa: E402

IMPORT_CPU = time.process_time() - _CPU0


def synthetic_log(path: Path, minutes: float = 60.0, seed: int = 0) -> int:
    """Write a zig-zagging vessel's NMEA 0183 log; returns the number of sentences."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(0.0, minutes * 60.0, 0.02), 3)  # 50 Hz master clock
    U = 2.0
    delta = np.deg2rad(20.0) * np.sign(np.sin(2 * np.pi * t / 60.0))
    r = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 60.0 - 0.5)
    psi = np.cumsum(r) * 0.02
    x = np.cumsum(U * np.cos(psi)) * 0.02
    y = np.cumsum(U * np.sin(psi)) * 0.02
    lat = 54.0 + x / 111_320.0
    lon = 10.0 + y / (111_320.0 * np.cos(np.deg2rad(54.0)))
    gnss = (np.arange(len(t)) % 5) == 0  # 10 Hz
    nan = np.full(len(t), np.nan)
    df = pd.DataFrame(
        {
            "t": t,
            "lat": np.where(gnss, lat, nan),
            "lon": np.where(gnss, lon, nan),
            "sog": np.where(gnss, U + rng.normal(0, 0.02, len(t)), nan),
            "cog": np.where(gnss, psi, nan),
            "psi": psi + rng.normal(0, 0.002, len(t)),
            "r": np.where(gnss, r, nan),
            "delta": delta,
        }
    )
    lines = nmea0183_lines(Trial(df, name="bench"), t0_utc="2025-06-01T10:00:00Z")
    path.write_text("\r\n".join(lines) + "\r\n", encoding="ascii")
    return len(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--engine", default="fast", choices=["fast", "pynmeagps"])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "bench.nmea"
        t0 = time.perf_counter()
        n = synthetic_log(p, args.minutes)
        print(f"generated {n} sentences ({p.stat().st_size / 1e6:.1f} MB) "
              f"in {time.perf_counter() - t0:.1f} s")
        t1 = time.perf_counter()
        c1 = time.process_time()
        trial = read_nmea0183(p, engine=args.engine)
        t_read = time.perf_counter() - t1
        print(f"read ({args.engine}): {t_read:.2f} s = {n / t_read:,.0f} sentences/s; "
              f"{len(trial)} rows, channels {trial.channels}, rejected {trial.rejected}")
        t_prep = 0.0
        try:
            from usvid.prep import prepare
        except ImportError:
            prepare = None
        if prepare is not None:
            t2 = time.perf_counter()
            prepped = prepare(trial, rate_hz=50.0)
            t_prep = time.perf_counter() - t2
            print(f"prepare to 50 Hz: {t_prep:.2f} s; {len(prepped)} rows, "
                  f"rate {prepped.sample_rate:.2f} Hz")
        else:
            print("usvid.prep.prepare not available: reading only")
        job_cpu = IMPORT_CPU + time.process_time() - c1  # the read, the import of prepare, it
        peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # kB on Linux
        total = t_read + t_prep
        verdict = "OK" if n / total >= 20_000 else "BELOW TARGET"
        print(f"end to end: {total:.2f} s = {n / total:,.0f} sentences/s (target >= 20,000: "
              f"{verdict}); peak RSS {peak_kb / 1024:.0f} MB")
        print(f"the job's CPU, imports + read + prepare: {job_cpu:.2f} s (imports "
              f"{IMPORT_CPU:.2f} s)")


if __name__ == "__main__":
    main()
