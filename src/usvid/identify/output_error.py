"""Output-error refinement by multiple shooting, and the batch simulators it needs.

The equation-error (least-squares) estimate of :mod:`usvid.identify.estimator` is biased when the
regressors are noisy (the yaw rate appears on both sides). Output-error refinement minimises the
difference between *simulated* and *measured* outputs instead (heading and yaw rate; for the
3-DOF and catamaran models also u and v):

.. math:: \\min_p \\sum_w \\sum_k \\| W (y_{sim}(t_k; p, x_w) - y_{meas}(t_k)) \\|^2

Multiple shooting: every trial is cut into windows of ``window_s`` seconds (default 20 s, optional
overlap), each started from its own initial state (r, psi; or u, v, r, psi), which is estimated
together with the model parameters starting from the smoothed measurement. A course-unstable model
(Norrbin n1 < 0, KVLCC2) therefore cannot drift away over a long record, and noisy initial states
do not bias the estimate. All windows are simulated at once (batch axis first, time next) by a
numba RK4 kernel at the (decimated) sample step.

Solver: Levenberg-Marquardt on the normal equations with the window states eliminated window by
window (Schur complement, cost linear in the number of windows; ``solver="schur"``), or
``scipy.optimize.least_squares`` with the same grouped finite-difference Jacobian
(``solver="scipy"``, the reference; same optimum).

Covariance from the Jacobian at the optimum. With at least ``MIN_CLUSTERS`` windows the
cluster-robust (sandwich) form with the windows as clusters,

.. math:: \\mathrm{cov}(p) = S^{-1} \\Big(\\sum_w \\psi_w \\psi_w^T\\Big) S^{-1}
          \\frac{B}{B-1}\\frac{m-1}{m-k}

(S the parameter block of J^T J after eliminating the window states, psi_w the window's score),
valid for any residual correlation inside a window (disturbances, model error); intervals then use
Student's t with B - 1 degrees of freedom. With fewer windows the Gauss-Newton form
``(J^T J)^-1 s^2 f_ac``, ``s^2 = r^T r / (m - k)``, inflated by ``f_ac = 1 + 2 sum_k rho_k``
(Bartlett-weighted residual autocorrelation).

Units: time [s], angles [rad], yaw rate [rad/s], speeds [m/s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from scipy.optimize import least_squares

from usvid.errors import IdentificationError
from usvid.identify.metrics import rmse

#: Parameter names (order of the kernel's parameter vector) of each simulated model kind.
PARAM_NAMES: dict[str, tuple[str, ...]] = {
    "nomoto1": ("K", "T", "delta0"),
    "nomoto2": ("K", "T1", "T2", "T3", "delta0"),
    "norrbin": ("K", "T", "n1", "n3", "delta0"),
    "threedof": ("a_vr", "a_u", "a_tau", "b_ur", "b_v", "c_uv", "c_r", "c_tau"),
    "catamaran": ("a_vr", "a_u", "a_tau", "b_ur", "b_v", "c_uv", "c_r", "c_tau"),
}
RESPONSE_KINDS = ("nomoto1", "nomoto2", "norrbin")
_KIND_CODE = {"nomoto1": 0, "nomoto2": 1, "norrbin": 2}
_R_CLIP = 50.0  # [rad/s] a diverging trial model is clipped here (keeps residuals finite)
_V_CLIP = 1e3  # [m/s]
#: Fewest windows for the cluster-robust covariance; below it the autocorrelation factor is used.
MIN_CLUSTERS = 8
#: Largest dense Jacobian (rows x columns) of the output-error fit; above it a sparse one (lsmr).
DENSE_MAX = 4_000_000
_EPS_FD = 1.4901161193847656e-08  # sqrt(machine epsilon): forward-difference relative step


@nb.njit(cache=True)
def _response_rhs(code, p, x1, x2, u, du):
    """Time derivative of the response-model state (x1 = r; x2 the 2nd-order auxiliary state).

    nomoto1: T r' + r = K (delta + delta0) (seed 000 eq. 35, alpha = 0);
    norrbin: T r' + n1 r + n3 r^3 = K (delta + delta0) (seed 000 eq. 35 with n1 free);
    nomoto2: T1 T2 r'' + (T1 + T2) r' + r = K (delta + delta0 + T3 delta') (seed 000 eq. 30),
    written in observable canonical form x1' = -a1 x1 + x2 + b1 u, x2' = -a0 x1 + b0 u.
    """
    if code == 0:
        return (p[0] * (u + p[2]) - x1) / p[1], 0.0
    if code == 2:
        return (p[0] * (u + p[4]) - p[2] * x1 - p[3] * x1 * x1 * x1) / p[1], 0.0
    t12 = p[1] * p[2]
    a1 = (p[1] + p[2]) / t12
    a0 = 1.0 / t12
    b1 = p[0] * p[3] / t12
    b0 = p[0] / t12
    ue = u + p[4]
    return -a1 * x1 + x2 + b1 * ue, -a0 * x1 + b0 * ue


@nb.njit(cache=True)
def _response_rk4(code, p, x1, x2, u0, u1, h):
    """One RK4 step of :func:`_response_rhs` over [t, t + h] with the input linear from ``u0`` to
    ``u1`` (midpoint value at the inner stages). Returns the new (x1, x2), not clipped."""
    um = 0.5 * (u0 + u1)
    du = (u1 - u0) / h
    k1a, k1b = _response_rhs(code, p, x1, x2, u0, du)
    k2a, k2b = _response_rhs(code, p, x1 + 0.5 * h * k1a, x2 + 0.5 * h * k1b, um, du)
    k3a, k3b = _response_rhs(code, p, x1 + 0.5 * h * k2a, x2 + 0.5 * h * k2b, um, du)
    k4a, k4b = _response_rhs(code, p, x1 + h * k3a, x2 + h * k3b, u1, du)
    xn = x1 + h / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a)
    x2n = x2 + h / 6.0 * (k1b + 2.0 * k2b + 2.0 * k3b + k4b)
    return xn, x2n


@nb.njit(cache=True)
def simulate_response_batch(code, p, delta, h, r0, rdot0, psi0):
    """RK4 simulation of a response model over a batch of windows (numba).

    Parameters
    ----------
    code : int
        0 nomoto1, 1 nomoto2, 2 norrbin.
    p : (n_p,) float array
        Parameters in the order of :data:`PARAM_NAMES`.
    delta : (B, W) float array
        Rudder angle [rad] at the sample instants (linear between samples).
    h : float
        Sample step [s].
    r0, rdot0, psi0 : (B,) float arrays
        Initial yaw rate [rad/s], yaw acceleration [rad/s^2] (2nd order only), heading [rad].

    Returns
    -------
    r, psi : (B, W) arrays [rad/s, rad].
    """
    B, W = delta.shape
    r = np.empty((B, W))
    psi = np.empty((B, W))
    t12 = p[1] * p[2] if code == 1 else 1.0
    for b in range(B):
        x1 = r0[b]
        x2 = 0.0
        if code == 1:
            a1 = (p[1] + p[2]) / t12
            b1 = p[0] * p[3] / t12
            x2 = rdot0[b] + a1 * x1 - b1 * (delta[b, 0] + p[4])
        ps = psi0[b]
        r[b, 0] = x1
        psi[b, 0] = ps
        for k in range(W - 1):
            xn, x2 = _response_rk4(code, p, x1, x2, delta[b, k], delta[b, k + 1], h)
            if not np.isfinite(xn) or xn > _R_CLIP:
                xn = _R_CLIP
            elif xn < -_R_CLIP:
                xn = -_R_CLIP
            if not np.isfinite(x2) or abs(x2) > 1e6:
                x2 = 0.0
            ps = ps + h * (x1 + xn) * 0.5  # trapezoid in r: exact to O(h^3) as RK4's r is smooth
            x1 = xn
            r[b, k + 1] = x1
            psi[b, k + 1] = ps
    return r, psi


@nb.njit(cache=True)
def _threedof_rhs(p, u, v, r, tu, tr):
    """Seed 000 eq. 37 regression form: u' = a_vr v r + a_u u + a_tau tau_u,
    v' = b_ur u r + b_v v, r' = c_uv u v + c_r r + c_tau tau_r."""
    du = p[0] * v * r + p[1] * u + p[2] * tu
    dv = p[3] * u * r + p[4] * v
    dr = p[5] * u * v + p[6] * r + p[7] * tr
    return du, dv, dr


@nb.njit(cache=True)
def simulate_threedof_batch(p, tau_u, tau_r, h, u0, v0, r0, psi0):
    """RK4 simulation of the seed 000 eq. 37 3-DOF regression model over a batch of windows.

    ``tau_u`` [N], ``tau_r`` [N m] (or, for the catamaran, the thrust regressors) are (B, W) arrays
    at the sample instants (linear between samples), ``h`` [s] the step; initial u, v [m/s],
    r [rad/s], psi [rad] are (B,) arrays. Returns u, v, r, psi as (B, W) arrays.
    """
    B, W = tau_u.shape
    U = np.empty((B, W))
    V = np.empty((B, W))
    R = np.empty((B, W))
    P = np.empty((B, W))
    for b in range(B):
        u = u0[b]
        v = v0[b]
        r = r0[b]
        ps = psi0[b]
        U[b, 0] = u
        V[b, 0] = v
        R[b, 0] = r
        P[b, 0] = ps
        for k in range(W - 1):
            a0 = tau_u[b, k]
            a1 = tau_u[b, k + 1]
            c0 = tau_r[b, k]
            c1 = tau_r[b, k + 1]
            am = 0.5 * (a0 + a1)
            cm = 0.5 * (c0 + c1)
            k1u, k1v, k1r = _threedof_rhs(p, u, v, r, a0, c0)
            k2u, k2v, k2r = _threedof_rhs(p, u + 0.5 * h * k1u, v + 0.5 * h * k1v,
                                          r + 0.5 * h * k1r, am, cm)
            k3u, k3v, k3r = _threedof_rhs(p, u + 0.5 * h * k2u, v + 0.5 * h * k2v,
                                          r + 0.5 * h * k2r, am, cm)
            k4u, k4v, k4r = _threedof_rhs(p, u + h * k3u, v + h * k3v, r + h * k3r, a1, c1)
            un = u + h / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
            vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
            rn = r + h / 6.0 * (k1r + 2.0 * k2r + 2.0 * k3r + k4r)
            if not (np.isfinite(un) and np.isfinite(vn) and np.isfinite(rn)):
                un, vn, rn = _V_CLIP, _V_CLIP, _R_CLIP
            un = min(max(un, -_V_CLIP), _V_CLIP)
            vn = min(max(vn, -_V_CLIP), _V_CLIP)
            rn = min(max(rn, -_R_CLIP), _R_CLIP)
            ps = ps + 0.5 * h * (r + rn)
            u, v, r = un, vn, rn
            U[b, k + 1] = u
            V[b, k + 1] = v
            R[b, k + 1] = r
            P[b, k + 1] = ps
    return U, V, R, P


@dataclass
class Windows:
    """Measured data cut into equal windows (batch first, time next), ready for simulation.

    ``inputs`` maps input name -> (B, W) ([rad] delta, or tau_u/tau_r), ``outputs`` output name ->
    (B, W) measured (``psi``, ``r`` and, for 3-DOF, ``u``, ``v``), ``init`` name -> (B,) smoothed
    initial states (``r``, ``rdot``, ``psi``, ``u``, ``v``), ``h`` the step [s].
    """

    h: float
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    init: dict[str, np.ndarray]
    trial_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def batch_size(self) -> int:
        return next(iter(self.outputs.values())).shape[0]


def make_windows(series: list[dict[str, np.ndarray]], h: float, window_s: float,
                 overlap: float = 0.0) -> Windows:
    """Cut uniformly sampled series into windows of ``window_s`` seconds.

    ``series`` holds one dict per trial with 1-D arrays on the same grid of step ``h`` [s]:
    inputs (``delta`` or ``tau_u``, ``tau_r``), measured outputs (``psi``, ``r``, ``u``, ``v``) and
    smoothed states for initialisation (``r_s``, ``rdot_s``, ``psi``, ``u_s``, ``v_s``).
    Windows start every ``(1 - overlap) W`` samples (``overlap`` in [0, 1): 0.5 makes every
    sample appear in two windows of different phase, which makes the fit less sensitive to where
    the window edges fall in a manoeuvre); a last window is aligned with the end of the trial so
    the whole record is used. A trial shorter than one window is one window.
    """
    if not 0 <= overlap < 1:
        raise IdentificationError(f"`overlap` must be in [0, 1) (got {overlap!r})")
    W = max(int(round(window_s / h)) + 1, 3)
    in_names = [k for k in ("delta", "tau_u", "tau_r") if k in series[0]]
    out_names = [k for k in ("psi", "r", "u", "v") if k in series[0]]
    W = min(W, min(len(s["psi"]) for s in series))
    starts_all: list[tuple[int, int]] = []
    for i, s in enumerate(series):
        n = len(s["psi"])
        stride = max(int(round((W - 1) * (1 - overlap))), 1)
        starts = list(range(0, n - W + 1, stride))
        if starts[-1] + W < n:
            starts.append(n - W)
        starts_all += [(i, k) for k in starts]
    idx = np.array([k for _, k in starts_all])
    tri = np.array([i for i, _ in starts_all])

    def stack(name: str) -> np.ndarray:
        return np.stack([series[i][name][k:k + W] for i, k in starts_all])

    def first(name: str) -> np.ndarray:
        return np.array([series[i][name][k] for i, k in starts_all], dtype=float)

    init = {}
    for name, src in (("r", "r_s"), ("rdot", "rdot_s"), ("psi", "psi_s"), ("u", "u_s"),
                      ("v", "v_s")):
        if src in series[0]:
            init[name] = first(src)
    del idx
    return Windows(h=h, inputs={k: stack(k) for k in in_names},
                   outputs={k: stack(k) for k in out_names}, init=init, trial_index=tri)


def simulate_windows(kind: str, params: np.ndarray, win: Windows) -> dict[str, np.ndarray]:
    """Simulate every window of ``win`` with parameter vector ``params`` (order of PARAM_NAMES).

    Returns name -> (B, W) simulated outputs (``psi``, ``r`` and for 3-DOF kinds ``u``, ``v``).
    """
    p = np.asarray(params, dtype=float)
    if kind in RESPONSE_KINDS:
        rdot = win.init.get("rdot", np.zeros_like(win.init["r"]))
        r, psi = simulate_response_batch(_KIND_CODE[kind], p, win.inputs["delta"], win.h,
                                         win.init["r"], rdot, win.init["psi"])
        return {"r": r, "psi": psi}
    U, V, R, P = simulate_threedof_batch(p, win.inputs["tau_u"], win.inputs["tau_r"], win.h,
                                         win.init["u"], win.init["v"], win.init["r"],
                                         win.init["psi"])
    return {"u": U, "v": V, "r": R, "psi": P}


def autocorrelation_factor(res: np.ndarray, max_lag: int | None = None) -> float:
    """Variance inflation ``1 + 2 sum_k (1 - k/L) rho_k`` of a (B, W) residual batch.

    rho_k is the lag-k autocorrelation pooled over windows (lags within a window only), summed with
    Bartlett weights up to ``L`` = ``max_lag`` (default W/4) or the first non-positive lag. This is
    the ratio of the true variance of a mean of correlated residuals to the white-noise variance;
    it is >= 1 by construction (clipped).
    """
    res = np.asarray(res, dtype=float)
    if res.ndim == 1:
        res = res[None, :]
    res = res - res.mean()
    W = res.shape[1]
    L = max_lag or max(W // 4, 1)
    var = float(np.mean(res * res))
    if var <= 0:
        return 1.0
    f = 1.0
    for k in range(1, min(L, W - 1) + 1):
        rho = float(np.mean(res[:, k:] * res[:, :-k])) / var
        if rho <= 0:
            break
        f += 2.0 * (1.0 - k / (L + 1)) * rho
    return max(f, 1.0)


@dataclass
class OEResult:
    """Result of :func:`refine_output_error`: parameters, covariance and diagnostics."""

    params: np.ndarray
    cov: np.ndarray
    std_errors: np.ndarray
    names: tuple[str, ...]
    cost: float
    nfev: int
    success: bool
    message: str
    sigma: dict[str, float]
    ac_factor: float
    n_residuals: int
    free: np.ndarray
    dof: float = math.inf  # degrees of freedom of the interval quantile (clusters - 1)


def _bounds(kind: str, p0: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lo = np.full(len(p0), -np.inf)
    hi = np.full(len(p0), np.inf)
    names = PARAM_NAMES[kind]
    for i, n in enumerate(names):
        if n in ("T", "T1", "T2"):
            lo[i] = 1e-4
    lo, hi = lo[free], hi[free]
    return lo, hi


def _init_names(kind: str) -> tuple[str, ...]:
    return ("r", "psi") if kind in RESPONSE_KINDS else ("u", "v", "r", "psi")


def _fd_params(fun, x: np.ndarray, f0: np.ndarray, nf: int, hi: np.ndarray) -> np.ndarray:
    """Forward-difference derivatives of ``fun`` (residuals shaped like ``f0``) with respect to
    the first ``nf`` unknowns (model parameters): array ``f0.shape + (nf,)``. Relative step
    sqrt(eps), taken backwards at an upper bound."""
    out = np.empty(f0.shape + (nf,))
    for j in range(nf):
        h = _EPS_FD * max(1.0, abs(x[j]))
        if x[j] + h > hi[j]:
            h = -h
        x1 = x.copy()
        x1[j] += h
        out[..., j] = (fun(x1) - f0) / h
    return out


def _fd_states(fun, x: np.ndarray, f0: np.ndarray, nf: int, ni: int, B: int
               ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Grouped forward differences for the window initial states: for each of the ``ni`` states,
    all ``B`` windows perturbed at once (a window's state moves only its own residuals). Returns
    per state ``(fun(x + h) - f0, h)`` with ``h`` (B,) the steps."""
    out = []
    for j in range(ni):
        sl = slice(nf + j * B, nf + (j + 1) * B)
        h = _EPS_FD * np.maximum(1.0, np.abs(x[sl]))
        x1 = x.copy()
        x1[sl] += h
        out.append((fun(x1) - f0, h))
    return out


