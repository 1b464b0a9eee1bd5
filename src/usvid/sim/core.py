"""The integration core: fixed-step RK4 over a batch of lanes, for every model kind.

One kernel integrates simulations (a batch of runs), output-error windows, closed-loop zig-zag
replays and servo fits: the same right-hand side (the kind's ``rhs``, :mod:`usvid.models.kind`),
the same servo and limits, the same input hold. It is specialised per kind at first use (numba)
and cached on disk; chunks of lanes run in parallel on a thread pool.

Joint state of a lane (a row of ``Z``, lanes along the first axis): x, y [m, NED], psi [rad],
the kind's states, the servo angle delta [rad] and rate [rad/s], the disturbance filter (w1, w2).

Time stepping (step ``dt`` [s], lane ``b`` runs ``nsteps[b]`` steps):

* **Logic** at the start of each step: ``0`` commanded series, ``1`` turning, ``2`` zig-zag,
  ``3`` PID course change. A logic issues command *events* (time, value) into the lane's
  dead-time queue; an event takes effect on the servo input ``delay`` seconds later (servo dead
  time). Turning and zig-zag start at their exact ``t_start``; the PID and commanded series issue
  one event per step (a digital controller at the step rate, zero-order hold).
* **Events inside a step split it**: when a queued command takes effect, or an ideal servo's
  rate-limited ramp reaches its target, inside a step, that lane's step is integrated as
  sub-steps ending at those instants. An ideal servo is a rate-limited ramp (its angle has the
  piecewise-constant derivative 0 or +-max_rate, so RK4 integrates it exactly); first- and
  second-order servos are integrated with the vessel (Mu et al. 2018, eq. 11-12).
* **Zig-zag switching is event-located**: after a step in which the heading deviation crossed
  the switching angle, the crossing instant is interpolated linearly within the step, the
  command reverses there, and (without dead time) the step is integrated again with the
  reversal at that instant. Simulated manoeuvres are then continuous in the model parameters
  (output-error fits of zig-zags need that) and their metrics do not jump with dt.
* **Measured inputs** (rudder angle ``delta``, shaft speed ``n``, thruster commands) are linear
  between samples (first-order hold) inside the step; a measured rudder angle bypasses the
  servo. A commanded ``delta_cmd`` series goes through the servo (zero-order hold).
* **Divergence**: a lane whose state stops being finite, or whose yaw rate exceeds
  :data:`R_MAX`, stops; its status says when (``SimResult.success``/``message``).

Records (every ``record_every`` steps, at the step start): :data:`CHANNELS`. Accumulators per
lane: ITAE [rad s^2] and IAE [rad s] of the heading error (course logic, trapezoid at the step
points), max |delta| [rad]; zig-zag reversal instants and overshoots (:data:`N_ZZ`).

The cos/sin of the heading and of the steering angle are rotated from the step start's values by
the angle-sum formula (:func:`_rot`) instead of library calls.
"""

from __future__ import annotations

import math
import types
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba
import numpy as np
from numba.np.unsafe.ndarray import to_fixed_tuple

from usvid.models.kind import S0, ModelKind

#: fast-math flags: FMA contraction and reassociation, NaN/inf semantics kept (np.isnan)
_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}

#: Recorded channels in this order (``slots[i]``: row of channel i in ``rec``, or -1).
CHANNELS = ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n", "n_port", "n_stbd",
            "dist")
#: Logic codes.
COMMANDED, TURNING, ZIGZAG, COURSE = 0, 1, 2, 3
#: FOH input series channels (rows of ``F0``/``F1``): measured rudder angle, n, n_port, n_stbd.
SERIES = ("delta", "n", "n_port", "n_stbd")
#: Zig-zag overshoots tracked online.
N_ZZ = 8
#: Seed disturbance filter 0.42 s / (s^2 + 0.36 s + 0.37) (Mu et al. 2018, section 6.1).
DIST_B, DIST_A1, DIST_A0 = 0.42, 0.36, 0.37
#: Largest |r| [rad/s] before a lane is declared diverged.
R_MAX = 100.0
#: Servo row layout: max_angle, max_rate, T or omega_n, zeta, gain, delay [s], 1/T.
SERVO_ROWS = 7

