"""The integration core: fixed-step RK4 over a batch of lanes, for every model kind.

One kernel integrates simulations (a batch of runs), output-error windows, closed-loop zig-zag
replays and servo fits: the same right-hand side (the kind's ``rhs``, :mod:`usvid.models.kind`),
the same servo and limits, the same input hold. It is specialised per kind at first use (numba)
and cached on disk; chunks of lanes run in parallel on a thread pool.

Joint state of a lane (a row of ``Z``, lanes along the first axis): x, y [m, NED], psi [rad],
the kind's states, the servo angle delta [rad] and rate [rad/s], the disturbance filter (w1, w2).
Inside a chunk its rows and the helpers that load, store and combine it are generated from the
kind's state names (:mod:`usvid.sim.layout`): a kind has any number of states.

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

import functools
import hashlib
import math
import types
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba
import numba.extending
import numpy as np
from llvmlite import ir as llvmir

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.models.kind import S0, ModelKind
from usvid.sim import layout as _layout
from usvid.sim.layout import (
    CH,
    JDD,
    JDL,
    JPSI,
    JS,
    JW1,
    JW2,
    LACT,
    LCMDLOG,
    LCUR,
    LESD,
    LFLAG,
    LIAE,
    LINTEG,
    LITAE,
    LMAXD,
    LNS,
    LOVMAX,
    LPSI0,
    LQ,
    LQH,
    LQN,
    LREND,
    LSW,
    LTQ,
    LZZN,
    RDL,
    RPSI,
    RW2,
    VCMD,
    VF,
    VL,
    VNOISE,
    VRAMP,
    VS,
    VT,
    VZ,
)

#: fast-math flags: FMA contraction and reassociation, NaN/inf semantics kept (np.isnan)
_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}

#: Recorded channels in this order (``slots[i]``: row of channel i in ``rec``, or -1).
CHANNELS = ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n", "n_port", "n_stbd",
            "dist", "phi", "p")
NCH = len(CHANNELS)
#: Channels read from a kind state of the same name (roll angle [rad], roll rate [rad/s]):
#: recorded for the kinds that have them.
STATE_CHANNELS = ("phi", "p")
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
SERVO_ROWS = len(_layout.SERVO)
#: The external force passed to the kind's right-hand side in calm water: (X, Y, K, N) all
#: -0.0, so that the kind's ``+ f[i]`` vanishes at compile time (x + -0.0 is x for every x).
NOF = (-0.0, -0.0, -0.0, -0.0)

# -- kind-specific globals (replaced when a kind is specialised, see :func:`kernel`) ----------
NS = 1  # number of kind states
NPK = 1  # length of a lane's parameter tuple (the kind's packed length)
NT = JS + 1  # length of a lane's joint-state tuple
VP = VZ + NT  # first parameter row of V
VB = VP + NPK  # first scratch row of V: the joint state and overshoot before the vector step
# (NT + 1 rows), then its new max |delta| and overshoot (copied after its lane loop)
VN = VB + NT + 3  # first row of the per-lane step's result
VROWS = VN + NT  # rows of V
BU, BV, BR = -1, -1, 0  # positions of u, v, r among the kind's states (-1: constant U / zero)
ZU, ZV, ZR = JS, JS, JS  # their positions in the joint-state tuple (and rows VZ + ..)
ZPHI, ZP = -1, -1  # positions of the states phi and p (-1: the kind has none)
SPEED_ROW = 3  # position of the constant speed U in a constant-speed kind's parameters
TRIG = False  # the kind reads cos/sin of the steering angle
SWR = -1  # the kind's switch row of P (ModelKind.switch_row; -1: none)
SWV = np.array([np.nan])  # its values with a vector step of their own (ModelKind.switch_values)
NSW = 1  # number of vector steps (at most 4: one per switch value, then the generic one)


def rhs(p, s, a, f):  # pragma: no cover - placeholder, the kind's (see :func:`kernel`)
    return 0.0, 0.0, 0.0, (0.0,)


# the joint-state and parameter helpers, generated per kind and variant from the kind's state
# names (:func:`usvid.sim.layout.joint_helpers`, :func:`usvid.sim.layout.param_tuple`)
_ztup = _zput = _states = _joint = _with_dl = _with_servo = _finite = _axpy = _rk4sum = None
_vaxpy = _vrk4sum = _vput = _ptup = None


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


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, forceinline=True)
def _rot_nan(a: float, a0: float, c0: float, s0: float) -> tuple[float, float]:
    """:func:`_rot` without the library branch, for the vectorised step: (NaN, NaN) where
    |a - a0| > 0.05 rad (that lane's step is then integrated again by :func:`_rot`)."""
    h = a - a0
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    bad = np.nan if abs(h) > 0.05 else 0.0  # (added, not selected: with a select of the
    # results LLVM loads c0, s0 only where they are used, masked)
    return (c0 * ch - s0 * sh) + bad, (s0 * ch + c0 * sh) + bad


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _push(qt, qv, b, head, n, tr, value):
    """Queue a command taking effect at time tr in lane b's dead-time ring buffer (rows
    ``qt[b]``, ``qv[b]``); returns the new (head, n). A newer command due at the same time
    replaces the older one."""
    cap = qt.shape[1]
    if n > 0:
        last = (head + n - 1) % cap
        if qt[b, last] == tr:
            qv[b, last] = value
            return head, n
    if n == cap:  # full (the driver sizes the buffer so that this cannot happen)
        head = (head + 1) % cap
        n -= 1
    slot = (head + n) % cap
    qt[b, slot] = tr
    qv[b, slot] = value
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
    """Time derivative of a lane's joint-state tuple ``z`` (x, y, psi, servo angle and rate,
    disturbance filter, the kind's states: :mod:`usvid.sim.layout`) at the fraction ``tau`` of
    the current step.

    ``p`` the lane's parameter tuple, ``srv`` its servo values (max angle, max rate, T or
    omega_n, zeta, gain, delay, 1/T) blended with the batch's 0/1 weights w0 (ideal: ramp
    rate ``ramp``), w1 (first order), w2 (second order) driven by ``cmdin``; ``noise`` the
    step's white-noise sample; ``fs`` the first-order-hold series (start and end values of
    delta, n, n_port, n_stbd; NaN when absent); ``tr`` the trig bases (psi0, cos, sin, de0,
    cos, sin) of the step start. Scalars and tuples only.
    """
    zdl = z[JDL]
    ma = srv[0]
    mr = srv[1]
    d = _clip(zdl, ma)
    w = z[JDD]
    rate = w1 * _clip((cmdin - zdl) * srv[6], mr) + w2 * _clip(w, mr)
    if (zdl >= ma and rate > 0.0) or (zdl <= -ma and rate < 0.0):
        rate = 0.0
    wn = srv[2]
    w2d = z[JW2]
    fd = fs[0] + tau * (fs[4] - fs[0])
    de = (d if np.isnan(fd) else fd) + DIST_B * w2d
    cd = 1.0
    sd = 0.0
    if TRIG:
        cd, sd = _rot(de, tr[3], tr[4], tr[5])
    u, v, r, ds = rhs(p, _states(z), (de, cd, sd, fs[1] + tau * (fs[5] - fs[1]),
                                      fs[2] + tau * (fs[6] - fs[2]),
                                      fs[3] + tau * (fs[7] - fs[3])), NOF)
    cps, sps = _rot(z[JPSI], tr[0], tr[1], tr[2])
    return _joint(u * cps - v * sps, u * sps + v * cps, r, w0 * ramp + rate,
                  w2 * (wn * wn * (srv[4] * cmdin - zdl) - 2.0 * srv[3] * wn * w),
                  w2d, -DIST_A0 * z[JW1] - DIST_A1 * w2d + noise, ds)


def _rk4(p, z, h, tau0, frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr):
    """One classical RK4 step of length h [s] from z, covering the fractions tau0 .. tau0 +
    frac of the current step (for the first-order-hold series)."""
    k1 = _deriv(p, tau0, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, z)
    tm = tau0 + 0.5 * frac
    k2 = _deriv(p, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k1))
    k3 = _deriv(p, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k2))
    k4 = _deriv(p, tau0 + frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, h, k3))
    return _rk4sum(z, h / 6.0, k1, k2, k3, k4)


