"""The vector path of the integration core: one step of all lanes of a chunk, vectorised
across the lanes (templates, specialised per kind and variant by :mod:`usvid.sim.specialise`).

:func:`_vstep` is a C callback (one per kind and variant, called by the chunk driver through
its address): the trig bases, one RK4 step (:func:`_vrk4` of :func:`_vderiv`) and the end of
the step of every lane slot, with the lane loop innermost so that LLVM vectorises it (SIMD);
the right-hand side of the kind is inlined. A variant fixes at compile time the servo kind
(``SK``), the absence of disturbance and input series (``NOD``), whether x and y are
integrated (``XY``), whether the batch has wind loads or wave drift (``WIND``: the multirate
hold of the loads, :func:`usvid.sim.lane._heldload`, evaluated for every lane in a loop of
their own before the step's at the steps the driver says and extrapolated at every step, no
library call in them, so the loops vectorise; without x and y the heading's trig base is
rotated at those steps only, over the load interval: nothing else in the step reads it), whether
a steady wind batch has an external force series (``FORCE``) and, for a
kind with a switch row, its value (a literal in ``_ptup``).

Globals the specialisation sets: the kind's ``rhs``, ``TRIG``, the layout constants (``VB``,
``NT``, ``VROWS``, ``ZR``), the variant's constants and the generated joint-state helpers
(``_ztup``, ``_zput``, ``_states``, ``_joint``, ``_finite``, ``_vaxpy``, ``_vrk4sum``,
``_vput``, ``_ptup``).
"""

from __future__ import annotations

import numba
import numpy as np

from usvid.sim.lane import _heldload, _holdget, _holdset
from usvid.sim.layout import (
    CH,
    DIST_A0,
    DIST_A1,
    DIST_B,
    HOLD_ROWS,
    JDD,
    JDL,
    JPSI,
    JW1,
    JW2,
    LACT,
    LCUR,
    LFLAG,
    LMAXD,
    LOVMAX,
    LPSI0,
    LQ,
    LSW,
    LZZN,
    NOF,
    R_MAX,
    RDL,
    RPSI,
    RW2,
    SFORCE,
    VC,
    VCMD,
    VF,
    VH,
    VL,
    VNOISE,
    VRAMP,
    VS,
    VT,
)
from usvid.sim.scalar import _clip, _rot_nan, _rotv

# -- set by the specialisation (placeholders) --------------------------------------------------
#: Variant constants: servo kind (0 ideal, 1 first order, 2 second order, -1 any: the blend of
#: the per-lane path); no disturbance and no input series in the batch (the disturbance filter
#: stays at rest and the steering angle is the servo's); x and y integrated (not when neither is
#: recorded: no other quantity depends on them, and with them goes the heading's rotation).
SK, NOD, XY = 2, False, True
#: Variant constant: the batch has wind loads or wave drift (the environment block after the
#: kind's parameters, ``_etup``; the loads' multirate hold,
#: :func:`usvid.sim.lane._heldload`), with x, y (XY) and the environment's series (force,
#: current, wind: with WIND, NOD means no disturbance and no delta or n series only).
WIND = False
#: Variant constant (with WIND): the batch's series are the environment's only and constant in
#: time, or absent (the driver loads them once; start and end rows equal): the external force
#: series is added to the held loads once per step, in the loads' loop of :func:`_vstep`, and
#: the current read at the step start (the first-order hold of a constant is that constant).
STEADY = False
#: Variant constant (with WIND): every lane has the same environment block (``_etup``), read
#: once per step before the lane loop (a load inside the loop from a row of lane slot 0, which
#: the loop's stores might overwrite as far as LLVM can tell, keeps it from vectorising).
SHARED = False
#: Variant constant (with STEADY): some lane has an external force series (else its rows hold
#: zeros and are not read: their loads and adds were, in the heading-only wind zig-zag of
#: ``benchmarks/bench_sim.py --wind``, 3 ns of the lane-step's 26).
FORCE = True
ZU = 0  # position of u in the joint-state tuple (-1: the constant speed, parameter SPEEDROW)
ZV = 0  # position of v in the joint-state tuple (-1: none, zero)
SPEEDROW = 0  # parameter row of the constant speed of a response kind
TRIG = False  # the kind reads cos/sin of the steering angle
VB = 0  # first scratch row
NT = 1  # joint-state length
VROWS = 1  # rows of the chunk array
ZR = 0  # position of r in the joint-state tuple
#: Lanes of one vector (the AVX2 width of float64): a chunk of at most VW lanes (a single run)
#: takes the vector step of VW lane slots, not CH, and the driver's vectorised loops compute
#: the chunk's lanes rounded up to a multiple of VW, so that one run costs one vector of lanes.
VW = 4
NLANES = CH  # the vector step's lane slots (CH, or VW: set by the specialisation)
rhs = _ztup = _zput = _states = _joint = _finite = _vaxpy = _vrk4sum = _vput = _ptup = None
_etup = None


