"""Second-order under-damped steering-servo identification with a dead-time search.

Model (Mu et al. 2018 eq. 12 and sec. 5.1.3; Mu et al. 2016 eq. 22, 26-27): commanded angle
``delta_cmd`` [rad] to actual angle ``delta`` [rad],

.. math::

    \\frac{\\delta(s)}{\\delta_{cmd}(s)} = \\frac{K \\omega_n^2}{s^2 + 2\\zeta\\omega_n s
    + \\omega_n^2} e^{-\\tau s}

(Mu et al. 2018 found 1.95 / (s^2 + 2.38125 s + 1.95) e^{-s}: omega_n = 1.396 rad/s, zeta = 0.853,
K = 1, tau = 1 s).

Method (documented choices; the seeds only say "recursive least squares"):

1. **ARX delay scan** (Mu et al. 2016 eq. 26 form). For every candidate delay d (samples) fit by
   least squares ``delta_k = -a1 delta_{k-1} - a2 delta_{k-2} + b1 u_{k-1-d} + b2 u_{k-2-d}`` on a
   common sample range; the d with the smallest residual RMS is the first estimate. The discrete
   model ``(b1 z + b2) / (z^2 + a1 z + a2) z^-d`` is converted to continuous time by ZOH
   (:func:`usvid.identify.d2c.d2c`) and read as omega_n = sqrt(den[2]), zeta = den[1] /
   (2 omega_n), K = G(0).
2. **Output-error refinement** (``refine=True``, default). Equation-error ARX is biased by sensor
   noise on ``delta`` (poles at z ~ 0.97 for dt = 0.02 s are very sensitive; its delay is often
   several samples off), so the continuous parameters (omega_n, zeta, K) are refined by
   ``scipy.optimize.least_squares`` on the *simulation* error (the servo simulated by the
   integration core -- the servo of every usvid simulation -- driven by the measured command,
   held over each sample), at the delay found by a pattern search (steps of 4, 2, 1 samples from
   the ARX delay, each fit started from the best so far): the delay of smallest simulation RMS.

Rate limit (``max_rate``): a steering gear moves at most at its pump's rate (IMO MSC.137(76):
35 deg to 30 deg the other side in 28 s), which no linear servo reproduces: fitted to a record
of small autopilot orders and large rate-limited steps it settles on a compromise (a rate-limited
ideal helm read as omega_n 1.4-1.7 rad/s: its 20/20 zig-zag overshoots 1.0-1.5 deg too small).
With ``max_rate`` [rad/s] (e.g. measured on the rudder's ramps,
:func:`usvid.identify.replay.helm_rate`) the same second-order servo is fitted behind that rate
limit (the servo of every simulation carries it: :class:`usvid.models.servo.SecondOrderServo`);
the estimator fits both and keeps the one that reproduces the rudder better.

Standard errors. Refined: Gauss-Newton asymptotics ``cov = s^2 (J^T J)^-1`` of the output-error
fit (J the Jacobian of the simulated output w.r.t. (omega_n, zeta, K), s^2 the residual variance;
assumes white measurement noise). ARX only: delta method, ``cov_phys = G cov_arx G^T`` with G the
numerical Jacobian of (omega_n, zeta, K) w.r.t. (a1, a2, b1, b2). The delay is discrete: its
resolution is one sample ``dt``; the scan (``delay_scan``) shows how sharply it is determined.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize

from usvid.errors import IdentificationError
from usvid.identify.ls import (
    LeastSquares,
    arx_regressors,
    interval95,
    numerical_jacobian,
    quantile975,
    standard_errors,
)
from usvid.identify.metrics import FitMetrics, fit_metrics, rmse
from usvid.models import registry
from usvid.models.d2c import d2c
from usvid.models.servo import SecondOrderServo
from usvid.sim.simulate import Lanes, initial_state

PARAM_NAMES = ("omega_n", "zeta", "gain")


@dataclass
class ServoIdentification:
    """Identified second-order servo.

    omega_n [rad/s], zeta [-], gain [-], delay [s] (= delay_samples * dt); std_errors and ci95 of
    (omega_n, zeta, gain); arx: the ARX coefficients at the chosen delay (a1, a2, b1, b2) with
    standard errors; delay_scan: (n_candidates, 2) array of (delay [samples], cost) where cost is
    the simulation RMS [rad] after refinement (the delays the search visited), or the ARX
    residual RMS [rad] otherwise;
    fit: simulation fit metrics of the final model [rad]; method: "arx" or "arx+oe".
    """

    omega_n: float
    zeta: float
    gain: float
    delay: float
    delay_samples: int
    dt: float
    std_errors: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    arx: dict[str, Any]
    delay_scan: np.ndarray
    fit: FitMetrics
    method: str
    arx_delay_scan: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    max_rate: float = math.inf  # [rad/s] the rate limit the servo was fitted behind (held)

    @property
    def servo(self) -> SecondOrderServo:
        """The :class:`usvid.models.servo.SecondOrderServo` (default limits)."""
        return SecondOrderServo(omega_n=self.omega_n, zeta=self.zeta, gain=self.gain,
                                delay=self.delay, max_rate=self.max_rate)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (model-file servo block plus uncertainty and fit)."""
        return {
            "kind": "second_order", "omega_n": self.omega_n, "zeta": self.zeta,
            "gain": self.gain, "delay": self.delay, "delay_samples": self.delay_samples,
            "dt": self.dt, "max_rate": self.max_rate, "std_errors": self.std_errors,
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "arx": self.arx, "fit": self.fit.to_dict(), "method": self.method,
        }