# -- the vector step (compiled per kind and variant, see :func:`vector_step`) -----------------
#: Variant constants of the vector step: servo kind (0 ideal, 1 first order, 2 second order);
#: no disturbance and no input series in the batch (the disturbance filter stays at rest and
#: the steering angle is the servo's); x and y integrated (not when neither is recorded: no
#: other quantity depends on them, and with them goes the heading's rotation).
SK, NOD, XY = 2, False, True


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, forceinline=True)
def _rotv(a: float, a0: float, c0: float, s0: float) -> tuple[float, float, float]:
    """:func:`_rot` without the library branch, for the vector step: (cos a, sin a, |a - a0|);
    the caller flags the lane when |a - a0| > 0.05 rad (the series is then not accurate)."""
    h = a - a0
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    return c0 * ch - s0 * sh, s0 * ch + c0 * sh, abs(h)


def _vderiv(p, tau, srv, cmdin, ramp, noise, fs, tr, z, first):
    """:func:`_deriv` for the vector step, with the variant's constants :data:`SK`,
    :data:`NOD`, :data:`XY` (the branches of the other variants vanish at compile time); returns
    (the derivative, the largest |angle - base angle| of its rotations). ``first``: the step
    start (stage 1), where the angles are the bases' own (no rotation)."""
    zdl = z[JDL]
    ma = srv[0]
    mr = srv[1]
    d = _clip(zdl, ma)
    w = z[JDD]
    if SK == 0:  # the ramp (not limited: it ends at the target)
        rate = ramp
    else:
        if SK == 1:
            rate = _clip((cmdin - zdl) * srv[6], mr)
        elif SK == 2:
            rate = _clip(w, mr)
        else:  # any servo kind: the blend of the per-lane flavour (weights w0, w1, w2 in srv)
            rate = srv[8] * _clip((cmdin - zdl) * srv[6], mr) + srv[9] * _clip(w, mr)
        if (zdl >= ma and rate > 0.0) or (zdl <= -ma and rate < 0.0):
            rate = 0.0
        if SK < 0:
            rate = srv[7] * ramp + rate
    if NOD:
        de = d
        n0 = np.nan
        n1 = np.nan
        n2 = np.nan
    else:
        fd = fs[0] + tau * (fs[4] - fs[0])
        de = (d if np.isnan(fd) else fd) + DIST_B * z[JW2]
        n0 = fs[1] + tau * (fs[5] - fs[1])
        n1 = fs[2] + tau * (fs[6] - fs[2])
        n2 = fs[3] + tau * (fs[7] - fs[3])
    cd = 1.0
    sd = 0.0
    hm = 0.0
    if TRIG:
        if first and NOD:  # the steering angle is its base's
            cd = tr[4]
            sd = tr[5]
        else:
            cd, sd, hm = _rotv(de, tr[3], tr[4], tr[5])
    u, v, r, ds = rhs(p, _states(z), (de, cd, sd, n0, n1, n2), NOF)
    k0 = 0.0
    k1 = 0.0
    if XY:
        cps = tr[1]
        sps = tr[2]
        if not first:
            cps, sps, hp = _rotv(z[JPSI], tr[0], tr[1], tr[2])
            hm = max(hm, hp)
        k0 = u * cps - v * sps
        k1 = u * sps + v * cps
    acc = 0.0
    if SK == 2 or SK < 0:
        wn = srv[2]
        acc = wn * wn * (srv[4] * cmdin - zdl) - 2.0 * srv[3] * wn * w
        if SK < 0:
            acc = srv[9] * acc
    k5 = 0.0
    k6 = 0.0
    if not NOD:
        k5 = z[JW2]
        k6 = -DIST_A0 * z[JW1] - DIST_A1 * z[JW2] + noise
    return _joint(k0, k1, r, rate, acc, k5, k6, ds), hm


def _vrk4(p, z, h, frac, srv, cmdin, ramp, noise, fs, tr):
    """:func:`_rk4` for the vector step (a whole step: tau from 0 to ``frac``); the heading
    is NaN when an angle moved more than 0.05 rad from its base (the lane is then flagged)."""
    k1, m1 = _vderiv(p, 0.0, srv, cmdin, ramp, noise, fs, tr, z, True)
    tm = 0.5 * frac
    k2, m2 = _vderiv(p, tm, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, 0.5 * h, k1), False)
    k3, m3 = _vderiv(p, tm, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, 0.5 * h, k2), False)
    k4, m4 = _vderiv(p, frac, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, h, k3), False)
    far = max(max(m1, m2), max(m3, m4)) > 0.05
    return _vrk4sum(z, h / 6.0, k1, k2, k3, k4, far)


# -- a chunk's work array V: row r of lane j at V[r * CH + j] (:mod:`usvid.sim.layout`) -------
def _inputs(V, j):
    """Lane j's servo values, input series and trig bases from ``V``."""
    o = VS * CH + j
    srv = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
           V[o + 6 * CH])
    o = VF * CH + j
    fs = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
          V[o + 6 * CH], V[o + 7 * CH])
    o = VT * CH + j
    tr = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH])
    return srv, fs, tr


def _load_series(V, o, SER, sidx, row, k, kk):
    """The input series at the step ends (first-order hold) into the rows VF.. of ``V``."""
    for i in range(4):
        s = sidx[i]
        V[o + i * CH] = SER[s, row, k] if s >= 0 else np.nan
        V[o + (4 + i) * CH] = SER[s, row, kk] if s >= 0 else np.nan


def _steer(V, j):
    """Lane j's steering angle at the step start [rad]: the measured one, else the servo's
    (limited), plus the disturbance."""
    fd = V[VF * CH + j]
    # every value loaded whatever fd and the clip written as selects (:func:`_clip`): no
    # branch, no conditional load, so that the lane loop of :func:`_vbases` vectorises
    x = V[RDL * CH + j]
    ma = V[VS * CH + j]
    d = ma if x > ma else (-ma if x < -ma else x)
    return (d if np.isnan(fd) else fd) + DIST_B * V[RW2 * CH + j]


def _vbases(V):
    """The step's trig bases (angle, cos, sin of the heading; TRIG: of the steering angle) for
    all CH lane slots, rotated from the previous step's (:func:`_rot_nan`, vectorised) and
    renormalised; NaN where the angle moved more than 0.05 rad (then :func:`_base_far`).
    Returns the number of NaN bases."""
    nfar = 0.0
    for j in range(CH):
        o = VT * CH + j
        a = V[RPSI * CH + j]
        c_, s_ = _rot_nan(a, V[o], V[o + CH], V[o + 2 * CH])
        g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
        V[o] = a
        V[o + CH] = c_ * g_
        V[o + 2 * CH] = s_ * g_
        nfar += 1.0 if np.isnan(c_) else 0.0
    if TRIG:  # a loop of its own: LLVM vectorises the two loops, not the fused one
        for j in range(CH):
            o = (VT + 3) * CH + j
            a = _steer(V, j)
            c_, s_ = _rot_nan(a, V[o], V[o + CH], V[o + 2 * CH])
            g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
            V[o] = a
            V[o + CH] = c_ * g_
            V[o + 2 * CH] = s_ * g_
            nfar += 1.0 if np.isnan(c_) else 0.0
    return nfar