def _dnow(V, j):
    """Lane j's steering angle at the step start [rad] as recorded (without the disturbance):
    the measured one (series ``delta``, row VF), else the servo's, limited."""
    fd = V[VF * CH + j]
    # every value loaded whatever fd and the clip written as selects (:func:`_clip`): no
    # branch, no conditional load, so that the lane loops calling it (:func:`_vbases`, the
    # driver's ``_vmaxd``) vectorise
    x = V[RDL * CH + j]
    ma = V[VS * CH + j]
    d = ma if x > ma else (-ma if x < -ma else x)
    return d if np.isnan(fd) else fd


def _steer(V, j):
    """Lane j's steering angle at the step start [rad]: :func:`_dnow` plus the disturbance."""
    return _dnow(V, j) + DIST_B * V[RW2 * CH + j]


def _hbase(V, j):
    """Lane slot j's heading and its cosine and sine at the step start (the trig base of the
    step): rotated from the previous step's base by the series of :func:`_rot_nan` (NaN when
    the heading moved more than 0.05 rad) and renormalised."""
    a = V[RPSI * CH + j]
    o = VT * CH + j
    c_, s_ = _rot_nan(a, V[o], V[o + CH], V[o + 2 * CH])
    g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
    return a, c_ * g_, s_ * g_


def _vheld(V, j, c0, s0, pe):
    """Lane slot j's environment loads (an evaluation of the hold, :func:`usvid.sim.lane._heldload`)
    at the step start: its joint state, its environment block ``pe`` (``_etup``), the
    environment series there and the cosine ``c0`` and sine ``s0`` of its heading
    (:func:`_hbase`)."""
    o = VF * CH + j
    nan = np.nan
    # the step's start (tau = 0): the end values are those of the start (s + 0 (e - s) is s for
    # finite values, and without this the end rows are loaded too: 0 (e - s) is not 0 for an
    # infinite e - s, so LLVM keeps the loads)
    cn = V[o + 8 * CH]
    ce = V[o + 9 * CH]
    wn = V[o + 10 * CH]
    we = V[o + 11 * CH]
    fs = (nan, nan, nan, nan, nan, nan, nan, nan, cn, ce, wn, we, nan, nan, nan, nan, nan, nan,
          nan, nan, cn, ce, wn, we)
    return _heldload(_ptup(V, j), pe, _ztup(V, j), 0.0, fs, c0, s0)


def _vderiv(p, fe, tau, srv, cmdin, ramp, noise, fs, tr, z, first):
    """:func:`_deriv` for the vector step, with the variant's constants :data:`SK`,
    :data:`NOD`, :data:`XY`, :data:`WIND` (the branches of the other variants vanish at compile
    time; ``fe`` the environment's loads held over the step, read only with WIND); returns
    (the derivative, the largest |angle - base angle| of its rotations). ``first``: 1.0 at the
    step start (stage 1), where the angles are the bases' own (no rotation), else 0.0 (a float,
    not a bool: numba types a constant True and False as two literal types and compiled this
    function twice, 12 s of a first MMG run; inlined, LLVM folds the constant all the same)."""
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
    if NOD:  # no series: calm water (-0.0 forces vanish in the kind's sums), no current
        de = d
        n0 = np.nan
        n1 = np.nan
        n2 = np.nan
        f = NOF
        cx = 0.0
        cy = 0.0
        if WIND and STEADY:  # the series' force is in fe (constant: :data:`STEADY`)
            cx = fs[8]
            cy = fs[9]
        elif WIND:  # but the environment's series (force, current; the wind's are in fe)
            f = (fs[4] + tau * (fs[16] - fs[4]), fs[5] + tau * (fs[17] - fs[5]),
                 fs[6] + tau * (fs[18] - fs[6]), fs[7] + tau * (fs[19] - fs[7]))
            cx = fs[8] + tau * (fs[20] - fs[8])
            cy = fs[9] + tau * (fs[21] - fs[9])
    else:
        fd = fs[0] + tau * (fs[12] - fs[0])
        de = (d if np.isnan(fd) else fd) + DIST_B * z[JW2]
        n0 = fs[1] + tau * (fs[13] - fs[1])
        n1 = fs[2] + tau * (fs[14] - fs[2])
        n2 = fs[3] + tau * (fs[15] - fs[3])
        f = NOF
        if WIND and STEADY:  # the series' force is in fe (constant: :data:`STEADY`)
            cx = fs[8]
            cy = fs[9]
        else:
            f = (fs[4] + tau * (fs[16] - fs[4]), fs[5] + tau * (fs[17] - fs[5]),
                 fs[6] + tau * (fs[18] - fs[6]), fs[7] + tau * (fs[19] - fs[7]))
            cx = fs[8] + tau * (fs[20] - fs[8])
            cy = fs[9] + tau * (fs[21] - fs[9])
    cd = 1.0
    sd = 0.0
    hm = 0.0
    if TRIG:
        if first != 0.0 and NOD:  # the steering angle is its base's
            cd = tr[4]
            sd = tr[5]
        else:
            cd, sd, hm = _rotv(de, tr[3], tr[4], tr[5])
    if WIND and STEADY:  # the series' force and the held loads (:func:`_vstep`)
        f = fe
    elif WIND:  # the loads held over the step (:func:`usvid.sim.lane._heldload`)
        f = (f[0] + fe[0], f[1] + fe[1], f[2] + fe[2], f[3] + fe[3])
    u, v, r, ds = rhs(p, _states(z), (de, cd, sd, n0, n1, n2), f)
    k0 = 0.0
    k1 = 0.0
    if XY:
        cps = tr[1]
        sps = tr[2]
        if first == 0.0:
            cps, sps, hp = _rotv(z[JPSI], tr[0], tr[1], tr[2])
            hm = max(hm, hp)
        k0 = u * cps - v * sps
        k1 = u * sps + v * cps
        if WIND or not NOD:  # the velocity over ground: through the water plus the current
            k0 += cx
            k1 += cy
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