def _rms_sigma(kind: str, unpack, x: np.ndarray, meas: dict[str, np.ndarray],
               channels: tuple[str, ...]) -> dict[str, float]:
    """Second-pass channel weights: RMS of each channel's residual at ``x`` (floored at 1e-12)."""
    p, w = unpack(x)
    sim = simulate_windows(kind, p, w)
    return {c: max(rmse(meas[c][:, 1:], sim[c][:, 1:]), 1e-12) for c in channels}


def _singular(kind: str, free: np.ndarray) -> IdentificationError:
    """The error of a singular Jacobian at the optimum, naming the free parameters."""
    return IdentificationError(
        f"output-error fit of {kind}: singular Jacobian (parameters "
        f"{', '.join(np.array(PARAM_NAMES[kind])[free])} not separately identifiable from these "
        "data)")


def _param_covariance(n_params: int, free: np.ndarray, Sinv: np.ndarray, s2: float, fac: float,
                      B: int, m: int, ncol: int, sandwich
                      ) -> tuple[np.ndarray, np.ndarray, float]:
    """Covariance (n_params, n_params; zero rows for held parameters), standard errors and the
    reported inflation factor.

    ``Sinv`` is the free-parameter block of ``(J^T J)^-1``; ``sandwich()`` gives the uncorrected
    cluster-robust form of that block. With ``B >= MIN_CLUSTERS`` windows the sandwich times
    ``B/(B-1) (m-1)/(m-ncol)`` (the factor then is its mean ratio to the white-noise
    covariance), else ``Sinv s2 fac``.
    """
    if B >= MIN_CLUSTERS:
        corr = B / (B - 1) * (m - 1) / max(m - ncol, 1)
        cov_free = sandwich() * corr
        with np.errstate(over="ignore"):  # a runaway parameter (nomoto2 T1 -> inf): fac = inf
            fac = float(np.mean(np.diag(cov_free) / np.maximum(np.diag(Sinv) * s2, 1e-300)))
    else:
        cov_free = Sinv * s2 * fac
    cov = np.zeros((n_params, n_params))
    cov[np.ix_(free, free)] = cov_free
    return cov, np.sqrt(np.clip(np.diag(cov), 0, None)), fac


