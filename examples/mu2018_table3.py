"""Mu et al. 2018, Table 3 (PID 37.98, PD 38.6): which readings give these numbers and their
order (docs/papers.md, "Mu et al. 2018, Table 3"). About 20 s.

Run: ``.venv/bin/python examples/mu2018_table3.py [MODEL] [--seeds N]`` (MODEL default
``examples/lanxin.json``: Nomoto T 0.332 s, K 0.707 1/s, the identified servo with its 1 s dead
time, +-35 deg). Printed:

1. the documented single-realisation reading (what ``usvid simulate course-keeping`` prints);
2. the integral term in calm water: ITAE_PID - ITAE_PD over the horizon, its benefit B(H) (the
   bound on any seed-averaged gain, :mod:`usvid.control.itae_reading`), the largest rudder angle
   it adds, the heading offset it leaves;
3. seed averages over N realisations (common random numbers) on a grid of noise intensity and
   horizon: mean PID and PD ITAE, E[PID - PD] with its standard error, the share of
   realisations with PID < PD and with PD - PID >= 0.62 (the paper's gap), for the readings
   whose means are within 10 % of the paper's; the smallest E[PID - PD] of the grid; the same
   with the ITAE of the course-keeping phase only;
4. the arithmetic that excludes an ITAE in degrees;
5. two other readings, the printed "K = 0.332, T = 0.707" and the integral as a sum of samples
   without dt (ki acting as 0.00095 / 0.02 s = 0.0475 1/s): their calm ITAEs, and the points of
   the grid (200 realisations each) where both means are within 10 % of Table 3.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from usvid.control.itae_reading import TABLE3_ITAE, integral_effect, paired_itae
from usvid.io.modelfile import load_model
from usvid.models import VesselModel
from usvid.sim import run_course

HERE = Path(__file__).resolve().parent
#: The documented reading: rudder-equivalent disturbance std [deg], horizon [s], realisation.
READING = {"noise_deg": 0.75, "t_end": 50.0, "seed": 12}
#: Grid of the seed averages: noise std [deg] x horizon [s].
NOISE_DEG = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0)
HORIZONS = (20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0)
GAP = TABLE3_ITAE["pd"] - TABLE3_ITAE["pid"]


def within(pid: float, pd: float, tol: float = 0.10) -> bool:
    """Both within ``tol`` of Table 3."""
    return abs(pid / TABLE3_ITAE["pid"] - 1) < tol and abs(pd / TABLE3_ITAE["pd"] - 1) < tol


def main(model_path: Path, n_seeds: int) -> None:
    model = load_model(model_path)
    print(f"model {model_path.name} ({model.kind}); Table 3: PID {TABLE3_ITAE['pid']}, "
          f"PD {TABLE3_ITAE['pd']}")

    # 1. the documented reading, exactly as the CLI runs it
    r = {c: run_course(model, controller=c, **READING)[1]["itae"] for c in ("pid", "pd")}
    print(f"\n1. noise {READING['noise_deg']:g} deg, horizon {READING['t_end']:g} s, seed "
          f"{READING['seed']}: PID {r['pid']:.2f} ({100 * (r['pid'] / 37.98 - 1):+.1f} %), "
          f"PD {r['pd']:.2f} ({100 * (r['pd'] / 38.6 - 1):+.1f} %), PD - PID "
          f"{r['pd'] - r['pid']:.2f}")

    # 2. calm water
    hs = np.array([20.0, 30.0, 50.0, 60.0, 100.0])
    ie = integral_effect(model, hs)
    print(f"\n2. calm: largest rudder added by the integral term <= "
          f"{math.degrees(ie.max_integral_rudder):.2f} deg; PID - PD smallest "
          f"{ie.min_difference:+.3f} at H = {ie.t_min_difference:.1f} s")
    for h, d, b, o in zip(hs, ie.difference, ie.benefit, ie.offset, strict=True):
        print(f"   H {h:5.0f} s: PID - PD {d:+8.3f}, benefit B(H) {b:.3f}, PID heading "
              f"offset {math.degrees(o):+.3f} deg")

    # 3. seed averages
    seeds = np.arange(1, n_seeds + 1)
    print(f"\n3. {n_seeds} realisations each (readings with both means within 10 %):")
    print("   noise deg  H s   mean PID  mean PD   E[PID-PD] +- se   P(PID<PD)  P(gap>=0.62)")
    calm = integral_effect(model, np.array(HORIZONS))
    lowest = (math.inf, 0.0, 0.0)
    for nd in NOISE_DEG:
        p = paired_itae(model, noise_deg=nd, seeds=seeds, horizons=HORIZONS)
        for j, h in enumerate(HORIZONS):
            a, b = p.pid[:, j], p.pd[:, j]
            d = a - b
            lowest = min(lowest, (float(d.mean()), nd, h))
            if not within(a.mean(), b.mean()):
                continue
            print(f"   {nd:8.2f} {h:5.0f} {a.mean():9.2f} {b.mean():8.2f}   {d.mean():+7.3f} +- "
                  f"{d.std(ddof=1) / math.sqrt(d.size):.3f}   {np.mean(d < 0):9.3f}  "
                  f"{np.mean(-d >= GAP):12.3f}   (B = {calm.benefit[j]:.3f})")
    print(f"   smallest E[PID - PD] on the whole grid: {lowest[0]:+.3f} ({lowest[1]:g} deg, "
          f"{lowest[2]:g} s)")
    print("   course-keeping phase only (from the first error below 0.5 deg, time reset), "
          "readings with both means within 10 %:")
    for nd in NOISE_DEG:
        p = paired_itae(model, noise_deg=nd, seeds=seeds, horizons=HORIZONS,
                        from_arrival_deg=0.5)
        for j, h in enumerate(HORIZONS):
            a, b = p.pid[:, j], p.pd[:, j]
            if within(a.mean(), b.mean()):
                print(f"   {nd:8.2f} {h:5.0f} {a.mean():9.2f} {b.mean():8.2f}   "
                      f"{np.mean(a - b):+7.3f}   P(PID<PD) {np.mean(a < b):.3f}")

    # 4. degrees
    delay = float(getattr(model.servo, "delay", 0.0))
    print(f"\n4. in degrees: the error is 100 deg during the servo's dead time ({delay:g} s), "
          f"so ITAE >= 100 * {delay:g}^2 / 2 = {100 * delay**2 / 2:.0f} deg s^2 "
          f"(> 1.1 * 38.6 = 42.5)")

    # 5. other readings: calm figures, then the grid (200 realisations) for means in the band
    readings = {"ki 0.0475 1/s (sum of samples)": (model, (0.7, 0.00095 / 0.02, 1.0))}
    if model.kind == "nomoto1":
        swapped = VesselModel(model.dynamics.replace(K=model.dynamics.T, T=model.dynamics.K),
                              model.servo, model.vessel)
        readings["K 0.332, T 0.707 (as printed)"] = (swapped, (0.7, 0.00095, 1.0))
    print("\n5. other readings")
    for label, (m, gains) in readings.items():
        p = paired_itae(m, noise_deg=0.0, seeds=[1], horizons=[20.0, 30.0, 60.0], gains=gains)
        print(f"   {label}: calm PID " + ", ".join(f"{v:.2f}" for v in p.pid[0]) + "; PD "
              + ", ".join(f"{v:.2f}" for v in p.pd[0]) + " (20, 30, 60 s)")
        band = []
        for nd in NOISE_DEG:
            q = paired_itae(m, noise_deg=nd, seeds=np.arange(1, 201), horizons=HORIZONS,
                            gains=gains)
            band += [(nd, h) for j, h in enumerate(HORIZONS)
                     if within(q.pid[:, j].mean(), q.pd[:, j].mean())]
        print(f"   {label}: grid points with both means within 10 %: {band or 'none'}")

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model", nargs="?", type=Path, default=HERE / "lanxin.json")
    ap.add_argument("--seeds", type=int, default=1000)
    args = ap.parse_args()
    main(args.model, args.seeds)