def _validate(delta_cmd: Any, delta: Any, dt: float) -> tuple[np.ndarray, np.ndarray]:
    u = np.asarray(delta_cmd, dtype=float)
    y = np.asarray(delta, dtype=float)
    if u.ndim != 1 or y.ndim != 1 or u.shape != y.shape:
        raise IdentificationError(
            f"servo identification: delta_cmd and delta must be 1-D of equal length "
            f"(got {u.shape} and {y.shape})")
    if not (np.isfinite(dt) and dt > 0):
        raise IdentificationError(f"servo identification: dt must be > 0 s (got {dt!r})")
    for name, a in (("delta_cmd", u), ("delta", y)):
        if not np.all(np.isfinite(a)):
            i = int(np.argmax(~np.isfinite(a)))
            raise IdentificationError(f"servo identification: {name} is not finite at sample {i}")
    if np.ptp(u) == 0:
        raise IdentificationError(
            "servo identification: no excitation (delta_cmd is constant)")
    return u, y


def _physical(theta: np.ndarray, dt: float) -> np.ndarray:
    """(a1, a2, b1, b2) -> (omega_n, zeta, gain) via ZOH d2c (nan when not a 2nd-order servo)."""
    a1, a2, b1, b2 = theta
    try:
        c = d2c([b1, b2], [1.0, a1, a2], dt, "zoh")
    except IdentificationError:
        return np.full(3, np.nan)
    den = c.den
    if den.size != 3 or den[2] <= 0:
        return np.full(3, np.nan)
    wn = np.sqrt(den[2])
    return np.array([wn, den[1] / (2 * wn), c.dc_gain])


@functools.lru_cache(maxsize=1)
def _servo_rig() -> tuple[Any, np.ndarray, np.ndarray, int]:
    """The constant part of :func:`_simulate`'s lanes: the zero-gain yaw model's kind, its
    packed parameter column, its initial-state column at rest and the row of the servo angle
    in it (built once: they cost half of a servo simulation)."""
    kind = registry.get("nomoto1")
    dyn = kind.dynamics(K=0.0, T=1.0)
    P = kind.pack(dyn, 1.0).reshape(-1, 1)
    Z0 = initial_state(kind, dyn, 1)
    row = int(np.flatnonzero(initial_state(kind, dyn, 1, values={"delta": 1.0})[:, 0]
                             != Z0[:, 0])[0])
    for a in (P, Z0):
        a.setflags(write=False)
    return kind, P, Z0, row


