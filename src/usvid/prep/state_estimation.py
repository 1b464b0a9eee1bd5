"""State estimation: body-frame velocities and accelerations from noisy positions and heading.

Force-model regression (MMG, 3-DOF) needs the body-frame velocities u, v [m/s], r [rad/s] and their
time derivatives u', v' [m/s^2], r' [rad/s^2]. Differentiating GNSS positions numerically is too
noisy for the second derivative, so this module fits a kinematic process model to all the
measurements at once with an extended Kalman filter (Kalman 1960) and a Rauch-Tung-Striebel
fixed-interval smoother (Rauch, Tung & Striebel 1965), as Alexandersson et al. (2022) do for
the KVLCC2 free-running tests. The stage knows nothing of vessel models: the process model is
pure kinematics, so its output can be used to identify any model.

State (9): ``s = [x, y, psi, u, v, r, u', v', r']``, x, y [m, NED north/east], psi [rad, clockwise,
continuous (never wrapped)], u, v [m/s, body], r [rad/s], u', v' [m/s^2], r' [rad/s^2] (the time
derivatives of u, v, r, the quantities the equations of motion use; Fossen 2021, Handbook of
Marine Craft Hydrodynamics and Motion Control, ch. 2 and 6).

Continuous process model (planar kinematics of Fossen 2021, ch. 2, and white jerk)::

    x'   = u cos psi - v sin psi          u'' = w_u,  E[w_u(t) w_u(t+tau)] = q_u delta(tau)
    y'   = u sin psi + v cos psi          v'' = w_v,  q_v [m^2/s^5]
    psi' = r                              r'' = w_r,  q_r [rad^2/s^5]

The accelerations are a random walk (a "nearly constant acceleration", Wiener-process
acceleration model; Bar-Shalom, Li & Kirubarajan 2001, ch. 6), not a Singer (1970) first-order
Gauss-Markov acceleration: the Singer model's mean reversion with time constant tau biases a
sustained acceleration (the speed loss in a turn lasts tens of seconds) towards zero and adds a
time constant per axis that one trial does not determine; the random walk has no such bias, and
over the sample steps and measurement gaps of a trial log (< a few seconds) its variance growth
is harmless.

Discretisation over a step ``h = t[k+1] - t[k]`` (any, the grid may be non-uniform): the (u, u'),
(v, v') and (psi, r, r') chains are linear and discretised exactly (``u+ = u + h u'``, ``psi+ = psi
+ h r + h^2/2 r'``), the position by the second-order Taylor step ``p+ = p + h p' + h^2/2 p''``
with ``x'' = u' cos psi - v' sin psi - r y'`` and ``y'' = u' sin psi + v' cos psi + r x'`` (local
error h^3/6 |p'''|, 3e-7 m at 50 Hz for a USV turning at 0.2 rad/s and 5 m/s). The process noise
covariance is the exact one of a white-jerk triple integrator per body axis::

    Q3(q, h) = q [[h^5/20, h^4/8, h^3/6], [h^4/8, h^3/3, h^2/2], [h^3/6, h^2/2, h]]

for (psi, r, r') and for (body-axis position, u, u') and (.., v, v'), the body-axis position
rotated into NED by psi at the start of the step.

Measurements (scalar, processed one after the other, each only at the rows where the channel has a
finite sample; stale GNSS fixes are blanked first by :func:`usvid.prep.drop_stale`, since a
repeated position is not a measurement): ``x``, ``y``; ``psi`` (innovation wrapped to [-pi, pi));
gyro ``r``; body ``u``, ``v`` when logged; speed over ground ``U = sqrt(u^2 + v^2)``; course
over ground ``cog = psi + atan2(v, u)`` (innovation wrapped; used only where the predicted speed
exceeds ``cog_min_speed``, the course of a vessel at rest being noise). Velocities are those of
the position reference point (the GNSS antenna): no lever arm, no current.

Current (optional, ``current=True``): two more states, the current ``c_N``, ``c_E`` [m/s, the
water's velocity over ground, towards], each a random walk of density ``q_c`` [m^2/s^3] (the
bias model of Fossen 2021, ch. 13, "Kalman filter with bias estimation": ``b' = w``). u, v are
then the velocities through the water and the position moves with the sum::

    x' = u cos psi - v sin psi + c_N,     y' = u sin psi + v cos psi + c_E,     c_N' = c_E' = w_c

(Fossen 2021, ch. 10.3: ground velocity = body velocity through the water rotated + current);
logged body u, v (an INS), speed and course over ground are then predicted over ground (through
the water plus the current). ``q_c`` is held (default :data:`Q_CURRENT`, 1e-6 m^2/s^3), not
tuned by the likelihood: the likelihood cannot tell a slow current from slow changes of u, v.
What separates them in a kinematic model is only the smoothness prior of u, v (white jerk): a
current seen from the turning body frame is a velocity oscillating with the heading, which costs
jerk ``|c| r^2``; a steady turn of an agile craft makes that visible, a ship's or a zig-zag's
hardly, and the speed changes a real turn has are cheap in the prior. The per-trial summary
therefore reports the smoothed correlation of u (v) with the current along the same body axis
(near -1: only their sum is seen). Measured on a virtual 1.5 m catamaran in a 0.2 m/s current
(random thrust levels and differentials, 240 s, 10 Hz GNSS and Doppler): the kinematic estimate
is off by 0.14 m/s (0.33 m/s without the logged u, v), correlation -0.96 (-0.93); weaving about
one course 0.34 m/s (0.26 m/s), correlation -0.99 (-1.00). A current is only separable with a
model of the hull: the identification estimates it with the hull's coefficients
(:mod:`usvid.identify.disturbance`), from the current-free state estimate. A force bias (sway
force, yaw moment) has no state here: in a kinematic model a force is an acceleration (u', v',
r' are states already), and a bias state ``b`` entering ``v' = a_v + b`` would be the same
observation twice; Fossen's bias observers (2021, ch. 13) separate it through the vessel's model
``M nu' + D nu = tau + b``, which is again the identification's job (the output error's bias
parameters).

Noise defaults, from the data (each overridable in SI units):

* measurement noise std of each channel from the scatter of its third divided differences
  (:func:`white_noise_std`). This measures the *white* part of the noise only: slow GNSS wander
  (metre-level, minutes) is indistinguishable from motion and is followed by the estimate (it
  appears as a velocity error of order wander / correlation time).
* process noise densities q_u, q_v, q_r by maximising the innovation likelihood (Schweppe 1965;
  prediction-error decomposition, Harvey 1989)
  ``log L = -1/2 sum (log(2 pi S_k) + nu_k^2 / S_k)`` over log10 q: a grid in steps of two
  decades (+-4 decades around a start from the data's speed and yaw-rate scale) for q_r, then for
  q_u = q_v, then Nelder-Mead in (log10 q_u, log10 q_v, log10 q_r) (scipy, to 0.1 decade), about
  60 forward passes. Rows without a measurement are left out of the search; a trial with more than
  ``tune_rows`` measured rows is searched on 4 contiguous blocks spread over it (each filtered
  from its own start). Any q given is held. One q per axis cannot be right both on a straight
  run and at a rudder reversal; the likelihood settles where the reversals are followed (little
  lag), at the price of some noise in the accelerations between them. For a force regression
  that is the better side to err on: noise in the accelerations (the regressand) averages out in
  least squares, a lagged acceleration does not.

Consistency: for each measurement channel the normalised innovation squared
``NIS = nu^2 / S`` of the forward pass (Bar-Shalom et al. 2001, ch. 5) has mean 1 when the
noise model is right; it is reported per channel with its 95 % interval for white innovations,
the lag-1 autocorrelation of the normalised innovations, and the counts of updates and rejects.

Cost: the filter loop and the smoother are numba-compiled (sparse transition Jacobian, scalar
updates, the smoother's gain by a Cholesky solve of the correlation form of the predicted
covariance); the filtered covariances are stored packed (45 numbers per row), about 0.7 kB per
row at the peak. A one-hour 50 Hz log (180,000 rows) takes about 1.2 s on one core
(``benchmarks/bench_state_estimation.py``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
import pandas as pd

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.prep.filters import unwrap_angle
from usvid.prep.geodesy import to_ned
from usvid.prep.stale import drop_stale
from usvid.trial import Trial

__all__ = [
    "CURRENT_STATES",
    "MEASUREMENT_CHANNELS",
    "STATE_NAMES",
    "StateEstimate",
    "StateEstimationError",
    "estimate_states",
    "white_noise_std",
]

#: State vector, in order (output names of :meth:`StateEstimate.to_trial`).
STATE_NAMES: tuple[str, ...] = ("x", "y", "psi", "u", "v", "r", "udot", "vdot", "rdot")
#: State units (SI).
STATE_UNITS: dict[str, str] = {"x": "m", "y": "m", "psi": "rad", "u": "m/s", "v": "m/s",
                               "r": "rad/s", "udot": "m/s^2", "vdot": "m/s^2", "rdot": "rad/s^2"}
#: Trial channels the filter can use as measurements, in kernel order.
MEASUREMENT_CHANNELS: tuple[str, ...] = ("x", "y", "psi", "r", "u", "v", "U", "cog")
_ANGLE_CHANNELS = ("psi", "cog")
#: Fewest position fixes / heading samples accepted (a smoother over fewer is meaningless).
MIN_FIXES = 10
#: Lower bounds of data-derived noise std (noise-free or quantised data): m, rad, rad/s, m/s.
_SIGMA_FLOOR = {"x": 1e-3, "y": 1e-3, "psi": 1e-4, "r": 1e-5, "u": 1e-3, "v": 1e-3,
                "U": 1e-3, "cog": 1e-4}
_NX = 9
#: The optional current states (appended to :data:`STATE_NAMES` with ``current=True``), m/s.
CURRENT_STATES: tuple[str, ...] = ("current_north", "current_east")
#: Default random-walk density of the current [m^2/s^3]: a 1-sigma drift of 0.025 m/s in 10 min.
Q_CURRENT = 1e-6
#: Default prior std of the current [m/s] (the tidal and wind-driven currents of trial areas).
CURRENT_PRIOR_SD = 1.0
#: Contiguous blocks the likelihood search uses when a trial has more than ``tune_rows`` rows.
TUNE_BLOCKS = 4


class StateEstimationError(UsvidError):
    """The trial cannot support a state estimate (no heading, too few fixes, bad time, ...)."""


# ------------------------------------------------------------------------------------------
# numba kernels
# ------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True)
def _transition(s, h, q, sn, F, Q):  # pragma: no cover - numba
    """Second-order step of the process model over ``h`` [s]: next state ``sn``, Jacobian ``F``,
    process noise covariance ``Q`` (module docstring). ``q`` = (q_u, q_v, q_r[, q_c]); a state
    of 11 carries the current (north, east) [m/s] in s[9], s[10]: u, v are then the velocities
    through the water and the position moves with the current too."""
    n = s.shape[0]
    qu, qv, qr = q[0], q[1], q[2]
    psi, u, v, r = s[2], s[3], s[4], s[5]
    au, av, ar = s[6], s[7], s[8]
    c = math.cos(psi)
    sp = math.sin(psi)
    xw = u * c - v * sp  # velocity through the water, NED
    yw = u * sp + v * c
    cn = s[9] if n > 9 else 0.0
    ce = s[10] if n > 9 else 0.0
    xdd = au * c - av * sp - r * yw
    ydd = au * sp + av * c + r * xw
    h2 = 0.5 * h * h
    sn[0] = s[0] + h * (xw + cn) + h2 * xdd
    sn[1] = s[1] + h * (yw + ce) + h2 * ydd
    sn[2] = psi + h * r + h2 * ar
    sn[3] = u + h * au
    sn[4] = v + h * av
    sn[5] = r + h * ar
    sn[6] = au
    sn[7] = av
    sn[8] = ar
    for i in range(9, n):
        sn[i] = s[i]
    for i in range(n):
        for j in range(n):
            F[i, j] = 0.0
            Q[i, j] = 0.0
        F[i, i] = 1.0
    # x row
    F[0, 2] = -h * yw + h2 * (-au * sp - av * c - r * xw)
    F[0, 3] = h * c - h2 * r * sp
    F[0, 4] = -h * sp - h2 * r * c
    F[0, 5] = -h2 * yw
    F[0, 6] = h2 * c
    F[0, 7] = -h2 * sp
    # y row
    F[1, 2] = h * xw + h2 * (au * c - av * sp - r * yw)
    F[1, 3] = h * sp + h2 * r * c
    F[1, 4] = h * c - h2 * r * sp
    F[1, 5] = h2 * xw
    F[1, 6] = h2 * sp
    F[1, 7] = h2 * c
    if n > 9:  # the current moves the position; a random walk of density q_c
        F[0, 9] = h
        F[1, 10] = h
        Q[9, 9] = q[3] * h
        Q[10, 10] = q[3] * h
    # psi, u, v, r rows
    F[2, 5] = h
    F[2, 8] = h2
    F[3, 6] = h
    F[4, 7] = h
    F[5, 8] = h
    # white-jerk process noise: Q3 per chain
    h3 = h * h * h
    q00 = h3 * h * h / 20.0
    q01 = h3 * h / 8.0
    q02 = h3 / 6.0
    q11 = h3 / 3.0
    q12 = h * h / 2.0
    q22 = h
    # psi chain (2, 5, 8)
    Q[2, 2] = qr * q00
    Q[2, 5] = qr * q01
    Q[5, 2] = qr * q01
    Q[2, 8] = qr * q02
    Q[8, 2] = qr * q02
    Q[5, 5] = qr * q11
    Q[5, 8] = qr * q12
    Q[8, 5] = qr * q12
    Q[8, 8] = qr * q22
    # surge chain: body-axis position along (c, sp), u (3), u' (6)
    # sway chain: along (-sp, c), v (4), v' (7)
    Q[0, 0] = q00 * (qu * c * c + qv * sp * sp)
    Q[1, 1] = q00 * (qu * sp * sp + qv * c * c)
    Q[0, 1] = q00 * (qu - qv) * c * sp
    Q[1, 0] = Q[0, 1]
    Q[0, 3] = qu * q01 * c
    Q[1, 3] = qu * q01 * sp
    Q[0, 6] = qu * q02 * c
    Q[1, 6] = qu * q02 * sp
    Q[0, 4] = -qv * q01 * sp
    Q[1, 4] = qv * q01 * c
    Q[0, 7] = -qv * q02 * sp
    Q[1, 7] = qv * q02 * c
    for i in (0, 1):
        for j in (3, 4, 6, 7):
            Q[j, i] = Q[i, j]
    Q[3, 3] = qu * q11
    Q[3, 6] = qu * q12
    Q[6, 3] = qu * q12
    Q[6, 6] = qu * q22
    Q[4, 4] = qv * q11
    Q[4, 7] = qv * q12
    Q[7, 4] = qv * q12
    Q[7, 7] = qv * q22


#: Non-zero off-diagonal columns of the transition Jacobian F = I + G, per row (rows 6-8: none).
#: With the current (11 states) rows 0 and 1 have one more: the current's column (9, 10).
_GCOLS = np.array([[2, 3, 4, 5, 6, 7, 9], [2, 3, 4, 5, 6, 7, 10], [5, 8, 0, 0, 0, 0, 0],
                   [6, 0, 0, 0, 0, 0, 0], [7, 0, 0, 0, 0, 0, 0], [8, 0, 0, 0, 0, 0, 0]],
                  dtype=np.int64)
_GN9 = np.array([6, 6, 2, 1, 1, 1], dtype=np.int64)
_GN11 = np.array([7, 7, 2, 1, 1, 1], dtype=np.int64)


@numba.njit(cache=True)
def _f_times(F, P, A):  # pragma: no cover - numba
    """A = F P for the sparse F = I + G of :func:`_transition`."""
    n = P.shape[0]
    gn = _GN11 if n > 9 else _GN9
    for i in range(n):
        for j in range(n):
            A[i, j] = P[i, j]
    for i in range(6):
        for m in range(gn[i]):
            c = _GCOLS[i, m]
            g = F[i, c]
            for j in range(n):
                A[i, j] += g * P[c, j]


@numba.njit(cache=True)
def _times_ft_plus_q(A, F, Q, out):  # pragma: no cover - numba
    """out = A F' + Q (upper triangle computed, mirrored) for the sparse F = I + G."""
    n = A.shape[0]
    gn = _GN11 if n > 9 else _GN9
    for i in range(n):
        for j in range(i, n):
            acc = A[i, j] + 0.5 * (Q[i, j] + Q[j, i])
            if j < 6:
                for m in range(gn[j]):
                    c = _GCOLS[j, m]
                    acc += A[i, c] * F[j, c]
            out[i, j] = acc
            out[j, i] = acc


