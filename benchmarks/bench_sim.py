"""Batch simulator benchmark: 10,000 zig-zag 10/10 runs of the Lanxin 3-DOF model (Mu et al. 2018).

Model: Mu et al. 2018 eq. 37 (``mu2018_threedof``, x_l = 3.5 m, thrust holding 10 kn = 5.144 m/s)
with the identified second-order servo 1.95/(s^2 + 2.38125 s + 1.95) e^{-s} (+-35 deg);
100 s at dt = 0.02 s (5,000 RK4 steps per run). Timed after a warm-up call, so numba
compilation (or cache loading) is excluded. Heading is kept every 10 steps (0.2 s); the
overshoots come from the kernel's online zig-zag tracker.

Reference: the same model and logic run once through ``scipy.integrate.solve_ivp`` (RK45,
rtol 1e-8), with the switches located as events and the 1 s servo dead time applied from the
switch history.

Printed: wall and CPU time, numba threads, load average, per-run times and their ratio, peak
memory (tracemalloc peak of Python/numpy allocations during the batch, and the process max RSS);
then a table of ns CPU per RK4 step per model kind for the SIMD kernel and for the per-lane path
(``core.SIMD = False``: every step integrated lane by lane, the reference; its right-hand side
is called out of line), with their ratio and the ratio to solve_ivp; then the 3-DOF zig-zag in
calm water and with a constant wind and current (:data:`WIND`: the wind loads of the apparent wind
evaluated every load interval, 0.1 s by default, and extrapolated to each RK4 step, on the vector
step's wind variant), recording the
heading only and recording x and y too, the minimum of three runs each, interleaved, with the
wind/calm ratios (``--wind``: only that table; ``USVID_BENCH_REPEATS`` its repeats). The
machine may be shared: CPU time per step is the figure to compare; wall time depends on the
load.
"""

from __future__ import annotations

import math
import os
import resource
import sys
import time
import tracemalloc

import numba
import numpy as np
from scipy.integrate import solve_ivp

from usvid.models import Nomoto1, VesselModel, mu2018_servo, mu2018_threedof
from usvid.sim import Environment, ZigZag, core, simulate
from usvid.trial import Vessel

B = int(os.environ.get("USVID_BENCH_RUNS", "10000"))
T_END, DT = 100.0, 0.02
AMP = math.radians(10.0)
U0 = 5.144
#: The wind-and-current row: a true wind of 8 m/s from 45 deg (north-east) and a current of
#: 0.5 m/s towards 90 deg (east), constant; the windage of a 7 m USV (A_T, A_L [m^2], assumed:
#: the Lanxin paper gives none), so Blendermann (1994), type speed boat.
WIND = Environment(wind_speed=8.0, wind_dir=math.radians(45.0), current_speed=0.5,
                   current_dir=math.radians(90.0))
WINDAGE = {"frontal_area": 2.0, "lateral_area": 5.0}


def _model(kind: str) -> VesselModel:
    dyn = mu2018_threedof(x_l=3.5) if kind == "threedof" else Nomoto1(K=0.2, T=5.0)
    return VesselModel(dyn, servo=mu2018_servo(),
                       vessel=Vessel(length=7.02, speed=U0, **WINDAGE))


def batch(kind: str = "threedof", runs: int = B, simd: bool = True,
          environment: Environment | None = None, channels: tuple[str, ...] = ("psi",)
          ) -> tuple[float, float, np.ndarray, int]:
    """``runs`` zig-zags of ``kind`` (in ``environment``, None: calm water) recording
    ``channels``; (wall [s], CPU [s], overshoots [deg], traced peak [B])."""
    core.SIMD = simd
    model = _model(kind)
    simulate(model, ZigZag(AMP, AMP), t_end=1.0, dt=DT, channels=channels,
             environment=environment)  # compile / load
    logic = ZigZag(np.full(runs, AMP), AMP)
    tracemalloc.start()
    w0, c0 = time.perf_counter(), time.process_time()
    res = simulate(model, logic, t_end=T_END, dt=DT, record_every=10, channels=channels,
                   environment=environment)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    core.SIMD = True
    return wall, cpu, np.degrees(res.zigzag_online["overshoot"]), peak


def reference() -> tuple[float, float]:
    """One run through solve_ivp; returns (wall time [s], first overshoot [deg])."""
    p = mu2018_threedof(x_l=3.5)
    s = mu2018_servo()
    T = p.d11 * U0
    wn, zeta, delay, lim = s.omega_n, s.zeta, s.delay, s.max_angle
    switches = [(0.0, AMP)]  # (time, command)

    def command(t: float) -> float:
        c = 0.0
        for ts, v in switches:
            if ts <= t:
                c = v
        return c

    def rhs(t, z):
        x, y, psi, u, v, r, d, dd = z
        dc = min(max(d, -lim), lim)
        tau_u, tau_r = T * math.cos(dc), p.x_l * T * math.sin(dc)
        return [u * math.cos(psi) - v * math.sin(psi), u * math.sin(psi) + v * math.cos(psi), r,
                (p.m22 * v * r - p.d11 * u + tau_u) / p.m11,
                (-p.m11 * u * r - p.d22 * v) / p.m22,
                ((p.m11 - p.m22) * u * v - p.d33 * r + tau_r) / p.m33,
                dd, wn * wn * (command(t - delay) - d) - 2 * zeta * wn * dd]

    z = np.array([0, 0, 0, U0, 0, 0, 0, 0], float)
    t0, cur, first_over, peak = 0.0, 1.0, math.nan, 0.0
    w0 = time.perf_counter()
    while t0 < T_END:
        c = cur

        def ev(t, z, c=c):
            return c * z[2] - AMP

        ev.terminal, ev.direction = True, 1
        sol = solve_ivp(rhs, (t0, T_END), z, events=ev, rtol=1e-8, atol=1e-10, dense_output=True)
        if len(switches) == 2:  # between 1st and 2nd reversal: the first overshoot
            tt = np.linspace(t0, sol.t[-1], 2000)
            peak = np.max(sol.sol(tt)[2])
            first_over = math.degrees(peak - AMP)
        if sol.status != 1:
            break
        t0, z = sol.t_events[0][0], sol.y_events[0][0]
        cur = -cur
        switches.append((t0, cur * AMP))
    return time.perf_counter() - w0, first_over