def _base_far(V, j, i, a):
    """Trig base ``i`` (0 heading, 3 steering) of lane j at angle a [rad] by the library."""
    o = (VT + i) * CH + j
    c_ = math.cos(a)
    s_ = math.sin(a)
    g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
    V[o] = a
    V[o + CH] = c_ * g_
    V[o + 2 * CH] = s_ * g_


def _vstep(Vp, h, frac, zig, sk):
    """One step of all :data:`CH` lane slots of a chunk, vectorised across lanes (the lane loop
    innermost; a C callback, see :func:`vector_step`): the step's trig bases, one RK4 step of
    length h [s] (the fraction ``frac`` of the step), and the end of the step of the quiet
    lanes (row LQ); returns the number of active lanes flagged (row LFLAG = 1) for the per-lane
    branch of :func:`_chunk`. The trip count is the constant CH whatever the chunk's number of
    lanes (unused slots hold zeros or stale values and are ignored): every lane is computed by
    the same vector code, so a lane's result does not depend on its position or on the
    chunking.

    ``Vp`` points to the chunk's work array ``V`` (rows: joint state, servo values, command /
    ramp rate / noise, input series, trig bases, logic variables, parameters, scratch;
    :mod:`usvid.sim.layout`): one array, so that LLVM knows every access's offset and needs
    no alias checks. Per lane slot:

    * trig bases: the heading's (with :data:`XY`) and, for a TRIG kind, the steering angle's,
      rotated from the previous step's (:func:`_rot_nan`) and renormalised; NaN where the angle
      moved more than 0.05 rad (the lane is then flagged, and its bases are computed by the
      library before the per-lane step);
    * max |delta| of the quiet lanes at the step start;
    * the RK4 step (:func:`_vrk4`; the heading NaN where an angle moved more than 0.05 rad from
      its base within the step);
    * the end of the step, the same arithmetic as the per-lane branch of :func:`_chunk`: the
      servo limits, the zig-zag overshoot tracker (``zig``: the logic is a zig-zag); a lane is
      flagged when its step must go the per-lane way: not quiet, a state not finite, a zig-zag
      reversal inside the step, or divergence (:data:`R_MAX`).

    The new rows (joint state, overshoot) of every lane slot go into ``V``, the old ones into
    the scratch rows ``zb``, from which :func:`_chunk` restores the flagged and the inactive
    lanes (:func:`_restore`): a blend stored in place (``V[o] = new if fast else V[o]``)
    compiles to masked stores, microcoded on AMD Zen; for the same reason the new max |delta|
    and overshoot (a select of the old value) go to scratch rows and are copied afterwards.
    """
    V = numba.carray(Vp, VROWS * CH)
    w0 = 1.0 if sk == 0.0 else 0.0  # the servo blend's weights (variant SK = -1)
    w1 = 1.0 if sk == 1.0 else 0.0
    w2 = 1.0 if sk == 2.0 else 0.0
    nslow = 0.0
    for j in range(CH):
        a = V[RPSI * CH + j]
        c0 = 1.0
        s0 = 0.0
        if XY:
            o = VT * CH + j
            c_, s_ = _rot_nan(a, V[o], V[o + CH], V[o + 2 * CH])
            g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
            c0 = c_ * g_
            s0 = s_ * g_
            V[o] = a
            V[o + CH] = c0
            V[o + 2 * CH] = s0
        x7 = V[RDL * CH + j]
        ma = V[VS * CH + j]
        d = ma if x7 > ma else (-ma if x7 < -ma else x7)  # _clip, as selects
        a3 = 0.0
        c3 = 1.0
        s3 = 0.0
        if TRIG:
            o = (VT + 3) * CH + j
            a3 = d if NOD else _steer(V, j)
            c_, s_ = _rot_nan(a3, V[o], V[o + CH], V[o + 2 * CH])
            g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
            c3 = c_ * g_
            s3 = s_ * g_
            V[o] = a3
            V[o + CH] = c3
            V[o + 2 * CH] = s3
        tr = (a, c0, s0, a3, c3, s3)
        o = VS * CH + j
        srv = (ma, V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
               V[o + 6 * CH], w0, w1, w2)
        if NOD:
            fs = (np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan)
        else:
            o = VF * CH + j
            fs = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
                  V[o + 6 * CH], V[o + 7 * CH])
        z = _ztup(V, j)
        y = _vrk4(_ptup(V, j), z, h, frac, srv, V[VCMD * CH + j], V[VRAMP * CH + j],
                  V[VNOISE * CH + j], fs, tr)
        quiet = V[(VL + LQ) * CH + j] > 0.0
        # max |delta| of the quiet lanes at the step start (the measured angle is absent on
        # the quiet path: the servo's, limited)
        V[(VB + NT + 1) * CH + j] = max(V[(VL + LMAXD) * CH + j], abs(d) if quiet else 0.0)
        # the end of the step (bitwise & and |: no short-circuit branches in the vector loop;
        # every load unconditional, clips as selects: no masked loads and stores)
        ok = _finite(y)
        cur = V[(VL + LCUR) * CH + j]
        cur = cur if zig > 0.0 else 0.0
        sw = V[(VL + LSW) * CH + j]
        dev1 = y[JPSI] - V[(VL + LPSI0) * CH + j]
        cross = ((cur > 0.0) & (dev1 >= sw)) | ((cur < 0.0) & (dev1 <= -sw))
        ovmax = V[(VL + LOVMAX) * CH + j]
        ov = -cur * dev1 - sw
        upd = (cur != 0.0) & (V[(VL + LZZN) * CH + j] >= 1.0) & (np.isnan(ovmax) | (ov > ovmax))
        dl = y[JDL]
        dd = y[JDD]
        if SK != 0:
            above = dl > ma
            below = dl < -ma
            dd2 = min(dd, 0.0) if above else (max(dd, 0.0) if below else dd)
            dl2 = ma if above else (-ma if below else dl)
            if SK == 2 or SK < 0:
                mr = srv[1]
                dd3 = mr if dd2 > mr else (-mr if dd2 < -mr else dd2)
                dd2 = dd3 if (SK == 2 or sk == 2.0) else dd2
            dl = dl2 if (SK > 0 or sk != 0.0) else dl
            dd = dd2 if (SK > 0 or sk != 0.0) else dd
        fast = quiet & ok & (not cross) & (abs(y[ZR]) <= R_MAX)
        flag = 0.0 if fast else 1.0
        V[(VL + LFLAG) * CH + j] = flag
        nslow += flag * V[(VL + LACT) * CH + j]  # (a product: a select would load it masked)
        _zput(V, VB * CH + j, z)
        V[(VB + NT) * CH + j] = ovmax
        V[(VB + NT + 2) * CH + j] = ov if upd else ovmax
        _vput(V, j, y, dl, dd)
    for j in range(CH):
        V[(VL + LMAXD) * CH + j] = V[(VB + NT + 1) * CH + j]
        V[(VL + LOVMAX) * CH + j] = V[(VB + NT + 2) * CH + j]
    return nslow