#: Length of a lane's joint-state tuple in the step (x, y, psi, four kind states, servo angle
#: and rate, disturbance filter).
NT = 11
#: Length of a lane's parameter tuple: the kind's packed length (a constant of the
#: specialisation, see :func:`kernel`).
NPK = 1
BU, BV, BR = -1, -1, 0  # positions of u, v, r among the kind's states (-1: constant U / zero)
ZU, ZV, ZR = 3, 4, 3  # their positions in the joint-state tuple (literal indices)
SPEED_ROW = 3  # position of the constant speed U in a constant-speed kind's parameters

# -- kind-specific globals (replaced when a kind is specialised) -----------------------------
NS = 1  # number of kind states
TRIG = False  # the kind reads cos/sin of the steering angle


def rhs(P, b, Z, D, delta, cd, sd, n, n_port, n_stbd):  # pragma: no cover - placeholder
    return 0.0, 0.0, 0.0


# -- scalar helpers ----------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _splitmix(state: np.uint64) -> tuple[np.uint64, np.uint64]:
    state = state + np.uint64(0x9E3779B97F4A7C15)
    z = state
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return state, z


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _normal(state: np.uint64) -> tuple[np.uint64, float]:
    """One standard normal by Box-Muller from two splitmix64 uniforms."""
    state, a = _splitmix(state)
    state, b = _splitmix(state)
    u1 = ((a >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = (b >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return state, math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _clip(x: float, lim: float) -> float:
    if x > lim:
        return lim
    if x < -lim:
        return -lim
    return x


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _rot(a: float, a0: float, c0: float, s0: float) -> tuple[float, float]:
    """(cos a, sin a) from (c0, s0) = (cos a0, sin a0): for |a - a0| <= 0.05 rad by the
    angle-sum formula with the Taylor series of cos h, sin h to h^7 (error < 1e-16 there),
    else the library functions (a lane's code is scalar: the branch is predictable)."""
    h = a - a0
    if abs(h) > 0.05:
        return math.cos(a), math.sin(a)
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    return c0 * ch - s0 * sh, s0 * ch + c0 * sh


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _push(qt, qv, head, n, tr, value):
    """Queue a command taking effect at time tr in a lane's dead-time ring buffer (qt, qv);
    returns the new (head, n). A newer command due at the same time replaces the older one."""
    cap = qt.shape[0]
    if n > 0:
        last = (head + n - 1) % cap
        if qt[last] == tr:
            qv[last] = value
            return head, n
    if n == cap:  # full (the driver sizes the buffer so that this cannot happen)
        head = (head + 1) % cap
        n -= 1
    slot = (head + n) % cap
    qt[slot] = tr
    qv[slot] = value
    return head, n + 1


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _start_ramp(t, target, d, rate):
    """An ideal servo at angle d [rad] gets a new target at time t: (angle now, ramp rate
    [rad/s], ramp end time [s]) -- a jump without a rate limit."""
    gap = target - d
    if gap == 0.0:
        return d, 0.0, math.inf
    if math.isinf(rate):
        return target, 0.0, math.inf
    return d, (rate if gap > 0.0 else -rate), t + abs(gap) / rate


# -- the kernel template (specialised per kind) -----------------------------------------------
def _deriv(p, tau, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, z):
    """Time derivative of a lane's joint-state tuple ``z`` (x, y, psi, four kind states, servo
    angle and rate, disturbance filter) at the fraction ``tau`` of the current step.

    ``p`` the lane's parameter tuple, ``srv`` its servo values (max angle, max rate, T or
    omega_n, zeta, gain, delay, 1/T) blended with the batch's 0/1 weights w0 (ideal: ramp
    rate ``ramp``), w1 (first order), w2 (second order) driven by ``cmdin``; ``noise`` the
    step's white-noise sample; ``fs`` the first-order-hold series (start and end values of
    delta, n, n_port, n_stbd; NaN when absent); ``tr`` the trig bases (psi0, cos, sin, de0,
    cos, sin) of the step start. Scalars and tuples only.
    """
    zdl = z[7]
    ma = srv[0]
    mr = srv[1]
    d = _clip(zdl, ma)
    w = z[8]
    rate = w1 * _clip((cmdin - zdl) * srv[6], mr) + w2 * _clip(w, mr)
    if (zdl >= ma and rate > 0.0) or (zdl <= -ma and rate < 0.0):
        rate = 0.0
    wn = srv[2]
    w2d = z[10]
    fd = fs[0] + tau * (fs[4] - fs[0])
    de = (d if np.isnan(fd) else fd) + DIST_B * w2d
    cd = 1.0
    sd = 0.0
    if TRIG:
        cd, sd = _rot(de, tr[3], tr[4], tr[5])
    u, v, r, d0, d1, d2, d3 = rhs(p, z[3], z[4], z[5], z[6], de, cd, sd,
                                  fs[1] + tau * (fs[5] - fs[1]),
                                  fs[2] + tau * (fs[6] - fs[2]),
                                  fs[3] + tau * (fs[7] - fs[3]))
    cps, sps = _rot(z[2], tr[0], tr[1], tr[2])
    return (u * cps - v * sps, u * sps + v * cps, r, d0, d1, d2, d3,
            w0 * ramp + rate, w2 * (wn * wn * (srv[4] * cmdin - zdl) - 2.0 * srv[3] * wn * w),
            w2d, -DIST_A0 * z[9] - DIST_A1 * w2d + noise)


def _axpy(z, h, k):
    """z + h k for the joint-state tuples."""
    return (z[0] + h * k[0], z[1] + h * k[1], z[2] + h * k[2], z[3] + h * k[3],
            z[4] + h * k[4], z[5] + h * k[5], z[6] + h * k[6], z[7] + h * k[7],
            z[8] + h * k[8], z[9] + h * k[9], z[10] + h * k[10])


def _rk4(p, z, h, tau0, frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr):
    """One classical RK4 step of length h [s] from z, covering the fractions tau0 .. tau0 +
    frac of the current step (for the first-order-hold series)."""
    k1 = _deriv(p, tau0, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, z)
    tm = tau0 + 0.5 * frac
    k2 = _deriv(p, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k1))
    k3 = _deriv(p, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k2))
    k4 = _deriv(p, tau0 + frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, h, k3))
    h6 = h / 6.0
    return (z[0] + h6 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            z[1] + h6 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            z[2] + h6 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
            z[3] + h6 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
            z[4] + h6 * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
            z[5] + h6 * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]),
            z[6] + h6 * (k1[6] + 2.0 * k2[6] + 2.0 * k3[6] + k4[6]),
            z[7] + h6 * (k1[7] + 2.0 * k2[7] + 2.0 * k3[7] + k4[7]),
            z[8] + h6 * (k1[8] + 2.0 * k2[8] + 2.0 * k3[8] + k4[8]),
            z[9] + h6 * (k1[9] + 2.0 * k2[9] + 2.0 * k3[9] + k4[9]),
            z[10] + h6 * (k1[10] + 2.0 * k2[10] + 2.0 * k3[10] + k4[10]))


