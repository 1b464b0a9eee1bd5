"""The per-lane path of the integration core: one lane's step, integrated exactly as the
reference (templates, specialised per kind by :mod:`usvid.sim.specialise`).

A lane takes this path for a step with an event inside it (a dead-time command taking effect,
the end of an ideal servo's ramp, a zig-zag reversal), for a step the vector path flags, and
for every step with ``core.SIMD = False`` (the reference the vector path is tested against).
The step is split into sub-steps ending at the events (:func:`_substeps`), each one classical
RK4 step (:func:`_rk4`) of the joint derivative (:func:`_deriv`: the kinematics, the servo, the
disturbance filter and the kind's right-hand side). :func:`_lstep` is the C callback the chunk
driver calls: it reads the lane's joint state from its rows of the chunk array and writes the
step's result to the per-lane result rows (``VN``).

Globals the specialisation sets (:mod:`usvid.sim.layout`, :func:`usvid.sim.specialise.kernel`):
the kind's ``rhs``, ``TRIG``, the layout constants (``VP``, ``VN``, ``VROWS``, ...) and the
generated joint-state helpers (``_ztup``, ``_zput``, ``_states``, ``_joint``, ``_axpy``,
``_rk4sum``, ``_with_dl``, ``_ptup``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from usvid.models.environment.waves import mean_drift_cs
from usvid.models.environment.wind import air_relative_body
from usvid.models.environment.wind_loads import wind_load_body
from usvid.sim.layout import (
    CH,
    DIST_A0,
    DIST_A1,
    DIST_B,
    JDD,
    JDL,
    JPSI,
    JW1,
    JW2,
    NOF,
    VC,
    VF,
    VH,
    VNOISE,
    VS,
    VT,
)
from usvid.sim.scalar import _clip, _rot, _start_ramp

# -- set by the specialisation (placeholders) --------------------------------------------------
TRIG = False  # the kind reads cos/sin of the steering angle
ENV = True  # the batch has an environment (force or current series): else compiled away
WIND = True  # the batch has wind loads or wave drift (the environment block): else compiled away
ZU = 0  # position of u in the joint-state tuple (-1: the constant speed, parameter SPEEDROW)
ZV = 0  # position of v in the joint-state tuple (-1: none, zero)
SPEEDROW = 0  # parameter row of the constant speed of a response kind
VN = 0  # first row of the per-lane step's result
VROWS = 1  # rows of the chunk array
rhs = _ztup = _zput = _states = _joint = _with_dl = _axpy = _rk4sum = _ptup = None
_etup = None


def _inputs(V, j):
    """Lane j's servo values, input series and trig bases from ``V``."""
    o = VS * CH + j
    srv = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
           V[o + 6 * CH])
    o = VF * CH + j
    fs = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
          V[o + 6 * CH], V[o + 7 * CH], V[o + 8 * CH], V[o + 9 * CH], V[o + 10 * CH],
          V[o + 11 * CH], V[o + 12 * CH], V[o + 13 * CH], V[o + 14 * CH], V[o + 15 * CH],
          V[o + 16 * CH], V[o + 17 * CH], V[o + 18 * CH], V[o + 19 * CH], V[o + 20 * CH],
          V[o + 21 * CH], V[o + 22 * CH], V[o + 23 * CH])
    o = VT * CH + j
    tr = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH])
    return srv, fs, tr