def main() -> None:
    steps = T_END / DT
    wall, cpu, over, peak = batch()
    ref_wall, ref_over = reference()
    per_run = wall / B
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"bench_sim: {B} zig-zag 10/10 runs, Lanxin 3-DOF + 2nd-order servo, "
          f"{T_END:.0f} s at dt={DT} s ({int(steps)} RK4 steps/run)")
    print(f"  numba threads: {numba.get_num_threads()}  (os.cpu_count() = {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f} before, machine shared)")
    print(f"  batch (SIMD kernel, compile excluded): wall {wall:.2f} s, CPU {cpu:.2f} s, "
          f"{per_run * 1e6:.0f} us/run, {cpu / (B * steps) * 1e9:.0f} ns CPU/step "
          "[target <= 0.7 s wall on 2 free cores]")
    print(f"  CPU time / {numba.get_num_threads()} threads = {cpu / numba.get_num_threads():.2f} s "
          "(the wall time on otherwise idle cores)")
    print(f"  solve_ivp RK45 (one run):        wall {ref_wall:.3f} s/run")
    print(f"  ratio solve_ivp / numba per run: {ref_wall / per_run:.0f}x")
    print(f"  first overshoot: numba {np.nanmean(over[:, 0]):.3f} deg, "
          f"solve_ivp {ref_over:.3f} deg")
    print(f"  peak memory: traced {peak / 2**20:.1f} MiB during the batch, "
          f"process max RSS {rss:.0f} MiB")
    print("  ns CPU per RK4 step (per run), SIMD kernel vs the per-lane path (core.SIMD = False, "
          "the reference, rhs out of line), same process:")
    print(f"    {'kind':10s} {'runs':>6s} {'SIMD wall':>10s} {'SIMD ns':>8s} {'per-lane ns':>12s} "
          f"{'speed-up':>9s} {'vs solve_ivp':>12s}  load")
    n = max(B // 4, 64)
    for kind in ("nomoto1", "threedof"):
        w1, c1, o1, _ = batch(kind, n, True)
        w2, c2, o2, _ = batch(kind, n, False)
        same = np.allclose(o1, o2, rtol=1e-9, atol=1e-12, equal_nan=True)
        print(f"    {kind:10s} {n:6d} {w1:9.2f}s {c1 / (n * steps) * 1e9:8.1f} "
              f"{c2 / (n * steps) * 1e9:12.1f} {c2 / c1:8.1f}x {ref_wall / (w1 / n):11.0f}x  "
              f"{os.getloadavg()[0]:.1f}{'' if same else '  (overshoots differ!)'}")
    sys.stdout.flush()
    wind_table(n, steps)


def wind_table(n: int, steps: float, repeats: int = 3) -> None:
    """ns CPU per lane-step of the threedof zig-zag in calm water and with wind and current
    (:data:`WIND`), SIMD kernel and per-lane path, interleaved in one process (calm, wind, calm,
    wind, ...); the minimum of ``repeats`` (the machine is shared: the least disturbed run is
    the closest to the cost), each with the load average when it was taken. Like for like: the
    same runs and manoeuvre recording the heading only (neither integrates x and y: nothing
    reads them), then recording x and y too (both integrate them)."""
    print(f"  threedof zig-zag 10/10, calm vs wind 8 m/s from 45 deg + current 0.5 m/s towards "
          f"90 deg, ns CPU per lane-step (min of {repeats}, interleaved), same process:")
    print(f"    {'case':28s} {'runs':>6s} {'SIMD ns':>8s} {'load':>5s} {'per-lane ns':>12s} "
          f"{'load':>5s} {'speed-up':>9s}")
    rows = (("calm", None, ("psi",)), ("wind + current", WIND, ("psi",)),
            ("calm, x y recorded", None, ("psi", "x", "y")),
            ("wind + current, x y recorded", WIND, ("psi", "x", "y")))
    best: dict[tuple[str, bool], tuple[float, float]] = {}
    for _ in range(repeats):
        for name, env, ch in rows:
            for simd in (True, False):
                _, c, _, _ = batch("threedof", n, simd, env, ch)
                key = (name, simd)
                v = c / (n * steps) * 1e9
                if v < best.get(key, (math.inf, 0.0))[0]:
                    best[key] = (v, os.getloadavg()[0])
    for name, _, _ in rows:
        (s_, ls), (p_, lp) = best[(name, True)], best[(name, False)]
        print(f"    {name:28s} {n:6d} {s_:8.1f} {ls:5.1f} {p_:12.1f} {lp:5.1f} {p_ / s_:8.1f}x")
    for a, b in ((1, 0), (3, 2)):
        wa, ca = best[(rows[a][0], True)][0], best[(rows[b][0], True)][0]
        print(f"    {rows[a][0]} / {rows[b][0]} (SIMD): {wa / ca:.2f}x [target <= 1.5x]")
    sys.stdout.flush()


if __name__ == "__main__":
    if "--wind" in sys.argv[1:]:  # only the calm vs wind-and-current table
        wind_table(max(B // 4, 64), T_END / DT, int(os.environ.get("USVID_BENCH_REPEATS", "3")))
    else:
        main()