def _lane(b, P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps, dt, rec_every, slots, rec,
          acc, zz, zzt, status, qt, qv):
    """Integrate lane b over its ``nsteps[b]`` steps (see the module docstring).

    The lane's parameters, servo values, state and logic variables live in locals and tuples
    during the run; its dead-time queue in the rows ``qt[b]``, ``qv[b]``; the joint state is
    written back to ``Z[b]`` at the end.
    """
    ID = S0 + NS
    p = to_fixed_tuple(P[b], NPK)
    srv = (S[b, 0], S[b, 1], S[b, 2], S[b, 3], S[b, 4], S[b, 5], S[b, 6])
    ma = srv[0]
    mr = srv[1]
    delay = srv[5]
    w0 = 1.0 if skind == 0 else 0.0
    w1 = 1.0 if skind == 1 else 0.0
    w2 = 1.0 if skind == 2 else 0.0
    lp = (L[b, 0], L[b, 1], L[b, 2], L[b, 3], L[b, 4], L[b, 5])
    qtb = qt[b]
    qvb = qv[b]
    qh = 0
    qn = 0
    z = (Z[b, 0], Z[b, 1], Z[b, 2], Z[b, S0],
         Z[b, S0 + 1] if NS > 1 else 0.0, Z[b, S0 + 2] if NS > 2 else 0.0,
         Z[b, S0 + 3] if NS > 3 else 0.0,
         Z[b, ID], Z[b, ID + 1], Z[b, ID + 2], Z[b, ID + 3])
    # at rest on the initial angle: the command in force is the one that holds it
    cmdin = z[7] / srv[4] if skind == 2 else z[7]
    cmdlog = cmdin
    ramp = 0.0
    rend = math.inf
    cur = 0.0
    psi0 = 0.0
    zzn = 0
    integ = 0.0
    itae = 0.0
    iae = 0.0
    maxd = 0.0
    if lk == ZIGZAG and lp[5] != 0.0:  # a replay started in the middle of a zig-zag
        cur = lp[5]
        psi0 = lp[4]
        cmdlog = cur * lp[0]
        cmdin = cmdlog
        if skind == 0:
            dl, ramp, rend = _start_ramp(0.0, _clip(cmdin, ma), z[7], mr)
            z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], dl, z[8], z[9], z[10])
    for i in range(N_ZZ):
        zz[b, i] = np.nan
    for i in range(N_ZZ + 1):
        zzt[b, i] = np.nan
    status[b, 0] = 0.0
    status[b, 1] = np.nan
    # noise stream (seed, stream): a splitmix hash of the seed, hashed again with the lane's
    # stream index (its lane index unless the caller shares streams between lanes)
    _, h0 = _splitmix(np.uint64(int(Dq[b, 1])))
    _, rng = _splitmix(h0 ^ np.uint64(int(Dq[b, 2])))
    esd = math.sqrt(Dq[b, 0] / dt) if Dq[b, 0] > 0.0 else 0.0
    tpsi = (z[2], math.cos(z[2]), math.sin(z[2]))
    tde = (0.0, 1.0, 0.0)
    row = b * sstride
    s0_, s1_, s2_, s3_, s4_ = sidx[0], sidx[1], sidx[2], sidx[3], sidx[4]
    n = nsteps[b]
    eps = 1e-9 * dt
    idt = 1.0 / dt
    rcount = 0
    jrec = 0
    ovmax = np.nan
    for k in range(n + 1):
        t = k * dt
        t1 = t + dt
        # -- input series at the step ends (first-order hold) --
        kk = k + 1 if k < n else k
        fs = (SER[s0_, row, k] if s0_ >= 0 else np.nan, SER[s1_, row, k] if s1_ >= 0 else np.nan,
              SER[s2_, row, k] if s2_ >= 0 else np.nan, SER[s3_, row, k] if s3_ >= 0 else np.nan,
              SER[s0_, row, kk] if s0_ >= 0 else np.nan,
              SER[s1_, row, kk] if s1_ >= 0 else np.nan,
              SER[s2_, row, kk] if s2_ >= 0 else np.nan,
              SER[s3_, row, kk] if s3_ >= 0 else np.nan)
        # -- logic -> command events --
        psi = z[2]
        if lk == COMMANDED:
            if s4_ >= 0:
                c = SER[s4_, row, k]
                if c != cmdlog or k == 0:
                    cmdlog = c
                    qh, qn = _push(qtb, qvb, qh, qn, t + delay, c)
        elif lk == TURNING:
            if cur == 0.0 and lp[1] < t1 - eps:
                cur = 1.0
                cmdlog = lp[0]
                qh, qn = _push(qtb, qvb, qh, qn, max(lp[1], t) + delay, lp[0])
        elif lk == ZIGZAG:
            if cur == 0.0 and lp[3] < t1 - eps:
                cur = lp[2]
                psi0 = psi if np.isnan(lp[4]) else lp[4]
                tev = max(lp[3], t)
                zzt[b, 0] = tev
                cmdlog = cur * lp[0]
                qh, qn = _push(qtb, qvb, qh, qn, tev + delay, cmdlog)
        else:
            err = _wrap(lp[0] - psi)
            c = lp[1] * err + lp[2] * integ - lp[3] * z[ZR]
            sat = c > ma or c < -ma
            if not (lp[4] != 0.0 and sat and c * err > 0.0):
                integ += err * dt
            w = 0.5 if (k == 0 or k == n) else 1.0
            itae += w * t * abs(err) * dt
            iae += w * abs(err) * dt
            cmdlog = c
            qh, qn = _push(qtb, qvb, qh, qn, t + delay, c)
        # -- events due at the step start --
        while qn > 0 and qtb[qh] <= t + eps:
            cmdin = qvb[qh]
            qh = (qh + 1) % qtb.shape[0]
            qn -= 1
            if skind == 0:
                dl, ramp, rend = _start_ramp(t, _clip(cmdin, ma), z[7], mr)
                z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], dl, z[8], z[9], z[10])
        if rend <= t + eps:
            z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], _clip(cmdin, ma), z[8], z[9], z[10])
            ramp = 0.0
            rend = math.inf
        # -- record (at the step start) --
        dnow = _clip(z[7], ma) if np.isnan(fs[0]) else fs[0]
        if abs(dnow) > maxd:
            maxd = abs(dnow)
        if rcount == 0:
            for ch in range(13):
                sl = slots[ch]
                if sl < 0:
                    continue
                if ch <= 2:
                    val = z[0] if ch == 0 else (z[1] if ch == 1 else z[2])
                elif ch == 3:
                    val = p[SPEED_ROW] if BU < 0 else z[ZU]
                elif ch == 4:
                    val = 0.0 if BV < 0 else z[ZV]
                elif ch == 5:
                    val = z[ZR]
                elif ch == 6:
                    if BU < 0:
                        val = p[SPEED_ROW]
                    else:
                        val = math.sqrt(z[ZU] * z[ZU] + z[ZV] * z[ZV])
                elif ch == 7:
                    val = dnow
                elif ch == 8:
                    val = cmdlog
                elif ch == 9:
                    val = fs[1]
                elif ch == 10:
                    val = fs[2]
                elif ch == 11:
                    val = fs[3]
                else:
                    val = DIST_B * z[10]
                rec[sl, b, jrec] = val
            jrec += 1
        rcount += 1
        if rcount == rec_every:
            rcount = 0
        if k == n:
            break
        # -- noise sample, trig bases --
        noise = 0.0
        if esd > 0.0:
            rng, g = _normal(rng)
            noise = esd * g
        c_, s_ = _rot(z[2], tpsi[0], tpsi[1], tpsi[2])
        g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
        tpsi = (z[2], c_ * g_, s_ * g_)
        if TRIG:
            de = (_clip(z[7], ma) if np.isnan(fs[0]) else fs[0]) + DIST_B * z[10]
            c_, s_ = _rot(de, tde[0], tde[1], tde[2])
            g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
            tde = (de, c_ * g_, s_ * g_)
        tr = (tpsi[0], tpsi[1], tpsi[2], tde[0], tde[1], tde[2])
        # -- the step: sub-steps ending at the events inside it (one RK4 call site); a
        # zig-zag reversal taking effect inside the step integrates it again --
        zs = z
        sv = (cmdin, ramp, rend)
        qsave = (qh, qn)
        redo_t = -1.0
        for attempt in range(2):
            if attempt == 1:
                z = zs
                cmdin, ramp, rend = sv
                qh, qn = qsave
                qh, qn = _push(qtb, qvb, qh, qn, redo_t, cmdlog)
            tc = t
            while True:
                tb = t1
                what = 0
                if qn > 0 and qtb[qh] < tb:
                    tb = qtb[qh]
                    what = 1
                if rend < tb:
                    tb = rend
                    what = 2
                if tb > tc + eps:
                    te = min(tb, t1)
                    z = _rk4(p, z, te - tc, (tc - t) * idt, (te - tc) * idt, srv, w0, w1, w2,
                             cmdin, ramp, noise, fs, tr)
                    tc = te
                if what == 1 and tb <= t1 + eps:
                    cmdin = qvb[qh]
                    qh = (qh + 1) % qtb.shape[0]
                    qn -= 1
                    if skind == 0:
                        dl, ramp, rend = _start_ramp(tb, _clip(cmdin, ma), z[7], mr)
                        z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], dl, z[8], z[9], z[10])
                elif what == 2 and tb <= t1 + eps:
                    z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], _clip(cmdin, ma), z[8],
                         z[9], z[10])
                    ramp = 0.0
                    rend = math.inf
                if what == 0 or tb >= t1 - eps:
                    break
            if attempt == 1 or lk != ZIGZAG or cur == 0.0:
                break
            # -- zig-zag switching, event-located --
            sw = lp[1]
            dev0 = zs[2] - psi0
            dev1 = z[2] - psi0
            if zzn >= 1:
                ov = -cur * dev1 - sw
                if np.isnan(ovmax) or ov > ovmax:
                    ovmax = ov
            if not ((cur > 0.0 and dev1 >= sw) or (cur < 0.0 and dev1 <= -sw)):
                break
            lvl = sw if cur > 0.0 else -sw
            f = 0.0
            if (cur > 0.0 and dev0 < lvl) or (cur < 0.0 and dev0 > lvl):
                f = (lvl - dev0) / (dev1 - dev0)
            tsw = t + f * dt
            if zzn >= 1 and zzn <= N_ZZ:
                zz[b, zzn - 1] = ovmax
            ovmax = np.nan
            cur = -cur
            zzn += 1
            if zzn <= N_ZZ:
                zzt[b, zzn] = tsw
            cmdlog = cur * lp[0]
            if tsw + delay < t1 - eps:
                redo_t = tsw + delay  # takes effect inside this step: integrate it again
                continue
            qh, qn = _push(qtb, qvb, qh, qn, tsw + delay, cmdlog)
            break
        # -- servo limits, divergence --
        if skind != 0:
            dl = z[7]
            dd = z[8]
            if dl > ma:
                dl = ma
                dd = min(dd, 0.0)
            elif dl < -ma:
                dl = -ma
                dd = max(dd, 0.0)
            if skind == 2:
                dd = _clip(dd, mr)
            z = (z[0], z[1], z[2], z[3], z[4], z[5], z[6], dl, dd, z[9], z[10])
        ok = (abs(z[ZR]) <= R_MAX and np.isfinite(z[0]) and np.isfinite(z[1])
              and np.isfinite(z[2]) and np.isfinite(z[3]) and np.isfinite(z[4])
              and np.isfinite(z[5]) and np.isfinite(z[6]))
        if not ok:
            status[b, 0] = 1.0
            status[b, 1] = t1
            break
    if zzn >= 1 and zzn <= N_ZZ:  # the overshoot after the last reversal, so far
        zz[b, zzn - 1] = ovmax
    for i in range(N_ZZ):  # an overshoot counts once the next reversal has happened
        if i + 2 > zzn:
            zz[b, i] = np.nan
    acc[b, 0] = itae
    acc[b, 1] = iae
    acc[b, 2] = maxd
    Z[b, 0] = z[0]
    Z[b, 1] = z[1]
    Z[b, 2] = z[2]
    for i in range(NS):
        Z[b, S0 + i] = z[3 + i]
    Z[b, ID] = z[7]
    Z[b, ID + 1] = z[8]
    Z[b, ID + 2] = z[9]
    Z[b, ID + 3] = z[10]