def _simulate(params: np.ndarray, u: np.ndarray, d: int, dt: float,
              max_rate: float = math.inf) -> np.ndarray:
    """The servo ``K wn^2 / (s^2 + 2 zeta wn s + wn^2) e^{-d dt s}`` driven by the command u
    (held over each sample), at rest on u[0]: integrated by the core (:mod:`usvid.sim.core`,
    the servo of every simulation) on a zero-gain yaw model. ``params`` (wn [rad/s], zeta,
    K) or a batch of them (B, 3), one lane each; returns delta [rad], (N,) or (B, N). The rows
    are built directly (not through :class:`SecondOrderServo`), so that the optimiser may
    cross K <= 0. ``max_rate`` [rad/s]: the servo's rate limit (inf: none)."""
    p = np.atleast_2d(np.asarray(params, dtype=float))
    B = p.shape[0]
    kind, P, Z1, row = _servo_rig()
    S = np.zeros((7, B))
    S[0], S[1], S[5] = math.pi, max_rate, d * dt
    S[2:5] = p.T
    Z0 = np.repeat(Z1, B, axis=1)
    Z0[row] = p[:, 2] * u[0]
    lanes = Lanes(kind=kind, P=np.repeat(P, B, axis=1), servo=2, S=S, Z0=Z0,
                  nsteps=np.full(B, u.size - 1), dt=dt,
                  series={"delta_cmd": u[None, :]}, channels=("delta",))
    out = lanes.run().channels["delta"]
    return out[0] if np.ndim(params) == 1 else out


def _oe_fit(u: np.ndarray, y: np.ndarray, d: int, dt: float, x0: np.ndarray,
            max_rate: float = math.inf) -> optimize.OptimizeResult:
    """Output-error fit of (wn, zeta, K) at the dead time of ``d`` samples (behind the rate
    limit ``max_rate`` [rad/s]).

    The Jacobian is scipy's forward difference ('2-point': step sqrt(eps) max(1, |x|), taken
    backwards where a bound is near) with the three shifted servos simulated in one batch of
    lanes, rather than three separate calls to the core."""
    lo = np.array([1e-3, 1e-3, -np.inf])
    hi = np.array([np.pi / dt, 10.0, np.inf])
    x0 = np.clip(x0, lo + 1e-9, np.minimum(hi - 1e-9, [np.pi / dt * 0.5, 5.0, np.inf]))
    # the core's RK4 at the log step is stable for |pole dt| < 2.78: start inside that region;
    # a simulation that diverges is a large residual (the step is rejected), not an error
    fast = x0[0] * dt * (x0[1] + math.sqrt(max(x0[1] ** 2 - 1.0, 0.0)))
    if fast > 2.0:
        x0[0] *= 2.0 / fast
    big = 1e3 * max(float(np.ptp(y)), 1e-3)

    def resid(p: np.ndarray) -> np.ndarray:
        e = _simulate(p, u, d, dt, max_rate) - y
        return np.where(np.isfinite(e), e, big)

    def jac(p: np.ndarray) -> np.ndarray:
        h = np.sqrt(np.finfo(float).eps) * np.where(p >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(p))
        h = np.where((p + h > hi) | (p + h < lo), -h, h)  # one-sided, inside the bounds
        h = (p + h) - p  # the step as represented
        shifted = p + np.diag(h)
        e = _simulate(np.vstack([p, shifted]), u, d, dt, max_rate) - y
        e = np.where(np.isfinite(e), e, big)
        return ((e[1:] - e[0]) / h[:, None]).T

    return optimize.least_squares(resid, x0, jac=jac, bounds=(lo, hi), x_scale="jac",
                                  method="trf")


