"""Steady force balances of the Dalian twin-thruster USV's sine and circle runs: what the sine
run can and cannot tell about the circle (README, twin-thruster USV).

Usage: ``python examples/usv_twin_balance.py DIR`` with DIR the folder of ``boat1_2_sin.xlsx``
and ``boat1_2_circle.xlsx``. Both logs are read with the shipped ``twin_thruster_xlsx`` spec
and put on a 0.1 s grid; the start from rest (first 15 s, 20 s for yaw) is left out.
Printed:

* **surge**: the least-squares constant c of ``U^2 = c (T_port + T_stbd)/thrust_full`` [m^2/s^2]
  per run, for the declared linear map (T proportional to the PWM level s) and for a quadratic
  map (T proportional to s|s|). A map that is right gives the same c in both runs (the
  resistance of the hull does not change between them).
* **yaw**: the steady yaw balance ``r U^k = g d + b S`` fitted on the sine run (moving means
  over 5 s, the commands 1 s earlier; d = s_port - s_stbd, S = s_port + s_stbd, r [rad/s],
  U [m/s]), for k = 0 (yaw damping independent of speed), 1 (the MMG form: the hull's
  linear damping N_r' r' (rho/2) L^2 d U^2 = N_r' (rho/2) L^3 d U r) and 2; its prediction of
  the circle run's mean yaw rate and diameter 2U/r after 60 s against the measured; and how far
  the relation fitted on one half of the sine run is off on the other half (mean error).
* **60 s windows**: what the issue's metric (heading RMS over 60 s of free run) allows at best
  for the first-order yaw model ``T dr/dt + r = (g d + b S + c) / U^k`` (k = 0, 1; commands 1 s
  earlier; c a constant yaw bias) fitted by least squares on the metric itself, that is on the
  heading errors of every 60 s window (starting every 5 s) of one run, each simulated from its
  measured initial yaw rate. Printed: the windows' RMS in that same run (in sample: median,
  range, share under 10 deg), the circle's first 60 s predicted by the sine-run fit, and the
  circle's first 60 s under the fit to the circle run's own windows.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

import usvid.io

H = 0.1  # grid step [s]


def grid(path: Path) -> dict[str, np.ndarray]:
    """The log on a 0.1 s grid: t [s from the first record], psi (unwrapped) [rad], U [m/s],
    PWM levels s_port, s_stbd (declared map: (pwm - 1500)/500 clipped to -1..1)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = usvid.io.read_trial(path, "twin_thruster_xlsx")
    t = tr.t - tr.t[0]
    tg = np.arange(0.0, t[-1], H)
    out = {"t": tg, "psi": np.interp(tg, t, np.unwrap(tr["psi"])), "U": np.interp(tg, t, tr["U"])}
    for side, ch in (("port", "pwm_port"), ("stbd", "pwm_stbd")):
        out[side] = np.clip((np.interp(tg, t, tr[ch]) - 1500.0) / 500.0, -1.0, 1.0)
    return out


def moving(x: np.ndarray, n: int) -> np.ndarray:
    return np.convolve(x, np.ones(n) / n, mode="same")


def surge_constant(g: dict[str, np.ndarray], k: float) -> float:
    """Least-squares c of U^2 = c (|s_p|^k sgn s_p + |s_s|^k sgn s_s) after the first 15 s."""
    m = g["t"] > 15.0
    T = sum(np.sign(g[s]) * np.abs(g[s]) ** k for s in ("port", "stbd"))[m]
    return float(T @ g["U"][m] ** 2 / (T @ T))


def yaw_terms(g: dict[str, np.ndarray]) -> tuple[np.ndarray, ...]:
    """(d, S, r, U): 5 s moving means, d and S 1 s earlier than r and U."""
    n, lag = int(round(5.0 / H)), int(round(1.0 / H))
    r = moving(np.gradient(g["psi"], H), n)
    U = moving(g["U"], n)
    d = moving(g["port"] - g["stbd"], n)
    S = moving(g["port"] + g["stbd"], n)
    d = np.r_[np.full(lag, d[0]), d[:-lag]]
    S = np.r_[np.full(lag, S[0]), S[:-lag]]
    return d, S, r, U


