"""PID heading autopilot by pole placement for the Nomoto form (Fossen 2021, Sec. 15.3).

The yaw dynamics in Nomoto form ``m r' + d r = delta`` (m = T/K [s^2], d = 1/K [s]) with the
PID ``delta = kp e + ki int(e) - kd r`` (e = psi_d - psi, :class:`usvid.sim.PID`) close the loop

    m psi'' + (d + kd) psi' + kp psi = kp psi_d     (PD part, ki small)

whose poles are placed at the natural frequency omega_n and relative damping zeta:

    kp = m omega_n^2,     kd = 2 zeta omega_n m - d,     ki = (omega_n / 10) kp

(the integral pole a decade below omega_n), with omega_n from the closed-loop bandwidth
omega_b [rad/s] (the frequency where the closed-loop gain is -3 dB):

    omega_n = omega_b / sqrt(1 - 2 zeta^2 + sqrt(4 zeta^4 - 4 zeta^2 + 2))

Fossen 2021 ("Handbook of Marine Craft Hydrodynamics and Motion Control", 2nd ed., Sec. 15.3,
PID pole placement; the same rules as Fossen 2011). A course-unstable vessel (d < 0) is
handled by the same formulas (kd then also cancels the negative damping).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from usvid.control.linear import loop_margins, with_servo
from usvid.errors import UsvidError


def natural_frequency(bandwidth: float, zeta: float = 1.0) -> float:
    """omega_n [rad/s] of the closed loop whose bandwidth is ``bandwidth`` [rad/s] at relative
    damping ``zeta`` (Fossen 2021, Sec. 15.3):
    ``omega_n = omega_b / sqrt(1 - 2 zeta^2 + sqrt(4 zeta^4 - 4 zeta^2 + 2))``."""
    if not (math.isfinite(bandwidth) and bandwidth > 0):
        raise UsvidError(f"--bandwidth must be > 0 rad/s (got {bandwidth!r})")
    if not (math.isfinite(zeta) and zeta > 0):
        raise UsvidError(f"zeta must be > 0 (got {zeta!r})")
    z2 = zeta * zeta
    return bandwidth / math.sqrt(1.0 - 2.0 * z2 + math.sqrt(4.0 * z2 * z2 - 4.0 * z2 + 2.0))


def pole_placement(K: Any, T: Any, bandwidth: float, *, zeta: float = 1.0,
                   integral: bool = True) -> tuple[float, float, float]:
    """Fossen's PID gains (kp [rad/rad], ki [1/s], kd [s]) for ``T r' + r = K delta`` (K [1/s],
    T [s]) at the closed-loop bandwidth ``bandwidth`` [rad/s] and damping ``zeta``
    (Fossen 2021, Sec. 15.3; module docstring): m = T/K, d = 1/K,
    ``kp = m omega_n^2``, ``kd = 2 zeta omega_n m - d``, ``ki = omega_n kp / 10`` (0 for a PD,
    ``integral=False``). kd < 0 (a bandwidth below the vessel's own damping) is returned as is:
    the caller decides (:func:`usvid.control.design.design_autopilot` clips it to 0)."""
    K, T = float(K), float(T)
    if not (math.isfinite(K) and K != 0 and math.isfinite(T) and T != 0):
        raise UsvidError(f"pole placement needs a finite, non-zero Nomoto K and T "
                         f"(got K={K!r} 1/s, T={T!r} s)")
    wn = natural_frequency(bandwidth, zeta)
    m, d = T / K, 1.0 / K
    kp = m * wn * wn
    kd = 2.0 * zeta * wn * m - d
    ki = wn / 10.0 * kp if integral else 0.0
    return float(kp), float(ki), float(kd)


def default_bandwidth(eq: Any, servo: Any, *, zeta: float = 0.8, integral: bool = False,
                      min_gain_margin_db: float = 6.0, min_phase_margin_deg: float = 45.0,
                      dt: float = 0.02) -> float:
    """The largest closed-loop bandwidth [rad/s] whose pole-placement gains keep the classical
    margins (gain margin >= 6 dB, phase margin >= 45 deg; Ogata 2010, Sec. 7-6) on the loop
    linearised about straight running with the servo and its exact dead time
    (:func:`usvid.control.linear.loop_margins`): 400 bandwidths from 1e-3 / T_e to 10 / T_e
    (T_e the time constant of ``eq`` with the servo lag) evaluated as one batch. Raises
    :class:`UsvidError` when none qualifies."""
    K, T = with_servo(eq, servo)
    wbs = np.logspace(-3, 1, 400) / abs(T)
    G = np.array([pole_placement(K, T, wb, zeta=zeta, integral=integral) for wb in wbs])
    mg = loop_margins(eq, servo, G[:, 0], G[:, 1], np.maximum(G[:, 2], 0.0), dt=dt)
    ok = (mg.gain_margin_db >= min_gain_margin_db) & (mg.phase_margin_deg >= min_phase_margin_deg)
    if not np.any(ok):
        raise UsvidError("no closed-loop bandwidth keeps a 6 dB gain margin and a 45 deg phase "
                         "margin for this model; give --bandwidth")
    return float(wbs[np.nonzero(ok)[0][-1]])
