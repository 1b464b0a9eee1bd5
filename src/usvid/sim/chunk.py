"""The chunk driver of the integration core: steps a chunk of lanes (at most
:data:`usvid.sim.layout.CH`) from start to end; the same compiled code for every model kind.

It owns the time loop, the manoeuvre logic (commanded series, turning, zig-zag, PID course
change), the dead-time queues, the servo limits, the event-located zig-zag switching, the
records, the accumulators and the divergence test. A kind enters only through

* ``kinfo`` (:data:`usvid.sim.layout.KINFO`): its number of states and parameters, the rows of
  its chunk array and where u, v, r, phi, p sit (read at run time);
* the address of its vector step (``vaddr``: :mod:`usvid.sim.vector`, the variant the batch
  needs; 0: none) and of its per-lane step (``laddr``: :func:`usvid.sim.lane._lstep`), C
  callbacks compiled per kind (:mod:`usvid.sim.specialise`).

So the driver is compiled (and cached on disk) once, not once per kind. Each step:

* **quiet lanes** (:func:`_vquiet`: no logic acting and no event due at the start of the step
  or inside it) get their first-order-hold input series at the step ends (:func:`_vload`:
  a measured steering angle or shaft speed, a current, a force varying in time) and are
  recorded channel by channel (:func:`_vrecord`); so output error's windows (a measured
  angle and shaft speed per lane, no command) step on the quiet path: 306 -> 224 ns CPU a
  lane-step of its Jacobian batches (2712 lanes x 200 steps, 2 threads), where every lane
  used to take phases 1 and 3 at every step;
* **phase 1**, per lane, for the other lanes only: the input series at the step ends, the logic
  (command events into the lane's dead-time queue), the events due at the step start, the
  record and max |delta|, the noise sample;
* **phase 2**: the vector step of all lanes (trig bases, RK4, max |delta| and the end of the step
  of the quiet lanes; it flags the lanes whose step must be done the per-lane way), else the max
  |delta| of the quiet lanes (:func:`_vmaxd`) and the trig bases (:func:`_vbases`);
* **phase 3**, per lane, for the flagged and the other lanes only: the step integrated again by
  the per-lane step where an event falls inside it (or the vector step flagged it), the zig-zag
  switching located, the servo limits and the divergence test applied.

The quiet and the per-lane branches do the same arithmetic, so a lane's result does not depend
on which lanes share its chunk. Without ``simd`` every step takes the per-lane path (the
reference).
"""

from __future__ import annotations

import math

import numba
import numba.extending
import numpy as np
from llvmlite import ir as llvmir

from usvid.models.kind import S0  # the kind's first row in the external joint state Z
from usvid.sim.layout import (
    CH,
    COMMANDED,
    COURSE,
    DIST_B,
    JDD,
    JDL,
    JPSI,
    JS,
    KNPK,
    KNS,
    KNT,
    KROWS,
    KSPEED,
    KTRIG,
    KVB,
    KVN,
    KVP,
    KZP,
    KZPHI,
    KZR,
    KZU,
    KZV,
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
    N_ZZ,
    NCH,
    NSER,
    R_MAX,
    RDD,
    RDL,
    RPSI,
    RW2,
    SCUR,
    SERVO_ROWS,
    SFORCE,
    TURNING,
    VC,
    VCMD,
    VF,
    VH,
    VL,
    VNOISE,
    VRAMP,
    VS,
    VT,
    VZ,
    ZIGZAG,
)
from usvid.sim.scalar import (
    _clip,
    _fin,
    _normal,
    _push,
    _rot_nan,
    _splitmix,
    _start_ramp,
    _wrap,
)
from usvid.sim.vector import _dnow, _steer


@numba.extending.intrinsic
def _vcall(typingctx, addr, V, h, frac, zig, sk):
    """Call the vector step at address ``addr`` (:func:`usvid.sim.vector._vstep`) on V."""
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


@numba.extending.intrinsic
def _lcall(typingctx, addr, V, qt, qv, out, cap, b, j, skind, qh, qn, t, t1, eps, idt, cmdin,
           ramp, rend):
    """Call the per-lane step at address ``addr`` (:func:`usvid.sim.lane._lstep`): the arrays
    V, qt, qv, out by their data pointers, then the integers and the floats."""
    f8 = numba.types.float64
    i8 = numba.types.int64
    sig = f8(i8, V, qt, qv, out, i8, i8, i8, i8, i8, i8, f8, f8, f8, f8, f8, f8, f8)

    def codegen(context, builder, signature, args):
        ptrs = [context.make_array(signature.args[k])(context, builder, args[k]).data
                for k in range(1, 5)]
        rest = list(args[5:])
        fnty = llvmir.FunctionType(llvmir.DoubleType(), [p.type for p in ptrs]
                                   + [v.type for v in rest])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(fn, ptrs + rest)

    return sig, codegen