@numba.njit(cache=True)
def _propagate_cov(F, P, Q, A, out):  # pragma: no cover - numba
    """out = F P F' + Q (symmetrised); A is scratch. ``out`` may alias ``P``."""
    _f_times(F, P, A)
    _times_ft_plus_q(A, F, Q, out)


@numba.njit(cache=True)
def _pack(P, row):  # pragma: no cover - numba
    m = 0
    n = P.shape[0]
    for i in range(n):
        for j in range(i, n):
            row[m] = P[i, j]
            m += 1


@numba.njit(cache=True)
def _unpack(row, P):  # pragma: no cover - numba
    m = 0
    n = P.shape[0]
    for i in range(n):
        for j in range(i, n):
            P[i, j] = row[m]
            P[j, i] = row[m]
            m += 1


#: State index of the directly measured channels 0-5 (kernel order x, y, psi, r, u, v).
_DIRECT = (0, 1, 2, 5, 3, 4)


@numba.njit(cache=True)
def _measure(j, s, hvec, cog_min_speed):  # pragma: no cover - numba
    """Predicted value of measurement channel ``j`` (kernel order) and its Jacobian row ``hvec``.

    Returns ``(prediction, is_angle, ok)``; ``ok`` False where the channel is undefined (speed or
    course at a speed below the threshold). With the current states (11) the logged body
    velocities, the speed and the course are over ground: the velocity through the water plus
    the current."""
    n = s.shape[0]
    for i in range(n):
        hvec[i] = 0.0
    if n > 9 and j >= 4:  # over ground = through the water + current
        psi, u, v, cn, ce = s[2], s[3], s[4], s[9], s[10]
        c = math.cos(psi)
        sp = math.sin(psi)
        if j == 4:  # body u over ground
            hvec[3] = 1.0
            hvec[2] = -cn * sp + ce * c
            hvec[9] = c
            hvec[10] = sp
            return u + cn * c + ce * sp, False, True
        if j == 5:  # body v over ground
            hvec[4] = 1.0
            hvec[2] = -cn * c - ce * sp
            hvec[9] = -sp
            hvec[10] = c
            return v - cn * sp + ce * c, False, True
        xw = u * c - v * sp
        yw = u * sp + v * c
        gx = xw + cn
        gy = yw + ce
        G2 = gx * gx + gy * gy
        G = math.sqrt(G2)
        if j == 6:
            if G < 1e-3:
                return G, False, False
            hvec[2] = (-gx * yw + gy * xw) / G
            hvec[3] = (gx * c + gy * sp) / G
            hvec[4] = (-gx * sp + gy * c) / G
            hvec[9] = gx / G
            hvec[10] = gy / G
            return G, False, True
        if G < cog_min_speed or G < 1e-3:
            return 0.0, True, False
        hvec[2] = (gx * xw + gy * yw) / G2
        hvec[3] = (gx * sp - gy * c) / G2
        hvec[4] = (gx * c + gy * sp) / G2
        hvec[9] = -gy / G2
        hvec[10] = gx / G2
        return math.atan2(gy, gx), True, True
    if j < 6:  # a state measured directly: x, y, psi, r, u, v
        k = _DIRECT[j]
        hvec[k] = 1.0
        return s[k], j == 2, True
    u = s[3]
    v = s[4]
    U2 = u * u + v * v
    U = math.sqrt(U2)
    if j == 6:
        if U < 1e-3:
            return U, False, False
        hvec[3] = u / U
        hvec[4] = v / U
        return U, False, True
    # course over ground
    if U < cog_min_speed or U < 1e-3:
        return 0.0, True, False
    hvec[2] = 1.0
    hvec[3] = -v / U2
    hvec[4] = u / U2
    return s[2] + math.atan2(v, u), True, True