def _lanes(lo, hi, P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps, dt, rec_every,
           slots, rec, acc, zz, zzt, status, qt, qv):
    """Integrate lanes lo..hi-1 (one task of :func:`run`)."""
    for b in range(lo, hi):
        _lane(b, P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps, dt, rec_every, slots,
              rec, acc, zz, zzt, status, qt, qv)


def run(kind: ModelKind, P: np.ndarray, S: np.ndarray, skind: int, lk: int, L: np.ndarray,
        Dq: np.ndarray, SER: np.ndarray, sidx: np.ndarray, Z: np.ndarray, nsteps: np.ndarray,
        dt: float, rec_every: int, slots: np.ndarray, rec: np.ndarray, acc: np.ndarray,
        zz: np.ndarray, zzt: np.ndarray, status: np.ndarray, qcap: int,
        chunk: int = 8) -> None:
    """Integrate all lanes of ``Z`` (in place) and fill the outputs.

    Arrays are lane-major (a lane's parameters, state and work values contiguous): ``P``
    (B, n_params), ``S`` (B, SERVO_ROWS), ``L`` (B, 6), ``Dq`` (B, 3) (spectral density, seed,
    noise stream index), ``Z`` (B, n_states),
    ``acc`` (B, 3), ``zz`` (B, N_ZZ), ``zzt`` (B, N_ZZ + 1), ``status`` (B, 2); ``SER``
    (n_series, 1 or B, N) and ``rec`` (n_channels, B, N_rec). Lanes are integrated in chunks of
    ``chunk`` lanes that step together; chunks run in parallel on a thread pool (the kernel is
    compiled ``nogil``), as many threads as numba's thread count.
    """
    B, nz = Z.shape
    if B == 0:
        return
    lanes = kernel(kind)
    qt, qv = np.empty((B, qcap)), np.empty((B, qcap))
    sstride = 1 if SER.shape[1] > 1 else 0

    def task(lo: int) -> None:
        lanes(lo, min(B, lo + chunk), P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps,
              dt, rec_every, slots, rec, acc, zz, zzt, status, qt, qv)

    starts = list(range(0, B, chunk))
    threads = min(numba.get_num_threads(), len(starts))
    if threads <= 1:
        for lo in starts:
            task(lo)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        for fut in [pool.submit(task, lo) for lo in starts]:
            fut.result()


