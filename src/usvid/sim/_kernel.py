"""numba kernel: fixed-step RK4 over a batch of runs (prange over runs, one compile for all).

Internal; the public entry is :func:`usvid.sim.simulate`, which packs the dataclasses into the
flat parameter rows documented here.

State vector (NZ = 12): x, y, psi, u, v, r, z1, z2, delta, delta_dot, w1, w2
(z1, z2: Nomoto-2 realisation; delta, delta_dot: servo; w1, w2: disturbance filter).

Model rows ``P[b]`` by kind:

- 0 nomoto1:  K, T, delta0, U
- 1 nomoto2:  K, T1, T2, T3, delta0, U
- 2 norrbin:  K, T, n1, n3, delta0, U
- 3 threedof: m11 m22 m33 d11 d22 d33 m23 m32 d23 d32 x_l sway tmode T0 n0 D P_D theta t_P
  w_P rho c d      (tmode 0 constant T0, 1 propeller(n, u), 2 pod(V=u, n))
- 4 catamaran: m11 m22 m33 d11 d22 d33 b cmd0 steer tmode k nf nr offset scale lo hi deadband
  fwd[6] rev[6]   (tmode 0 T = k c, 1 TwinThrust polynomial)

Speed: per run the parameter rows are copied into tuples and the RK4 stages are tuples (kept in
registers, no array aliasing); cos/sin of psi and of the thruster angle are rotated from the
previous step's values by the angle-sum formula (:func:`_rot`) instead of library calls. About
45 ns per RK4 step for Nomoto 1 and 80 ns for the 3-DOF model with the second-order servo
(one core), see ``benchmarks/bench_sim.py``.

Servo rows ``S[b]``: max_angle, max_rate, T_or_omega_n, zeta, gain, delay_steps, 1/T.
Model rows carry derived constants in 30..33 (1/T; a0, a1, K a0; 1/m11, 1/det; 1/m_ii).
Logic rows ``L[b]``: turning (delta, t_start); zigzag (amp, switch, first, t_start);
course (target, kp, ki, kd, anti_windup). Disturbance rows ``Dq[b]``: q, seed.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from usvid.models.thrust import pod_thrust_nb, propeller_thrust_nb, twin_thrust_nb

#: fast-math flags: FMA contraction and reassociation, but NaN/inf semantics kept (np.isnan)
_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}

NZ = 12
IX, IY, IPSI, IU, IV, IR, IZ1, IZ2, IDL, IDLD, IW1, IW2 = range(NZ)

# recorded channels, in this order (the Python side maps names to these slots)
CHANNELS = ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n", "n_port", "n_stbd",
            "dist")
NCH = len(CHANNELS)
N_ZZ = 8  # zig-zag overshoots tracked online

DIST_B, DIST_A1, DIST_A0 = 0.42, 0.36, 0.37


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
    """(cos a, sin a) from the known (c0, s0) = (cos a0, sin a0): for a small increment
    h = a - a0 (|h| <= 0.05 rad) by the angle-sum formula with Taylor series of cos h and sin h
    to h^7 (truncation error < 1e-16 there); else the library functions."""
    h = a - a0
    if h == 0.0:
        return c0, s0
    if abs(h) > 0.05:
        return math.cos(a), math.sin(a)
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    return c0 * ch - s0 * sh, s0 * ch + c0 * sh


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _cat_thrust(p: np.ndarray, c: float) -> float:
    if p[9] == 0.0:
        return p[10] * c
    nf = int(p[11])
    nr = int(p[12])
    return twin_thrust_nb(c, p[18:18 + nf], p[24:24 + nr], p[13], p[14], p[15], p[16], p[17])


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _thrust3(p: tuple, u: float, n: float) -> float:
    mode = p[12]
    if mode == 0.0:
        return p[13]
    if mode == 1.0:
        return propeller_thrust_nb(n, u, p[15], p[16], p[17], p[18], p[19], p[20])
    return pod_thrust_nb(u, n, p[21], p[22])


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, inline="always")
def _deriv(kind: int, p: tuple, pa: np.ndarray, skind: int, sp: tuple, z: tuple, cmd: float,
           e: float, thr0: float, thr1: float, trig: tuple) -> tuple:
    """d(z)/dt for one run, as a 12-tuple (kept in registers; no array aliasing).

    z: the state tuple (layout in the module docstring); cmd: servo command (delayed);
    e: white noise sample; thr0/thr1: thruster commands (threedof n in thr0; catamaran
    port/stbd); trig = (psi0, cos psi0, sin psi0, de0, cos de0, sin de0) at the step start (see
    _rot); p, sp: the run's model and servo rows as tuples; pa: the model row as an array (for
    the thrust polynomials).
    """
    max_angle = sp[0]
    max_rate = sp[1]
    zdl = z[IDL]
    # --- servo ---
    d = _clip(zdl, max_angle)
    ddl = 0.0
    ddld = 0.0
    if skind == 1:
        rate = _clip((cmd - zdl) * sp[6], max_rate)
        if (zdl >= max_angle and rate > 0.0) or (zdl <= -max_angle and rate < 0.0):
            rate = 0.0
        ddl = rate
    elif skind == 2:
        wn = sp[2]
        w = z[IDLD]
        rate = _clip(w, max_rate)
        if (zdl >= max_angle and rate > 0.0) or (zdl <= -max_angle and rate < 0.0):
            rate = 0.0
        ddl = rate
        ddld = wn * wn * (sp[4] * cmd - zdl) - 2.0 * sp[3] * wn * w
    # --- disturbance filter: w1' = w2, w2' = -a0 w1 - a1 w2 + e; d = b w2 ---
    w2 = z[IW2]
    dw1 = w2
    dw2 = -DIST_A0 * z[IW1] - DIST_A1 * w2 + e
    de = d + DIST_B * w2
    cpsi, spsi = _rot(z[IPSI], trig[0], trig[1], trig[2])
    dz1 = 0.0
    dz2 = 0.0
    if kind <= 2:
        U = p[3] if kind == 0 else p[5]
        if kind == 0:
            r = z[IR]
            dr = (p[0] * (de + p[2]) - r) * p[30]
        elif kind == 2:
            r = z[IR]
            dr = (p[0] * (de + p[4]) - p[2] * r - p[3] * r * r * r) * p[30]
        else:
            r = p[32] * (z[IZ1] + p[3] * z[IZ2])
            dr = 0.0
            dz1 = z[IZ2]
            dz2 = de + p[4] - p[31] * z[IZ2] - p[30] * z[IZ1]
        return (U * cpsi, U * spsi, r, 0.0, 0.0, dr, dz1, dz2, ddl, ddld, dw1, dw2)
    u = z[IU]
    v = z[IV]
    r = z[IR]
    if kind == 3:
        T = _thrust3(p, u, thr0)
        cd, sd = _rot(de, trig[3], trig[4], trig[5])
        tu = T * cd
        tv = -T * sd if p[11] != 0.0 else 0.0
        tr = p[10] * T * sd
        m11 = p[0]
        m22 = p[1]
        m33 = p[2]
        m23 = p[6]
        m32 = p[7]
        a = m22 * v + m23 * r
        f1 = tu + a * r - p[3] * u
        f2 = tv - m11 * u * r - p[4] * v - p[8] * r
        f3 = tr - a * u + m11 * u * v - p[9] * v - p[5] * r
        du = f1 * p[30]
        dv = (m33 * f2 - m23 * f3) * p[31]
        dr = (m22 * f3 - m32 * f2) * p[31]
    else:
        Tp = _cat_thrust(pa, thr0)
        Ts = _cat_thrust(pa, thr1)
        m11 = p[0]
        m22 = p[1]
        du = (m22 * v * r - p[3] * u + Tp + Ts) * p[30]
        dv = (-m11 * u * r - p[4] * v) * p[31]
        dr = ((m11 - m22) * u * v - p[5] * r + (Tp - Ts) * p[6] * 0.5) * p[32]
    return (u * cpsi - v * spsi, u * spsi + v * cpsi, r, du, dv, dr, dz1, dz2, ddl, ddld, dw1,
            dw2)


@numba.njit(cache=True, fastmath=_FM)
def _axpy(z: tuple, h: float, k: tuple) -> tuple:
    """z + h k for 12-tuples."""
    return (z[0] + h * k[0], z[1] + h * k[1], z[2] + h * k[2], z[3] + h * k[3],
            z[4] + h * k[4], z[5] + h * k[5], z[6] + h * k[6], z[7] + h * k[7],
            z[8] + h * k[8], z[9] + h * k[9], z[10] + h * k[10], z[11] + h * k[11])


@numba.njit(cache=True)
def _row12(a: np.ndarray) -> tuple:
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11])


@numba.njit(cache=True)
def _row34(a: np.ndarray) -> tuple:
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12],
            a[13], a[14], a[15], a[16], a[17], a[18], a[19], a[20], a[21], a[22], a[23], a[24],
            a[25], a[26], a[27], a[28], a[29], a[30], a[31], a[32], a[33])


@numba.njit(cache=True)
def _row7(a: np.ndarray) -> tuple:
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6])


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _run_one(b: int, kind: int, P: np.ndarray, skind: int, S: np.ndarray, lkind: int,
             L: np.ndarray, Dq: np.ndarray, cmd_series: np.ndarray, thr_series: np.ndarray,
             Z0: np.ndarray, dt: float, nsteps: int, record_every: int, slots: np.ndarray,
             rec: np.ndarray, course: np.ndarray, zz: np.ndarray, zz_t: np.ndarray,
             nd_max: int, cstride: int, tstride: int) -> None:
    """Integrate run b of the batch (see :func:`run_batch`). A plain function, so that the
    parallel loop stays trivial (parfor analysis of a large body is slow to compile)."""
    pa = P[b]
    p = _row34(pa)
    sp = _row7(S[b])
    lp = L[b]
    z = Z0[b].copy()
    trig = np.empty(6)
    trig[0] = z[IPSI]
    trig[1] = math.cos(z[IPSI])
    trig[2] = math.sin(z[IPSI])
    trig[3] = 0.0
    trig[4] = 1.0
    trig[5] = 0.0
    rec_cnt = 0
    j_rec = 0
    nd = int(sp[5])
    buf = np.empty(nd_max + 1)
    buf[:] = z[IDL]
    max_angle = sp[0]
    max_rate = sp[1]
    q = Dq[b, 0]
    # stream (seed, b): the start state is a splitmix hash of the seed, hashed again with the
    # run index. (A linear start seed * golden + b put seed s + 2 on seed s's stream one normal
    # later: two "different" seeds gave the same disturbance shifted by one step.)
    _, h = _splitmix(np.uint64(int(Dq[b, 1])))
    _, rng = _splitmix(h ^ np.uint64(b))
    esd = math.sqrt(q / dt) if q > 0.0 else 0.0
    cb = b * cstride
    tb = b * tstride
    # logic state
    zz_cur = 0.0
    zz_psi0 = 0.0
    zz_n = 0
    integ = 0.0
    itae = 0.0
    iae = 0.0
    maxd = 0.0
    for i in range(N_ZZ):
        zz[b, i] = np.nan
    for i in range(N_ZZ + 1):
        zz_t[b, i] = np.nan
    for k in range(nsteps + 1):
        t = k * dt
        psi = z[IPSI]
        # --- logic -> command ---
        if lkind == 0:
            cmd = cmd_series[cb, k]
        elif lkind == 1:
            cmd = lp[0] if t >= lp[1] - 1e-9 * dt else 0.0
        elif lkind == 2:
            if zz_cur == 0.0 and t >= lp[3] - 1e-9 * dt:
                zz_cur = lp[2]
                zz_psi0 = psi
                zz_t[b, 0] = t
            elif zz_cur != 0.0:
                dev = psi - zz_psi0
                if zz_n >= 1 and zz_n <= N_ZZ:
                    # overshoot after reversal zz_n: excursion on the side of the old command
                    ov = -zz_cur * dev - lp[1]
                    if np.isnan(zz[b, zz_n - 1]) or ov > zz[b, zz_n - 1]:
                        zz[b, zz_n - 1] = ov
                if (zz_cur > 0.0 and dev >= lp[1]) or (zz_cur < 0.0 and dev <= -lp[1]):
                    zz_cur = -zz_cur
                    zz_n += 1
                    if zz_n <= N_ZZ:
                        zz_t[b, zz_n] = t
            cmd = zz_cur * lp[0]
        else:
            err = _wrap(lp[0] - psi)
            cmd = lp[1] * err + lp[2] * integ - lp[3] * z[IR]
            sat = cmd > max_angle or cmd < -max_angle
            if not (lp[4] != 0.0 and sat and cmd * err > 0.0):
                integ += err * dt
            w = 0.5 if (k == 0 or k == nsteps) else 1.0
            itae += w * t * abs(err) * dt
            iae += w * abs(err) * dt
        # --- dead time ---
        # ring buffer of nd + 1 commands: slot k mod (nd + 1) holds cmd(k)
        if nd == 0:
            cmd_d = cmd
        else:
            slot = k - (k // (nd + 1)) * (nd + 1)
            buf[slot] = cmd
            old = slot + 1 if slot < nd else 0
            cmd_d = buf[old] if k >= nd else Z0[b, IDL]
        # --- ideal servo: angle set at the step start (rate limited) ---
        if skind == 0:
            target = _clip(cmd_d, max_angle)
            z[IDL] = z[IDL] + _clip(target - z[IDL], max_rate * dt)
        dnow = _clip(z[IDL], max_angle)
        if abs(dnow) > maxd:
            maxd = abs(dnow)
        # --- thruster commands ---
        thr0 = thr_series[tb, k, 0]
        thr1 = thr_series[tb, k, 1]
        if kind == 3:
            if np.isnan(thr0):
                thr0 = p[14]
        elif kind == 4:
            if np.isnan(thr0):
                thr0 = p[7] + p[8] * dnow
                thr1 = p[7] - p[8] * dnow
        # --- record ---
        if rec_cnt == 0:
            j = j_rec
            j_rec += 1
            for ch in range(NCH):
                s = slots[ch]
                if s < 0:
                    continue
                if ch <= 5:
                    val = z[ch]
                    if kind <= 2 and ch == 3:
                        val = p[3] if kind == 0 else p[5]
                elif ch == 6:
                    if kind <= 2:
                        val = p[3] if kind == 0 else p[5]
                    else:
                        val = math.sqrt(z[IU] * z[IU] + z[IV] * z[IV])
                elif ch == 7:
                    val = dnow
                elif ch == 8:
                    val = cmd
                elif ch == 9:
                    val = thr0 if kind == 3 else np.nan
                elif ch == 10:
                    val = thr0 if kind == 4 else np.nan
                elif ch == 11:
                    val = thr1 if kind == 4 else np.nan
                else:
                    val = DIST_B * z[IW2]
                rec[s, b, j] = val
        rec_cnt += 1
        if rec_cnt == record_every:
            rec_cnt = 0
        if k == nsteps:
            break
        # --- noise sample for this step ---
        e = 0.0
        if esd > 0.0:
            rng, g = _normal(rng)
            e = esd * g
        # --- RK4 ---
        # cos/sin at the step start, rotated from the previous step's (no library call
        # for the usual small increments; renormalised so rounding cannot accumulate)
        c_, s_ = _rot(z[IPSI], trig[0], trig[1], trig[2])
        g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
        trig[0] = z[IPSI]
        trig[1] = c_ * g_
        trig[2] = s_ * g_
        if kind == 3:
            de_ = _clip(z[IDL], max_angle) + DIST_B * z[IW2]
            c_, s_ = _rot(de_, trig[3], trig[4], trig[5])
            g_ = 1.5 - 0.5 * (c_ * c_ + s_ * s_)
            trig[3] = de_
            trig[4] = c_ * g_
            trig[5] = s_ * g_
        zt0 = _row12(z)
        tg = (trig[0], trig[1], trig[2], trig[3], trig[4], trig[5])
        k1 = _deriv(kind, p, pa, skind, sp, zt0, cmd_d, e, thr0, thr1, tg)
        k2 = _deriv(kind, p, pa, skind, sp, _axpy(zt0, 0.5 * dt, k1), cmd_d, e, thr0, thr1,
                    tg)
        k3 = _deriv(kind, p, pa, skind, sp, _axpy(zt0, 0.5 * dt, k2), cmd_d, e, thr0, thr1,
                    tg)
        k4 = _deriv(kind, p, pa, skind, sp, _axpy(zt0, dt, k3), cmd_d, e, thr0, thr1, tg)
        h6 = dt / 6.0
        for i in range(NZ):
            z[i] = zt0[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if kind == 1:  # Nomoto 2: r is algebraic in (z1, z2)
            z[IR] = p[32] * (z[IZ1] + p[3] * z[IZ2])
        # --- servo limits after the step ---
        if skind != 0:
            if z[IDL] > max_angle:
                z[IDL] = max_angle
                if z[IDLD] > 0.0:
                    z[IDLD] = 0.0
            elif z[IDL] < -max_angle:
                z[IDL] = -max_angle
                if z[IDLD] < 0.0:
                    z[IDLD] = 0.0
            if skind == 2:
                z[IDLD] = _clip(z[IDLD], max_rate)
    # zig-zag: an overshoot counts only once the next reversal has happened
    for i in range(N_ZZ):
        if i + 2 > zz_n:
            zz[b, i] = np.nan
    course[b, 0] = itae
    course[b, 1] = iae
    course[b, 2] = maxd


@numba.njit(cache=True, parallel=True)
def run_batch(kind: int, P: np.ndarray, skind: int, S: np.ndarray, lkind: int, L: np.ndarray,
              Dq: np.ndarray, cmd_series: np.ndarray, thr_series: np.ndarray, Z0: np.ndarray,
              dt: float, nsteps: int, record_every: int, slots: np.ndarray, rec: np.ndarray,
              course: np.ndarray, zz: np.ndarray, zz_t: np.ndarray) -> None:
    """Integrate B runs. Output arrays are filled in place:

    rec (nrec_ch, B, N) recorded channels (slots[ch] = row in rec or -1); course (B, 3) = ITAE
    [rad s^2], IAE [rad s], max |delta| [rad]; zz (B, N_ZZ) zig-zag overshoots [rad] (NaN when not
    completed); zz_t (B, N_ZZ + 1) zig-zag switch (reversal command) times [s], NaN when none.
    lkind: 0 commanded, 1 turning, 2 zigzag, 3 course. cmd_series (1 or B, nsteps+1);
    thr_series (1 or B, nsteps+1, 2) with NaN meaning "the model's nominal".
    """
    B = P.shape[0]
    nd_max = 0
    for b in range(B):
        nd_max = max(nd_max, int(S[b, 5]))
    cstride = np.int64(1) if cmd_series.shape[0] > 1 else np.int64(0)
    tstride = np.int64(1) if thr_series.shape[0] > 1 else np.int64(0)
    for bu in numba.prange(B):
        _run_one(np.int64(bu), kind, P, skind, S, lkind, L, Dq, cmd_series, thr_series, Z0, dt,
                 nsteps, record_every, slots, rec, course, zz, zz_t, nd_max, cstride, tstride)
