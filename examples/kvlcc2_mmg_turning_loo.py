"""35 deg turning circle of the KVLCC2 predicted by the MMG model identified from the HSVA
zig-zags, and how stable it is when single runs are left out (leave-one-out).

Usage: ``python examples/kvlcc2_mmg_turning_loo.py DIR`` with DIR the folder of the 13 HSVA
``HSVA_CPMC_KVLCC2_Z_*.dat`` logs (SIMMAN 2008). Each of the 13 fits is
``ModelEstimator("mmg", "oe")`` with default options on the other 12 runs; printed: advance/L
and tactical diameter/L of a 35 deg turn to starboard and to port (``usvid.sim.run_turning``,
approach 1.18 m/s at the logged 10.23 rps), then their median, minimum and maximum.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np

import usvid.io
import usvid.prep
from usvid.errors import UsvidError
from usvid.identify import ModelEstimator
from usvid.sim import run_turning


def turning(model) -> list[float]:
    """[advance/L, tactical/L] to starboard, then to port (NaN where the turn diverges)."""
    L = model.vessel.length
    out: list[float] = []
    for delta in (35.0, -35.0):
        try:
            _, m = run_turning(model, delta)
            out += [m.advance_m / L, m.tactical_diameter_m / L]
        except UsvidError:
            out += [math.nan, math.nan]
    return out


def main(folder: str) -> int:
    warnings.simplefilter("ignore")
    files = sorted(Path(folder).glob("HSVA_CPMC_KVLCC2_Z_*.dat"))
    trials = [usvid.prep.prepare(usvid.io.read_trial(f, "hsva_kvlcc2")) for f in files]
    rows = []
    for i, f in enumerate(files):
        est = ModelEstimator("mmg", "oe").fit([t for j, t in enumerate(trials) if j != i])
        rows.append(turning(est.model_))
        print(f"without {f.stem}: stbd advance/L {rows[-1][0]:.3f} tactical/L {rows[-1][1]:.3f};"
              f" port advance/L {rows[-1][2]:.3f} tactical/L {rows[-1][3]:.3f}", flush=True)
    a = np.array(rows)
    for name, fn in (("median", np.nanmedian), ("min", np.nanmin), ("max", np.nanmax)):
        print(name, np.round(fn(a, axis=0), 3))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "../shared/data/kvlcc2_hsva"))