@numba.extending.intrinsic
def _vcall(typingctx, addr, V, h, frac, zig, sk):
    """Call the vector step at address ``addr`` (:func:`vector_step`) on the array V."""
    f8 = numba.types.float64
    sig = f8(numba.types.int64, V, f8, f8, f8, f8)

    def codegen(context, builder, signature, args):
        a, v, hh, fr, zg, k = args
        pv = context.make_array(signature.args[1])(context, builder, v).data
        fnty = llvmir.FunctionType(llvmir.DoubleType(),
                                   [pv.type, hh.type, fr.type, zg.type, k.type])
        fn = builder.inttoptr(a, fnty.as_pointer())
        return builder.call(fn, [pv, hh, fr, zg, k])

    return sig, codegen


def _substeps(V, j, z, t, t1, eps, idt, w0, w1, w2, skind, cmdin, ramp, rend, qt, qv, b, qh,
              qn):
    """Lane j's step from t to t1 [s] on the per-lane path: sub-steps ending at the events
    inside it (dead-time queue of lane b, end of an ideal servo's ramp), one RK4 call site.
    Returns (z, cmdin, ramp, rend, qh, qn)."""
    p = _ptup(V, j)
    srv, fs, tr = _inputs(V, j)
    noise = V[VNOISE * CH + j]
    ma = srv[0]
    mr = srv[1]
    cap = qt.shape[1]
    tc = t
    while True:
        tb = t1
        what = 0
        if qn > 0 and qt[b, qh] < tb:
            tb = qt[b, qh]
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
            cmdin = qv[b, qh]
            qh = (qh + 1) % cap
            qn -= 1
            if skind == 0:
                dl, ramp, rend = _start_ramp(tb, _clip(cmdin, ma), z[JDL], mr)
                z = _with_dl(z, dl)
        elif what == 2 and tb <= t1 + eps:
            z = _with_dl(z, _clip(cmdin, ma))
            ramp = 0.0
            rend = math.inf
        if what == 0 or tb >= t1 - eps:
            break
    return z, cmdin, ramp, rend, qh, qn


def _chval(V, j, ch, dnow, cmdlog):
    """Lane j's value of channel ``ch`` (:data:`CHANNELS`) at the step start."""
    if ch <= 2:
        return V[(VZ + ch) * CH + j]  # x, y, psi
    if ch == 3:
        return V[(VP + SPEED_ROW) * CH + j] if BU < 0 else V[(VZ + ZU) * CH + j]
    if ch == 4:
        return 0.0 if BV < 0 else V[(VZ + ZV) * CH + j]
    if ch == 5:
        return V[(VZ + ZR) * CH + j]
    if ch == 6:
        if BU < 0:
            return V[(VP + SPEED_ROW) * CH + j]
        vu = V[(VZ + ZU) * CH + j]
        vv = V[(VZ + ZV) * CH + j]
        return math.sqrt(vu * vu + vv * vv)
    if ch == 7:
        return dnow
    if ch == 8:
        return cmdlog
    if ch <= 11:
        return V[(VF + ch - 8) * CH + j]  # n, n_port, n_stbd at the step start
    if ch == 12:
        return DIST_B * V[RW2 * CH + j]
    if ch == 13:
        return np.nan if ZPHI < 0 else V[(VZ + ZPHI) * CH + j]
    return np.nan if ZP < 0 else V[(VZ + ZP) * CH + j]


def _record(V, j, b, jrec, slots, rec, dnow, cmdlog):
    """Record lane j (lane b of the batch) at the step start into ``rec[:, b, jrec]``."""
    for ch in range(NCH):
        sl = slots[ch]
        if sl >= 0:
            rec[sl, b, jrec] = _chval(V, j, ch, dnow, cmdlog)


def _vrecord(V, lo, W, jrec, slots, rec):
    """Record the quiet lanes (row LQ) of the chunk at the step start, channel by channel (the
    values of :func:`_record`: the measured steering angle is absent on the quiet path)."""
    for ch in range(NCH):
        sl = slots[ch]
        if sl < 0:
            continue
        for j in range(W):
            if V[(VL + LQ) * CH + j] > 0.0:
                rec[sl, lo + j, jrec] = _chval(V, j, ch, _clip(V[RDL * CH + j], V[VS * CH + j]),
                                               V[(VL + LCMDLOG) * CH + j])


def _quiet_until(V, j, b, lk, L, qt, busy):
    """Time [s] up to which lane j (lane b of the batch) is quiet: no command event queued, no
    ideal-servo ramp ending and no logic start pending before it (-inf: never, for logics and
    inputs acting at every step, or a noise input). A step ending at t1 with t1 + eps <= this
    time takes the quiet path of :func:`_chunk` (the per-lane branches would do nothing)."""
    if busy or V[(VL + LESD) * CH + j] > 0.0:
        return -math.inf
    tq = math.inf
    if V[(VL + LQN) * CH + j] > 0.0:
        tq = qt[b, int(V[(VL + LQH) * CH + j])]
    rend = V[(VL + LREND) * CH + j]
    if rend < tq:
        tq = rend
    if V[(VL + LCUR) * CH + j] == 0.0:
        ts = math.inf
        if lk == ZIGZAG:
            ts = L[b, 3]
        elif lk == TURNING:
            ts = L[b, 1]
        if ts < tq:
            tq = ts
    return tq


def _vquiet(V, kf, tq1):
    """Row LQ = 1 for the active lanes that are quiet in the step ending at t1 (``tq1`` = t1 +
    eps, ``kf`` the step index; see :func:`_quiet_until`), vectorised; returns their number."""
    nq = 0.0
    for j in range(CH):
        q = ((V[(VL + LACT) * CH + j] > 0.0) & (kf < V[(VL + LNS) * CH + j])
             & (tq1 <= V[(VL + LTQ) * CH + j]))
        f = 1.0 if q else 0.0
        V[(VL + LQ) * CH + j] = f
        nq += f
    return nq


def _vmaxd(V, tmp):
    """max |delta| [rad] of the quiet lanes (row LQ) at the step start, vectorised (the
    measured steering angle is absent on the quiet path: the servo's, limited).

    The updated row goes through the scratch row ``tmp`` (CH values) and is copied back:
    ``V[o] = new if cond else V[o]`` would compile to a masked store (``vmaskmovpd``, slow)."""
    o = (VL + LMAXD) * CH
    for j in range(CH):
        x = V[RDL * CH + j]
        ma = V[VS * CH + j]
        d = abs(ma if x > ma else (-ma if x < -ma else x))  # _clip, as selects
        m = V[o + j]
        tmp[j] = d if ((V[(VL + LQ) * CH + j] > 0.0) & (d > m)) else m
    for j in range(CH):
        V[o + j] = tmp[j]


def _restore(V, zb, j):
    """Lane j's joint state and overshoot from before the vector step (:func:`_vstep`)."""
    for r in range(NT):
        V[(VZ + r) * CH + j] = zb[r * CH + j]
    V[(VL + LOVMAX) * CH + j] = zb[NT * CH + j]