# Not cached on its own: numba keys a function's cache to its own file only, so a cached copy
# would keep an edited load formula of usvid.models.environment; compiled into the templates,
# whose cache key holds those modules' sources (usvid.sim.specialise.core_digest).
@numba.njit(error_model="numpy", forceinline=True)
def _envload(pe, wx, wy, vn, ve, cps, sps):
    """The state-dependent environment loads (X, Y [N], K, N [N m], body axes) of the
    environment block ``pe`` (:data:`usvid.sim.layout.ENVBLOCK`) for the true wind moving the
    air with the velocity ``wx``, ``wy`` [m/s, north, east], the vessel's velocity over ground
    ``vn``, ``ve`` [m/s] and the cosine ``cps`` and sine ``sps`` of its heading.

    Wind: the loads of the apparent wind (the wind triangle in body axes,
    :func:`usvid.models.environment.wind.air_relative_body`, and the coefficient model,
    :func:`usvid.models.environment.wind_loads.wind_load_body`) less those of the still air the
    vessel moves through, :math:`F(V_{A}) - F(V_{A,0})` with :math:`V_{A,0}` the apparent wind
    of its own motion (the wind-resistance correction of ISO 15016:2015 and ITTC 7.5-04-01-01.1:
    a model identified from trials holds the still-air load in its calm-water terms, so zero
    true wind is calm water). The roll moment of a model without one (Fujiwara et al. 1998:
    NaN) is taken as 0. Waves: the mean drift force
    (:func:`usvid.models.environment.waves.mean_drift_cs`, no yaw moment).

    No library call but square roots and every branch a select: the per-lane step and the
    vector step (:mod:`usvid.sim.vector`, vectorised over the lanes) call this one function,
    compiled without fast-math (the same arithmetic on both paths)."""
    x = 0.0
    y = 0.0
    k = 0.0
    n = 0.0
    if pe[0] != 0.0:  # a wind-load model (a literal in a vector-step variant: else compiled away)
        ax, ay = air_relative_body(wx, wy, vn, ve, cps, sps)
        x1, y1, n1, k1 = wind_load_body(pe, ax, ay)
        ax0, ay0 = air_relative_body(0.0, 0.0, vn, ve, cps, sps)
        x0, y0, n0, k0 = wind_load_body(pe, ax0, ay0)
        x = x1 - x0
        y = y1 - y0
        k = k1 - k0
        k = 0.0 if np.isnan(k) else k
        n = n1 - n0
    dx, dy = mean_drift_cs(pe[16], pe[17], pe[18], pe[19], cps, sps)
    return x + dx, y + dy, k, n


