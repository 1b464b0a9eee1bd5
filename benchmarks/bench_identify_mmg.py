"""MMG identification benchmark: the 13 HSVA KVLCC2 zig-zags (SIMMAN 2008, 20 Hz).

Reads the 13 runs of ``../shared/data/kvlcc2_hsva`` with the shipped ``hsva_kvlcc2`` spec
(skipped with a message where the data are not present), then times
``ModelEstimator("mmg", "ls")`` (state estimation by EKF + RTS smoother of every run, the
regularised regression of the 17 hull coefficients, the replay fit metrics) and
``ModelEstimator("mmg", "oe")`` (the same, then output error by multiple shooting over 20 s
windows). Printed: wall and CPU time of each fit (after a warm-up fit of one run, so numba
compilation or cache loading is excluded), peak memory of Python/numpy allocations
(tracemalloc), the process max RSS, and the 35 deg turning circles (advance/L, tactical
diameter/L, to starboard and port) the identified models predict.
"""

from __future__ import annotations

import resource
import sys
import time
import tracemalloc
import warnings
from pathlib import Path

import usvid.io
import usvid.prep
from usvid.errors import UsvidError
from usvid.identify import ModelEstimator
from usvid.sim import run_turning

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "kvlcc2_hsva"


def main() -> int:
    files = sorted(DATA.glob("HSVA_CPMC_KVLCC2_Z_*.dat"))
    if not files:
        print(f"HSVA data not found in {DATA}: benchmark skipped")
        return 0
    warnings.simplefilter("ignore")
    trials = [usvid.prep.prepare(usvid.io.read_trial(f, "hsva_kvlcc2")) for f in files]
    ModelEstimator("mmg", "ls").fit(trials[:1])  # warm-up: compilation / cache loading
    for method in ("ls", "oe"):
        tracemalloc.start()
        t0, c0 = time.perf_counter(), time.process_time()
        est = ModelEstimator("mmg", method).fit(trials)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        L = est.model_.vessel.length
        turns = []
        for d in (35.0, -35.0):
            side = "stbd" if d > 0 else "port"
            try:
                _, m = run_turning(est.model_, d)
            except UsvidError as exc:  # a model that extrapolates badly to 35 deg
                turns.append(f"{side} {exc}")
                continue
            turns.append(f"{side} advance/L {m.advance_m / L:.3f} "
                         f"tactical/L {m.tactical_diameter_m / L:.3f}")
        print(f"mmg {method}: {len(trials)} runs ({sum(len(t) for t in trials)} rows), "
              f"{wall:.1f} s wall, {cpu:.1f} s CPU, peak traced memory {peak:.0f} MiB; "
              f"35 deg turn {'; '.join(turns)}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"process max RSS {rss:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
