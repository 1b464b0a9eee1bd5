"""State estimation benchmark: EKF + RTS smoother over a one-hour 50 Hz log (180,000 rows).

Data: the Lanxin 3-DOF model (``examples/lanxin_threedof.json``) steering a continuous 20/20
zig-zag for 3600 s, seen through virtual sensors without time-stamp jitter (so the 10 Hz GNSS
stamps fall on the 50 Hz heading/gyro rows: 180,001 rows): GNSS positions 10 Hz, 0.05 m white
noise; heading 50 Hz, 0.3 deg; gyro 50 Hz, 0.2 deg/s.

Timed after a warm-up call on a short slice (numba compilation or cache loading excluded):
``estimate_states`` with default settings (noise levels from the data, process noise by maximum
likelihood on at most 10,000 measured rows: 4 blocks of 2,500), and once with the process noise
given (filter and smoother only). Printed: wall and CPU time of each, the filter + smoother part,
peak memory of Python/numpy allocations (tracemalloc), the process max RSS (the simulation
included), and the RMS error of u, v, r against the simulation truth.
"""

from __future__ import annotations

import math
import resource
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

from usvid.io.modelfile import load_model
from usvid.prep.state_estimation import estimate_states
from usvid.sim import Turning, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial

T_END = 3600.0
MODEL = Path(__file__).resolve().parents[1] / "examples" / "lanxin_threedof.json"


def main() -> int:
    model = load_model(MODEL)
    u_ss = float(simulate(model, Turning(0.0), t_end=60.0).channels["u"][0, -1])
    amp = math.radians(20.0)
    res = simulate(model, ZigZag(amp, amp, t_start=5.0), t_end=T_END, dt=0.02, u0=u_ss)
    sensors = SensorModel(gps_rate_hz=10.0, gps_sigma_m=0.05, heading_rate_hz=50.0,
                          heading_sigma_deg=0.3, gyro_rate_hz=50.0, gyro_sigma_deg_s=0.2,
                          jitter_s=0.0)
    trial = virtual_trial(res, sensors, seed=1, name="one_hour_zigzag")
    trial = trial.with_data(trial.data.drop(columns=["u", "v", "U"]))
    print(f"rows: {len(trial)}, duration {trial.duration:.0f} s, channels used: x, y, psi, r")
    estimate_states(trial.slice_time(0.0, 60.0))  # compile / load the numba cache

    tracemalloc.start()
    w0, c0 = time.perf_counter(), time.process_time()
    est = estimate_states(trial)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    tune = est.info["tuning"]
    print(f"estimate_states (defaults): {wall:.2f} s wall, {cpu:.2f} s CPU; filter + smoother "
          f"{est.info['time_s']['filter_smoother']:.2f} s; likelihood search "
          f"{tune['evaluations']} forward passes on {tune['rows']} rows")
    print(f"peak traced memory: {peak / 2**20:.0f} MiB")

    w0, c0 = time.perf_counter(), time.process_time()
    estimate_states(trial, q_u=est.q["q_u"], q_v=est.q["q_v"], q_r=est.q["q_r"])
    print(f"estimate_states (q given, no search): {time.perf_counter() - w0:.2f} s wall, "
          f"{time.process_time() - c0:.2f} s CPU")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"process max RSS: {rss:.0f} MiB")

    sel = (est.t > 5.0) & (est.t < est.t[-1] - 5.0)
    for name in ("u", "v", "r"):
        truth = np.interp(est.t, res.t, res.channels[name][0])
        rms = float(np.sqrt(np.mean((est[name] - truth)[sel] ** 2)))
        unit = "rad/s" if name == "r" else "m/s"
        print(f"RMS error {name}: {rms:.4g} {unit}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