def refine_output_error(kind: str, p0: np.ndarray, win: Windows, *,
                        channels: tuple[str, ...] | None = None,
                        free: np.ndarray | None = None, max_nfev: int = 100,
                        estimate_initial: bool = True, reweight: bool = True,
                        solver: str = "schur") -> OEResult:
    """Minimise weighted simulated-minus-measured outputs over all windows (multiple shooting).

    Parameters
    ----------
    kind : str
        Model kind (key of :data:`PARAM_NAMES`).
    p0 : array
        Starting parameters (the least-squares estimate), SI units.
    win : Windows
        Measured windows (:func:`make_windows`).
    channels : tuple of str
        Outputs compared; default ``("psi", "r")`` for response models and
        ``("u", "v", "r", "psi")`` for 3-DOF kinds.
    free : bool array
        Which parameters are estimated (others held at ``p0``), default all.
    estimate_initial : bool
        Estimate each window's initial state (r, psi; or u, v, r, psi) together with the
        parameters, starting from the smoothed measurement (true multiple shooting with
        independent windows). The Jacobian is sparse (a window's initial state moves only that
        window's residuals), so finite differences cost one extra simulation per state. This
        removes the bias of noisy initial states and lets the intervals account for them.
    reweight : bool
        Two passes: the second weights each channel by the inverse RMS of its first-pass residual
        (so heading [rad] and yaw rate [rad/s] count by their own error level).
    solver : {"schur", "scipy"}
        ``"schur"`` (default): Levenberg-Marquardt on the normal equations with the per-window
        initial states eliminated window by window (Schur complement; block-sparse, no large
        matrix, cost linear in the number of windows). ``"scipy"``:
        ``scipy.optimize.least_squares`` (trf) with the same grouped finite-difference Jacobian;
        same optimum, slower on long records (kept as the reference implementation).

    Returns
    -------
    OEResult with parameters, covariance and standard errors (0 for held parameters). With at
    least ``MIN_CLUSTERS`` windows the covariance is the cluster-robust sandwich
    ``(J^T J)^-1 (sum_w J_w^T r_w r_w^T J_w) (J^T J)^-1 B/(B-1) (m-1)/(m-k)`` with the windows as
    clusters (valid for any residual correlation inside a window: disturbances, model error);
    with fewer windows the Gauss-Newton ``(J^T J)^-1 s^2`` inflated by the residual
    autocorrelation factor. ``ac_factor`` reports the ratio to the white-noise covariance;
    ``dof`` = B - 1 is the Student-t degrees of freedom for intervals from the cluster-robust
    covariance (the usual small-sample rule for B clusters), infinite otherwise.
    """
    from scipy import sparse

    p0 = np.asarray(p0, dtype=float).copy()
    names = PARAM_NAMES[kind]
    if channels is None:
        channels = ("psi", "r") if kind in RESPONSE_KINDS else ("u", "v", "r", "psi")
    free = np.ones(len(p0), bool) if free is None else np.asarray(free, bool)
    nf = int(free.sum())
    meas = {c: win.outputs[c] for c in channels}
    B, W = meas[channels[0]].shape
    # first-pass weights: sample-to-sample scatter is a noise-level proxy (never zero)
    sigma = {}
    for c in channels:
        sc = float(np.std(np.diff(meas[c], axis=1)))
        sigma[c] = max(sc, 1e-3 * float(np.std(meas[c])), 1e-9)
    inames = _init_names(kind) if estimate_initial else ()
    init0 = {k: np.asarray(win.init[k], float).copy() for k in _init_names(kind)}

    def unpack(x: np.ndarray) -> tuple[np.ndarray, Windows]:
        p = p0.copy()
        p[free] = x[:nf]
        if not inames:
            return p, win
        init = dict(win.init)
        for j, k in enumerate(inames):
            init[k] = x[nf + j * B: nf + (j + 1) * B]
        return p, Windows(h=win.h, inputs=win.inputs, outputs=win.outputs, init=init,
                          trial_index=win.trial_index)

    def resid(x: np.ndarray, sig: dict[str, float]) -> np.ndarray:
        p, w = unpack(x)
        sim = simulate_windows(kind, p, w)
        out = [((sim[c] - meas[c]) / sig[c])[:, 1:].ravel() for c in channels]
        return np.concatenate(out)

    x0 = np.concatenate([p0[free]] + [init0[k] for k in inames])
    lo_p, hi_p = _bounds(kind, p0, free)
    lo = np.concatenate([lo_p, np.full(len(x0) - nf, -np.inf)])
    hi = np.concatenate([hi_p, np.full(len(x0) - nf, np.inf)])
    x0 = np.clip(x0, lo + 1e-12, hi)
    m = len(channels) * B * (W - 1)
    rows_of_window = np.arange(m).reshape(len(channels), B, W - 1)
    dense = m * len(x0) <= DENSE_MAX

    def jac(x: np.ndarray, sig: dict[str, float]):
        """Forward differences, grouped: one simulation per model parameter and one per initial
        state (all windows perturbed at once: a window's state moves only its residuals)."""
        def fun(x1: np.ndarray) -> np.ndarray:
            return resid(x1, sig)

        f0 = fun(x)
        Jg = _fd_params(fun, x, f0, nf, hi)
        blocks = []
        for j, (df, h) in enumerate(_fd_states(fun, x, f0, nf, len(inames), B)):
            d = df.reshape(len(channels), B, W - 1) / h[None, :, None]
            cols = np.broadcast_to((nf + j * B + np.arange(B))[None, :, None], d.shape)
            blocks.append((rows_of_window.ravel(), cols.ravel(), d.ravel()))
        if dense:
            Jd = np.zeros((m, len(x)))
            Jd[:, :nf] = Jg
            for rr, cc, dd in blocks:
                Jd[rr, cc] = dd
            return Jd
        rr = [np.repeat(np.arange(m), nf)] + [b[0] for b in blocks]
        cc = [np.tile(np.arange(nf), m)] + [b[1] for b in blocks]
        dd = [Jg.ravel()] + [b[2] for b in blocks]
        return sparse.csr_matrix((np.concatenate(dd), (np.concatenate(rr), np.concatenate(cc))),
                                 shape=(m, len(x)))

    passes = 2 if reweight else 1
    if solver == "schur":
        return _refine_schur(kind, p0, win, channels, free, inames, sigma, lo, hi, x0,
                             passes, max_nfev, unpack, resid, meas)
    if solver != "scipy":
        raise IdentificationError(f"`solver` must be 'schur' or 'scipy' (got {solver!r})")
    res = None
    for k in range(passes):
        res = least_squares(resid, x0, jac=jac, args=(sigma,), bounds=(lo, hi), x_scale="jac",
                            max_nfev=max_nfev, method="trf")
        x0 = res.x
        if k < passes - 1:
            sigma = _rms_sigma(kind, unpack, x0, meas, channels)
    assert res is not None
    J = res.jac
    r = res.fun
    m, ncol = J.shape
    s2 = float(r @ r) / max(m - ncol, 1)
    blocks = r.reshape(len(channels), B, -1)
    fac = max(autocorrelation_factor(b) for b in blocks)
    JtJ = J.T @ J
    JtJ = JtJ.toarray() if sparse.issparse(JtJ) else np.asarray(JtJ)
    try:
        inv = np.linalg.inv(JtJ)
    except np.linalg.LinAlgError as exc:
        raise _singular(kind, free) from exc

    def sandwich() -> np.ndarray:
        # cluster-robust (sandwich) covariance with the windows as clusters: valid for any
        # correlation of the residuals within a window (disturbances, model error)
        A = sparse.csr_matrix((np.ones(m), (np.arange(m),
                                            np.tile(np.repeat(np.arange(B), W - 1),
                                                    len(channels)))), shape=(m, B))
        Jr = sparse.csr_matrix(J).multiply(r[:, None]).tocsr() if sparse.issparse(J) else (
            J * r[:, None])
        S = np.asarray((Jr.T @ A).todense()) if sparse.issparse(Jr) else Jr.T @ A.toarray()
        meat = S @ S.T
        return (inv @ meat @ inv)[:nf, :nf]

    cov, se, fac = _param_covariance(len(p0), free, inv[:nf, :nf], s2, fac, B, m, ncol,
                                     sandwich)
    p_hat, _ = unpack(res.x)
    return OEResult(params=p_hat, cov=cov, std_errors=se, names=names,
                    cost=float(res.cost), nfev=int(res.nfev), success=bool(res.success),
                    message=str(res.message), sigma=sigma, ac_factor=float(fac),
                    n_residuals=int(m), free=free,
                    dof=float(B - 1) if B >= MIN_CLUSTERS else math.inf)


