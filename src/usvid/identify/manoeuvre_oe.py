"""Closed-loop (manoeuvre-replay) output error for zig-zag trials.

Why
---
The open-loop output-error fit of :mod:`usvid.identify.output_error` replays the *measured*
rudder on the model. A course-unstable or marginally stable ship (KVLCC2) drifts away from the
measured heading over a long horizon, so that fit cuts the record into short windows (multiple
shooting) and re-estimates every window's initial state. The result then depends on the window
length: windows shorter than a zig-zag half period never contain a whole overshoot, so the fit
is free to trade the yaw damping against the initial states, and on the HSVA KVLCC2 zig-zags the
first overshoot of the identified model moves by +-2 deg between 20 s and 40 s windows.

A zig-zag trial is a closed-loop experiment: the helmsman (autopilot) reverses the rudder when
the heading deviation reaches the switching angle. Replaying the *manoeuvre* instead of the
rudder record closes that loop on the model: every training zig-zag is simulated with its own
logic (rudder amplitude, switching angle, first side, helm rate limit, initial yaw rate from the
record), exactly as a zig-zag is simulated at validation, and the parameters minimise the
heading and yaw-rate error over the whole run:

.. math:: \\min_p \\sum_j \\sum_k \\Big(\\frac{\\psi_{sim,j}(t_k; p) - \\psi_{j}(t_k)}
          {\\sigma_\\psi}\\Big)^2 + \\Big(\\frac{r_{sim,j}(t_k; p) - r_{j}(t_k)}{\\sigma_r}\\Big)^2

Because the rudder follows the simulated heading, the simulation stays bounded for any
parameter set (a course-unstable model is stabilised by the switching logic, as the ship is),
and the quantities the fit matches (overshoots, periods, the timing of the rudder reversals)
are the ones the model is validated on.

Horizon (closed-loop shooting)
------------------------------
A replay of a whole 180 s run lets the phase drift of a misspecified model dominate the cost
(a 1 s period error is a 10 deg heading error three cycles later), and the fit then trades the
first overshoot for the later cycles. The default replays therefore start at the execute
instant and ``lead_s`` = 2.5 s before every measured rudder reversal, from the smoothed
measured state there, and run to the next measured reversal (``horizon=1``). Every replay
still contains a reversal decided by the *model's* heading and the whole overshoot that
follows, and the replays are aligned with the manoeuvre, so no window length is left to
choose. ``horizon="run"`` (whole runs) and larger integers are available.

HSVA KVLCC2 (train 10/05, 15/05, 20/05; first-overshoot error [deg] on 10/10 P, 10/10 S,
20/10 P, 20/10 S; validation at the fit's 15.8 deg/s helm rate), norrbin:

* horizon 1, lead 2.5 s (default): +1.60, +1.64, -0.76, -0.49 (second: -2.6, -5.2, -0.7, -2.5)
* horizon 1, lead 0 s: +1.54, +1.55, -1.70, -1.39; lead 5 s: +2.52, +2.64, -0.30, +0.01
* horizon 2, lead 2.5 s: +3.66, +2.56, -0.17, -0.28; whole runs: +6.20, +2.50, +0.73, -0.15
* open-loop OE (method "oe", 20-60 s windows): -1.9 .. +3.9 depending on the window.

The 20/10 overshoots are met within 1.5 deg; the 10/10 ones are over-predicted by 1.5-2.6 deg
whatever the horizon: a first-order Norrbin model identified on 5-deg-switch zig-zags does
not carry exactly to 10-deg switching. Linear models (nomoto1, nomoto2) under-predict every
first overshoot by 2.5-4 deg (course-unstable ship).

Details
-------
* The rudder follows the command at the helm rate limit (trapezoid). The rate is the vessel's
  ``helm_rate_deg_s`` (``Vessel.extra``, e.g. 15.8 deg/s for the HSVA model) when known, else the
  measured rudder rate (median slope on the ramps, as :func:`usvid.identify.validate.
  zigzag_check`). The identified model's servo carries that rate so that the validation
  zig-zag uses the same servo (``IdealServo(max_rate=rate)``).
* Switching is event-located: the step in which the heading crosses the switching angle is
  re-integrated with the rudder ramp starting at the interpolated crossing time. The simulated
  outputs are then continuous in the parameters (a switch decided at a sample instant would
  make the cost piecewise constant and the finite-difference Jacobian useless).
* The zig-zags, their amplitude, switching angle and first side come from
  ``usvid.prep.find_manoeuvres``; the heading deviation is taken from the heading at execute.
  A replay starts from the smoothed measured yaw rate (and yaw acceleration for nomoto2), the
  measured heading deviation and rudder angle and the command in force; it ends at its
  horizon or at the end of the zig-zag segment.
* The reversal follows the crossing without delay (the standard logic, as at validation); the
  HSVA helm reacts about 0.3 s after the crossing (``ZigZagRun.delay`` models it; fitting with
  it changed the first overshoots by 0.1-0.7 deg, not consistently, so it is not used).
* Channel weights: two passes, the second with 1/sigma_c from the first pass's residual RMS of
  each channel (iteratively reweighted output error; each channel counts by its own noise).
* Norrbin is fitted in the T = 1 normalisation (``T r' + n1 r + n3 r^3 = K (delta + delta0)``
  divided by T) so that n1 passes continuously through 0 between course-stable and
  course-unstable; the estimator maps the result back to ``|n1| = 1`` (regressors.py).
* Covariance: Gauss-Newton ``(J^T J)^-1 s^2 f_ac``, inflated by the residual autocorrelation
  factor (the residuals of a free run are strongly coloured; there are too few runs for a
  cluster-robust form).

Units: time [s], angles [rad], yaw rate [rad/s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from scipy.optimize import least_squares

from usvid.errors import IdentificationError
from usvid.identify.output_error import (
    _KIND_CODE,
    PARAM_NAMES,
    RESPONSE_KINDS,
    OEResult,
    _response_rhs,
    autocorrelation_factor,
)

__all__ = ["ZigZagRun", "zigzag_runs", "replay_zigzag", "refine_zigzag_oe", "fit_zigzag_params",
           "helm_rate", "measured_rudder_rate"]

#: Largest |r| [rad/s] of a replayed run (keeps residuals finite for absurd trial parameters).
_R_CLIP = 50.0


@dataclass
class ZigZagRun:
    """One training zig-zag ready for replay (SI units, time from the execute instant).

    ``h`` simulation step [s] (the log step); ``stride`` residual decimation (every stride-th
    sample is compared); ``psi`` [rad] measured heading deviation from the heading at execute,
    ``r`` [rad/s] measured yaw rate, ``delta`` [rad] measured rudder (reference only), all (n,);
    ``delta_amp`` [rad] rudder amplitude, ``psi_switch`` [rad] switching angle, ``first`` +1/-1
    side of the first rudder (+1 starboard), ``rate`` [rad/s] rudder rate limit, ``r0`` [rad/s]
    and ``rdot0`` [rad/s^2] initial yaw rate and acceleration, ``delta_init`` [rad] rudder angle
    at execute.
    """

    name: str
    h: float
    stride: int
    psi: np.ndarray
    r: np.ndarray
    delta: np.ndarray
    delta_amp: float
    psi_switch: float
    first: int
    rate: float
    r0: float
    rdot0: float
    delta_init: float
    t_execute: float
    psi0: float = 0.0
    cmd0: float = math.nan
    delay: float = 0.0

    def __post_init__(self) -> None:
        if math.isnan(self.cmd0):
            self.cmd0 = self.first * self.delta_amp


@nb.njit(cache=True)
def _ramp(t, t0, d0, cmd, rate):
    """Rudder angle [rad] and rate [rad/s] at time t of a rate-limited move from d0 (at t0)
    towards cmd."""
    gap = cmd - d0
    s = 1.0 if gap >= 0 else -1.0
    tr = abs(gap) / rate
    if t <= t0:
        return d0, 0.0
    if t - t0 >= tr:
        return cmd, 0.0
    return d0 + s * rate * (t - t0), s * rate


@nb.njit(cache=True)
def _rudder(t, ts, ta, da, ca, tb, db, cb, rate):
    """Piecewise rudder: ramp a before the switch instant ts, ramp b from ts on."""
    if t < ts:
        return _ramp(t, ta, da, ca, rate)
    return _ramp(t, tb, db, cb, rate)


@nb.njit(cache=True)
def _rk4_step(code, p, x1, x2, t, h, ts, ta, da, ca, tb, db, cb, rate):
    d0, dd0 = _rudder(t, ts, ta, da, ca, tb, db, cb, rate)
    dm, ddm = _rudder(t + 0.5 * h, ts, ta, da, ca, tb, db, cb, rate)
    d1, dd1 = _rudder(t + h, ts, ta, da, ca, tb, db, cb, rate)
    k1a, k1b = _response_rhs(code, p, x1, x2, d0, dd0)
    k2a, k2b = _response_rhs(code, p, x1 + 0.5 * h * k1a, x2 + 0.5 * h * k1b, dm, ddm)
    k3a, k3b = _response_rhs(code, p, x1 + 0.5 * h * k2a, x2 + 0.5 * h * k2b, dm, ddm)
    k4a, k4b = _response_rhs(code, p, x1 + h * k3a, x2 + h * k3b, d1, dd1)
    xn = x1 + h / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a)
    x2n = x2 + h / 6.0 * (k1b + 2.0 * k2b + 2.0 * k3b + k4b)
    if not np.isfinite(xn) or xn > _R_CLIP:
        xn = _R_CLIP
    elif xn < -_R_CLIP:
        xn = -_R_CLIP
    if not np.isfinite(x2n) or abs(x2n) > 1e6:
        x2n = 0.0
    return xn, x2n, d1


@nb.njit(cache=True)
def _replay_kernel(code, p, amp, sw, first, rate, h, n, r0, rdot0, d_init, psi0, cmd0, delay):
    """Closed-loop zig-zag from t = 0 on a response model, event-located switching.

    The command starts at ``cmd0`` (``first * amp`` at the execute instant); it reverses when the
    heading deviation ``first * psi`` (starting at ``psi0``) reaches ``+sw`` while the command is
    towards the first side and ``-sw`` while it is towards the other (ITTC 7.5-04-02-01 logic,
    as :class:`usvid.sim.ZigZag`), ``delay`` [s] after the crossing (helm reaction; 0 in the
    standard logic). The crossing instant is interpolated linearly within its step and the
    step holding the reversal is re-integrated with the new rudder ramp starting exactly there.
    Returns r [rad/s], psi [rad], delta [rad] (n,).
    """
    r = np.empty(n)
    psi = np.empty(n)
    dl = np.empty(n)
    x1 = r0
    x2 = 0.0
    if code == 1:
        t12 = p[1] * p[2]
        a1 = (p[1] + p[2]) / t12
        b1 = p[0] * p[3] / t12
        x2 = rdot0 + a1 * x1 - b1 * (d_init + p[4])
    ps = psi0
    # current ramp (start time, start angle, command)
    ta = 0.0
    da = d_init
    ca = cmd0
    pending = False
    tp = 0.0
    r[0] = x1
    psi[0] = ps
    dl[0] = d_init
    for k in range(n - 1):
        t = k * h
        if pending and tp < t + h:
            ts = max(tp, t)
            dts, _ = _ramp(ts, ta, da, ca, rate)
            cb = -ca
            xn, x2n, dn = _rk4_step(code, p, x1, x2, t, h, ts, ta, da, ca, ts, dts, cb, rate)
            psn = ps + 0.5 * h * (x1 + xn)
            ta, da, ca = ts, dts, cb
            pending = False
        else:
            xn, x2n, dn = _rk4_step(code, p, x1, x2, t, h, 1e300, ta, da, ca, ta, da, ca, rate)
            psn = ps + 0.5 * h * (x1 + xn)
            if not pending:
                z0 = first * ps
                z1 = first * psn
                towards = ca * first > 0
                lvl = sw if towards else -sw
                crossed = (z1 >= lvl and z0 < lvl) if towards else (z1 <= lvl and z0 > lvl)
                at_start = (z0 >= lvl) if towards else (z0 <= lvl)
                if crossed or at_start:
                    f = 0.0
                    if not at_start:
                        f = (lvl - z0) / (z1 - z0)
                    ts = t + f * h + delay
                    if ts < t + h:
                        dts, _ = _ramp(ts, ta, da, ca, rate)
                        cb = -ca
                        xn, x2n, dn = _rk4_step(code, p, x1, x2, t, h, ts, ta, da, ca, ts, dts,
                                                cb, rate)
                        psn = ps + 0.5 * h * (x1 + xn)
                        ta, da, ca = ts, dts, cb
                    else:
                        pending = True
                        tp = ts
        x1, x2, ps = xn, x2n, psn
        r[k + 1] = x1
        psi[k + 1] = ps
        dl[k + 1] = dn
    return r, psi, dl


def replay_zigzag(kind: str, params: np.ndarray, run: ZigZagRun) -> dict[str, np.ndarray]:
    """Replay one training zig-zag on a response model (parameters in PARAM_NAMES order).

    Returns ``r`` [rad/s], ``psi`` [rad] (deviation from the heading at execute) and ``delta``
    [rad] on the run's full grid (step ``run.h``).
    """
    p = np.asarray(params, dtype=float)
    r, psi, d = _replay_kernel(_KIND_CODE[kind], p, run.delta_amp, run.psi_switch,
                               float(run.first), run.rate, run.h, len(run.psi), run.r0,
                               run.rdot0, run.delta_init, run.psi0, run.cmd0, run.delay)
    return {"r": r, "psi": psi, "delta": d}


def measured_rudder_rate(t: np.ndarray, delta: np.ndarray) -> float:
    """Rudder rate [rad/s] on the ramps: |d delta/dt| of the 0.5 s Savitzky-Golay smoothed rudder,
    median over the samples above half its maximum (the rule of ``zigzag_check``)."""
    from scipy.signal import savgol_filter

    hs = float(np.median(np.diff(t)))
    win = max(int(round(0.5 / hs)) | 1, 5)
    if len(delta) > win:
        dd = np.abs(savgol_filter(delta, win, 2, deriv=1, delta=hs))
    else:
        dd = np.abs(np.gradient(delta, t))
    moving = dd > 0.5 * np.max(dd)
    return float(np.median(dd[moving])) if np.any(moving) else math.inf


def helm_rate(vessel: Any) -> float | None:
    """The vessel's helm (steering gear) rate [rad/s] from ``vessel.extra["helm_rate_deg_s"]``
    (or ``rudder_rate_deg_s``), None when not given."""
    extra = getattr(vessel, "extra", None) or {}
    for key in ("helm_rate_deg_s", "rudder_rate_deg_s"):
        v = extra.get(key)
        if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
            return math.radians(float(v))
    return None


def _crossings(z: np.ndarray, sw: float) -> list[int]:
    """Indices where the heading deviation ``z`` (first side positive) reaches +sw, then -sw,
    then +sw ... alternately (the reversal instants of the zig-zag logic)."""
    out: list[int] = []
    k = 0
    up = True
    while k < len(z):
        hit = np.flatnonzero(z[k:] >= sw) if up else np.flatnonzero(z[k:] <= -sw)
        if len(hit) == 0:
            break
        k += int(hit[0])
        out.append(k)
        up = not up
    return out


def zigzag_runs(trials: list[Any], series: list[Any], *, rate: float | None = None,
                step: float = 0.1, horizon: str | float = "run", lead_s: float = 0.0
                ) -> list[ZigZagRun]:
    """The zig-zag runs of ``trials`` (one per zig-zag found by ``find_manoeuvres``).

    ``series`` are the estimator's smoothed series of the same trials (``trial_series``), used
    for the initial yaw rate/acceleration; ``rate`` [rad/s] the rudder rate limit (default
    :func:`helm_rate` of the trial's vessel, else :func:`measured_rudder_rate`); ``step`` [s]
    the residual step (the simulation runs at the log step).

    ``horizon``: ``"run"`` one replay from the execute instant to the end of the zig-zag;
    an integer n (``"cycle"`` = 2): closed-loop shooting, one replay from the execute instant and
    from every measured reversal, each over the next n reversals (to the n-th next reversal
    instant, or the end of the record), started from the measured (smoothed) state there.
    Raises IdentificationError when a trial holds no zig-zag.
    """
    from usvid.prep import find_manoeuvres

    nrev = None if horizon == "run" else (2 if horizon == "cycle" else int(horizon))
    runs = []
    for tr, s in zip(trials, series, strict=True):
        segs = [g for g in find_manoeuvres(tr) if g.kind == "zigzag"]
        if not segs:
            raise IdentificationError(
                f"trial {tr.name or '?'}: no zig-zag found; the closed-loop (zig-zag replay) "
                "output error needs zig-zag trials (use method 'oe' with windows otherwise)")
        t = s["t"]
        h = s.h
        for g in segs:
            i0 = int(np.searchsorted(t, g.t_execute))
            i1 = int(np.searchsorted(t, g.t_end, side="right"))
            if i1 - i0 < 10:
                continue
            rr = rate if rate is not None else helm_rate(tr.vessel)
            if rr is None:
                rr = measured_rudder_rate(t[i0:i1], s["delta"][i0:i1])
            amp = float(g.level)
            sw = float(g.psi_switch)
            side = int(g.side)
            dev = s["psi"] - s["psi_s"][i0]
            dev_s = s["psi_s"] - s["psi_s"][i0]
            starts = [(i0, 0.0, side * amp)]
            ends = [i1]
            if nrev is not None:
                cr = [i0 + c for c in _crossings(side * dev_s[i0:i1], sw)]
                marks = [i0] + cr
                lead = int(round(lead_s / h))
                starts = [(i0, 0.0, side * amp)] + [
                    (c, float(dev_s[c]), side * amp * (-1.0) ** (m + 1)) if lead == 0 else
                    (max(c - lead, i0), float(dev_s[max(c - lead, i0)]),
                     side * amp * (-1.0) ** m)
                    for m, c in enumerate(cr)]
                ends = [marks[m + nrev] if m + nrev < len(marks) else i1
                        for m in range(len(marks))]
            for (j, p0, c0), j1 in zip(starts, ends, strict=True):
                if j1 - j < 10:
                    continue
                runs.append(ZigZagRun(
                    name=f"{tr.name}@{t[j]:.1f}s", h=h,
                    stride=max(int(round(step / h)), 1), psi=dev[j:j1], r=s["r"][j:j1],
                    delta=s["delta"][j:j1], delta_amp=amp, psi_switch=sw,
                    first=side, rate=float(rr), r0=float(s["r_s"][j]),
                    rdot0=float(s["rdot_s"][j]) if "rdot_s" in s else 0.0,
                    delta_init=float(s["delta"][j]), t_execute=float(t[i0]),
                    psi0=p0, cmd0=c0))
    if not runs:
        raise IdentificationError("no zig-zag runs long enough for the zig-zag replay fit")
    return runs


def _residuals(kind: str, p: np.ndarray, runs: list[ZigZagRun], sigma: dict[str, float]
               ) -> np.ndarray:
    out = []
    for run in runs:
        sim = replay_zigzag(kind, p, run)
        sl = slice(run.stride, None, run.stride)
        out.append((sim["psi"][sl] - run.psi[sl]) / sigma["psi"])
        out.append((sim["r"][sl] - run.r[sl]) / sigma["r"])
    return np.concatenate(out)


def _channel_rms(kind: str, p: np.ndarray, runs: list[ZigZagRun]) -> dict[str, float]:
    e = {"psi": [], "r": []}
    for run in runs:
        sim = replay_zigzag(kind, p, run)
        sl = slice(run.stride, None, run.stride)
        e["psi"].append(sim["psi"][sl] - run.psi[sl])
        e["r"].append(sim["r"][sl] - run.r[sl])
    return {c: max(float(np.sqrt(np.mean(np.concatenate(v) ** 2))), 1e-12)
            for c, v in e.items()}


def refine_zigzag_oe(kind: str, p0: np.ndarray, runs: list[ZigZagRun], *,
                     free: np.ndarray | None = None, max_nfev: int = 200,
                     passes: int = 2, channels: tuple[str, ...] = ("psi", "r")) -> OEResult:
    """Closed-loop zig-zag output error: minimise the weighted heading and yaw-rate errors of
    the replayed training zig-zags (module docstring) from the start ``p0`` (PARAM_NAMES order).

    ``free`` marks the fitted parameters (others held at ``p0``). Returns an
    :class:`usvid.identify.output_error.OEResult` (parameters, covariance, diagnostics).
    """
    if kind not in RESPONSE_KINDS:
        raise IdentificationError(f"zig-zag replay output error fits response models "
                                  f"({', '.join(RESPONSE_KINDS)}), not {kind!r}")
    names = PARAM_NAMES[kind]
    p0 = np.asarray(p0, dtype=float)
    free = np.ones(len(p0), bool) if free is None else np.asarray(free, bool)
    lo = np.full(len(p0), -np.inf)
    hi = np.full(len(p0), np.inf)
    for i, nm in enumerate(names):
        if nm in ("T", "T1", "T2"):
            lo[i] = 1e-3
    lo, hi = lo[free], hi[free]
    x0 = np.clip(p0[free], lo + 1e-9, hi)

    def full(x: np.ndarray) -> np.ndarray:
        p = p0.copy()
        p[free] = x
        return p

    sigma = {"psi": math.radians(1.0), "r": math.radians(0.1)}
    for c in ("psi", "r"):
        if c not in channels:
            sigma[c] = 1e12
    res = None
    for k in range(passes):
        res = least_squares(lambda x, sg=sigma: _residuals(kind, full(x), runs, sg), x0,
                            bounds=(lo, hi), x_scale="jac", max_nfev=max_nfev, method="trf",
                            diff_step=1e-6)
        x0 = res.x
        if k < passes - 1:
            sigma = _channel_rms(kind, full(x0), runs)
        for c in ("psi", "r"):
            if c not in channels:
                sigma[c] = 1e12
    assert res is not None
    J = res.jac
    f = res.fun
    m, nf = J.shape
    s2 = float(f @ f) / max(m - nf, 1)
    # autocorrelation factor per run and channel (blocks in the residual vector)
    blocks = []
    i = 0
    for run in runs:
        nk = len(range(run.stride, len(run.psi), run.stride))
        blocks += [f[i:i + nk], f[i + nk:i + 2 * nk]]
        i += 2 * nk
    fac = max(autocorrelation_factor(b) for b in blocks)
    try:
        inv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError as exc:
        raise IdentificationError(
            f"zig-zag replay fit of {kind}: singular Jacobian (parameters "
            f"{', '.join(np.array(names)[free])} not separately identifiable)") from exc
    cov = np.zeros((len(p0), len(p0)))
    cov[np.ix_(free, free)] = inv * s2 * fac
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    return OEResult(params=full(res.x), cov=cov, std_errors=se, names=names,
                    cost=float(res.cost), nfev=int(res.nfev), success=bool(res.success),
                    message=str(res.message), sigma=sigma, ac_factor=float(fac),
                    n_residuals=int(m), free=free)


#: Default closed-loop shooting horizon (reversals per replay) and lead [s] of
#: :func:`fit_zigzag_params` (see its docstring for the choice).
DEFAULT_HORIZON = 1
DEFAULT_LEAD_S = 2.5


def fit_zigzag_params(kind: str, params: dict[str, float], trials: list[Any],
                      series: list[Any], *, horizon: str | float = DEFAULT_HORIZON,
                      lead_s: float = DEFAULT_LEAD_S, rate: float | None = None,
                      step: float = 0.1
                      ) -> tuple[dict[str, float], np.ndarray, dict[str, Any], OEResult, float]:
    """Refine response-model ``params`` (e.g. the least-squares start) by closed-loop zig-zag
    output error on ``trials`` (their estimator ``series``).

    ``horizon``/``lead_s``: see :func:`zigzag_runs`. The default is closed-loop shooting over
    one reversal interval, each replay starting ``lead_s`` = 2.5 s before a measured reversal
    (and one from the execute instant): every replay then contains a model-decided rudder
    reversal and the overshoot that follows it, which is what the zig-zag validation compares,
    while the horizon stays shorter than the phase drift of a misspecified model over a whole
    run (replays of a whole run let the later cycles' phase errors dominate the fit; see the
    report in the module docstring). ``rate`` [rad/s]: rudder rate limit (default the vessel's
    helm rate, else measured).

    Norrbin is fitted with T = 1 (n1 free through 0) and returned with ``|n1| = 1``.
    Returns (parameters, covariance in PARAM_NAMES order, diagnostics, OEResult, rate [rad/s]).
    """
    from usvid.identify.estimator import _norrbin_from_t1, _norrbin_to_t1
    from usvid.identify.ls import numerical_jacobian

    names = PARAM_NAMES[kind]
    runs = zigzag_runs(trials, series, rate=rate, step=step, horizon=horizon, lead_s=lead_s)
    p0 = np.array([params[n] for n in names], dtype=float)
    free = np.ones(len(names), bool)
    if kind == "norrbin":
        free[names.index("T")] = False
        p0 = _norrbin_to_t1(p0)
    oe = refine_zigzag_oe(kind, p0, runs, free=free)
    pe, cov = oe.params, oe.cov
    if kind == "norrbin":
        G = numerical_jacobian(_norrbin_from_t1, pe)
        pe, cov = _norrbin_from_t1(pe), G @ cov @ G.T
    used_rate = float(np.median([r.rate for r in runs]))
    diag = {"cost": oe.cost, "nfev": oe.nfev, "success": oe.success, "message": oe.message,
            "ac_factor": oe.ac_factor, "sigma": oe.sigma, "n_residuals": oe.n_residuals,
            "horizon": horizon, "lead_s": lead_s, "n_replays": len(runs),
            "rudder_rate_deg_s": math.degrees(used_rate)}
    return dict(zip(names, pe.tolist(), strict=True)), cov, diag, oe, used_rate