def identify_second_order_servo(delta_cmd: Any, delta: Any, dt: float, *,
                                max_delay: float = 2.0, refine: bool = True,
                                initial_step: int = 4,
                                max_rate: float = math.inf) -> ServoIdentification:
    """Identify omega_n, zeta, gain and dead time of a steering servo (see module docstring).

    Parameters
    ----------
    delta_cmd, delta : array (N,)
        Commanded and measured servo angle [rad] on a uniform grid.
    dt : float
        Sample time [s].
    max_delay : float
        Largest dead time searched [s] (candidates 0, dt, ..., max_delay).
    refine : bool
        Output-error refinement (recommended with sensor noise).
    initial_step : int
        First step [samples] of the pattern search over the delay (halved down to one sample
        where no neighbour improves the simulation RMS).
    max_rate : float
        Rate limit [rad/s] the servo is fitted behind (held; inf: none; module docstring).
        Needs ``refine`` (the ARX form is linear).
    """
    u, y = _validate(delta_cmd, delta, dt)
    if not max_rate > 0:
        raise IdentificationError(f"servo identification: max_rate must be > 0 rad/s (got "
                                  f"{max_rate!r})")
    if math.isfinite(max_rate) and not refine:
        raise IdentificationError("servo identification: a rate limit needs refine=True (the "
                                  "ARX form is linear)")
    dmax = int(round(max_delay / dt))
    if dmax < 0:
        raise IdentificationError(f"servo identification: max_delay must be >= 0 (got {max_delay})")
    k0 = 2 + dmax
    if y.size - k0 < 20:
        raise IdentificationError(
            f"servo identification: too few samples ({y.size}) for a delay search up to "
            f"{max_delay} s at dt = {dt} s (need at least {k0 + 20})")
    arx_cost = np.empty(dmax + 1)
    for d in range(dmax + 1):
        X, t, _ = arx_regressors(u, y, 2, 2, 1 + d, start=k0)  # ARX(2, 2), dead time d
        theta, *_ = np.linalg.lstsq(X, t, rcond=None)
        arx_cost[d] = rmse(t, X @ theta)
    d_arx = int(np.argmin(arx_cost))
    X, t, _ = arx_regressors(u, y, 2, 2, 1 + d_arx, start=k0)
    ls = LeastSquares().fit(X, t, names=["a1", "a2", "b1", "b2"], y_name="delta")
    arx = {"params": dict(zip(ls.names_, ls.coef_.tolist(), strict=True)),
           "std_errors": dict(zip(ls.names_, ls.std_errors_.tolist(), strict=True)),
           "delay_samples": d_arx}
    phys = _physical(ls.coef_, dt)
    arx_scan = np.column_stack([np.arange(dmax + 1), arx_cost])

    if not refine:
        if not np.all(np.isfinite(phys)):
            raise IdentificationError(
                "servo identification: the ARX model is not a second-order servo (a discrete "
                "pole on the negative real axis or an unstable/over-damped real pair); try "
                "refine=True")
        G = numerical_jacobian(lambda th: _physical(th, dt), ls.coef_, floor=1e-3)
        cov = G @ ls.cov_ @ G.T
        se = standard_errors(cov)
        d_best, params, scan, method = d_arx, phys, arx_scan, "arx"
        q = quantile975()
    else:
        g0 = float(u @ y / (u @ u)) if u @ u > 0 else 1.0  # least-squares static gain
        x0 = phys if np.all(np.isfinite(phys)) and phys[2] > 0 else np.array(
            [1.0, 0.7, g0 if g0 > 0 else 1.0])
        # pattern search over the integer delay on the simulation RMS: steps of 4, 2, 1 samples
        # from the ARX delay, each fit started from the best fit so far
        results: dict[int, optimize.OptimizeResult] = {
            d_arx: _oe_fit(u, y, d_arx, dt, x0, max_rate)}
        best, step = d_arx, max(1, int(initial_step))
        while True:
            for d in (best - step, best + step):
                if 0 <= d <= dmax and d not in results:
                    results[d] = _oe_fit(u, y, d, dt, results[best].x.copy(), max_rate)
                if d in results and results[d].cost < results[best].cost:
                    best = d
                    break
            else:
                if step == 1:
                    break
                step //= 2
        res = results[best]
        n, p = y.size, 3
        s2 = 2 * res.cost / (n - p)
        J = res.jac
        cov = s2 * np.linalg.pinv(J.T @ J)
        se = standard_errors(cov)
        d_best, params, method = best, res.x, "arx+oe"
        ds = np.array(sorted(results))
        scan = np.column_stack([ds, [np.sqrt(2 * results[k].cost / n) for k in ds]])
        q = quantile975(n - p)
    if not np.all(np.isfinite(params)):
        raise IdentificationError("servo identification failed: non-finite parameters")
    if params[2] <= 0:
        raise IdentificationError(
            f"servo identification: negative servo gain ({params[2]:.3g}); check the sign "
            "convention of delta and delta_cmd")
    sim = _simulate(params, u, d_best, dt, max_rate)
    return ServoIdentification(
        omega_n=float(params[0]), zeta=float(params[1]), gain=float(params[2]),
        delay=d_best * float(dt), delay_samples=int(d_best), dt=float(dt),
        std_errors=dict(zip(PARAM_NAMES, se.tolist(), strict=True)),
        ci95={k: tuple(lh) for k, lh in zip(PARAM_NAMES, interval95(params, se, q).tolist(),
                                            strict=True)},
        arx=arx, delay_scan=scan, fit=fit_metrics(y, sim), method=method,
        arx_delay_scan=arx_scan, max_rate=float(max_rate))