def _chunk(lo, hi, P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps, dt, rec_every, slots,
           rec, acc, zz, zzt, status, qt, qv, simd, vaddr):
    """Integrate lanes lo..hi-1 (at most :data:`CH`) together: one task of :func:`run`.

    The chunk's joint states, parameters, servo values, inputs and logic variables live in
    the work array ``V`` (a row per quantity, a column per lane; rows :data:`VS` ..,
    :data:`VL` + :data:`LCMDLOG` ..). A lane is *quiet* in a step when no logic acts and no
    event is due at its start or inside it (:func:`_quiet_until`, :func:`_vquiet`). Each step:
    the quiet lanes' records; per lane, for the other lanes only, the logic, the events due at
    the step start, the record and the noise; the vector step of all lanes (:func:`_vstep`:
    trig bases, RK4, max |delta| and the end of the step of the quiet lanes; when ``simd``,
    the variant at ``vaddr[swi]``, ``swi`` the chunk's switch value, see :func:`run`); per
    lane, for the lanes it flags and the others only, the step is integrated again on the
    per-lane path (:func:`_substeps`) where an event falls inside it (or the vector step
    flagged it), the zig-zag switching is located, the servo limits and the divergence test
    are applied. The quiet and the per-lane branches do the same arithmetic (results do not
    depend on which lanes share a chunk). Without ``simd`` every step takes the per-lane path
    (the reference).
    """
    ID = S0 + NS
    W = hi - lo
    V = np.zeros(VROWS * CH)
    zb = V[VB * CH:]  # the scratch rows (of _vstep, _vmaxd)
    for j in range(CH):
        V[(VT + 1) * CH + j] = 1.0  # trig bases: cos 0, sin 0
        V[(VT + 4) * CH + j] = 1.0
        for i in range(8):  # input series: absent
            V[(VF + i) * CH + j] = np.nan
    act = np.zeros(W, dtype=np.bool_)
    simple = np.zeros(W, dtype=np.bool_)
    rngs = np.zeros(W, dtype=np.uint64)
    w0 = 1.0 if skind == 0 else 0.0
    w1 = 1.0 if skind == 1 else 0.0
    w2 = 1.0 if skind == 2 else 0.0
    s4_ = sidx[4]
    series = sidx[0] >= 0 or sidx[1] >= 0 or sidx[2] >= 0 or sidx[3] >= 0
    cap = qt.shape[1]
    eps = 1e-9 * dt
    idt = 1.0 / dt
    nmax = 0
    for j in range(W):
        b = lo + j
        nmax = max(nmax, nsteps[b])
        for i in range(NPK):
            V[(VP + i) * CH + j] = P[b, i]
        for i in range(SERVO_ROWS):
            V[(VS + i) * CH + j] = S[b, i]
        ma = S[b, 0]
        for i in range(3):  # x, y, psi
            V[(VZ + i) * CH + j] = Z[b, i]
        for i in range(NS):
            V[(VZ + JS + i) * CH + j] = Z[b, S0 + i]
        for i in range(4):  # servo angle and rate, disturbance filter
            V[(VZ + JDL + i) * CH + j] = Z[b, ID + i]
        # at rest on the initial angle: the command in force is the one that holds it
        cmdin = Z[b, ID] / S[b, 4] if skind == 2 else Z[b, ID]
        V[(VL + LREND) * CH + j] = math.inf
        V[(VL + LOVMAX) * CH + j] = np.nan
        if lk == ZIGZAG and L[b, 5] != 0.0:  # a replay started in the middle of a zig-zag
            V[(VL + LCUR) * CH + j] = L[b, 5]
            V[(VL + LPSI0) * CH + j] = L[b, 4]
            cmdin = L[b, 5] * L[b, 0]
            if skind == 0:
                dl, ramp, rend = _start_ramp(0.0, _clip(cmdin, ma), Z[b, ID], S[b, 1])
                V[RDL * CH + j] = dl
                V[VRAMP * CH + j] = ramp
                V[(VL + LREND) * CH + j] = rend
        V[(VL + LCMDLOG) * CH + j] = cmdin
        V[VCMD * CH + j] = cmdin
        for i in range(N_ZZ):
            zz[b, i] = np.nan
        for i in range(N_ZZ + 1):
            zzt[b, i] = np.nan
        status[b, 0] = 0.0
        status[b, 1] = np.nan
        # noise stream (seed, stream): a splitmix hash of the seed, hashed again with the lane's
        # stream index (Dq[b, 2] when given, else the lane index)
        _, h0 = _splitmix(np.uint64(int(Dq[b, 1])))
        stream = int(Dq[b, 2]) if Dq.shape[1] > 2 else b
        _, rngs[j] = _splitmix(h0 ^ np.uint64(stream))
        V[(VL + LESD) * CH + j] = math.sqrt(Dq[b, 0] / dt) if Dq[b, 0] > 0.0 else 0.0
        V[VT * CH + j] = Z[b, 2]
        V[(VT + 1) * CH + j] = math.cos(Z[b, 2])
        V[(VT + 2) * CH + j] = math.sin(Z[b, 2])
        V[(VL + LTQ) * CH + j] = -math.inf  # the first step takes the per-lane path
        V[(VL + LSW) * CH + j] = L[b, 1] if lk == ZIGZAG else 0.0
        V[(VL + LNS) * CH + j] = nsteps[b]
        V[(VL + LACT) * CH + j] = 1.0
        act[j] = True
    nact = W
    # the vector step of the chunk's switch value (the generic one for mixed or other values)
    swi = NSW - 1
    if SWR >= 0 and W > 0:
        sv0 = P[lo, SWR]
        for i in range(NSW - 1):
            if SWV[i] == sv0:
                swi = i
        for j in range(W):
            if P[lo + j, SWR] != sv0:
                swi = NSW - 1
    if vaddr[swi] == 0:  # no vector step compiled for it (run() compiles the chunks' ones)
        simd = False
    # lanes whose logic or inputs act at every step are never quiet
    busy = series or lk == COURSE or (lk == COMMANDED and s4_ >= 0)
    for k in range(nmax + 1):
        t = k * dt
        t1 = t + dt
        recnow = k % rec_every == 0
        jrec = k // rec_every
        # -- quiet lanes (no logic and no event at the start of or inside the step: the
        # per-lane branches below would do nothing but the record and max |delta|) --
        nq = _vquiet(V, float(k), t1 + eps)
        nsimple = int(nq) if simd else 0
        if recnow and nq > 0.0:
            _vrecord(V, lo, W, jrec, slots, rec)
        # -- phase 1, per lane: inputs, logic, events at the step start, record, trig bases --
        for j in range(W if nq < nact else 0):
            if not act[j] or V[(VL + LQ) * CH + j] > 0.0:
                continue
            b = lo + j
            n = nsteps[b]
            row = b * sstride
            ma = V[VS * CH + j]
            delay = V[(VS + 5) * CH + j]
            qh = int(V[(VL + LQH) * CH + j])
            qn = int(V[(VL + LQN) * CH + j])
            cmdin = V[VCMD * CH + j]
            ramp = V[VRAMP * CH + j]
            cmdlog = V[(VL + LCMDLOG) * CH + j]
            rend = V[(VL + LREND) * CH + j]
            cur = V[(VL + LCUR) * CH + j]
            z7 = V[RDL * CH + j]
            # input series at the step ends (first-order hold)
            kk = k + 1 if k < n else k
            o = VF * CH + j
            if series:
                _load_series(V, o, SER, sidx, row, k, kk)
            fd = V[o]
            # logic -> command events
            psi = V[RPSI * CH + j]
            if lk == COMMANDED:
                if s4_ >= 0:
                    c = SER[s4_, row, k]
                    if c != cmdlog or k == 0:
                        cmdlog = c
                        qh, qn = _push(qt, qv, b, qh, qn, t + delay, c)
            elif lk == TURNING:
                if cur == 0.0 and L[b, 1] < t1 - eps:
                    cur = 1.0
                    cmdlog = L[b, 0]
                    qh, qn = _push(qt, qv, b, qh, qn, max(L[b, 1], t) + delay, L[b, 0])
            elif lk == ZIGZAG:
                if cur == 0.0 and L[b, 3] < t1 - eps:
                    cur = L[b, 2]
                    V[(VL + LPSI0) * CH + j] = psi if np.isnan(L[b, 4]) else L[b, 4]
                    tev = max(L[b, 3], t)
                    zzt[b, 0] = tev
                    cmdlog = cur * L[b, 0]
                    qh, qn = _push(qt, qv, b, qh, qn, tev + delay, cmdlog)
            else:
                err = _wrap(L[b, 0] - psi)
                c = (L[b, 1] * err + L[b, 2] * V[(VL + LINTEG) * CH + j]
                     - L[b, 3] * V[(VZ + ZR) * CH + j])
                sat = c > ma or c < -ma
                if not (L[b, 4] != 0.0 and sat and c * err > 0.0):
                    V[(VL + LINTEG) * CH + j] += err * dt
                w = 0.5 if (k == 0 or k == n) else 1.0
                V[(VL + LITAE) * CH + j] += w * t * abs(err) * dt
                V[(VL + LIAE) * CH + j] += w * abs(err) * dt
                cmdlog = c
                qh, qn = _push(qt, qv, b, qh, qn, t + delay, c)
            # events due at the step start
            while qn > 0 and qt[b, qh] <= t + eps:
                cmdin = qv[b, qh]
                qh = (qh + 1) % cap
                qn -= 1
                if skind == 0:
                    z7, ramp, rend = _start_ramp(t, _clip(cmdin, ma), z7, V[(VS + 1) * CH + j])
            if rend <= t + eps:
                z7 = _clip(cmdin, ma)
                ramp = 0.0
                rend = math.inf
            V[RDL * CH + j] = z7
            # record (at the step start)
            dnow = _clip(z7, ma) if np.isnan(fd) else fd
            if abs(dnow) > V[(VL + LMAXD) * CH + j]:
                V[(VL + LMAXD) * CH + j] = abs(dnow)
            if recnow:
                _record(V, j, b, jrec, slots, rec, dnow, cmdlog)
            V[(VL + LQH) * CH + j] = qh
            V[(VL + LQN) * CH + j] = qn
            V[VCMD * CH + j] = cmdin
            V[VRAMP * CH + j] = ramp
            V[(VL + LCMDLOG) * CH + j] = cmdlog
            V[(VL + LREND) * CH + j] = rend
            V[(VL + LCUR) * CH + j] = cur
            if k == n:
                act[j] = False
                V[(VL + LACT) * CH + j] = 0.0
                nact -= 1
                continue
            # noise sample, trig bases
            noise = 0.0
            if V[(VL + LESD) * CH + j] > 0.0:
                rngs[j], g = _normal(rngs[j])
                noise = V[(VL + LESD) * CH + j] * g
            V[VNOISE * CH + j] = noise
            simple[j] = simd and not ((qn > 0 and qt[b, qh] < t1) or rend < t1)
            nsimple += simple[j]
        # -- phase 2: the vector step of all lanes (the quiet lanes' step is complete unless
        # flagged, row LFLAG); else the max |delta| of the quiet lanes and the trig bases --
        nslow = float(nact)
        if nsimple > 0:
            nslow = _vcall(vaddr[swi], V, t1 - t, (t1 - t) * idt,
                           1.0 if lk == ZIGZAG else 0.0, float(skind))
        else:
            _vmaxd(V, zb)
            for j in range(W if _vbases(V) > 0.0 else 0):
                if act[j] and np.isnan(V[(VT + 1) * CH + j]):
                    _base_far(V, j, 0, V[RPSI * CH + j])
                if TRIG and act[j] and np.isnan(V[(VT + 4) * CH + j]):
                    _base_far(V, j, 3, _steer(V, j))
        # -- phase 3, per lane: events inside the step, zig-zag switching, limits, divergence --
        for j in range(W if (nslow > 0.0 or (nsimple > 0 and nact < W)) else 0):
            zv = _ztup(V, j)  # the vector step's result (limits applied)
            if nsimple > 0 and (not act[j] or V[(VL + LFLAG) * CH + j] != 0.0):
                _restore(V, zb, j)  # the state before the vector step
            if not act[j] or (nsimple > 0 and V[(VL + LFLAG) * CH + j] == 0.0):
                continue
            if nsimple > 0:  # a trig base the vector step left NaN: by the library
                if np.isnan(V[(VT + 1) * CH + j]):
                    _base_far(V, j, 0, V[RPSI * CH + j])
                if TRIG and np.isnan(V[(VT + 4) * CH + j]):
                    _base_far(V, j, 3, _steer(V, j))
            b = lo + j
            ok = False
            if (simd and V[(VL + LQ) * CH + j] > 0.0) or simple[j]:
                z = zv
                ok = _finite(z)
            if not ok:
                z, cmdin, ramp, rend, qh, qn = _substeps(
                    V, j, _ztup(V, j), t, t1, eps, idt, w0, w1, w2, skind, V[VCMD * CH + j],
                    V[VRAMP * CH + j], V[(VL + LREND) * CH + j], qt, qv, b,
                    int(V[(VL + LQH) * CH + j]), int(V[(VL + LQN) * CH + j]))
                sv = (V[VCMD * CH + j], V[VRAMP * CH + j], V[(VL + LREND) * CH + j],
                      V[(VL + LQH) * CH + j], V[(VL + LQN) * CH + j])  # the state before the
                # step (for a zig-zag redo)
                V[VCMD * CH + j] = cmdin
                V[VRAMP * CH + j] = ramp
                V[(VL + LREND) * CH + j] = rend
                V[(VL + LQH) * CH + j] = qh
                V[(VL + LQN) * CH + j] = qn
            else:
                sv = (V[VCMD * CH + j], V[VRAMP * CH + j], V[(VL + LREND) * CH + j],
                      V[(VL + LQH) * CH + j], V[(VL + LQN) * CH + j])
            cur = V[(VL + LCUR) * CH + j]
            if lk == ZIGZAG and cur != 0.0:  # zig-zag switching, event-located
                sw = L[b, 1]
                psi0 = V[(VL + LPSI0) * CH + j]
                dev0 = V[RPSI * CH + j] - psi0  # the heading at the step start
                dev1 = z[JPSI] - psi0
                if V[(VL + LZZN) * CH + j] >= 1.0:
                    ov = -cur * dev1 - sw
                    if np.isnan(V[(VL + LOVMAX) * CH + j]) or ov > V[(VL + LOVMAX) * CH + j]:
                        V[(VL + LOVMAX) * CH + j] = ov
                if (cur > 0.0 and dev1 >= sw) or (cur < 0.0 and dev1 <= -sw):
                    zzn = int(V[(VL + LZZN) * CH + j])
                    lvl = sw if cur > 0.0 else -sw
                    f = 0.0
                    if (cur > 0.0 and dev0 < lvl) or (cur < 0.0 and dev0 > lvl):
                        f = (lvl - dev0) / (dev1 - dev0)
                    tsw = t + f * dt
                    if zzn >= 1 and zzn <= N_ZZ:
                        zz[b, zzn - 1] = V[(VL + LOVMAX) * CH + j]
                    V[(VL + LOVMAX) * CH + j] = np.nan
                    cur = -cur
                    zzn += 1
                    if zzn <= N_ZZ:
                        zzt[b, zzn] = tsw
                    cmdlog = cur * L[b, 0]
                    V[(VL + LCMDLOG) * CH + j] = cmdlog
                    V[(VL + LCUR) * CH + j] = cur
                    V[(VL + LZZN) * CH + j] = zzn
                    tr = tsw + V[(VS + 5) * CH + j]
                    if tr < t1 - eps:
                        # takes effect inside this step: integrate the step again
                        ok = False  # (the divergence test then checks every state)
                        qh, qn = _push(qt, qv, b, int(sv[3]), int(sv[4]), tr, cmdlog)
                        z, cmdin, ramp, rend, qh, qn = _substeps(
                            V, j, _ztup(V, j), t, t1, eps, idt, w0, w1, w2, skind, sv[0],
                            sv[1], sv[2], qt, qv, b, qh, qn)
                        V[VCMD * CH + j] = cmdin
                        V[VRAMP * CH + j] = ramp
                        V[(VL + LREND) * CH + j] = rend
                    else:
                        qh, qn = _push(qt, qv, b, int(V[(VL + LQH) * CH + j]),
                                       int(V[(VL + LQN) * CH + j]), tr, cmdlog)
                    V[(VL + LQH) * CH + j] = qh
                    V[(VL + LQN) * CH + j] = qn
            # servo limits, divergence
            dl = z[JDL]
            dd = z[JDD]
            if skind != 0:
                ma = V[VS * CH + j]
                if dl > ma:
                    dl = ma
                    dd = min(dd, 0.0)
                elif dl < -ma:
                    dl = -ma
                    dd = max(dd, 0.0)
                if skind == 2:
                    dd = _clip(dd, V[(VS + 1) * CH + j])
            _zput(V, VZ * CH + j, _with_servo(z, dl, dd))
            if not (abs(z[ZR]) <= R_MAX and (ok or _finite(z))):
                status[b, 0] = 1.0
                status[b, 1] = t1
                act[j] = False
                V[(VL + LACT) * CH + j] = 0.0
                nact -= 1
            V[(VL + LTQ) * CH + j] = _quiet_until(V, j, b, lk, L, qt, busy)
    for j in range(W):
        b = lo + j
        zzn = int(V[(VL + LZZN) * CH + j])
        if zzn >= 1 and zzn <= N_ZZ:  # the overshoot after the last reversal, so far
            zz[b, zzn - 1] = V[(VL + LOVMAX) * CH + j]
        for i in range(N_ZZ):  # an overshoot counts once the next reversal has happened
            if i + 2 > zzn:
                zz[b, i] = np.nan
        acc[b, 0] = V[(VL + LITAE) * CH + j]
        acc[b, 1] = V[(VL + LIAE) * CH + j]
        acc[b, 2] = V[(VL + LMAXD) * CH + j]
        for i in range(3):
            Z[b, i] = V[(VZ + i) * CH + j]
        for i in range(NS):
            Z[b, S0 + i] = V[(VZ + JS + i) * CH + j]
        for i in range(4):
            Z[b, ID + i] = V[(VZ + JDL + i) * CH + j]