@numba.njit(cache=True)
def _forward(t, Z, rvar, q, x0, P0, cog_min_speed, gate2, store):  # pragma: no cover - numba
    """EKF forward pass (n = 9 states, or 11 with the current). Returns (xf (N,n), Pf packed
    (N,n(n+1)/2), normalised innovations (N,M),
    log-likelihood, update counts (M,), rejected counts (M,)); with ``store`` False the three
    arrays are empty (likelihood only)."""
    N = t.shape[0]
    M = Z.shape[1]
    n = x0.shape[0]
    npk = n * (n + 1) // 2
    if store:
        xf = np.empty((N, n))
        Pf = np.empty((N, npk))
        nu_n = np.full((N, M), np.nan)
    else:
        xf = np.empty((0, n))
        Pf = np.empty((0, npk))
        nu_n = np.empty((0, M))
    s = x0.copy()
    P = P0.copy()
    sn = np.empty(n)
    F = np.empty((n, n))
    Q = np.empty((n, n))
    A = np.empty((n, n))
    hv = np.empty(n)
    Ph = np.empty(n)
    hidx = np.empty(n, dtype=np.int64)
    counts = np.zeros(M, dtype=np.int64)
    rejected = np.zeros(M, dtype=np.int64)
    loglik = 0.0
    log2pi = math.log(2.0 * math.pi)
    for k in range(N):
        if k > 0:
            _transition(s, t[k] - t[k - 1], q, sn, F, Q)
            _propagate_cov(F, P, Q, A, P)
            for i in range(n):
                s[i] = sn[i]
        for j in range(M):
            z = Z[k, j]
            if not math.isfinite(z):
                continue
            pred, is_angle, ok = _measure(j, s, hv, cog_min_speed)
            if not ok:
                continue
            nu = z - pred
            if is_angle:
                nu = _wrap(nu)
            nh = 0
            for m in range(n):
                if hv[m] != 0.0:
                    hidx[nh] = m
                    nh += 1
            for i in range(n):
                acc = 0.0
                for a in range(nh):
                    m = hidx[a]
                    acc += P[i, m] * hv[m]
                Ph[i] = acc
            S = rvar[j]
            for a in range(nh):
                m = hidx[a]
                S += hv[m] * Ph[m]
            if not (S > 0.0) or not math.isfinite(S):
                continue
            e2 = nu * nu / S
            if gate2 > 0.0 and e2 > gate2:
                rejected[j] += 1
                continue
            counts[j] += 1
            loglik -= 0.5 * (log2pi + math.log(S) + e2)
            g = nu / S
            for i in range(n):
                s[i] += Ph[i] * g
            for i in range(n):
                a = Ph[i] / S
                for m in range(i, n):
                    v = P[i, m] - a * Ph[m]
                    P[i, m] = v
                    P[m, i] = v
            if store:
                nu_n[k, j] = nu / math.sqrt(S)
        if store:
            for i in range(n):
                xf[k, i] = s[i]
            _pack(P, Pf[k])
    return xf, Pf, nu_n, loglik, counts, rejected


