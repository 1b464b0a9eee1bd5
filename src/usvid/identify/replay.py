"""Closed-loop (manoeuvre-replay) output error for zig-zag trials, on the integration core.

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
* Every replay is a lane of the integration core (:mod:`usvid.sim.core`) running its
  :class:`usvid.sim.ZigZag` logic -- the same logic, servo and equations as ``usvid simulate
  zigzag``: switching is event-located (the crossing is interpolated within the step and the
  step integrated again with the reversal there), so the simulated outputs are continuous in
  the parameters (a switch decided at a sample instant would make the cost piecewise constant
  and the finite-difference Jacobian useless). Any kind whose outputs include psi and r can be
  replayed; a measured shaft speed (or thruster commands) is replayed with the logic.
* The zig-zags, their amplitude, switching angle and first side come from
  ``usvid.prep.find_manoeuvres``; the heading deviation is taken from the heading at execute.
  A replay starts from the smoothed measured yaw rate (and yaw acceleration for nomoto2), the
  measured heading deviation and rudder angle and the command in force; it ends at its
  horizon or at the end of the zig-zag segment.
* The reversal follows the crossing without delay (the standard logic, as at validation); the
  HSVA helm reacts about 0.3 s after the crossing (fitting with such a delay changed the first
  overshoots by 0.1-0.7 deg, not consistently, so it is not used).
* Channel weights: two passes, the second with 1/sigma_c from the first pass's residual RMS of
  each channel (iteratively reweighted output error; each channel counts by its own noise).
* Parameters are fitted in the kind's fit space (``ModelKind.fit_space``; Norrbin's T = 1
  normalisation, in which n1 passes continuously through 0 between course-stable and
  course-unstable).
* Covariance: Gauss-Newton ``(J^T J)^-1 s^2 f_ac``, inflated by the residual autocorrelation
  factor (the residuals of a free run are strongly coloured; there are too few runs for a
  cluster-robust form).

Units: time [s], angles [rad], yaw rate [rad/s].
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.ls import autocorrelation_factor, numerical_jacobian
from usvid.identify.output_error import OEProblem, OEResult
from usvid.identify.series import Series
from usvid.manoeuvres import find_manoeuvres, rudder_rate, zigzag_crossings
from usvid.models.kind import ModelKind
from usvid.models.servo import IdealServo
from usvid.sim import core
from usvid.sim.simulate import Lanes, initial_state, servo_rows

__all__ = ["ZigZagRun", "zigzag_runs", "replay_runs", "refine_zigzag_oe", "helm_rate",
           "DEFAULT_HORIZON", "DEFAULT_LEAD_S"]

#: Default closed-loop shooting horizon (reversals per replay) and lead [s] (module docstring).
DEFAULT_HORIZON = 1
DEFAULT_LEAD_S = 2.5


@dataclass
class ZigZagRun:
    """One replay of a measured zig-zag (SI units; time from the replay start, step ``h``).

    ``psi`` [rad] measured heading deviation from the heading at the zig-zag's execute, ``r``
    [rad/s] measured yaw rate, ``delta`` [rad] measured rudder (reference only), each (n,);
    ``delta_amp`` [rad], ``psi_switch`` [rad], ``first`` (+1 starboard) of the zig-zag;
    ``command`` the side (+1/-1) of the command in force at the start (0: the replay starts at
    the execute, the first order given there); ``rate`` [rad/s] the helm rate; initial values
    ``r0`` [rad/s], ``rdot0`` [rad/s^2], ``u0``, ``v0`` [m/s] (smoothed), ``psi0`` [rad]
    (deviation), ``delta0`` [rad]; ``inputs`` measured shaft speed / thruster commands (n,);
    ``stride`` the residual decimation.
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
    command: int
    rate: float
    r0: float
    rdot0: float
    psi0: float
    delta0: float
    u0: float = math.nan
    v0: float = 0.0
    inputs: dict[str, np.ndarray] | None = None