def _vrk4(p, fe, z, h, frac, srv, cmdin, ramp, noise, fs, tr):
    """:func:`_rk4` for the vector step (a whole step: tau from 0 to ``frac``; with WIND the
    environment's loads ``fe`` held over it, :func:`usvid.sim.lane._heldload`); the heading
    is NaN when an angle moved more than 0.05 rad from its base (the lane is then flagged)."""
    k1, m1 = _vderiv(p, fe, 0.0, srv, cmdin, ramp, noise, fs, tr, z, 1.0)
    tm = 0.5 * frac
    k2, m2 = _vderiv(p, fe, tm, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, 0.5 * h, k1), 0.0)
    k3, m3 = _vderiv(p, fe, tm, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, 0.5 * h, k2), 0.0)
    k4, m4 = _vderiv(p, fe, frac, srv, cmdin, ramp, noise, fs, tr, _vaxpy(z, h, k3), 0.0)
    far = max(max(m1, m2), max(m3, m4)) > 0.05
    return _vrk4sum(z, h / 6.0, k1, k2, k3, k4, far)


def _vstep(Vp, h, frac, zig, sk):
    """One step of the first :data:`NLANES` lane slots of a chunk (all :data:`CH`, or
    :data:`VW` in the variant for a chunk of at most VW lanes, e.g. a single run), vectorised
    across lanes (the lane loop innermost; a C callback, see :func:`vector_step`): the step's
    trig bases, one RK4 step of length h [s] (the fraction ``frac`` of the step), and the end of
    the step of the quiet lanes (row LQ); returns the number of active lanes flagged (row
    LFLAG = 1) for the per-lane branch of :func:`_chunk`. The trip count is the constant
    NLANES whatever the chunk's number of lanes (unused slots hold zeros or stale values and
    are ignored; a trip count known at compile time: LLVM then vectorises the loop, which it
    does not with a run-time one here): every lane is computed by the same vector code, so a
    lane's result does not depend on its position or on the chunking.

    ``Vp`` points to the chunk's work array ``V`` (rows: joint state, servo values, command /
    ramp rate / noise, input series, trig bases, logic variables, parameters, scratch;
    :mod:`usvid.sim.layout`): one array, so that LLVM knows every access's offset and needs
    no alias checks. Per lane slot:

    * trig bases: the heading's (with :data:`XY`; with WIND and without XY at the loads'
      evaluations only) and, for a TRIG kind, the steering angle's,
      rotated from the previous step's (:func:`_rot_nan`) and renormalised; NaN where the angle
      moved more than 0.05 rad (the lane is then flagged, and its bases are computed by the
      library before the per-lane step);
    * max |delta| of the quiet lanes at the step start (the measured angle, else the servo's);
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
    fe = NOF
    sh = 0.0
    if WIND:  # the multirate hold (:func:`usvid.sim.lane._holdset`,
        # :func:`usvid.sim.lane._holdget`; the control row VC the driver wrote, read before
        # the loops): at the steps the driver says, the loads of every lane evaluated first
        # (:func:`_vheld`), in a loop of their own (the other steps' loop has no evaluation),
        # into the scratch rows VB.. (free before the step's loop), then copied to the held
        # rows; the heading's bases there as in the step's loop (with XY: the same values,
        # stored by the step's loop; without: the only bases of the vector step, stored here)
        c = VC * CH
        sh = V[c + 2]
        if V[c] > 0.0:
            pe0 = _etup(V, 0)  # (SHARED: every lane's)
            kf = V[c + 1]
            g = V[c + 3]
            for j in range(NLANES):
                a, c0, s0 = _hbase(V, j)
                if not XY:
                    o = VT * CH + j
                    V[o] = a
                    V[o + CH] = c0
                    V[o + 2 * CH] = s0
                _holdset(V, j, _vheld(V, j, c0, s0, pe0 if SHARED else _etup(V, j)), g, kf,
                         not np.isnan(c0), VB)
            for j in range(NLANES):
                for i in range(HOLD_ROWS):
                    V[(VH + i) * CH + j] = V[(VB + i) * CH + j]
    for j in range(NLANES):
        a = V[RPSI * CH + j]
        c0 = 1.0
        s0 = 0.0
        if XY:
            o = VT * CH + j
            a, c0, s0 = _hbase(V, j)
            V[o] = a
            V[o + CH] = c0
            V[o + 2 * CH] = s0
        elif WIND:  # the heading's cosine at the last evaluation of the loads (NaN: the
            # evaluation could not rotate the base, the loads not refreshed); without x and
            # y nothing else in the step reads the bases: they follow the heading at the
            # evaluations only (rotated over the load interval, :func:`_hbase`)
            c0 = V[(VT + 1) * CH + j]
        if WIND:  # the loads held over the step; NaN with the heading's base (0 c0 is NaN
            # then, else a zero: X unchanged), so that such a lane's result is not finite and
            # the per-lane step takes the step (and evaluates the loads if due): without x, y
            # nothing else in the step reads the base, and held loads would go on unrefreshed
            fe = _holdget(V, j, sh)
            fe = (fe[0] + 0.0 * c0, fe[1], fe[2], fe[3])
            if STEADY and FORCE:  # the series' force (constant) plus the loads, as
                # :func:`_vderiv` adds
                o = (VF + SFORCE) * CH + j
                fe = (V[o] + fe[0], V[o + CH] + fe[1], V[o + 2 * CH] + fe[2],
                      V[o + 3 * CH] + fe[3])
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
        if NOD and not WIND:
            fs = (np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan,
                  np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan,
                  np.nan, np.nan, np.nan, np.nan)
        elif NOD and STEADY:  # (WIND) the current only, at the step start
            o = VF * CH + j
            nan = np.nan
            fs = (nan, nan, nan, nan, nan, nan, nan, nan, V[o + 8 * CH], V[o + 9 * CH], nan, nan,
                  nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan)
        else:
            o = VF * CH + j
            fs = (V[o], V[o + CH], V[o + 2 * CH], V[o + 3 * CH], V[o + 4 * CH], V[o + 5 * CH],
                  V[o + 6 * CH], V[o + 7 * CH], V[o + 8 * CH], V[o + 9 * CH], V[o + 10 * CH],
                  V[o + 11 * CH], V[o + 12 * CH], V[o + 13 * CH], V[o + 14 * CH],
                  V[o + 15 * CH], V[o + 16 * CH], V[o + 17 * CH], V[o + 18 * CH],
                  V[o + 19 * CH], V[o + 20 * CH], V[o + 21 * CH], V[o + 22 * CH],
                  V[o + 23 * CH])
        z = _ztup(V, j)
        y = _vrk4(_ptup(V, j), fe, z, h, frac, srv, V[VCMD * CH + j],
                  V[VRAMP * CH + j], V[VNOISE * CH + j], fs, tr)
        quiet = V[(VL + LQ) * CH + j] > 0.0
        # max |delta| of the quiet lanes at the step start: the measured angle (series delta,
        # loaded for the quiet lanes by the driver), else the servo's, limited (the value
        # :func:`_dnow` records, from the values loaded above; without series fs[0] is a NaN
        # literal and the select compiles away)
        dm = d if np.isnan(fs[0]) else fs[0]
        V[(VB + NT + 1) * CH + j] = max(V[(VL + LMAXD) * CH + j], abs(dm) if quiet else 0.0)
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
    for j in range(NLANES):
        V[(VL + LMAXD) * CH + j] = V[(VB + NT + 1) * CH + j]
        V[(VL + LOVMAX) * CH + j] = V[(VB + NT + 2) * CH + j]
    return nslow


_f8 = numba.types.float64
#: C signature of :func:`_vstep`: (V, h, frac, zig, servo kind) -> number of flagged lanes.
VSIG = _f8(numba.types.CPointer(_f8), _f8, _f8, _f8, _f8)
