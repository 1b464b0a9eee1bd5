"""Benchmark: identify a Norrbin model by least squares + output error from a one-hour 50 Hz
virtual trial (180 000 samples). Target <= 5 s. Prints times and peak memory (not asserted).

Run: ``.venv/bin/python benchmarks/bench_identify_oe.py``
"""

from __future__ import annotations

import math
import resource
import time
import tracemalloc

import numpy as np

from usvid.identify.estimator import ModelEstimator
from usvid.models import Norrbin
from usvid.models.model import VesselModel
from usvid.models.servo import SecondOrderServo
from usvid.sim import Disturbance, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel


def main() -> None:
    truth = Norrbin(K=0.5, T=3.0, n1=1.0, n3=2.0, delta0=math.radians(0.5))
    model = VesselModel(truth, servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5),
                        vessel=Vessel(length=7.0, speed=3.0))
    t0 = time.perf_counter()
    res = simulate(model, ZigZag(delta_amp=math.radians(25), psi_switch=math.radians(15)),
                   t_end=3600.0, dt=0.02, disturbance=Disturbance(intensity=0.001, seed=1))
    trial = virtual_trial_uniform(res, SensorModel(), seed=2, rate_hz=50.0, name="hour")
    print(f"virtual trial: {len(trial)} samples at {trial.sample_rate:.0f} Hz "
          f"(generated in {time.perf_counter() - t0:.2f} s, not counted)")

    # warm-up on a short slice so numba compilation (cached on disk) is not counted
    ModelEstimator("norrbin", "oe").fit(trial.slice_time(0.0, 120.0))

    tracemalloc.start()
    t1 = time.perf_counter()
    est_ls = ModelEstimator("norrbin", "ls").fit(trial)
    t2 = time.perf_counter()
    est = ModelEstimator("norrbin", "oe").fit(trial)
    t3 = time.perf_counter()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    print(f"LS  : {t2 - t1:6.2f} s  params {fmt(est_ls.params_)}")
    print(f"LS+OE: {t3 - t2:6.2f} s  params {fmt(est.params_)}  (target <= 5 s)")
    print(f"     std errors {fmt(est.std_errors_)}")
    d = est.result_.diagnostics["oe"]
    print(f"     OE: {d['nfev']} simulations of all windows, {d['n_residuals']} residuals, "
          f"{d['message']}")
    print(f"peak traced Python/numpy memory {peak / 2**20:.1f} MiB, max RSS {rss:.0f} MiB")
    err = {k: (est.params_[k] / v - 1) * 100 for k, v in
           (("K", 0.5), ("T", 3.0), ("n3", 2.0))}
    print("errors vs truth [%]: " + ", ".join(f"{k} {v:+.2f}" for k, v in err.items()))


def fmt(p: dict) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in p.items())


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