def _refine_schur(kind, p0, win, channels, free, inames, sigma, lo, hi, x0, passes, max_iter,
                  unpack, resid, meas) -> OEResult:
    """Levenberg-Marquardt with the window initial states eliminated (Schur complement).

    Unknowns: model parameters theta (nf) and, per window b, its initial state s_b (ni). With
    G_b = d r_b / d theta and L_b = d r_b / d s_b (forward differences, grouped), the damped
    normal equations are solved by eliminating each s_b:
    S = A - sum_b B_b C_b^-1 B_b^T, A = sum G_b^T G_b, B_b = G_b^T L_b, C_b = L_b^T L_b.
    The theta block of the inverse normal matrix is S^-1 (used for the covariance); the
    cluster-robust score of window b is psi_b = G_b^T r_b - B_b C_b^-1 L_b^T r_b.
    """
    names = PARAM_NAMES[kind]
    nf = int(free.sum())
    ni = len(inames)
    B = win.batch_size
    C = len(channels)
    W1 = win.outputs[channels[0]].shape[1] - 1
    M = C * W1

    def rb(x, sig):  # residuals as (B, M)
        return resid(x, sig).reshape(C, B, W1).transpose(1, 0, 2).reshape(B, M)

    def jac(x, f0, sig):
        def fun(x1: np.ndarray) -> np.ndarray:
            return rb(x1, sig)

        G = _fd_params(fun, x, f0, nf, hi)
        L = np.empty((B, M, ni))
        for j, (df, h) in enumerate(_fd_states(fun, x, f0, nf, ni, B)):
            L[:, :, j] = df / h[:, None]
        return G, L

    def normal(G, L, f):
        A = np.einsum("bmi,bmj->ij", G, G)
        g = np.einsum("bmi,bm->i", G, f)
        Bm = np.einsum("bmi,bmk->bik", G, L)
        Cm = np.einsum("bmk,bml->bkl", L, L)
        h = np.einsum("bmk,bm->bk", L, f)
        return A, g, Bm, Cm, h

    def solve(A, g, Bm, Cm, h, mu):
        Ad = A + mu * np.diag(np.diag(A))
        if ni:
            Cd = Cm + mu * np.einsum("bkk->bk", Cm)[:, :, None] * np.eye(ni)[None]
            Ci = np.linalg.inv(Cd)
            BC = np.einsum("bik,bkl->bil", Bm, Ci)
            S = Ad - np.einsum("bil,bjl->ij", BC, Bm)
            rhs = -g + np.einsum("bil,bl->i", BC, h)
        else:
            S, rhs = Ad, -g
        dth = np.linalg.solve(S, rhs)
        if ni:
            ds = np.einsum("bkl,bl->bk", Ci, -h - np.einsum("bik,i->bk", Bm, dth))
            return np.concatenate([dth, ds.T.ravel()])
        return dth

    x = x0.copy()
    nfev = 0
    message = "maximum number of iterations reached"
    success = False
    for k in range(passes):
        f = rb(x, sigma)
        cost = 0.5 * float(np.sum(f * f))
        mu = 1e-3
        for _ in range(max_iter):
            G, L = jac(x, f, sigma)
            nfev += 1 + nf + ni
            A, g, Bm, Cm, h = normal(G, L, f)
            improved = False
            for _ in range(20):
                try:
                    dx = solve(A, g, Bm, Cm, h, mu)
                except np.linalg.LinAlgError:
                    mu *= 10
                    continue
                xn = x + dx
                if np.any(xn[:nf] <= lo[:nf]) or np.any(xn[:nf] > hi[:nf]):
                    mu *= 4
                    continue
                fn = rb(xn, sigma)
                nfev += 1
                cn = 0.5 * float(np.sum(fn * fn))
                if np.isfinite(cn) and cn < cost:
                    improved = True
                    break
                mu *= 4
            if not improved:
                message, success = "no further decrease of the cost", True
                break
            rel = (cost - cn) / max(cost, 1e-300)
            step = float(np.max(np.abs(dx[:nf]) / np.maximum(np.abs(x[:nf]), 1e-12)))
            x, f, cost = xn, fn, cn
            mu = max(mu / 3, 1e-12)
            if rel < 1e-10 or step < 1e-10:
                message, success = "converged (cost or step tolerance)", True
                break
        if k < passes - 1:
            sigma = _rms_sigma(kind, unpack, x, meas, channels)
    # covariance at the optimum (mu = 0)
    G, L = jac(x, f, sigma)
    A, g, Bm, Cm, h = normal(G, L, f)
    m = B * M
    ncol = nf + ni * B
    r = f.reshape(B, C, W1).transpose(1, 0, 2)  # (C, B, W1)
    s2 = float(np.sum(f * f)) / max(m - ncol, 1)
    try:
        if ni:
            Ci = np.linalg.inv(Cm)
            BC = np.einsum("bik,bkl->bil", Bm, Ci)
            S = A - np.einsum("bil,bjl->ij", BC, Bm)
            psi = np.einsum("bmi,bm->bi", G, f) - np.einsum("bil,bl->bi", BC, h)
        else:
            S = A
            psi = np.einsum("bmi,bm->bi", G, f)
        Sinv = np.linalg.inv(S)
    except np.linalg.LinAlgError as exc:
        raise _singular(kind, free) from exc
    fac = max(autocorrelation_factor(b) for b in r)
    cov, se, fac = _param_covariance(len(p0), free, Sinv, s2, fac, B, m, ncol,
                                     lambda: Sinv @ (psi.T @ psi) @ Sinv)
    p_hat, _ = unpack(x)
    return OEResult(params=p_hat, cov=cov, std_errors=se, names=names,
                    cost=float(0.5 * np.sum(f * f)), nfev=int(nfev), success=success,
                    message=message, sigma=sigma, ac_factor=float(fac), n_residuals=int(m),
                    free=free, dof=float(B - 1) if B >= MIN_CLUSTERS else math.inf)