def helm_rate(vessel: Any, records: Sequence[tuple[Any, Any]] = ()) -> tuple[float | None, str]:
    """The helm (steering gear) rate [rad/s] and where it comes from: the vessel's
    ``extra["helm_rate_deg_s"]`` (or ``rudder_rate_deg_s``; source "vessel.extra.helm_rate_deg_s"),
    else the median rudder rate measured on the ramps of the ``records`` (``(t [s],
    delta [rad])`` pairs, :func:`usvid.manoeuvres.rudder_rate`; "measured rudder ramps"), else
    ``(None, "")``. The one place the helm rate is chosen: the identified model's servo carries
    it, and every simulation of the model (validation, ``usvid simulate``) uses that servo."""
    extra = getattr(vessel, "extra", None) or {}
    for key in ("helm_rate_deg_s", "rudder_rate_deg_s"):
        v = extra.get(key)
        if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
            return math.radians(float(v)), "vessel.extra.helm_rate_deg_s"
    rates = []
    for t, d in records:
        d = np.asarray(d, dtype=float)
        if np.isfinite(d).sum() > 2 and np.nanmax(d) - np.nanmin(d) > 2 * MIN_RUDDER_STD:
            rates.append(rudder_rate(t, d))
    rates = [r for r in rates if math.isfinite(r) and r > 0]
    if rates:
        return float(np.median(rates)), "measured rudder ramps"
    return None, ""


#: Rudder scatter [rad] below which a record has no ramps to measure the helm rate on.
MIN_RUDDER_STD = math.radians(0.2)


def zigzag_runs(trials: Sequence[Any], series: Sequence[Series], kind: ModelKind, *,
                rate: float | None = None, step: float = 0.1,
                horizon: str | float = DEFAULT_HORIZON, lead_s: float = DEFAULT_LEAD_S,
                psi_switch: float | None = None) -> list[ZigZagRun]:
    """The replays of the zig-zags of ``trials`` (found by ``find_manoeuvres``).

    ``series`` are the trials' identification series (smoothed states); ``rate`` [rad/s] the
    helm rate (default the vessel's ``helm_rate_deg_s``, else measured); ``step`` [s] the
    residual step (the simulation runs at the log step). ``horizon``: ``"run"`` one replay from
    the execute to the end of each zig-zag; an integer n: one replay from the execute and one
    from ``lead_s`` before every measured reversal, each to the n-th next reversal (or the end
    of the record); ``psi_switch`` [rad] the switching angle when known (default: detected).
    Raises IdentificationError when a trial holds no zig-zag.
    """
    nrev = None if horizon == "run" else (2 if horizon == "cycle" else int(horizon))
    runs = []
    for tr, s in zip(trials, series, strict=True):
        # a switching angle given by the user (``psi_switch`` [rad]) overrides detection
        segs = [g for g in find_manoeuvres(tr, psi_switch=psi_switch)
                if g.kind == "zigzag"]
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
            rr = rate if rate is not None else helm_rate(
                tr.vessel, [(t[i0:i1], s["delta"][i0:i1])])[0]
            if rr is None:
                raise IdentificationError(f"trial {tr.name or '?'}: no helm rate (no rudder "
                                          "ramp in the zig-zag and no vessel helm_rate_deg_s)")
            side = int(g.side)
            sw = float(g.psi_switch)
            dev = s["psi"] - s["psi_s"][i0]
            dev_s = s["psi_s"] - s["psi_s"][i0]
            starts = [(i0, 0)]
            ends = [i1]
            if nrev is not None:
                cr = [i0 + c for c in zigzag_crossings(t[i0:i1], side * dev_s[i0:i1], sw)[1]]
                marks = [i0] + cr
                lead = int(round(lead_s / h))
                # before the m-th reversal the command in force is the m-th order's side
                starts = [(i0, 0)] + [(max(c - lead, i0), side * (-1) ** m) if lead else
                                      (c, side * (-1) ** (m + 1)) for m, c in enumerate(cr)]
                ends = [marks[m + nrev] if m + nrev < len(marks) else i1
                        for m in range(len(marks))]
            for (j, cmd), j1 in zip(starts, ends, strict=True):
                if j1 - j < 10:
                    continue
                ins = {k: s[k][j:j1] for k in ("n", "n_port", "n_stbd")
                       if k in kind.inputs and k in s}
                runs.append(ZigZagRun(
                    name=f"{tr.name}@{t[j]:.1f}s", h=h, stride=max(int(round(step / h)), 1),
                    psi=dev[j:j1], r=s["r"][j:j1], delta=s["delta"][j:j1],
                    delta_amp=float(g.level), psi_switch=sw, first=side,
                    command=0 if j == i0 else int(cmd), rate=float(rr),
                    r0=float(s["r_s"][j]), rdot0=float(s["rdot_s"][j]),
                    psi0=0.0 if j == i0 else float(dev_s[j]), delta0=float(s["delta"][j]),
                    u0=float(s["u_s"][j]) if "u_s" in s else math.nan,
                    v0=float(s["v_s"][j]) if "v_s" in s else 0.0, inputs=ins or None))
    if not runs:
        raise IdentificationError("no zig-zag runs long enough for the zig-zag replay fit")
    return runs