#: Set to False to integrate every step on the per-lane path (the reference for the benchmark).
SIMD = True
#: Set to True to use the generic variant of the vector step (any servo kind, disturbance,
#: series, with x and y; see :func:`vector_step`) for every batch.
FORCE_GENERIC = False


def run(kind: ModelKind, P: np.ndarray, S: np.ndarray, skind: int, lk: int, L: np.ndarray,
        Dq: np.ndarray, SER: np.ndarray, sidx: np.ndarray, Z: np.ndarray, nsteps: np.ndarray,
        dt: float, rec_every: int, slots: np.ndarray, rec: np.ndarray, acc: np.ndarray,
        zz: np.ndarray, zzt: np.ndarray, status: np.ndarray, qcap: int,
        chunk: int = CH) -> None:
    """Integrate all lanes of ``Z`` (in place) and fill the outputs.

    Arrays are lane-major (a lane's parameters, state and work values contiguous): ``P``
    (B, n_params), ``S`` (B, SERVO_ROWS), ``L`` (B, 6), ``Dq`` (B, 2 or 3) (spectral density,
    seed, optional noise stream index), ``Z`` (B, n_states),
    ``acc`` (B, 3), ``zz`` (B, N_ZZ), ``zzt`` (B, N_ZZ + 1), ``status`` (B, 2); ``SER``
    (n_series, 1 or B, N) and ``rec`` (n_channels, B, N_rec). Lanes are integrated in chunks of
    ``chunk`` lanes that step together (:func:`_chunk`, vectorised across the chunk's lanes);
    chunks run in parallel on a thread pool (the kernel is compiled ``nogil``), as many threads
    as numba's thread count. The vector step's variant (:func:`vector_step`) follows from the
    batch: the servo kind, whether it has a disturbance or input series, whether x or y is
    recorded, and the chunks' switch values.
    """
    B, nz = Z.shape
    chunk = max(1, min(chunk, CH))
    if B == 0:
        return
    lanes = kernel(kind)
    qt, qv = np.empty((B, qcap)), np.empty((B, qcap))
    sstride = 1 if SER.shape[1] > 1 else 0
    simd = bool(SIMD)
    starts = list(range(0, B, chunk))
    vaddr = np.zeros(4, dtype=np.int64)
    if simd:
        ID = S0 + kind.n_states
        nod = (not bool(np.any(sidx[:4] >= 0)) and not bool(np.any(Dq[:, 0] > 0.0))
               and not bool(np.any(Z[:, ID + 2:ID + 4] != 0.0)))
        xy = bool(slots[0] >= 0 or slots[1] >= 0)
        for swi in _chunk_switches(kind, P, starts, chunk):
            vaddr[swi] = vector_step(kind, swi, skind, nod, xy)

    def task(lo: int) -> None:
        lanes(lo, min(B, lo + chunk), P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps,
              dt, rec_every, slots, rec, acc, zz, zzt, status, qt, qv, simd, vaddr)

    threads = min(numba.get_num_threads(), len(starts))
    if threads <= 1:
        for lo in starts:
            task(lo)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        for fut in [pool.submit(task, lo) for lo in starts]:
            fut.result()