@numba.njit(cache=True)
def _chol_solve(A, B, L, n):  # pragma: no cover - numba
    """Solve A X = B in place of B (A symmetric positive definite n x n, Cholesky in L).

    Returns False when A is not positive definite."""
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not (d > 0.0):
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, n):
            acc = A[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / d
    m = B.shape[1]
    for i in range(n):  # forward: L Y = B, row by row over all right-hand sides
        for k in range(i):
            lik = L[i, k]
            for c in range(m):
                B[i, c] -= lik * B[k, c]
        inv = 1.0 / L[i, i]
        for c in range(m):
            B[i, c] *= inv
    for i in range(n - 1, -1, -1):  # backward: L' X = Y
        for k in range(i + 1, n):
            lki = L[k, i]
            for c in range(m):
                B[i, c] -= lki * B[k, c]
        inv = 1.0 / L[i, i]
        for c in range(m):
            B[i, c] *= inv
    return True


@numba.njit(cache=True)
def _smooth(t, xf, Pf, q):  # pragma: no cover - numba
    """Rauch-Tung-Striebel backward pass: smoothed states (N,n) and standard deviations (N,n),
    and with the current (n = 11) the smoothed correlations (N,2) of the velocity through the
    water with the current's component along the same body axis (u with the current along x,
    v with the one along y; -1: only their sum is seen).

    ``C = Pf F' Pp^-1`` (gain), ``xs_k = xf_k + C (xs_{k+1} - f(xf_k))``,
    ``Ps_k = Pf_k + C (Ps_{k+1} - Pp) C'`` with ``Pp = F Pf F' + Q``. The predicted covariance is
    recomputed (not stored) and solved for by a Cholesky factorisation of its correlation form."""
    N = t.shape[0]
    n = xf.shape[1]
    xs = np.empty((N, n))
    sd = np.empty((N, n))
    cc = np.empty((N if n > 9 else 0, 2))
    Ps = np.empty((n, n))
    Pk = np.empty((n, n))
    Pp = np.empty((n, n))
    Acor = np.empty((n, n))
    B = np.empty((n, n))
    L = np.zeros((n, n))
    F = np.empty((n, n))
    Q = np.empty((n, n))
    sn = np.empty(n)
    D = np.empty(n)
    dx = np.empty(n)
    Mx = np.empty((n, n))
    T1 = np.empty((n, n))
    _unpack(Pf[N - 1], Ps)
    for i in range(n):
        xs[N - 1, i] = xf[N - 1, i]
        sd[N - 1, i] = math.sqrt(max(Ps[i, i], 0.0))
    if n > 9:
        _current_corr(Ps, xs[N - 1, 2], cc[N - 1])
    for k in range(N - 2, -1, -1):
        _unpack(Pf[k], Pk)
        _transition(xf[k], t[k + 1] - t[k], q, sn, F, Q)
        # B = F Pk ; Pp = B F' + Q
        _f_times(F, Pk, B)
        _times_ft_plus_q(B, F, Q, Pp)
        # scaled solve: Pp X = B  <=>  (D^-1 Pp D^-1) (D X) = D^-1 B ; X = C'
        for i in range(n):
            D[i] = math.sqrt(max(Pp[i, i], 1e-300))
        for i in range(n):
            for j in range(n):
                Acor[i, j] = Pp[i, j] / (D[i] * D[j])
                B[i, j] = B[i, j] / D[i]
        jitter = 0.0
        ok = _chol_solve(Acor, B, L, n)
        while not ok:
            jitter = 1e-12 if jitter == 0.0 else jitter * 100.0
            for i in range(n):
                for j in range(n):
                    Acor[i, j] = Pp[i, j] / (D[i] * D[j])
                    B[i, j] = 0.0
                Acor[i, i] += jitter
            _f_times(F, Pk, B)
            for i in range(n):
                for j in range(n):
                    B[i, j] = B[i, j] / D[i]
            ok = _chol_solve(Acor, B, L, n)
            if jitter > 1e-2:
                break
        for i in range(n):
            for j in range(n):
                B[i, j] = B[i, j] / D[i]  # X = C'
        # xs_k = xf_k + X' (xs_{k+1} - sn)
        for i in range(n):
            dx[i] = xs[k + 1, i] - sn[i]
        for i in range(n):
            acc = xf[k, i]
            for m in range(n):
                acc += B[m, i] * dx[m]
            xs[k, i] = acc
        # Ps_k = Pk + X' (Ps - Pp) X
        for i in range(n):
            for j in range(n):
                Mx[i, j] = Ps[i, j] - Pp[i, j]
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for m in range(n):
                    acc += Mx[i, m] * B[m, j]
                T1[i, j] = acc  # (Ps - Pp) X
        for i in range(n):
            for j in range(i, n):
                acc = Pk[i, j]
                for m in range(n):
                    acc += B[m, i] * T1[m, j]
                Ps[i, j] = acc
        for i in range(n):
            for j in range(i + 1, n):
                Ps[j, i] = Ps[i, j]
            sd[k, i] = math.sqrt(max(Ps[i, i], 0.0))
        if n > 9:
            _current_corr(Ps, xs[k, 2], cc[k])
    return xs, sd, cc


@numba.njit(cache=True)
def _current_corr(P, psi, out):  # pragma: no cover - numba
    """Correlations of u with the current along the body x axis and of v with the one along y
    (``cN cos psi + cE sin psi``, ``-cN sin psi + cE cos psi``) under the covariance ``P``."""
    c = math.cos(psi)
    sp = math.sin(psi)
    for a in range(2):
        i = 3 + a
        wn = c if a == 0 else -sp
        we = sp if a == 0 else c
        cov = P[i, 9] * wn + P[i, 10] * we
        var_c = wn * wn * P[9, 9] + 2.0 * wn * we * P[9, 10] + we * we * P[10, 10]
        den = math.sqrt(max(P[i, i], 0.0) * max(var_c, 0.0))
        out[a] = cov / den if den > 0.0 else 0.0


# ------------------------------------------------------------------------------------------
# noise levels from the data
# ------------------------------------------------------------------------------------------


def white_noise_std(t: np.ndarray, y: np.ndarray) -> float:
    """Std of the white noise on samples ``y`` at times ``t`` [s], from third divided differences
    (the variate-difference method, Tintner 1940, on a non-uniform grid).

    For each four consecutive finite samples, ``d = sum_i w_i y_i / sqrt(sum_i w_i^2)`` with
    ``w_i = 1 / prod_{j != i} (t_i - t_j)``: d is zero for any quadratic in t and has variance
    sigma^2 for white noise of std sigma, on any (non-uniform) spacing. Returns
    ``1.4826 median |d|`` (the normal-consistent median absolute deviation; the RMS when more
    than half the d are zero, as for quantised data). Same unit as ``y``; NaN when fewer than 4
    finite samples. Angles must be unwrapped first.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if t.size < 4:
        return float("nan")
    tt = np.stack([t[i:t.size - 3 + i] for i in range(4)])  # (4, n)
    yy = np.stack([y[i:y.size - 3 + i] for i in range(4)])
    w = np.empty_like(tt)
    for i in range(4):
        prod = np.ones(tt.shape[1])
        for j in range(4):
            if j != i:
                prod = prod * (tt[i] - tt[j])
        with np.errstate(divide="ignore"):
            w[i] = 1.0 / prod
    good = np.all(np.isfinite(w), axis=0)
    if not good.any():
        return float("nan")
    w, yy = w[:, good], yy[:, good]
    # scale the weights per window (the divided-difference weights span many decades)
    wn = w / np.max(np.abs(w), axis=0)
    d = np.sum(wn * yy, axis=0) / np.sqrt(np.sum(wn * wn, axis=0))
    mad = float(np.median(np.abs(d)))
    if mad > 0:
        return 1.4826 * mad
    return float(np.sqrt(np.mean(d * d)))


# ------------------------------------------------------------------------------------------
# results
# ------------------------------------------------------------------------------------------


@dataclass
class StateEstimate:
    """Smoothed states on the trial's time grid, their standard deviations, and diagnostics.

    Attributes
    ----------
    t : (N,) time [s] (the trial's rows).
    states : name -> (N,) smoothed state (:data:`STATE_NAMES`, units :data:`STATE_UNITS`);
        ``psi`` is continuous (not wrapped).
    std : name -> (N,) standard deviation of the smoothed state (same units).
    sigma : measurement channel -> noise std used (SI units of the channel).
    q : ``q_u`` [m^2/s^5], ``q_v`` [m^2/s^5], ``q_r`` [rad^2/s^5] process noise densities used.
    innovations : measurement channel -> (N,) normalised forward innovations nu / sqrt(S), NaN
        where the channel was not used at that row.
    nis : measurement channel -> mean normalised innovation squared (1 when consistent).
    loglik : innovation log-likelihood of the forward pass.
    trial : the input trial after stale fixes were blanked (and NED conversion).
    info : settings and statistics (what :meth:`to_trial` stores in ``meta["state_estimation"]``).
    current : with ``current=True``, the trial's current (:func:`_current_summary`), else None.
    """

    t: np.ndarray
    states: dict[str, np.ndarray]
    std: dict[str, np.ndarray]
    sigma: dict[str, float]
    q: dict[str, float]
    innovations: dict[str, np.ndarray]
    nis: dict[str, float]
    loglik: float
    trial: Trial
    info: dict[str, Any] = field(default_factory=dict)
    current: dict[str, Any] | None = None

    def __getitem__(self, name: str) -> np.ndarray:
        """Smoothed state ``name`` (:data:`STATE_NAMES`)."""
        if name not in self.states:
            raise StateEstimationError(
                f"state estimate of trial {self.trial.name or '?'}: no state '{name}' "
                f"(states: {', '.join(self.states)})")
        return self.states[name]

    def to_trial(self, *, keep_channels: bool = True, with_std: bool = False) -> Trial:
        """A :class:`Trial` on the same time grid with the smoothed ``x, y, psi, u, v, r, udot,
        vdot, rdot`` (SI units), optionally their ``<name>_std`` columns.

        ``keep_channels`` keeps the input's other channels (rudder, thrust, ...) unchanged; the
        measured channels the estimate replaces (x, y, psi, u, v, r) are dropped, and so are
        ``U`` and ``cog`` (derivable from u, v, psi). ``meta["state_estimation"]`` holds
        :attr:`info` (noise settings, innovation statistics).
        """
        data = {"t": self.t}
        for n in self.states:
            data[n] = self.states[n]
            if with_std:
                data[f"{n}_std"] = self.std[n]
        df = pd.DataFrame(data)
        if keep_channels:
            drop = set(STATE_NAMES) | {"t", "U", "cog", "lat", "lon"}
            rest = [c for c in self.trial.data.columns if c not in drop]
            if rest:
                df = pd.concat([df, self.trial.data[rest].reset_index(drop=True)], axis=1)
        meta = dict(self.trial.meta)
        meta["state_estimation"] = self.info
        return self.trial.with_data(df, meta=meta)


# ------------------------------------------------------------------------------------------
# the estimator
# ------------------------------------------------------------------------------------------


def _label(trial: Trial) -> str:
    return trial.name or "?"


def _check_time(trial: Trial) -> np.ndarray:
    t = trial.t
    name = _label(trial)
    if t.size == 0:
        raise StateEstimationError(f"trial {name}: no rows")
    bad = ~np.isfinite(t)
    if bad.any():
        i = int(np.argmax(bad))
        raise StateEstimationError(f"trial {name}: channel 't' has a non-finite time at row {i}")
    dt = np.diff(t)
    if (dt <= 0).any():
        i = int(np.argmax(dt <= 0)) + 1
        raise StateEstimationError(
            f"trial {name}: channel 't' is not strictly increasing at row {i} "
            f"(t = {t[i - 1]:.6g} s then {t[i]:.6g} s; use usvid.prep.sort_time)")
    return t


def _positive(name: str, value: float | None) -> float | None:
    if value is None:
        return None
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise StateEstimationError(f"{name} must be a finite number > 0 (got {value!r})")
    return v


def _initial_state(t: np.ndarray, Z: np.ndarray, sig: np.ndarray,
                   current_sd: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Crude start: first heading, first fix, velocity from a line through the first fixes;
    with ``current_sd`` [m/s] the current states too (zero, that prior std)."""
    x0 = np.zeros(_NX)
    psi_ok = np.flatnonzero(np.isfinite(Z[:, 2]))
    x0[2] = Z[psi_ok[0], 2]
    pos = np.flatnonzero(np.isfinite(Z[:, 0]) & np.isfinite(Z[:, 1]))
    x0[0], x0[1] = Z[pos[0], 0], Z[pos[0], 1]
    # velocity over the first fixes: at least 5 and 3 s
    n = max(5, int(np.searchsorted(t[pos], t[pos[0]] + 3.0)))
    sel = pos[:n]
    ts = t[sel] - t[sel[0]]
    U0 = 0.0
    if ts[-1] > 0:
        vx = np.polyfit(ts, Z[sel, 0], 1)[0]
        vy = np.polyfit(ts, Z[sel, 1], 1)[0]
        c, s = math.cos(x0[2]), math.sin(x0[2])
        x0[3] = vx * c + vy * s
        x0[4] = -vx * s + vy * c
        U0 = math.hypot(vx, vy)
        # back to the first row's time
        x0[0] -= vx * (t[sel[0]] - t[0])
        x0[1] -= vy * (t[sel[0]] - t[0])
    r_ok = np.flatnonzero(np.isfinite(Z[:, 3]))
    if r_ok.size:
        x0[5] = Z[r_ok[0], 3]
    gap = float(t[pos[0]] - t[0])
    pos_sd = max(10.0, 2.0 * U0 * gap)
    vel_sd = max(1.0, 0.5 * U0)
    sd = np.array([pos_sd, pos_sd, max(0.2, 3 * sig[2]), vel_sd, vel_sd, 0.2,
                   max(1.0, 0.2 * U0), max(1.0, 0.2 * U0), 0.1])
    if current_sd is not None:
        x0 = np.concatenate([x0, [0.0, 0.0]])
        sd = np.concatenate([sd, [current_sd, current_sd]])
    return x0, np.diag(sd ** 2)


def _current_summary(t: np.ndarray, states: dict[str, np.ndarray], std: dict[str, np.ndarray],
                     cc: np.ndarray, prior_sd: float) -> dict[str, Any]:
    """The trial's current from the smoothed current states (module docstring, "Current").

    Value: the time average of the smoothed ``current_north``, ``current_east`` [m/s] (trapezoid
    over ``t``); ``std_error``: the time average of their smoothed standard deviations, an upper
    bound of the average's std (the std of a mean is at most the mean of the stds, Minkowski,
    reached when the errors are fully correlated, as a nearly constant random walk's are);
    ``ci95`` = value +- 1.96 std_error. ``correlation``: the median over the rows of the
    smoothed correlation of u with the current along the body x axis and of v with the one along
    y, the larger in magnitude (near -1: the data see only their sum, the current is not
    separable from the velocity through the water); ``std_prior`` the prior std.
    """
    out: dict[str, Any] = {}
    span = float(t[-1] - t[0])

    def tmean(y: np.ndarray) -> float:
        if span <= 0:
            return float(np.mean(y))
        return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)) / span)

    for n in CURRENT_STATES:
        v, se = tmean(states[n]), tmean(std[n])
        out[n] = {"value": v, "std_error": se, "ci95": [v - 1.96 * se, v + 1.96 * se],
                  "unit": "m/s"}
    cn, ce = out["current_north"]["value"], out["current_east"]["value"]
    out["speed_m_s"] = float(math.hypot(cn, ce))
    out["towards_deg"] = float(math.degrees(math.atan2(ce, cn)) % 360.0)
    med = np.median(cc, axis=0) if cc.shape[0] else np.zeros(2)
    out["correlation"] = float(med[np.argmax(np.abs(med))])
    out["std_prior"] = float(prior_sd)
    return out