def replay_runs(kind: ModelKind, P: np.ndarray, dynamics: Any, runs: Sequence[ZigZagRun],
                speed: float = 1.0) -> list[dict[str, np.ndarray]]:
    """Replay every run (one lane each) with parameter rows ``P``; returns per run ``psi``
    [rad], ``r`` [rad/s], ``delta`` [rad] on its grid (NaN after a divergence)."""
    B = len(runs)
    n = np.array([len(r.psi) - 1 for r in runs], dtype=np.int64)
    N = int(n.max()) + 1
    servo = IdealServo(max_angle=max(max(r.delta_amp for r in runs), math.radians(35.0)),
                       max_rate=np.array([r.rate for r in runs]))
    skind, S = servo_rows(servo, B)
    L = np.zeros((6, B))
    L[0] = [r.delta_amp for r in runs]
    L[1] = [r.psi_switch for r in runs]
    L[2] = [r.first for r in runs]
    L[4] = [0.0 if r.command else np.nan for r in runs]
    L[5] = [r.command for r in runs]
    values: dict[str, Any] = {"r": np.array([r.r0 for r in runs]),
                              "rdot": np.array([r.rdot0 for r in runs]),
                              "delta": np.array([r.delta0 for r in runs])}
    if not kind.constant_speed:
        values["u"] = np.array([r.u0 for r in runs])
        values["v"] = np.array([r.v0 for r in runs])
    Z0 = initial_state(kind, dynamics, B, psi0=np.array([r.psi0 for r in runs]), values=values)
    series = {}
    for k in ("n", "n_port", "n_stbd"):
        if runs[0].inputs and k in runs[0].inputs:
            a = np.zeros((B, N))
            for i, r in enumerate(runs):
                v = r.inputs[k]
                a[i, :len(v)] = v
                a[i, len(v):] = v[-1]
            series[k] = a
    lanes = Lanes(kind=kind, P=np.broadcast_to(P, (P.shape[0], B)), servo=skind, S=S, Z0=Z0,
                  nsteps=n, dt=runs[0].h, logic=core.ZIGZAG, L=L, series=series,
                  channels=("psi", "r", "delta"))
    out = lanes.run()
    return [{c: out.channels[c][i, :len(r.psi)] for c in ("psi", "r", "delta")}
            for i, r in enumerate(runs)]