_TEMPLATES = ("_deriv", "_rk4", "_inputs", "_load_series", "_steer", "_vbases", "_base_far",
              "_substeps", "_chval", "_record", "_vrecord", "_quiet_until", "_vquiet", "_vmaxd",
              "_restore", "_chunk")
#: the vector step's templates (:func:`vector_step`)
_VTEMPLATES = ("_vderiv", "_vrk4")
#: the generated joint-state helpers of a vector-step variant (:func:`layout.joint_helpers`)
_VHELPERS = ("_vaxpy", "_vrk4sum", "_vput")
_KERNELS: dict[str, Any] = {}
_GLOBALS: dict[str, dict[str, Any]] = {}  # the specialised functions, by kernel key
_VSTEPS: dict[tuple[Any, ...], Any] = {}  # the compiled vector steps, by kernel key and variant
#: C signature of the vector step: (V, h, frac, zig, servo kind) -> number of flagged lanes
_VSIG = numba.types.float64(numba.types.CPointer(numba.types.float64), numba.types.float64,
                            numba.types.float64, numba.types.float64, numba.types.float64)


def kernel(kind: ModelKind) -> Any:
    """The core specialised for ``kind`` (compiled at first call, cached on disk).

    The template functions above are re-created with the kind's right-hand side and state
    layout as globals and compiled under a name that carries the kind and a hash of its module
    source, so that the on-disk cache of one kind (or of an edited kind) is never taken for
    another's. Everything that does not depend on the kind is compiled once for all kinds.
    """
    key = _kernel_key(kind)
    if key in _KERNELS:
        return _KERNELS[key]
    g = dict(globals())
    lay = _layout.Layout(kind.n_states, kind.n_params)
    g.update(lay.constants())
    phi, p = kind.state_row("phi"), kind.state_row("p")
    g.update(rhs=kind.rhs, TRIG=bool(kind.uses_trig), BU=kind.body[0], BV=kind.body[1],
             BR=kind.body[2], SPEED_ROW=kind.speed_row, ZU=JS + max(kind.body[0], 0),
             ZV=JS + max(kind.body[1], 0), ZR=JS + kind.body[2],
             ZPHI=JS + phi if phi >= 0 else -1, ZP=JS + p if p >= 0 else -1, LAYOUT=lay)
    values = tuple(float(v) for v in kind.switch_values) if kind.switch_row >= 0 else ()
    if len(values) > 3:
        raise ValueError(f"kind {kind.name}: at most 3 switch values")
    g.update(SWR=kind.switch_row if values else -1, SWV=np.array(values or (np.nan,)),
             NSW=len(values) + 1)
    for name, fn in _layout.joint_helpers(lay, g).items():
        g[name] = _helper(fn)
    g["_ptup"] = numba.njit(forceinline=True)(_layout.param_tuple(lay, g))
    for name in _TEMPLATES:
        _specialise(g, name, f"{name}__{key}")
    _KERNELS[key] = g["_chunk"]
    _GLOBALS[key] = g
    return g["_chunk"]


