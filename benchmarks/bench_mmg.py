"""The MMG kind against shipmmg, and its kernel cost against the 3-DOF kind's (``make bench``).

Model: the published KVLCC2 MMG model (Yasukawa & Yoshimura 2015, the paper's particulars) with
the wake and x_G that shipmmg implements (``wake_model='gaussian'``, C_w = 4, x_G = 0; the
mapping is in tests/test_mmg.py), approach 1.179 m/s, the shaft speed holding it.

* **One 35 deg turning, in process**: the rudder held at 35 deg from t = 0 in both (shipmmg
  integrates the rudder through a cubic spline of its samples, which would round a ramp's
  corner: with the rudder held, both integrate the same equations), 250 s. shipmmg:
  ``simulate_mmg_3dof`` (solve_ivp RK45, rtol 1e-9, atol 1e-10, the accuracy of the tests'
  cross-check). usvid: ``simulate`` (fixed-step RK4) at the largest step of :data:`DTS` whose
  tactical diameter (the transfer at 180 deg heading change, linear interpolation between
  samples) agrees with shipmmg's to 1e-5 relative; the whole call timed (packing, the core,
  the result), compilation excluded (warm-up call).
* **One 20/20 zig-zag, in process**: shipmmg's ``zigzag_test_mmg_3dof`` (its defaults: RK45 at
  rtol 1e-3, rudder rate 15.8 deg/s, samples every 0.01 s) against usvid ``simulate`` with an
  ideal servo at 15.8 deg/s (event-located switching, the tests' cross-check within 1 %),
  100 s, dt 0.01 s (the same sample grid); the overshoots of both printed.
* **Batch**: 10,000 zig-zags 10/10 (``USVID_BENCH_RUNS``) of the MMG kind and of the 3-DOF kind
  (:mod:`bench_sim`'s Lanxin model), the same second-order servo with dead time, 100 s at
  dt 0.02 s, heading kept every 10 steps; ns CPU per lane-step, the minimum of two interleaved
  runs each.

Each timing is the minimum of several repeats (the machine may be shared: the load average is
printed with every number). Nothing here asserts timings.
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from usvid.models import VesselModel, mu2018_servo, mu2018_threedof
from usvid.models import mmg as _mmg
from usvid.models.kinds.mmg import equilibrium_rps, from_physics
from usvid.models.servo import IdealServo
from usvid.sim import Turning, ZigZag, simulate
from usvid.trial import Vessel

U0 = 1.179  # approach speed of Y&Y 2015's KVLCC2 model [m/s]
RUDDER_RATE = math.radians(15.8)
T_TURN = 250.0
#: usvid's candidate steps for the turning [s], largest first.
DTS = (0.5, 0.4, 0.25, 0.2, 0.1, 0.05, 0.02)
TD_RTOL = 1e-5
B = int(os.environ.get("USVID_BENCH_RUNS", "10000"))


def _load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def _best(fn: Any, repeats: int) -> tuple[float, Any]:
    """(min CPU time [s] of ``repeats`` calls, the last result)."""
    best, out = math.inf, None
    for _ in range(repeats):
        c0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - c0)
    return best, out


def _params() -> Any:
    return _mmg.kvlcc2("paper").replace(wake_model="gaussian", C_w=4.0, x_G=0.0)


def _shipmmg(p: Any) -> tuple[Any, Any, Any]:
    import shipmmg.mmg_3dof as sm

    # the one mapping of usvid's MMG parameters to shipmmg's (shared with the tests)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from shipmmg_map import shipmmg_params

    return (sm, *shipmmg_params(sm, p))


def _tactical(x: np.ndarray, y: np.ndarray, psi: np.ndarray) -> float:
    """Tactical diameter [m]: y at 180 deg heading change (linear between samples)."""
    i = int(np.argmax(psi >= math.pi))
    if i <= 0:
        return math.nan
    return float(np.interp(math.pi, psi[i - 1:i + 1], y[i - 1:i + 1]))


def turning(repeats: int = 5) -> None:
    p = _params()
    n = equilibrium_rps(p, U0)
    sm, basic, man = _shipmmg(p)
    d35 = math.radians(35.0)
    t = np.arange(0.0, T_TURN + 1e-9, 0.01)

    def ship() -> float:
        sol = sm.simulate_mmg_3dof(basic, man, list(t), list(np.full(t.size, d35)),
                                   list(np.full(t.size, n)), u0=U0, ρ=p.rho, rtol=1e-9,
                                   atol=1e-10)
        ys = sol.sol(t)
        return _tactical(ys[3], ys[4], ys[5])

    model = VesselModel(from_physics(p, n=n), vessel=Vessel(length=p.L, speed=U0),
                        servo=IdealServo(max_angle=d35, max_rate=RUDDER_RATE))
    logic = Turning(delta=d35)

    def mine(dt: float) -> float:
        r = simulate(model, logic, t_end=T_TURN, dt=dt, u0=U0, initial={"delta": d35},
                     channels=("x", "y", "psi"))
        return _tactical(r["x"][0], r["y"][0], r["psi"][0])

    cs, td_s = _best(ship, repeats)
    mine(0.1)  # compile / load
    chosen = None
    for dt in DTS:
        td = mine(dt)
        if abs(td - td_s) <= TD_RTOL * abs(td_s):
            chosen = dt
            break
    print(f"  one KVLCC2 35 deg turning, rudder held, {T_TURN:.0f} s, CPU in process "
          f"(min of {repeats}):")
    print(f"    shipmmg solve_ivp rtol 1e-9: {cs * 1e3:8.2f} ms  tactical diameter "
          f"{td_s:.6f} m  {_load()}")
    for dt in ([chosen] if chosen is not None else []) + [0.02]:
        cm, td = _best(lambda dt=dt: mine(dt), repeats)
        rel = abs(td - td_s) / abs(td_s)
        tag = " (the largest of DTS within 1e-5)" if dt == chosen else ""
        print(f"    usvid RK4 dt {dt:g} s{tag}: {cm * 1e3:8.2f} ms  tactical diameter {td:.6f} m "
              f"(rel. diff {rel:.1e}), {cs / cm:.2f}x shipmmg's speed  {_load()}")
        if dt == chosen == 0.02:
            break
    if chosen is None:
        print(f"    no step of {DTS} gives the tactical diameter within {TD_RTOL:g}")
    sys.stdout.flush()


def zigzag(repeats: int = 3) -> None:
    p = _params()
    n = equilibrium_rps(p, U0)
    sm, basic, man = _shipmmg(p)
    amp = math.radians(20.0)
    dt, t_end = 0.01, 100.0
    t = np.arange(0.0, t_end + 1e-9, dt)
    steps = t.size - 1

    def ship() -> tuple[float, float]:
        out = sm.zigzag_test_mmg_3dof(basic, man, amp, amp, list(t), list(np.full(t.size, n)),
                                      δ_rad_rate=RUDDER_RATE, u0=U0, ρ=p.rho)
        return _overshoots(np.asarray(out[6]))

    model = VesselModel(from_physics(p, n=n), vessel=Vessel(length=p.L, speed=U0),
                        servo=IdealServo(max_angle=math.radians(35.0), max_rate=RUDDER_RATE))
    logic = ZigZag(amp, amp)

    def mine() -> tuple[float, float]:
        r = simulate(model, logic, t_end=t_end, dt=dt, u0=U0, channels=("psi",))
        return _overshoots(r["psi"][0])

    mine()  # compile / load
    cs, os_ = _best(ship, repeats)
    cm, om = _best(mine, repeats)
    print(f"  one KVLCC2 20/20 zig-zag, {t_end:.0f} s, {steps} samples of {dt} s, CPU in process "
          f"(min of {repeats}):")
    print(f"    shipmmg (its defaults, rtol 1e-3): {cs * 1e3:8.2f} ms, "
          f"{cs / steps * 1e6:6.2f} us/step, overshoots {os_[0]:.3f}, {os_[1]:.3f} deg  {_load()}")
    print(f"    usvid RK4 dt {dt} s:              {cm * 1e3:8.2f} ms, "
          f"{cm / steps * 1e6:6.2f} us/step, overshoots {om[0]:.3f}, {om[1]:.3f} deg, "
          f"{cs / cm:.2f}x shipmmg's speed  {_load()}")
    sys.stdout.flush()


def _overshoots(psi_rad: np.ndarray) -> tuple[float, float]:
    psi = np.degrees(np.asarray(psi_rad))
    i1 = int(np.argmax(psi >= 20.0))
    i2 = i1 + int(np.argmax(psi[i1:] <= -20.0))
    i3 = i2 + int(np.argmax(psi[i2:] >= 20.0))
    return float(psi[i1:i2].max() - 20.0), float(-psi[i2:i3].min() - 20.0)


def _batch_model(kind: str) -> VesselModel:
    if kind == "threedof":
        return VesselModel(mu2018_threedof(x_l=3.5), servo=mu2018_servo(),
                           vessel=Vessel(length=7.02, speed=5.144))
    p = _params()
    return VesselModel(from_physics(p, n=equilibrium_rps(p, U0)), servo=mu2018_servo(),
                       vessel=Vessel(length=p.L, speed=U0))


def batch(runs: int = B, repeats: int = 2) -> None:
    t_end, dt = 100.0, 0.02
    amp = math.radians(10.0)
    steps = t_end / dt
    models = {k: _batch_model(k) for k in ("threedof", "mmg")}
    for m in models.values():
        simulate(m, ZigZag(amp, amp), t_end=1.0, dt=dt, channels=("psi",))  # compile / load
    best: dict[str, float] = {}
    for _ in range(repeats):
        for k, m in models.items():
            logic = ZigZag(np.full(runs, amp), amp)
            c, _ = _best(lambda m=m, logic=logic: simulate(m, logic, t_end=t_end, dt=dt,
                                                           record_every=10, channels=("psi",)),
                         1)
            best[k] = min(best.get(k, math.inf), c / (runs * steps) * 1e9)
    print(f"  batch of {runs} zig-zags 10/10, {t_end:.0f} s at dt {dt} s, second-order servo with "
          f"dead time, ns CPU per lane-step (min of {repeats}, interleaved):")
    print(f"    threedof {best['threedof']:7.1f} ns   mmg {best['mmg']:7.1f} ns   "
          f"mmg / threedof {best['mmg'] / best['threedof']:.2f}x [target <= 3x]  {_load()}")
    sys.stdout.flush()


def main() -> None:
    print(f"bench_mmg: the MMG kind (KVLCC2, Y&Y 2015) vs shipmmg and vs the 3-DOF kind "
          f"(machine may be shared: {_load()} at start)")
    try:
        import shipmmg  # noqa: F401
    except ImportError:
        print("  shipmmg not installed (pip install -e '.[test]'): the peer rows are skipped")
    else:
        turning()
        zigzag()
    batch()


if __name__ == "__main__":
    main()