def refine_zigzag_oe(kind: ModelKind, start: Mapping[str, float], fixed: Mapping[str, Any],
                     runs: Sequence[ZigZagRun], *, max_nfev: int = 200, passes: int = 2,
                     channels: tuple[str, ...] = ("psi", "r")) -> OEResult:
    """Closed-loop zig-zag output error: minimise the weighted heading and yaw-rate errors of
    the replayed zig-zags (module docstring) from ``start`` (the kind's parameters), in the
    kind's fit space. Returns an :class:`usvid.identify.output_error.OEResult`."""
    if len({r.h for r in runs}) > 1:
        raise IdentificationError("zig-zag replays need one log step for all trials")
    prob = OEProblem(kind, fixed, None, ())  # only the parameter maps are used
    try:
        x_all = prob.fit_values(start)
        prob.dynamics(dict(start))
    except (UsvidError, ValueError, ZeroDivisionError) as exc:
        raise IdentificationError(f"zig-zag replay fit of {kind.name}: the start parameters "
                                  f"are not a valid model ({exc})") from None
    free = np.array([n not in prob.held for n in prob.names])
    big = 1e3

    def sims(x: np.ndarray) -> list[dict[str, np.ndarray]] | None:
        xa = x_all.copy()
        xa[free] = x
        try:
            dyn = prob.dynamics(prob.params(xa))
            P = kind.pack(dyn, 1.0)
        except (UsvidError, ValueError, ZeroDivisionError):
            return None
        return replay_runs(kind, P, dyn, runs)

    def residuals(x: np.ndarray, sig: Mapping[str, float]) -> np.ndarray:
        out = sims(x)
        parts = []
        for i, run in enumerate(runs):
            sl = slice(run.stride, None, run.stride)
            for c in ("psi", "r"):
                meas = getattr(run, c)[sl]
                if out is None:
                    parts.append(np.full(len(meas), big))
                    continue
                e = (out[i][c][sl] - meas) / sig[c]
                parts.append(np.where(np.isfinite(e), e, big))
        return np.concatenate(parts)

    def channel_rms(x: np.ndarray) -> dict[str, float]:
        out = sims(x)
        e: dict[str, list[np.ndarray]] = {"psi": [], "r": []}
        for i, run in enumerate(runs):
            sl = slice(run.stride, None, run.stride)
            for c in e:
                e[c].append(np.nan_to_num(out[i][c][sl]) - getattr(run, c)[sl])
        return {c: max(float(np.sqrt(np.mean(np.concatenate(v) ** 2))), 1e-12)
                for c, v in e.items()}

    sigma = {"psi": math.radians(1.0), "r": math.radians(0.1)}
    for c in ("psi", "r"):
        if c not in channels:
            sigma[c] = 1e12
    x0 = x_all[free].copy()
    res = None
    for k in range(passes):
        res = least_squares(lambda x, sg=sigma: residuals(x, sg), x0, x_scale="jac",
                            max_nfev=max_nfev, method="trf", diff_step=1e-6)
        x0 = res.x
        if k < passes - 1:
            sigma = channel_rms(x0)
        for c in ("psi", "r"):
            if c not in channels:
                sigma[c] = 1e12
    assert res is not None
    J = res.jac
    f = res.fun
    m, nf = J.shape
    s2 = float(f @ f) / max(m - nf, 1)
    blocks = []
    i = 0
    for run in runs:  # autocorrelation factor per run and channel
        nk = len(range(run.stride, len(run.psi), run.stride))
        blocks += [f[i:i + nk], f[i + nk:i + 2 * nk]]
        i += 2 * nk
    fac = max(autocorrelation_factor(b) for b in blocks)
    try:
        inv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError as exc:
        raise IdentificationError(
            f"zig-zag replay fit of {kind.name}: singular Jacobian (parameters "
            f"{', '.join(np.array(prob.names)[free])} not separately identifiable)") from exc
    xa = x_all.copy()
    xa[free] = res.x
    cov_x = np.zeros((len(xa), len(xa)))
    cov_x[np.ix_(free, free)] = inv * s2 * fac
    params = prob.params(xa)
    pnames = tuple(n for n in kind.dynamics.fit_names() if n in params)
    G = numerical_jacobian(lambda x: np.array([prob.params(x)[n] for n in pnames]), xa)
    return OEResult(x=xa, x_names=prob.names, x_cov=cov_x,
                    params={n: float(params[n]) for n in pnames}, cov=G @ cov_x @ G.T,
                    names=pnames, cost=float(res.cost), nfev=int(res.nfev),
                    success=bool(res.success), message=str(res.message), sigma=sigma,
                    ac_factor=float(fac), n_residuals=int(m))
