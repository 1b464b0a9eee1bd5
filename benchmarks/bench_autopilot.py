"""Autopilot robustness benchmark: the pole-placement design for the Lanxin USV (Mu et al.
2018, ``examples/lanxin.json``) evaluated over 1,000 samples of its parameter uncertainty
(10 % relative on K and T: the example file has no standard errors).

One batch of 1,000 lanes of the integration core: the 0 -> 100 deg course change over a
100 s horizon at dt = 0.02 s (5,000 RK4 steps each, second-order servo with 1 s dead time,
disturbance std 1 deg, seed 1), plus the gain and phase margins of the 1,000 linearised loops.
Timed after a warm-up call (numba compilation or cache loading excluded). The target is
< 10 s on 2 cores. Also timed: the two designs of ``usvid autopilot`` without robustness.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numba

from usvid.control import design_autopilot, robustness
from usvid.io.modelfile import load_model

N = int(os.environ.get("USVID_BENCH_SAMPLES", "1000"))
MODEL = Path(__file__).resolve().parents[1] / "examples" / "lanxin.json"


def main() -> None:
    model = load_model(MODEL)
    pp = design_autopilot(model, samples=0)
    robustness(model, pp.gains, samples=8)  # warm-up
    w0, c0 = time.perf_counter(), time.process_time()
    r = robustness(model, pp.gains, samples=N)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    print(f"bench_autopilot: robustness of kp {pp.gains.kp:.4g}, kd {pp.gains.kd:.4g} over {N} "
          f"parameter samples, 100 s horizon, numba threads {numba.get_num_threads()}")
    print(f"  wall {wall:.2f} s, CPU {cpu:.2f} s (target < 10 s wall on 2 cores)")
    print(f"  ITAE median {r.itae_median:.1f}, worst {r.itae_worst:.1f} rad s^2; worst overshoot "
          f"{r.overshoot_worst_deg:.2f} deg; min margins {r.gain_margin_min_db:.2f} dB, "
          f"{r.phase_margin_min_deg:.1f} deg")
    for method in ("pole-placement", "itae"):
        w0 = time.perf_counter()
        d = design_autopilot(model, method=method, samples=0)
        print(f"  design {method}: {time.perf_counter() - w0:.2f} s wall, ITAE "
              f"{d.step['itae']:.1f} vs paper gains {d.reference['step']['itae']:.1f}")


if __name__ == "__main__":
    main()