def main(folder: Path) -> None:
    sine, circle = grid(folder / "boat1_2_sin.xlsx"), grid(folder / "boat1_2_circle.xlsx")
    print("surge: U^2 = c (T_port + T_stbd)/thrust_full after the first 15 s")
    for k, name in ((1.0, "linear (declared)"), (2.0, "quadratic")):
        cs, cc = surge_constant(sine, k), surge_constant(circle, k)
        print(f"  {name:18s} c sine {cs:.3f}, circle {cc:.3f} m^2/s^2 (circle/sine {cc / cs:.3f})")
    d, S, r, U = yaw_terms(sine)
    t = sine["t"]
    use = (t > 20.0) & (t < t[-1] - 3.0)
    half = (t < 0.5 * t[-1])
    dc, Sc, rc, Uc = yaw_terms(circle)
    mc = circle["t"] > 60.0
    r_meas, U_meas = float(np.mean(rc[mc])), float(np.mean(Uc[mc]))
    print(f"yaw: circle after 60 s: mean d {np.mean(dc[mc]):.4f}, S {np.mean(Sc[mc]):.3f}, "
          f"U {U_meas:.3f} m/s, r {math.degrees(r_meas):.2f} deg/s, "
          f"2U/r {2 * U_meas / r_meas:.1f} m")
    for k in (0, 1, 2):
        A = np.column_stack([d, S])
        y = r * U ** k
        c, res, *_ = np.linalg.lstsq(A[use], y[use], rcond=None)
        rms = math.sqrt(float(res[0]) / use.sum())
        off = []
        for a, b in ((use & half, use & ~half), (use & ~half, use & half)):
            ch, *_ = np.linalg.lstsq(A[a], y[a], rcond=None)
            off.append(math.degrees(float(np.mean((A[b] @ ch) / U[b] ** k - r[b]))))
        rp = (c[0] * np.mean(dc[mc]) + c[1] * np.mean(Sc[mc])) / U_meas ** k
        print(f"  r U^{k} = {c[0]:.4f} d + {c[1]:.4f} S (sine fit rms {rms:.4f}; half 1 on "
              f"half 2 {off[0]:+.2f} deg/s, half 2 on half 1 {off[1]:+.2f}): circle r "
              f"{math.degrees(rp):.2f} deg/s, diameter {2 * U_meas / rp:.1f} m")


WIN, EVERY, LAG = 60.0, 5.0, 1.0  # window length, window spacing, command lag [s]


def window_errors(p: np.ndarray, g: dict[str, np.ndarray], starts: np.ndarray, k: int
                  ) -> np.ndarray:
    """Heading errors [rad], shape (steps, windows), of ``T dr/dt + r = (g d + b S + c) / U^k``
    (p = T [s], g, b, c [rad/s m^k/s^k]) simulated from each window's start (forward Euler at the
    grid step; all windows as one batch through ``lfilter``), against the measured heading."""
    T, gd, gs, c = p
    n, lag = int(round(WIN / H)), int(round(LAG / H))
    d, S = g["port"] - g["stbd"], g["port"] + g["stbd"]
    r_meas = moving(np.gradient(g["psi"], H), 5)
    j = starts[None, :] + np.arange(n)[:, None]  # grid indices, (steps, windows)
    jl = np.maximum(j - lag, 0)
    drive = (gd * d[jl] + gs * S[jl] + c) / np.maximum(g["U"][j], 0.05) ** k
    a = H / T  # r[i+1] = (1 - a) r[i] + a drive[i]
    r = lfilter([0.0, a], [1.0, a - 1.0], drive, axis=0,
                zi=((1.0 - a) * r_meas[starts])[None, :])[0]
    r[0] = r_meas[starts]
    psi = H * (np.cumsum(r, axis=0) - r)
    return psi - (g["psi"][j] - g["psi"][starts][None, :])


def fit_windows(g: dict[str, np.ndarray], k: int) -> tuple[np.ndarray, np.ndarray]:
    """(parameters, RMS per window [deg]): the fit on every window of run ``g``, best of three
    starting time constants."""
    starts = np.arange(0, len(g["t"]) - int(round(WIN / H)), int(round(EVERY / H)))
    best = min((least_squares(lambda p: window_errors(p, g, starts, k).ravel(),
                              [T0, 0.1, 0.0, 0.0], bounds=([0.05, -5, -5, -1], [60, 5, 5, 1]))
                for T0 in (0.5, 2.0, 5.0)), key=lambda r: r.cost)
    e = window_errors(best.x, g, starts, k)
    return best.x, np.degrees(np.sqrt(np.mean(e ** 2, axis=0)))


def first_window(p: np.ndarray, g: dict[str, np.ndarray], k: int) -> float:
    """Heading RMS [deg] over the first 60 s of run ``g`` under parameters ``p``."""
    return math.degrees(float(np.sqrt(np.mean(window_errors(p, g, np.array([0]), k) ** 2))))


def windows(folder: Path) -> None:
    sine, circle = grid(folder / "boat1_2_sin.xlsx"), grid(folder / "boat1_2_circle.xlsx")
    print(f"{WIN:.0f} s windows every {EVERY:.0f} s, T dr/dt + r = (g d + b S + c)/U^k fitted on "
          "the windows' heading errors")
    for k in (0, 1):
        ps, rs = fit_windows(sine, k)
        pc, rc = fit_windows(circle, k)
        print(f"  k={k}: sine fit T {ps[0]:.2f} s: its own windows median {np.median(rs):.1f} deg "
              f"({rs.min():.1f}-{rs.max():.1f}, {np.mean(rs < 10):.0%} under 10); circle's first "
              f"60 s {first_window(ps, circle, k):.1f} deg")
        print(f"       circle fit T {pc[0]:.2f} s: its own windows median {np.median(rc):.1f} deg "
              f"({rc.min():.1f}-{rc.max():.1f}, {np.mean(rc < 10):.0%} under 10); its first 60 s "
              f"{rc[0]:.1f} deg")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
    windows(Path(sys.argv[1]))