#: Candidate natural frequencies [rad/s] and dead times [s] of :func:`helm_from_zigzags`.
HELM_OMEGA = (2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0)
HELM_DELAYS = tuple(round(0.02 * k, 2) for k in range(76))  # 0 .. 1.5 s


@dataclass
class HelmFit:
    """The helm of zig-zag trials without a logged order (:func:`helm_from_zigzags`):
    ``servo`` (second order, zeta 1, at the given rate limit), ``rms`` [rad] of the rudder over
    the reversal windows, ``n_reversals`` used."""

    servo: SecondOrderServo
    rms: float
    n_reversals: int


def helm_from_zigzags(reversals: list[tuple[np.ndarray, np.ndarray, float]], rate: float, *,
                      max_angle: float | None = None, h: float = 0.005) -> HelmFit | None:
    """The helm of a zig-zag autopilot from its rudder record at the reversals.

    A zig-zag's order is known without a logged ``delta_cmd``: it reverses to the opposite
    amplitude when the heading deviation crosses the switching angle (IMO MSC.137(76)). Each
    reversal is ``(t, delta, t_cross)``: time [s] and rudder [rad] over a window from before
    the crossing instant ``t_cross`` [s] until the rudder has settled (before the next
    reversal); the order is the rudder held before the window, then the rudder held at its
    end. The servo ``delta'' + 2 omega_n delta' + omega_n^2 delta = omega_n^2 delta_cmd(t -
    tau)`` (critically damped: the ramps show no overshoot) with ``|delta'| <= rate`` [rad/s]
    (the vessel's helm rate) is fitted by a grid search over omega_n (:data:`HELM_OMEGA`
    [rad/s]) and the dead time tau (:data:`HELM_DELAYS` [s]) minimising the rudder RMS over
    all windows (integrated at ``h`` [s] as the core does: rate clipped). The dead time
    includes the helmsman's (autopilot's) reaction to the crossing. None without reversals.
    """
    wins = [(np.asarray(t, float), np.asarray(d, float), float(tc)) for t, d, tc in reversals
            if len(t) > 10]
    if not wins:
        return None
    T = max(float(t[-1] - tc) for t, _, tc in wins)
    t0 = min(float(t[0] - tc) for t, _, tc in wins)
    grid = np.arange(t0, T + h, h)
    nw = len(wins)
    d0 = np.array([d[0] for _, d, _ in wins])
    d1 = np.array([np.median(d[-max(len(d) // 10, 1):]) for _, d, _ in wins])
    meas = np.full((nw, grid.size), np.nan)
    for i, (t, d, tc) in enumerate(wins):
        sel = (grid >= t[0] - tc) & (grid <= t[-1] - tc)
        meas[i, sel] = np.interp(grid[sel], t - tc, d)
    wn = np.repeat(np.asarray(HELM_OMEGA, float), len(HELM_DELAYS))[:, None]
    tau = np.tile(np.asarray(HELM_DELAYS, float), len(HELM_OMEGA))[:, None]
    x = np.tile(d0, (wn.shape[0], 1))  # (candidates, windows)
    w = np.zeros_like(x)
    sse = np.zeros(x.shape[0])
    cnt = 0
    for k, s in enumerate(grid):
        cmd = np.where(s >= tau, d1, d0)
        a = wn * wn * (cmd - x) - 2.0 * wn * w
        w = np.clip(w + h * a, -rate, rate)
        x = x + h * w
        m = meas[:, k]
        ok = np.isfinite(m)
        if ok.any():
            sse += np.sum((x[:, ok] - m[ok]) ** 2, axis=1)
            cnt += int(ok.sum())
    b = int(np.argmin(sse))
    kw = {} if max_angle is None else {"max_angle": max_angle}
    servo = SecondOrderServo(omega_n=float(wn[b, 0]), zeta=1.0, delay=float(tau[b, 0]),
                             max_rate=rate, **kw)
    return HelmFit(servo, math.sqrt(sse[b] / max(cnt, 1)), nw)