def _q_start(t: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """Starting densities for the likelihood search: accelerations of 10 % of the speed (and of
    the yaw-rate scale) changing over T = 5 s: q ~ a^2 / T (white jerk, random-walk a)."""
    pos = np.isfinite(Z[:, 0]) & np.isfinite(Z[:, 1])
    tp = t[pos]
    speed = 1.0
    if tp.size > 2 and tp[-1] > tp[0]:
        d = np.hypot(np.diff(Z[pos, 0]), np.diff(Z[pos, 1])) / np.diff(tp)
        speed = max(float(np.median(d)), 0.1)
    if np.isfinite(Z[:, 3]).sum() > 3:
        r_scale = float(np.nanstd(Z[:, 3]))
    else:
        ok = np.isfinite(Z[:, 2])
        tpsi = t[ok]
        psi = np.unwrap(Z[ok, 2])
        r_scale = float(np.std(np.diff(psi) / np.diff(tpsi))) if tpsi.size > 2 else 0.05
    r_scale = max(r_scale, 1e-3)
    T = 5.0
    qa = (0.1 * speed / T) ** 2 / T
    qr = (r_scale / T) ** 2 / T
    return np.array([qa, qa, qr])


def _nis_stats(nu: np.ndarray) -> dict[str, Any]:
    from scipy.stats import chi2

    v = nu[np.isfinite(nu)]
    n = int(v.size)
    if n == 0:
        return {"n": 0}
    nis = float(np.mean(v * v))
    lo, hi = (float(x) / n for x in chi2.ppf([0.025, 0.975], n))
    lag1 = float(np.corrcoef(v[:-1], v[1:])[0, 1]) if n > 2 and np.std(v) > 0 else float("nan")
    return {"n": n, "nis_mean": nis, "nis_95": [lo, hi], "consistent": bool(lo <= nis <= hi),
            "mean": float(np.mean(v)), "frac_over_3_84": float(np.mean(v * v > 3.841)),
            "lag1_autocorr": lag1}


def estimate_states(
    trial: Trial,
    *,
    sigma_pos: float | None = None,
    sigma_psi: float | None = None,
    sigma_r: float | None = None,
    sigma_uv: float | None = None,
    sigma_U: float | None = None,
    sigma_cog: float | None = None,
    q_u: float | None = None,
    q_v: float | None = None,
    q_r: float | None = None,
    tune: bool = True,
    tune_rows: int = 10000,
    exclude: Sequence[str] = (),
    cog_min_speed: float = 0.5,
    gate: float | None = None,
    current: bool = False,
    q_c: float | None = None,
    current_sd: float | None = None,
) -> StateEstimate:
    """Smoothed body velocities, yaw rate and their derivatives of a trial (EKF + RTS smoother).

    Extended Kalman filter (Kalman 1960) forward, Rauch-Tung-Striebel smoother (Rauch, Tung &
    Striebel 1965) backward, on the kinematic body-frame model of the module docstring
    (state ``x, y [m], psi [rad], u, v [m/s], r [rad/s], u', v' [m/s^2], r' [rad/s^2]``, white
    jerk of densities q_u, q_v [m^2/s^5], q_r [rad^2/s^5]), the approach of Alexandersson et al.
    (2022) for free-running manoeuvring data.

    Parameters
    ----------
    trial : Trial
        ``t`` [s] strictly increasing; ``x``, ``y`` [m, north, east] (or ``lat``/``lon`` [deg],
        converted by :func:`usvid.prep.to_ned`); ``psi`` [rad]; optional ``r`` [rad/s] gyro,
        ``u``, ``v`` [m/s] body velocities, ``U`` [m/s] speed and ``cog`` [rad] course over
        ground. Multi-rate trials (NaN where a channel has no sample) are used as they are; the
        estimate is given at every row. Stale (repeated) GNSS fixes are not measurements
        (:func:`usvid.prep.drop_stale`).
    sigma_pos, sigma_psi, sigma_r, sigma_uv, sigma_U, sigma_cog : float, optional
        Measurement noise std: position per axis [m], heading [rad], gyro [rad/s], body
        velocities [m/s], speed over ground [m/s], course over ground [rad]. Default: from the
        data (:func:`white_noise_std`, floored at 1 mm, 1e-4 rad, 1e-5 rad/s, 1 mm/s).
    q_u, q_v, q_r : float, optional
        Process noise spectral densities of the jerk [m^2/s^5, m^2/s^5, rad^2/s^5]. Default:
        maximum innovation likelihood (``tune``), else a rough start from the data scale.
    tune : bool
        Search the q not given by maximum likelihood (module docstring).
    tune_rows : int
        Measured rows the search uses at most (a longer trial is searched on
        :data:`TUNE_BLOCKS` contiguous blocks spread over it; the final pass uses every row).
    exclude : sequence of str
        Measurement channels not to use (e.g. ``("u",)`` to hold a logged u out for checking).
    cog_min_speed : float
        Course over ground used only where the predicted speed exceeds this [m/s].
    gate : float, optional
        Reject a measurement whose innovation exceeds ``gate`` standard deviations (outliers);
        the rejects are counted per channel. Default: no gating.
    current : bool
        Estimate a current too (module docstring, "Current"): states ``current_north``,
        ``current_east`` [m/s, the velocity over ground of the water, towards]; ``u``, ``v``
        are then the velocities through the water. The per-trial value with its interval and
        separability is :attr:`StateEstimate.current`.
    q_c : float, optional
        Random-walk density of the current [m^2/s^3] (default :data:`Q_CURRENT`; held, not
        tuned: module docstring).
    current_sd : float, optional
        Prior std of the current [m/s] (default :data:`CURRENT_PRIOR_SD`).

    Returns
    -------
    StateEstimate

    Raises
    ------
    StateEstimationError
        No heading, fewer than :data:`MIN_FIXES` position fixes or heading samples, time not
        strictly increasing or not finite, an unknown channel in ``exclude``, a bad setting.
    """
    t_start = time.perf_counter()
    name = _label(trial)
    for ch in exclude:
        if ch not in MEASUREMENT_CHANNELS:
            raise StateEstimationError(
                f"trial {name}: cannot exclude channel '{ch}' (measurement channels: "
                f"{', '.join(MEASUREMENT_CHANNELS)})")
    given = {"pos": _positive("sigma_pos", sigma_pos), "psi": _positive("sigma_psi", sigma_psi),
             "r": _positive("sigma_r", sigma_r), "uv": _positive("sigma_uv", sigma_uv),
             "U": _positive("sigma_U", sigma_U), "cog": _positive("sigma_cog", sigma_cog)}
    q_given = [_positive("q_u", q_u), _positive("q_v", q_v), _positive("q_r", q_r)]
    if not (math.isfinite(cog_min_speed) and cog_min_speed >= 0):
        raise StateEstimationError(f"cog_min_speed must be >= 0 m/s (got {cog_min_speed!r})")
    gate_v = _positive("gate", gate)
    qc_v = _positive("q_c", q_c)
    csd_v = _positive("current_sd", current_sd)
    if not current and (qc_v is not None or csd_v is not None):
        raise StateEstimationError("q_c and current_sd are settings of the current states: "
                                   "give current=True")
    if current:
        qc_v = Q_CURRENT if qc_v is None else qc_v
        csd_v = CURRENT_PRIOR_SD if csd_v is None else csd_v
    if int(tune_rows) < 100:
        raise StateEstimationError(f"tune_rows must be >= 100 (got {tune_rows!r})")

    t = _check_time(trial)
    if not trial.has("psi"):
        raise StateEstimationError(
            f"trial {name}: no heading channel 'psi' (the body-frame velocities need the "
            f"heading; present: {', '.join(trial.channels) or 'none'})")
    if "psi" in exclude:
        raise StateEstimationError(f"trial {name}: channel 'psi' cannot be excluded (the "
                                   "body-frame velocities need the heading)")
    clean, stale = drop_stale(trial)
    if not (clean.has("x") and clean.has("y")) and clean.has("lat") and clean.has("lon"):
        clean = to_ned(clean)
    if not (clean.has("x") and clean.has("y")) or "x" in exclude or "y" in exclude:
        raise StateEstimationError(
            f"trial {name}: no position channels 'x', 'y' (or 'lat', 'lon') to estimate from")
    N = len(clean)
    Z = np.full((N, len(MEASUREMENT_CHANNELS)), np.nan)
    used: list[str] = []
    for j, ch in enumerate(MEASUREMENT_CHANNELS):
        if ch in exclude or ch not in clean.data.columns:
            continue
        col = clean[ch]
        if np.isfinite(col).any():
            Z[:, j] = col
            used.append(ch)
    n_fix = int((np.isfinite(Z[:, 0]) & np.isfinite(Z[:, 1])).sum())
    if n_fix < MIN_FIXES:
        raise StateEstimationError(
            f"trial {name}: channels 'x', 'y' have {n_fix} position fixes that are not stale "
            f"(at least {MIN_FIXES} needed)")
    n_psi = int(np.isfinite(Z[:, 2]).sum())
    if n_psi < MIN_FIXES:
        raise StateEstimationError(
            f"trial {name}: channel 'psi' has {n_psi} heading samples (at least {MIN_FIXES} "
            "needed)")
    # --- measurement noise ----------------------------------------------------------------
    sigma: dict[str, float] = {}
    source: dict[str, str] = {}

    def from_data(ch: str) -> float:
        col = Z[:, MEASUREMENT_CHANNELS.index(ch)]
        y = unwrap_angle(col) if ch in _ANGLE_CHANNELS else col
        s = white_noise_std(t, y)
        return max(s, _SIGMA_FLOOR[ch]) if math.isfinite(s) else _SIGMA_FLOOR[ch] * 100

    key = {"x": "pos", "y": "pos", "psi": "psi", "r": "r", "u": "uv", "v": "uv", "U": "U",
           "cog": "cog"}
    for ch in used:
        g = given[key[ch]]
        if g is not None:
            sigma[ch], source[ch] = g, "given"
    if given["pos"] is None:
        sp = math.sqrt(0.5 * (from_data("x") ** 2 + from_data("y") ** 2))
        sigma["x"] = sigma["y"] = sp
        source["x"] = source["y"] = "data"
    if given["uv"] is None and "u" in used and "v" in used:
        suv = math.sqrt(0.5 * (from_data("u") ** 2 + from_data("v") ** 2))
        sigma["u"] = sigma["v"] = suv
        source["u"] = source["v"] = "data"
    for ch in used:
        if ch not in sigma:
            sigma[ch], source[ch] = from_data(ch), "data"
    rvar = np.array([sigma.get(ch, 1.0) ** 2 for ch in MEASUREMENT_CHANNELS])
    sig_arr = np.array([sigma.get(ch, 1.0) for ch in MEASUREMENT_CHANNELS])
    x0, P0 = _initial_state(t, Z, sig_arr, csd_v if current else None)
    gate2 = gate_v ** 2 if gate_v is not None else 0.0

    # --- process noise ----------------------------------------------------------------------
    q0 = _q_start(t, Z)
    q = np.array([g if g is not None else q0[i] for i, g in enumerate(q_given)]
                 + ([qc_v] if current else []))
    free = [i for i, g in enumerate(q_given) if g is None]
    tuning: dict[str, Any] = {"tuned": False}
    if tune and free:
        q, tuning = _tune_q(t, Z, rvar, q, free, x0, P0, cog_min_speed, gate2, int(tune_rows))
    q_src = {n: ("given" if q_given[i] is not None else ("likelihood" if tune else "heuristic"))
             for i, n in enumerate(("q_u", "q_v", "q_r"))}

    # --- filter and smoother ------------------------------------------------------------------
    t_f = time.perf_counter()
    xf, Pf, nu, loglik, counts, rejected = _forward(t, Z, rvar, q, x0, P0, cog_min_speed,
                                                    gate2, True)
    if not np.all(np.isfinite(xf)):
        raise StateEstimationError(f"trial {name}: the filter diverged (non-finite state); "
                                   "check the units of psi and r and the noise settings")
    xs, sd, cc = _smooth(t, xf, Pf, q)
    del Pf
    if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(sd))):
        raise StateEstimationError(f"trial {name}: the smoother diverged (non-finite state); "
                                   "check the units of psi and r and the noise settings")
    t_done = time.perf_counter()
    names = STATE_NAMES + (CURRENT_STATES if current else ())
    states = {n: xs[:, i].copy() for i, n in enumerate(names)}
    std = {n: sd[:, i].copy() for i, n in enumerate(names)}
    innovations = {ch: nu[:, j].copy() for j, ch in enumerate(MEASUREMENT_CHANNELS)
                   if ch in used}
    stats = {ch: _nis_stats(innovations[ch]) for ch in used}
    for j, ch in enumerate(MEASUREMENT_CHANNELS):
        if ch in used:
            stats[ch]["updates"] = int(counts[j])
            stats[ch]["rejected"] = int(rejected[j])
    nis = {ch: stats[ch].get("nis_mean", float("nan")) for ch in used}
    qd = {"q_u": float(q[0]), "q_v": float(q[1]), "q_r": float(q[2])}
    cur = None
    if current:
        qd["q_c"] = float(q[3])
        q_src["q_c"] = "given" if q_c is not None else "default"
        cur = _current_summary(t, states, std, cc, csd_v)
    info: dict[str, Any] = {
        "method": "EKF (Kalman 1960) + RTS smoother (Rauch, Tung & Striebel 1965), kinematic "
                  "body-frame model, random-walk accelerations (white jerk)",
        "channels_used": used,
        "excluded": list(exclude),
        "sigma": dict(sigma),
        "sigma_source": source,
        "q": qd,
        "q_source": q_src,
        "tuning": tuning,
        "innovations": stats,
        "loglik": float(loglik),
        "stale_fixes": (stale.n_stale if stale is not None else 0),
        "cog_min_speed": float(cog_min_speed),
        "gate": gate_v,
        "rows": int(N),
        "time_s": {"total": t_done - t_start, "filter_smoother": t_done - t_f},
    }
    if cur is not None:
        info["current"] = cur
    return StateEstimate(t=t, states=states, std=std, sigma=dict(sigma), q=qd,
                         innovations=innovations, nis=nis, loglik=float(loglik), trial=clean,
                         info=info, current=cur)