def _load_series(V, o, SER, sidx, row, k, kk):
    """The input series at the step ends (first-order hold) into the rows VF.. of ``V``
    (absent: NaN for the actuators, 0 for the environment)."""
    for i in range(NSER):
        s = sidx[i]
        none = np.nan if i < SFORCE else 0.0
        V[o + i * CH] = SER[s, row, k] if s >= 0 else none
        V[o + (NSER + i) * CH] = SER[s, row, kk] if s >= 0 else none


def _vload(V, W, SER, sidx, row0, sstride, k):
    """The input series at the ends of step k (first-order hold) of the quiet lanes (row LQ)
    into the rows VF.. of ``V`` (the values :func:`_load_series` loads; a quiet lane has
    steps left, so its step ends at sample k + 1); ``row0``: the chunk's first lane's row of
    ``SER``. The absent series' rows keep their NaN or 0."""
    for i in range(NSER):
        s = sidx[i]
        if s < 0:
            continue
        for j in range(W):
            if V[(VL + LQ) * CH + j] > 0.0:
                row = row0 + j * sstride
                V[(VF + i) * CH + j] = SER[s, row, k]
                V[(VF + NSER + i) * CH + j] = SER[s, row, k + 1]


def _vbases(V, trig):
    """The step's trig bases (angle, cos, sin of the heading; ``trig``: of the steering angle)
    for all CH lane slots, rotated from the previous step's (:func:`_rot_nan`, vectorised) and
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
    if trig:  # a loop of its own: LLVM vectorises the two loops, not the fused one
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


def _chval(V, j, ch, dnow, cmdlog, ki):
    """Lane j's value of channel ``ch`` (:data:`usvid.sim.layout.CHANNELS`) at the step start
    (``ki`` the kind's :data:`usvid.sim.layout.KINFO`)."""
    if ch <= 2:
        return V[(VZ + ch) * CH + j]  # x, y, psi
    if ch <= 4 or ch == 6:  # u, v, U over ground: through the water plus the current
        zu = ki[KZU]
        vu = V[(ki[KVP] + ki[KSPEED]) * CH + j] if zu < 0 else V[(VZ + zu) * CH + j]
        vv = 0.0 if ki[KZV] < 0 else V[(VZ + ki[KZV]) * CH + j]
        cx = V[(VF + SCUR) * CH + j]
        cy = V[(VF + SCUR + 1) * CH + j]
        if cx != 0.0 or cy != 0.0:
            psi = V[RPSI * CH + j]
            c = math.cos(psi)
            s = math.sin(psi)
            vu, vv = vu + cx * c + cy * s, vv - cx * s + cy * c
        if ch == 3:
            return vu
        if ch == 4:
            return vv
        return math.sqrt(vu * vu + vv * vv)
    if ch == 5:
        return V[(VZ + ki[KZR]) * CH + j]
    if ch == 7:
        return dnow
    if ch == 8:
        return cmdlog
    if ch <= 11:
        return V[(VF + ch - 8) * CH + j]  # n, n_port, n_stbd at the step start
    if ch == 12:
        return DIST_B * V[RW2 * CH + j]
    zs = ki[KZPHI] if ch == 13 else ki[KZP]
    return np.nan if zs < 0 else V[(VZ + zs) * CH + j]


def _record(V, j, b, jrec, slots, rec, dnow, cmdlog, ki):
    """Record lane j (lane b of the batch) at the step start into ``rec[:, b, jrec]``."""
    for ch in range(NCH):
        sl = slots[ch]
        if sl >= 0:
            rec[sl, b, jrec] = _chval(V, j, ch, dnow, cmdlog, ki)


def _chrow(ch, ki, cur):
    """The row of ``V`` that holds channel ``ch``'s value (:func:`_chval`) for every lane, or
    -1 (a value computed per lane). ``cur``: the batch has a current (u, v over ground are
    then computed)."""
    if ch <= 2:
        return VZ + ch  # x, y, psi
    if ch == 5:
        return VZ + ki[KZR]
    if ch == 3 and not cur:
        zu = ki[KZU]
        return ki[KVP] + ki[KSPEED] if zu < 0 else VZ + zu
    if ch == 4 and not cur and ki[KZV] >= 0:
        return VZ + ki[KZV]
    if 9 <= ch <= 11:
        return VF + ch - 8  # n, n_port, n_stbd at the step start
    if ch == 13 and ki[KZPHI] >= 0:
        return VZ + ki[KZPHI]
    if ch == 14 and ki[KZP] >= 0:
        return VZ + ki[KZP]
    return -1


def _vrecord(V, lo, W, jrec, slots, rec, ki, cur):
    """Record the quiet lanes (row LQ) of the chunk at the step start, channel by channel (the
    values of :func:`_record`; the input series of the step loaded, :func:`_vload`): a
    channel held in a row of ``V`` (:func:`_chrow`; ``cur``: the batch has a current) copied
    from it, the others by :func:`_chval` (psi, r, u, v of the output-error windows: 143-163
    -> 132-142 ns a lane-step of its Jacobian batch, one thread, interleaved at a load of 2.5;
    100-110 at a load of 1)."""
    for ch in range(NCH):
        sl = slots[ch]
        if sl < 0:
            continue
        r = _chrow(ch, ki, cur)
        if r >= 0:
            for j in range(W):
                if V[(VL + LQ) * CH + j] > 0.0:
                    rec[sl, lo + j, jrec] = V[r * CH + j]
            continue
        for j in range(W):
            if V[(VL + LQ) * CH + j] > 0.0:
                rec[sl, lo + j, jrec] = _chval(V, j, ch, _dnow(V, j),
                                               V[(VL + LCMDLOG) * CH + j], ki)


def _quiet_until(V, j, b, lk, L, qt, busy):
    """Time [s] up to which lane j (lane b of the batch) is quiet: no command event queued, no
    ideal-servo ramp ending and no logic start pending before it (-inf: never, for logics
    acting at every step, a commanded rudder series or a noise input; the first-order-hold
    input series are loaded on the quiet path too, :func:`_vload`). A step ending at t1 with
    t1 + eps <= this time takes the quiet path of :func:`_chunk` (the per-lane branches would do
    nothing)."""
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
    measured steering angle, else the servo's, limited: :func:`usvid.sim.vector._dnow`).

    The updated row goes through the scratch row ``tmp`` (CH values) and is copied back:
    ``V[o] = new if cond else V[o]`` would compile to a masked store (``vmaskmovpd``, slow).
    (The vector step computes the same for the quiet lanes it steps.)"""
    o = (VL + LMAXD) * CH
    for j in range(CH):
        d = abs(_dnow(V, j))
        m = V[o + j]
        tmp[j] = d if ((V[(VL + LQ) * CH + j] > 0.0) & (d > m)) else m
    for j in range(CH):
        V[o + j] = tmp[j]


def _restore(V, zb, j, nt):
    """Lane j's joint state (``nt`` rows) and overshoot from before the vector step
    (:func:`usvid.sim.vector._vstep`, the scratch rows ``zb``)."""
    for r in range(nt):
        V[(VZ + r) * CH + j] = zb[r * CH + j]
    V[(VL + LOVMAX) * CH + j] = zb[nt * CH + j]


def _finite_rows(V, o, j, nt):
    """Lane j's positions, heading and kind states in the joint-state rows from ``o`` finite."""
    ok = _fin(V[(o + JPSI) * CH + j])  # (not np.isfinite: folded under fast math, _fin)
    for r in range(JPSI):
        ok = ok and _fin(V[(o + r) * CH + j])
    for r in range(JS, nt):
        ok = ok and _fin(V[(o + r) * CH + j])
    return ok


def _chunk(lo, hi, P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps, dt, rec_every, slots,
           rec, acc, zz, zzt, status, qt, qv, simd, vaddr, laddr, ki, sconst, hold_m, hold_w):
    """Integrate lanes lo..hi-1 (at most :data:`CH`) together: one task of
    :func:`usvid.sim.core.run` (module docstring).

    The chunk's joint states, parameters, servo values, inputs and logic variables live in
    the work array ``V`` (a row per quantity, a column per lane: :mod:`usvid.sim.layout`).
    ``vaddr`` is the address of the kind's vector step for this chunk (0: none, every step the
    per-lane way), ``laddr`` that of its per-lane step, ``ki`` its
    :data:`usvid.sim.layout.KINFO`. ``sconst``: the input series are the environment's only
    and constant in time (a constant current, wind, force): loaded once, at the start, so that
    the lanes may be quiet (as in calm water) instead of taking phase 1 at every step.
    ``hold_m`` > 0 (a batch with wind loads or wave drift): the multirate hold of the
    state-dependent loads, evaluated at the start of every ``hold_m``-th step and held, or
    (``hold_w`` = 1) linearly extrapolated from the last two evaluations to each step's
    midpoint (:func:`usvid.sim.lane._holdget`); the driver writes the hold's control row
    (:data:`usvid.sim.layout.HOLD_CTRL`) the vector and per-lane steps read.
    """
    ns = ki[KNS]
    npk = ki[KNPK]
    nt = ki[KNT]
    vn = ki[KVN]
    zr = ki[KZR]
    trig = ki[KTRIG] != 0
    ID = S0 + ns
    W = hi - lo
    V = np.zeros(ki[KROWS] * CH)
    zb = V[ki[KVB] * CH:]  # the scratch rows (of the vector step, _vmaxd)
    out = np.zeros(5)  # the per-lane step's command, ramp rate, ramp end, queue head and length
    for j in range(CH):
        V[(VT + 1) * CH + j] = 1.0  # trig bases: cos 0, sin 0
        V[(VT + 4) * CH + j] = 1.0
        for i in range(NSER):  # input series: absent (actuators NaN, environment 0)
            none = np.nan if i < SFORCE else 0.0
            V[(VF + i) * CH + j] = none
            V[(VF + NSER + i) * CH + j] = none
        V[(VH + 8) * CH + j] = -1.0  # the step of the last load evaluation: none yet
    act = np.zeros(W, dtype=np.bool_)
    simple = np.zeros(W, dtype=np.bool_)
    rngs = np.zeros(W, dtype=np.uint64)
    s4_ = sidx[NSER]  # the commanded rudder angle (delta_cmd)
    series = False
    for i in range(NSER):
        series = series or sidx[i] >= 0
    if sconst:  # loaded once below: nothing acts at every step
        series = False
    cap = qt.shape[1]
    eps = 1e-9 * dt
    idt = 1.0 / dt
    nmax = 0
    for j in range(W):
        b = lo + j
        nmax = max(nmax, nsteps[b])
        for i in range(npk):
            V[(ki[KVP] + i) * CH + j] = P[b, i]
        for i in range(SERVO_ROWS):
            V[(VS + i) * CH + j] = S[b, i]
        if sconst:
            _load_series(V, VF * CH + j, SER, sidx, b * sstride, 0, 0)
        ma = S[b, 0]
        for i in range(3):  # x, y, psi
            V[(VZ + i) * CH + j] = Z[b, i]
        for i in range(ns):
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
    if vaddr == 0:  # no vector step for this chunk
        simd = False
    # lanes whose logic or commanded input acts at every step are never quiet (the
    # first-order-hold series: loaded for the quiet lanes by _vload)
    busy = lk == COURSE or (lk == COMMANDED and s4_ >= 0)
    hascur = sidx[SCUR] >= 0 or sidx[SCUR + 1] >= 0  # a current (u, v over ground, _chrow)
    for k in range(nmax + 1):
        t = k * dt
        t1 = t + dt
        recnow = k % rec_every == 0
        if hold_m > 0:  # the multirate hold's control row (:data:`usvid.sim.layout.HOLD_CTRL`)
            kr = k % hold_m
            V[VC * CH] = 1.0 if kr == 0 else 0.0
            V[VC * CH + 1] = k
            V[VC * CH + 2] = hold_w * (kr + 0.5) * dt
            V[VC * CH + 3] = 0.0 if k == 0 else hold_w / (hold_m * dt)
        jrec = k // rec_every
        # -- quiet lanes (no logic and no event at the start of or inside the step: the
        # per-lane branches below would do nothing but the record and max |delta|) --
        nq = _vquiet(V, float(k), t1 + eps)
        nsimple = int(nq) if simd else 0
        if series and nq > 0.0:
            _vload(V, W, SER, sidx, lo * sstride, sstride, k)
        if recnow and nq > 0.0:
            _vrecord(V, lo, W, jrec, slots, rec, ki, hascur)
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
                     - L[b, 3] * V[(VZ + zr) * CH + j])
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
            dnow = _dnow(V, j)
            if abs(dnow) > V[(VL + LMAXD) * CH + j]:
                V[(VL + LMAXD) * CH + j] = abs(dnow)
            if recnow:
                _record(V, j, b, jrec, slots, rec, dnow, cmdlog, ki)
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
            nslow = _vcall(vaddr, V, t1 - t, (t1 - t) * idt, 1.0 if lk == ZIGZAG else 0.0,
                           float(skind))
        else:
            _vmaxd(V, zb)
            for j in range(W if _vbases(V, trig) > 0.0 else 0):
                if act[j] and np.isnan(V[(VT + 1) * CH + j]):
                    _base_far(V, j, 0, V[RPSI * CH + j])
                if trig and act[j] and np.isnan(V[(VT + 4) * CH + j]):
                    _base_far(V, j, 3, _steer(V, j))
        # -- phase 3, per lane: events inside the step, zig-zag switching, limits, divergence.
        # A lane's new joint state is in the rows vn..: the vector step's result (limits
        # applied), or the per-lane step's --
        for j in range(W if (nslow > 0.0 or (nsimple > 0 and nact < W)) else 0):
            if nsimple > 0 and (not act[j] or V[(VL + LFLAG) * CH + j] != 0.0):
                if act[j]:
                    for r in range(nt):  # the vector step's result
                        V[(vn + r) * CH + j] = V[(VZ + r) * CH + j]
                _restore(V, zb, j, nt)  # the state before the vector step
            if not act[j] or (nsimple > 0 and V[(VL + LFLAG) * CH + j] == 0.0):
                continue
            if nsimple > 0:  # a trig base the vector step left NaN: by the library
                if np.isnan(V[(VT + 1) * CH + j]):
                    _base_far(V, j, 0, V[RPSI * CH + j])
                if trig and np.isnan(V[(VT + 4) * CH + j]):
                    _base_far(V, j, 3, _steer(V, j))
            b = lo + j
            ok = False
            if (simd and V[(VL + LQ) * CH + j] > 0.0) or simple[j]:
                ok = _finite_rows(V, vn, j, nt)
            sv = (V[VCMD * CH + j], V[VRAMP * CH + j], V[(VL + LREND) * CH + j],
                  V[(VL + LQH) * CH + j], V[(VL + LQN) * CH + j])  # the state before the step
            # (for a zig-zag redo)
            if not ok:
                _lcall(laddr, V, qt, qv, out, cap, b, j, skind, int(sv[3]), int(sv[4]), t, t1,
                       eps, idt, sv[0], sv[1], sv[2])
                V[VCMD * CH + j] = out[0]
                V[VRAMP * CH + j] = out[1]
                V[(VL + LREND) * CH + j] = out[2]
                V[(VL + LQH) * CH + j] = out[3]
                V[(VL + LQN) * CH + j] = out[4]
            cur = V[(VL + LCUR) * CH + j]
            if lk == ZIGZAG and cur != 0.0:  # zig-zag switching, event-located
                sw = L[b, 1]
                psi0 = V[(VL + LPSI0) * CH + j]
                dev0 = V[RPSI * CH + j] - psi0  # the heading at the step start
                dev1 = V[(vn + JPSI) * CH + j] - psi0
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
                        _lcall(laddr, V, qt, qv, out, cap, b, j, skind, qh, qn, t, t1, eps,
                               idt, sv[0], sv[1], sv[2])
                        V[VCMD * CH + j] = out[0]
                        V[VRAMP * CH + j] = out[1]
                        V[(VL + LREND) * CH + j] = out[2]
                        qh = int(out[3])
                        qn = int(out[4])
                    else:
                        qh, qn = _push(qt, qv, b, int(V[(VL + LQH) * CH + j]),
                                       int(V[(VL + LQN) * CH + j]), tr, cmdlog)
                    V[(VL + LQH) * CH + j] = qh
                    V[(VL + LQN) * CH + j] = qn
            # servo limits, divergence
            dl = V[(vn + JDL) * CH + j]
            dd = V[(vn + JDD) * CH + j]
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
            for r in range(nt):
                V[(VZ + r) * CH + j] = V[(vn + r) * CH + j]
            V[RDL * CH + j] = dl
            V[RDD * CH + j] = dd
            if not (abs(V[(vn + zr) * CH + j]) <= R_MAX and (ok or _finite_rows(V, vn, j, nt))):
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
        for i in range(ns):
            Z[b, S0 + i] = V[(VZ + JS + i) * CH + j]
        for i in range(4):
            Z[b, ID + i] = V[(VZ + JDL + i) * CH + j]


#: The driver's template functions (specialised once for all kinds, :mod:`usvid.sim.specialise`).
TEMPLATES = ("_load_series", "_vload", "_steer", "_vbases", "_base_far", "_chval", "_chrow",
             "_dnow", "_record", "_vrecord", "_quiet_until", "_vquiet", "_vmaxd", "_restore",
             "_finite_rows", "_chunk")