_TEMPLATES = ("_deriv", "_axpy", "_rk4", "_lane", "_lanes")
_KERNELS: dict[str, Any] = {}


def kernel(kind: ModelKind) -> Any:
    """The core specialised for ``kind`` (compiled at first call, cached on disk).

    The template functions above are re-created with the kind's right-hand side and state
    layout as globals and compiled under a name that carries the kind and a hash of its module
    source, so that the on-disk cache of one kind (or of an edited kind) is never taken for
    another's. Everything that does not depend on the kind is compiled once for all kinds.
    """
    key = f"{kind.name}_{kind.source_hash or 'x'}"
    if key in _KERNELS:
        return _KERNELS[key]
    g = dict(globals())
    g.update(rhs=kind.rhs, NS=kind.n_states, TRIG=bool(kind.uses_trig), NPK=kind.n_params,
             BU=kind.body[0], BV=kind.body[1], BR=kind.body[2], SPEED_ROW=kind.speed_row,
             ZU=3 + max(kind.body[0], 0), ZV=3 + max(kind.body[1], 0), ZR=3 + kind.body[2])
    for name in _TEMPLATES:
        template = globals()[name]
        qual = f"{name}__{key}"
        code = template.__code__.replace(co_name=qual, co_qualname=qual)
        fn = types.FunctionType(code, g, qual, template.__defaults__)
        fn.__qualname__ = qual
        fn.__module__ = __name__
        opts: dict[str, Any] = {"cache": True, "error_model": "numpy", "fastmath": _FM}
        if name == "_lanes":
            opts["nogil"] = True
        if name in ("_deriv", "_axpy", "_rk4"):
            opts["inline"] = "always"  # tuples only: no reference counting
        g[name] = numba.njit(**opts)(fn)
    _KERNELS[key] = g["_lanes"]
    return g["_lanes"]