def _kernel_key(kind: ModelKind) -> str:
    """The name of a kind's specialisation: the kind, a hash of its sources (its module and
    :mod:`usvid.models`, :mod:`usvid.models.registry`) and of the core's (this module and the
    layout it generates code from), so that no on-disk cache of another kind or version is
    taken for it."""
    return f"{kind.name}_{kind.source_hash or 'x'}_{_core_digest()}"


@functools.cache
def _core_digest() -> str:
    h = hashlib.sha256()
    for mod in (__file__, _layout.__file__):
        with open(mod, "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:8]


def _helper(fn: Any) -> Any:
    """Compile a generated joint-state helper (inlined by LLVM; not cached on disk: it is
    compiled only into the cached kernels, which carry it)."""
    return numba.njit(error_model="numpy", fastmath=_FM, forceinline=True)(fn)


def _chunk_switches(kind: ModelKind, P: np.ndarray, starts: list[int], chunk: int) -> set[int]:
    """The switch-value indices (``swi`` of :func:`_chunk`) of the chunks starting at
    ``starts``: the index of the chunk's common value of the switch row in :data:`SWV`, else
    NSW - 1 (the generic step)."""
    g = _GLOBALS[_kernel_key(kind)]
    nsw, swr, swv = g["NSW"], g["SWR"], g["SWV"]
    if swr < 0:
        return {nsw - 1}
    col = P[:, swr]
    out = set()
    for lo in starts:
        seg = col[lo:lo + chunk]
        swi = nsw - 1
        for i in range(nsw - 1):
            if swv[i] == seg[0]:
                swi = i
        if np.any(seg != seg[0]):
            swi = nsw - 1
        out.add(swi)
    return out


def vector_step(kind: ModelKind, swi: int, sk: int, nod: bool, xy: bool) -> int:
    """Address of the vector step (:func:`_vstep`, a C callback) of ``kind`` for the switch
    value ``swi`` (index into the kind's switch values, the last: generic), the servo kind
    ``sk``, without disturbance and input series (``nod``), with x and y (``xy``); compiled at
    first use (cached on disk), only the variants a batch needs.

    One variant per combination keeps the vector code free of the others' branches: the
    servo's blend of the three kinds, the disturbance filter, the first-order-hold series and,
    when neither x nor y is recorded, the position and the heading's rotation (the quiet lanes'
    x and y then stay as they were: nothing reads them). The switch row of the parameters is a
    literal in the variant of a switch value (e.g. one thrust law in the code, not all). A kind
    whose right-hand side is not inlined (:data:`INLINE_MAX_PARAMS`: its lane loop is not
    vectorised, the variants would gain little) has one variant per switch value: any servo
    kind (``sk`` -1: the per-lane flavour's blend), disturbance, series, x and y."""
    key = _kernel_key(kind)
    kernel(kind)
    g = _GLOBALS[key]
    if g["NPK"] > INLINE_MAX_PARAMS or FORCE_GENERIC:
        sk, nod, xy = -1, False, True
    vk = (key, swi, sk, bool(nod), bool(xy))
    if vk in _VSTEPS:
        return _VSTEPS[vk].address
    swv, nsw, swr = g["SWV"], g["NSW"], g["SWR"]
    const = {swr: float(swv[swi])} if swr >= 0 and swi < nsw - 1 else {}
    gv = dict(g, SK=sk, NOD=bool(nod), XY=bool(xy))
    gv["_ptup"] = numba.njit(forceinline=True)(_layout.param_tuple(g["LAYOUT"], gv, const))
    helpers = _layout.joint_helpers(g["LAYOUT"], gv, xy=bool(xy), nod=bool(nod))
    for name in _VHELPERS:
        gv[name] = _helper(helpers[name])
    tag = f"{swi}{'g' if sk < 0 else sk}{int(bool(nod))}{int(bool(xy))}"
    for name in _VTEMPLATES:
        _specialise(gv, name, f"{name}{tag}__{key}")
    _VSTEPS[vk] = _specialise(gv, "_vstep", f"_vstep{tag}__{key}", cfunc=True)
    return _VSTEPS[vk].address


#: Kinds with more parameters than this keep one out-of-line copy of their right-hand side per
#: flavour instead of four inlined ones per RK4 step (an MMG model's rhs inlined eight times took
#: minutes to compile; its lanes gain little from SIMD).
INLINE_MAX_PARAMS = 40


def _specialise(g: dict[str, Any], name: str, qual: str, cfunc: bool = False) -> Any:
    """Compile the template ``name`` with the globals ``g`` under the name ``qual`` into g
    (``cfunc``: as a C callback of signature :data:`_VSIG`, compiled now); returns it."""
    template = globals()[name]
    code = template.__code__.replace(co_name=qual, co_qualname=qual)
    fn = types.FunctionType(code, g, qual, template.__defaults__)
    fn.__qualname__ = qual
    fn.__module__ = __name__
    opts: dict[str, Any] = {"cache": True, "error_model": "numpy", "fastmath": _FM}
    if name == "_chunk":
        opts["nogil"] = True
    if name in ("_deriv", "_rk4", "_inputs", "_steer", "_vderiv", "_vrk4", "_chval"):
        # inlined by LLVM (tuples only: no reference counting): numba's own inlining
        # (inline="always") copies the IR at every call site, most of the compile time
        opts["forceinline"] = True
    if name == "_deriv" or (name == "_vderiv" and g["NPK"] > INLINE_MAX_PARAMS):
        # one out-of-line copy in the per-lane flavour (integrating only the steps with an
        # event inside, or lanes the vector step does not take): a quarter of the compile work
        opts["forceinline"] = False
    g[name] = numba.cfunc(_VSIG, **opts)(fn) if cfunc else numba.njit(**opts)(fn)
    return g[name]