def _deriv(p, fe, tau, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, z):
    """Time derivative of a lane's joint-state tuple ``z`` (x, y, psi, servo angle and rate,
    disturbance filter, the kind's states: :mod:`usvid.sim.layout`) at the fraction ``tau`` of
    the current step.

    ``p`` the lane's parameter tuple, ``fe`` the environment's state-dependent loads (X, Y, K,
    N; :func:`_heldload`, read only with WIND), ``srv`` its servo values (max angle, max rate, T or
    omega_n, zeta, gain, delay, 1/T) blended with the batch's 0/1 weights w0 (ideal: ramp
    rate ``ramp``), w1 (first order), w2 (second order) driven by ``cmdin``; ``noise`` the
    step's white-noise sample; ``fs`` the first-order-hold series (start and end values of
    :data:`usvid.sim.layout.SERIES`: delta, n, n_port, n_stbd (NaN when absent), the external
    force X, Y, K, N and the current north, east (0 when absent)); ``tr`` the trig bases (psi0,
    cos, sin, de0, cos, sin) of the step start. Scalars and tuples only.

    The environment enters here, once for every kind: the kind's right-hand side takes the
    external force ``f`` (the series' force plus ``fe``) and its states are its velocities
    through the water; the kinematics add the current (the velocity over ground, Fossen 2021
    ch. 10.3).
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
    fd = fs[0] + tau * (fs[12] - fs[0])
    de = (d if np.isnan(fd) else fd) + DIST_B * w2d
    cd = 1.0
    sd = 0.0
    if TRIG:
        cd, sd = _rot(de, tr[3], tr[4], tr[5])
    f = NOF  # calm water: the -0.0 forces vanish in the kind's sums
    cx = 0.0
    cy = 0.0
    if ENV:
        f = (fs[4] + tau * (fs[16] - fs[4]), fs[5] + tau * (fs[17] - fs[5]),
             fs[6] + tau * (fs[18] - fs[6]), fs[7] + tau * (fs[19] - fs[7]))
        cx = fs[8] + tau * (fs[20] - fs[8])
        cy = fs[9] + tau * (fs[21] - fs[9])
    cps, sps = _rot(z[JPSI], tr[0], tr[1], tr[2])
    if WIND:  # the wind loads and wave drift of the (sub-)step's start, held (:func:`_rk4`)
        f = (f[0] + fe[0], f[1] + fe[1], f[2] + fe[2], f[3] + fe[3])
    u, v, r, ds = rhs(p, _states(z), (de, cd, sd, fs[1] + tau * (fs[13] - fs[1]),
                                      fs[2] + tau * (fs[14] - fs[2]),
                                      fs[3] + tau * (fs[15] - fs[3])), f)
    k0 = u * cps - v * sps
    k1 = u * sps + v * cps
    if ENV:  # the velocity over ground: through the water plus the current
        k0 += cx
        k1 += cy
    return _joint(k0, k1, r, w0 * ramp + rate,
                  w2 * (wn * wn * (srv[4] * cmdin - zdl) - 2.0 * srv[3] * wn * w),
                  w2d, -DIST_A0 * z[JW1] - DIST_A1 * w2d + noise, ds)


def _heldload(p, pe, z, tau, fs, cps, sps):
    """The state-dependent environment loads (X, Y, K, N) of the joint state ``z`` at the
    fraction ``tau`` of the step (the current and the true wind of the first-order-hold series
    ``fs`` there), the heading's cosine ``cps`` and sine ``sps`` (:func:`_envload`): one
    evaluation of the multirate hold (:func:`_holdset`, :func:`_holdget`). The one definition
    for the per-lane step and the vector step (:mod:`usvid.sim.vector`).

    The multirate hold of the wind and wave-drift forcing (the hull, rudder, servo and
    kinematics keep classical RK4): the loads are evaluated at the start of every m-th step
    (m = max(1, round(load_interval / dt)), :func:`usvid.sim.simulate.load_every`; the
    ``Environment.load_interval``, default 0.1 s), linearly extrapolated from the last two
    evaluations to each step's midpoint and held over the step (a multirate scheme, second
    order in the interval: Gear & Wells 1984 for multirate integration). Chosen by
    measurement: evaluated at every RK4 stage, the loads made the step 4.2-4.9x the calm
    step's cost (four evaluations of the apparent and of the still air's loads, each a square
    root and four divisions in the stage's dependency chain); once per step and held over it,
    1.8-2.3x. A 35 deg turning of the Lanxin 3-DOF model in an 8 m/s wind and a 0.5 m/s
    current at the default dt = 0.02 s and interval 0.1 s moves advance, transfer and
    tactical diameter by at most 3e-5 of their values from the continuous model's (the loads
    of every step's start held over it: 1.9e-4; the last evaluation held over 0.1 s: 9.4e-4)
    and the IMO drift by 4e-5 m/s; the error falls by four when the interval halves
    (tests/test_sim_wind_hold.py), far below what the wind-load coefficients are known to
    (Blendermann 1994: 10-20 %)."""
    uw = z[ZU] if ZU >= 0 else p[SPEEDROW]
    vw = z[ZV] if ZV >= 0 else 0.0
    cx = fs[8] + tau * (fs[20] - fs[8])
    cy = fs[9] + tau * (fs[21] - fs[9])
    return _envload(pe, fs[10] + tau * (fs[22] - fs[10]), fs[11] + tau * (fs[23] - fs[11]),
                    uw * cps - vw * sps + cx, uw * sps + vw * cps + cy, cps, sps)


def _holdset(V, j, fn, g, kf, ok, d):
    """Lane slot j's held-load rows (:data:`usvid.sim.layout.HOLD_ROWS`) after an evaluation of
    the loads ``fn`` (X, Y, K, N) at the start of step ``kf``: the rate from the previous
    evaluation, (fn - F) g (``g``: the extrapolation's weight over the evaluation interval
    [1/s], 0 at the first evaluation), then fn. The one definition for both paths. Not ``ok``
    (the vector step's heading base NaN, the lane then flagged): the rows kept (selects, no
    branch), so that the per-lane step evaluates the loads itself. Written to the rows from
    ``d`` (:data:`usvid.sim.layout.VH`: in place; the vector step: scratch rows it copies
    to VH after its loop): every row loaded unconditionally and a select of it stored
    elsewhere, because a select of a row's own value stored back in place compiles to a
    masked store (``vmaskmovpd``, microcoded on AMD Zen; the vector step's evaluation loop had
    eight a lane slot)."""
    o = VH * CH + j
    f0 = V[o]
    f1 = V[o + CH]
    f2 = V[o + 2 * CH]
    f3 = V[o + 3 * CH]
    r0 = V[o + 4 * CH]
    r1 = V[o + 5 * CH]
    r2 = V[o + 6 * CH]
    r3 = V[o + 7 * CH]
    k = V[o + 8 * CH]
    q = d * CH + j
    V[q + 4 * CH] = (fn[0] - f0) * g if ok else r0
    V[q + 5 * CH] = (fn[1] - f1) * g if ok else r1
    V[q + 6 * CH] = (fn[2] - f2) * g if ok else r2
    V[q + 7 * CH] = (fn[3] - f3) * g if ok else r3
    V[q] = fn[0] if ok else f0
    V[q + CH] = fn[1] if ok else f1
    V[q + 2 * CH] = fn[2] if ok else f2
    V[q + 3 * CH] = fn[3] if ok else f3
    V[q + 8 * CH] = kf if ok else k


def _holdget(V, j, s):
    """Lane slot j's loads held over the step (X, Y, K, N): those of the last evaluation plus
    ``s`` [s] (the time from it to the step's midpoint times the extrapolation's weight, 0 for
    a zero-order hold) times their rate (:func:`_holdset`)."""
    o = VH * CH + j
    return (V[o] + s * V[o + 4 * CH], V[o + CH] + s * V[o + 5 * CH],
            V[o + 2 * CH] + s * V[o + 6 * CH], V[o + 3 * CH] + s * V[o + 7 * CH])


def _rk4(p, fe, z, h, tau0, frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr):
    """One classical RK4 step of length h [s] from z, covering the fractions tau0 .. tau0 +
    frac of the current step (for the first-order-hold series); with WIND the state-dependent
    environment loads ``fe`` held over it (:func:`_substeps`)."""
    k1 = _deriv(p, fe, tau0, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, z)
    tm = tau0 + 0.5 * frac
    k2 = _deriv(p, fe, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k1))
    k3 = _deriv(p, fe, tm, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, 0.5 * h, k2))
    k4 = _deriv(p, fe, tau0 + frac, srv, w0, w1, w2, cmdin, ramp, noise, fs, tr, _axpy(z, h, k3))
    return _rk4sum(z, h / 6.0, k1, k2, k3, k4)


def _substeps(V, j, z, t, t1, eps, idt, w0, w1, w2, skind, cmdin, ramp, rend, qt, qv, b, qh,
              qn):
    """Lane j's step from t to t1 [s] on the per-lane path: sub-steps ending at the events
    inside it (dead-time queue of lane b, end of an ideal servo's ramp), one RK4 call site.
    Returns (z, cmdin, ramp, rend, qh, qn)."""
    p = _ptup(V, j)
    pe = _etup(V, j)
    srv, fs, tr = _inputs(V, j)
    noise = V[VNOISE * CH + j]
    fe = NOF
    if WIND:  # the multirate hold: evaluated at this step's start unless the vector step did
        # (the control row VC, written by the driver), then held over the whole step
        c = VC * CH
        if V[c] > 0.0 and V[(VH + 8) * CH + j] != V[c + 1]:
            cps, sps = _rot(z[JPSI], tr[0], tr[1], tr[2])
            _holdset(V, j, _heldload(p, pe, z, 0.0, fs, cps, sps), V[c + 3], V[c + 1], True,
                     VH)
        fe = _holdget(V, j, V[c + 2])
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
            z = _rk4(p, fe, z, te - tc, (tc - t) * idt, (te - tc) * idt, srv, w0, w1, w2,
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


def _lstep(Vp, qtp, qvp, outp, cap, b, j, skind, qh, qn, t, t1, eps, idt, cmdin, ramp, rend):
    """Lane slot j's (lane b's) step from t to t1 [s] (a C callback, :data:`LSIG`): from its
    joint state in the rows VZ.. of the chunk array ``Vp`` into the rows VN.. (:func:`_substeps`
    with the servo kind ``skind``, the command in force, ramp rate and ramp end, and the
    dead-time queue ``qtp``/``qvp`` (lanes x ``cap``, head ``qh``, length ``qn``)); the new
    command, ramp rate, ramp end, queue head and length go to ``outp[0..4]``."""
    V = numba.carray(Vp, VROWS * CH)
    qt = numba.carray(qtp, (b + 1, cap))
    qv = numba.carray(qvp, (b + 1, cap))
    out = numba.carray(outp, 5)
    w0 = 1.0 if skind == 0 else 0.0
    w1 = 1.0 if skind == 1 else 0.0
    w2 = 1.0 if skind == 2 else 0.0
    z, cmdin, ramp, rend, qh, qn = _substeps(V, j, _ztup(V, j), t, t1, eps, idt, w0, w1, w2,
                                             skind, cmdin, ramp, rend, qt, qv, b, qh, qn)
    _zput(V, VN * CH + j, z)
    out[0] = cmdin
    out[1] = ramp
    out[2] = rend
    out[3] = qh
    out[4] = qn
    return 0.0


_f8 = numba.types.float64
_i8 = numba.types.int64
_pf8 = numba.types.CPointer(_f8)
#: C signature of :func:`_lstep`.
LSIG = _f8(_pf8, _pf8, _pf8, _pf8, _i8, _i8, _i8, _i8, _i8, _i8, _f8, _f8, _f8, _f8, _f8, _f8,
           _f8)