def _tune_q(t: np.ndarray, Z: np.ndarray, rvar: np.ndarray, q: np.ndarray, free: list[int],
            x0: np.ndarray, P0: np.ndarray, cog_min_speed: float, gate2: float,
            tune_rows: int) -> tuple[np.ndarray, dict[str, Any]]:
    """Maximum-likelihood process noise (log10 grid per group, then Nelder-Mead)."""
    from scipy.optimize import minimize

    # rows without any measurement are pure prediction steps: leave them out (the linear part
    # of two steps is one step exactly; the position part to second order)
    meas = np.flatnonzero(np.isfinite(Z).any(axis=1))
    n_blocks = 1 if meas.size <= tune_rows else TUNE_BLOCKS
    blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    if n_blocks == 1:
        blocks.append((t[meas].copy(), np.ascontiguousarray(Z[meas]), x0, P0))
    else:  # contiguous blocks spread evenly over the trial, each filtered from its own start
        size = tune_rows // n_blocks
        for b in range(n_blocks):
            start = int(round(b * (meas.size - size) / (n_blocks - 1)))
            rows = meas[start:start + size]
            tb, Zb = t[rows].copy(), np.ascontiguousarray(Z[rows])
            if (np.isfinite(Zb[:, 0]) & np.isfinite(Zb[:, 1])).sum() < MIN_FIXES or \
                    np.isfinite(Zb[:, 2]).sum() < MIN_FIXES:
                continue
            xb, Pb = _initial_state(tb, Zb, np.sqrt(rvar),
                                    math.sqrt(P0[9, 9]) if x0.size > _NX else None)
            blocks.append((tb, Zb, xb, Pb))
        if not blocks:
            blocks.append((t[meas].copy(), np.ascontiguousarray(Z[meas]), x0, P0))
    evals = 0

    def nll(logq: np.ndarray) -> float:
        nonlocal evals
        evals += 1
        qq = q.copy()
        qq[free] = 10.0 ** np.clip(logq, -20.0, 8.0)
        ll = 0.0
        for tb, Zb, xb, Pb in blocks:
            ll += _forward(tb, Zb, rvar, qq, xb, Pb, cog_min_speed, gate2, False)[3]
        return -ll if math.isfinite(ll) else 1e300

    lq = np.log10(q[free])
    grid = np.arange(-4.0, 4.5, 2.0)
    groups = [[i for i, f in enumerate(free) if f == 2], [i for i, f in enumerate(free) if f < 2]]
    for g in groups:
        if not g:
            continue
        best, best_v = lq.copy(), math.inf
        for step in grid:
            trial_lq = lq.copy()
            trial_lq[g] = lq[g] + step
            v = nll(trial_lq)
            if v < best_v:
                best, best_v = trial_lq, v
        lq = best
    f_grid = nll(lq)
    res = minimize(nll, lq, method="Nelder-Mead",
                   options={"xatol": 0.1, "fatol": 0.1, "maxfev": 60,
                            "initial_simplex": np.vstack([lq, lq + 1.0 * np.eye(lq.size)])})
    if res.fun <= f_grid:
        lq, f_grid = res.x, float(res.fun)
    qq = q.copy()
    qq[free] = 10.0 ** np.clip(lq, -20.0, 8.0)
    info = {"tuned": True, "evaluations": evals, "rows": int(sum(b[0].size for b in blocks)),
            "blocks": len(blocks),
            "neg_loglik": float(f_grid)}
    return qq, info
