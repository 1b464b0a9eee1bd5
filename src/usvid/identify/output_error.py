"""Output-error refinement by multiple shooting, on the integration core.

The equation-error (least-squares) estimate is biased when the regressors are noisy (the yaw
rate appears on both sides). Output-error refinement minimises the difference between
*simulated* and *measured* outputs instead (heading and yaw rate; u and v too for kinds with
sway):

.. math:: \\min_p \\sum_w \\sum_k \\| W (y_{sim}(t_k; p, x_w) - y_{meas}(t_k)) \\|^2

Multiple shooting: every trial is cut into windows of ``window_s`` seconds (optional overlap),
each started from its own initial state (the kind's measured outputs: psi, r; or psi, r, u,
v), estimated together with the parameters from the smoothed measurement, so that a
course-unstable model (Norrbin n1 < 0, the KVLCC2) cannot drift away over a long record and
noisy initial states do not bias the estimate. The windows are lanes of the integration core
(:mod:`usvid.sim.replay`): the kind's own right-hand side, the measured inputs linear between
samples -- the same equations and input hold as every simulation of the identified model.
Parameters are fitted in the kind's fit space (``ModelKind.fit_space``: e.g. Norrbin's T = 1
normalisation, the inverse-mass coefficients of the Fossen kinds).

Solver: Levenberg-Marquardt on the normal equations with the window states eliminated window by
window (Schur complement, cost linear in the number of windows). Its Jacobian by forward
differences: every perturbed parameter set (one per parameter, one per initial state of all
windows) simulated in one call of the core, the windows of all sets as its lanes
(:meth:`OEProblem.simulate_sets`): full chunks of lanes on the kernel's threads instead of one
call per set. On large residuals (model error, correlated noise) Gauss-Newton converges only
linearly near the optimum, each iteration a Jacobian; two secant devices cut the Jacobians of
that tail (:func:`_refine_schur`): the structured secant approximation of the residuals'
second-order term added to the Gauss-Newton matrix (NL2SOL: Dennis, Gay & Welsch 1981), and
steps with the last Jacobian carried along by sparse Broyden updates (Broyden 1965; Schubert
1970; Dennis & Schnabel 1983, ch. 8 and 10), one simulation each, until a fresh
finite-difference Jacobian checks the stop. The stop and the covariance are always those of a
finite-difference Jacobian at the final point. Covariance from the Jacobian at
the optimum: with at least ``MIN_CLUSTERS`` windows the cluster-robust (sandwich) form with the
windows as clusters,

.. math:: \\mathrm{cov}(p) = S^{-1} \\Big(\\sum_w \\psi_w \\psi_w^T\\Big) S^{-1}
          \\frac{B}{B-1}\\frac{m-1}{m-k}

(S the parameter block of J^T J after eliminating the window states, psi_w the window's score),
valid for any residual correlation inside a window; intervals then use Student's t with B - 1
degrees of freedom. With fewer windows the Gauss-Newton form ``(J^T J)^-1 s^2 f_ac`` inflated
by the residual autocorrelation factor.

Units: time [s], angles [rad], yaw rate [rad/s], speeds [m/s].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.disturbance import Disturbance
from usvid.identify.ls import autocorrelation_factor, numerical_jacobian
from usvid.identify.metrics import rmse
from usvid.models.environment import WindLoadModel
from usvid.models.kind import Dynamics, ModelKind
from usvid.sim.layout import NENV, NWIND, STATE_CHANNELS
from usvid.sim.replay import Windows, window_initial_state, window_lanes
from usvid.sim.simulate import Lanes

#: Fewest windows for the cluster-robust covariance; below it the autocorrelation factor is used.
MIN_CLUSTERS = 8
_EPS_FD = 1.4901161193847656e-08  # sqrt(machine epsilon): forward-difference relative step
#: Residual (in units of the channel weight) given to samples after a lane diverged.
DIVERGED = 1e3
#: Most recorded values (sets x windows x samples x channels) of one core call of a Jacobian's
#: perturbed sets (2^24 float64: 128 MiB); more sets are simulated in several calls.
BATCH_VALUES = 2**24
#: The fit has converged when the undamped Gauss-Newton step from the current point moves every
#: parameter by less than this fraction of its standard error (the covariance the fit reports):
#: the optimizer's resolution. Near the optimum Gauss-Newton converges linearly (large
#: residuals), at a rate of about 0.6 per iteration on manoeuvring data, so the point is within
#: about 2.5 steps, 0.03 standard error, of the optimum; further iterations only move the
#: parameters inside their statistical noise. The Jacobian of the last point is the
#: covariance's.
SETTLED_SE = 0.01
#: The same for the first pass of a reweighted fit, whose optimum only sets the channel
#: weights (the residual RMS per channel, which a point 0.1 standard error from the optimum
#: changes by far less than its own sampling scatter).
SETTLED_SE_PASS = 0.1
#: The tail of a pass: after a step whose Gauss-Newton size was below this many standard
#: errors, the next points are found with the Jacobian carried along by secant updates (one
#: simulation a step, :func:`_refine_schur`) until its Gauss-Newton step is below
#: ``SECANT_STOP`` of the pass's tolerance (at most ``SECANT_MAX`` steps); then a
#: finite-difference Jacobian checks the stop and gives the covariance.
SECANT_SE = 0.3
SECANT_STOP = 0.5
SECANT_MAX = 10
#: Levenberg-Marquardt steps with the secant approximation of the residuals' second-order
#: term added to the Gauss-Newton matrix (NL2SOL's structured update, Dennis, Gay & Welsch
#: 1981) once a pass has two Jacobians; the plain step where that one does not decrease the cost.
STRUCTURED = True


@dataclass
class OEResult:
    """Result of :func:`refine_output_error`: fit-space parameters and their covariance, the
    kind's parameters (``params``, file names) with their covariance, diagnostics."""

    x: np.ndarray
    x_names: tuple[str, ...]
    x_cov: np.ndarray
    params: dict[str, float]
    cov: np.ndarray
    names: tuple[str, ...]
    cost: float
    nfev: int  # simulations of all windows (a Jacobian's perturbed sets counted one by one)
    success: bool
    message: str
    sigma: dict[str, float]
    ac_factor: float
    n_residuals: int
    dof: float = math.inf  # degrees of freedom of the interval quantile (clusters - 1)
    init: dict[str, np.ndarray] | None = None  # the windows' estimated initial states
    wind_scale: float | None = None  # the wind loads' multiplier (None: no wind simulated)
    wind_scale_se: float = 0.0       # its standard error (0: held)
    disturbance: Disturbance | None = None  # the per-trial current / bias in x (x_names)
    free_names: tuple[str, ...] = ()  # the fit-space names estimated (the rest held)
    #: each pass's optimum: (fit-space values x, the windows' initial states) (warm starts)
    pass_points: tuple[tuple[np.ndarray, dict[str, np.ndarray]], ...] = ()
    njac: int = 0  # finite-difference Jacobians computed
    #: each pass's last finite-difference Jacobian at its optimum: (G (B, M, free), L (B, M, ni),
    #: the channel weights) -- a warm fit's first approximation (None: not kept)
    pass_jacobians: tuple[tuple[np.ndarray, np.ndarray, dict[str, float]] | None, ...] = ()


class OEProblem:
    """A kind, its fixed particulars and measured windows: parameters -> simulated outputs.

    ``space``: the fit-space names, with ``to_params`` (fit values -> kind parameters) and
    ``held`` (fit names kept at their start values).
    """

    def __init__(self, kind: ModelKind, fixed: Mapping[str, Any], win: Windows,
                 channels: tuple[str, ...], wind: WindLoadModel | None = None,
                 fit_wind_scale: bool = True, disturbance: Disturbance | None = None) -> None:
        self.kind = kind
        self.fixed = dict(fixed)
        self.win = win
        self.channels = channels
        sp = kind.fit_space
        if sp is not None:
            self.names = sp.names
            self.held = sp.held
            self._to_params: Callable[[Mapping[str, float]], dict[str, float]] = sp.from_fit
            self._to_fit: Callable[[Mapping[str, float]], dict[str, float]] = sp.to_fit
        else:
            self.names = kind.dynamics.fit_names()
            self.held = ()
            self._to_params = dict
            self._to_fit = dict
        held_by = getattr(kind.dynamics, "held_names", None)  # e.g. the MMG twin variant's
        if held_by is not None:                                # sway coefficients
            self.held = tuple(self.held) + tuple(held_by(self.fixed))
        # the logged wind (windows with the series wind_x, wind_y): its loads inside the step,
        # times wind_scale, the last fit value (held at 1 unless fit_wind_scale)
        self.wind = wind if wind is not None and "wind_x" in win.inputs else None
        if self.wind is not None:
            self.names = (*self.names, "wind_scale")
            if not fit_wind_scale:
                self.held = (*self.held, "wind_scale")
        # the unlogged current / force biases per trial (usvid.identify.disturbance): the last
        # fit values, driving the core's current and force series of each window's trial
        self.disturbance = disturbance
        self._extra = ("wind_scale", *(disturbance.names if disturbance is not None else ()))
        if disturbance is not None:
            self.names = (*self.names, *disturbance.names)
        self.init_names = tuple(c for c in ("r", "psi", "u", "v", *STATE_CHANNELS)
                                if c in kind.outputs)
        self._lanes: Lanes | None = None  # the windows' lanes (simulate)
        self._tiles: dict[int, tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]] = {}
        self._models: dict[bytes, tuple[Dynamics, np.ndarray]] = {}  # (_model)
        # the model's fit values (x without the wind scale and disturbances) and, per
        # fit-space name, where it enters the packed rows alone (:meth:`_perturbed`)
        self._mpos = np.array([n not in self._extra for n in self.names])
        self._rows: dict[bytes, dict[int, tuple[int, float] | None]] = {}
        self._z0: dict[bytes, np.ndarray] = {}  # initial states by (model, init) (_initial)

    def fit_values(self, params: Mapping[str, float]) -> np.ndarray:
        f = dict(self._to_fit({k: v for k, v in params.items() if k not in self._extra}))
        f["wind_scale"] = float(params.get("wind_scale", 1.0))
        for n in self._extra[1:]:  # a disturbance starts at its given value, else none
            f[n] = float(params.get(n, 0.0))
        return np.array([f[n] for n in self.names], dtype=float)

    def params(self, x: np.ndarray) -> dict[str, float]:
        return self._to_params({n: v for n, v in zip(self.names, x, strict=True)
                                if n not in self._extra})

    def env_block(self, x: np.ndarray) -> np.ndarray | None:
        """The core's environment block (:data:`usvid.sim.layout.ENVBLOCK`) of the logged
        wind at the wind_scale of ``x``; None without wind."""
        if self.wind is None:
            return None
        blk = np.zeros((NENV, 1))
        blk[:NWIND, 0] = self.wind.packed(float(x[self.names.index("wind_scale")]))
        return blk

    def dynamics(self, params: Mapping[str, float]) -> Dynamics:
        return self.kind.dynamics(**{**self.fixed, **params})

    def _key(self, x: np.ndarray) -> bytes:
        """The model's key of fit-space values ``x``: its model values only (the wind scale
        and the disturbances do not change the parameter set)."""
        return np.asarray(x, dtype=float)[self._mpos].tobytes()

    def _model(self, x: np.ndarray) -> tuple[Dynamics, np.ndarray]:
        """The kind's parameter set of fit-space values ``x`` and its packed parameter rows,
        kept for the last few ``x`` (a Jacobian's initial-state sets and the step it was
        taken at share the model: built and validated once)."""
        key = self._key(x)
        hit = self._models.get(key)
        if hit is None:
            dyn = self.dynamics(self.params(x))
            speed = self.win.init.get("u", 1.0) if self.kind.constant_speed else 1.0
            hit = (dyn, self.kind.pack(dyn, speed))
            self._keep(key, hit)
        return hit

    def _keep(self, key: bytes, hit: tuple[Dynamics, np.ndarray]) -> None:
        if len(self._models) >= 4:
            old = next(iter(self._models))
            del self._models[old]
            self._rows.pop(old, None)
            for k in [k for k in self._z0 if k.startswith(old)]:
                del self._z0[k]
        self._models[key] = hit

    def _perturbed(self, x: np.ndarray) -> tuple[bytes, np.ndarray] | None:
        """The packed rows of ``x`` from those of a kept model that differs from it in one
        fit value which the kind places in one packed row alone (``ModelKind.packed_row``:
        a Jacobian's perturbed parameter, e.g. an MMG hull coefficient): that model's rows
        with the one row set, after the parameter's bounds check -- the same rows as building,
        validating and packing the set anew, without doing so. Returns (the kept model's key,
        the rows), or None (the set is built anew: no such kept model, a fit space other than
        the kind's own parameters, or the kind has no ``packed_row``)."""
        if self.kind.packed_row is None or self.kind.fit_space is not None:
            return None
        xm = np.asarray(x, dtype=float)[self._mpos]
        names = [n for n, m in zip(self.names, self._mpos, strict=True) if m]
        for key, (dyn, P) in self._models.items():
            d = np.flatnonzero(np.frombuffer(key) != xm)
            if len(d) != 1:
                continue
            j = int(d[0])
            rows = self._rows.setdefault(key, {})
            if j not in rows:
                rows[j] = self.kind.packed_row(dyn, names[j])
            where = rows[j]
            if where is None:
                return None
            spec = next(s for s in self.kind.dynamics.param_specs() if s.name == names[j])
            spec.check("parameters", float(xm[j]))
            out = P.copy()
            out[where[0]] = where[1] * float(xm[j])
            return key, out
        return None

    def _initial(self, key: bytes, dyn: Dynamics, init: Mapping[str, np.ndarray] | None
                 ) -> np.ndarray:
        """The windows' initial states (:func:`window_initial_state`) of the model ``key``
        and ``init``, kept while the model is (a Jacobian's perturbed parameter sets start
        from the same states; the kind's initial-state map does not read a parameter it
        places in a packed row alone)."""
        ik = key + b"|" + b"".join(k.encode() + np.asarray(v, float).tobytes()
                                   for k, v in sorted((init or {}).items()))
        z = self._z0.get(ik)
        if z is None:
            if len(self._z0) >= 64:
                self._z0.clear()
            z = self._z0[ik] = window_initial_state(self.kind, dyn, self.win, init)
        return z

    def simulate(self, x: np.ndarray, init: Mapping[str, np.ndarray] | None = None
                 ) -> dict[str, np.ndarray]:
        """Simulated outputs (B, W) of every window for fit-space values x.

        The windows' lanes (inputs, run lengths, servo rows) are built once; each call sets
        only the parameter rows and the initial states (of ``x``'s model and ``init``)."""
        dyn, P = self._model(x)
        base = self._lanes
        env = self.env_block(x)
        if base is None:
            base = self._lanes = window_lanes(self.kind, P, dyn, self.win, init=init,
                                              channels=self.channels, env_block=env)
            if self.disturbance is None:
                return base.run().channels
        lanes = replace(base, P=np.broadcast_to(P, (P.shape[0], base.size)),
                        Z0=window_initial_state(self.kind, dyn, self.win, init),
                        env_block=env)
        if self.disturbance is not None:
            lanes = replace(lanes, series={**base.series, **self.disturbance.series(
                x, self.names, self.win.trial_index, self.win.width)})
        return lanes.run().channels

    def simulate_sets(self, xs: Sequence[np.ndarray],
                      inits: Sequence[Mapping[str, np.ndarray] | None]
                      ) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Simulated outputs (K, B, W) of K fit-space sets ``xs`` with their window initial
        states ``inits``, every window of every set a lane of one call of the core (the
        windows' lanes repeated K times): the perturbed sets of a finite-difference Jacobian in
        one batch. Returns (outputs, ok (K,)); a set whose parameters or initial states are no
        valid model is not ok (its outputs are those of another set: not to be used).
        Lane for lane the same integration as :meth:`simulate`."""
        K = len(xs)
        if self._lanes is None:
            self.simulate(xs[0], inits[0])
        base = self._lanes
        assert base is not None
        B = base.size
        ok = np.ones(K, dtype=bool)
        Ps, Zs, envs = [], [], []
        for k, (x, init) in enumerate(zip(xs, inits, strict=True)):
            try:
                near = None if self._key(x) in self._models else self._perturbed(x)
                if near is not None:  # one packed row of a kept model changed
                    key, P = near
                    dyn = self._models[key][0]
                else:
                    key = self._key(x)
                    dyn, P = self._model(x)
                P = np.broadcast_to(P, (base.P.shape[0], B))
                Z0 = self._initial(key, dyn, init)
            except (UsvidError, ValueError, ZeroDivisionError):
                ok[k] = False
                P, Z0 = base.P, base.Z0
            Ps.append(P)
            Zs.append(Z0)
            env = self.env_block(x)
            envs.append(None if env is None else np.broadcast_to(env, (env.shape[0], B)))
        S, nsteps, series = self._tiled(K)
        if self.disturbance is not None:  # each set's own current / biases (as :meth:`simulate`)
            per = [self.disturbance.series(x, self.names, self.win.trial_index, self.win.width)
                   for x in xs]
            series = {**series, **{k: np.vstack([d[k] for d in per]) for k in per[0]}}
        lanes = replace(base, P=np.hstack(Ps), Z0=np.hstack(Zs), S=S, nsteps=nsteps,
                        series=series,
                        env_block=None if envs[0] is None else np.hstack(envs))
        out = lanes.run().channels
        return {c: v.reshape(K, B, -1) for c, v in out.items()}, ok

    def _tiled(self, K: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The windows' servo rows, run lengths and input series repeated for K sets (kept:
        the Jacobians of a fit have one or two group sizes)."""
        if K not in self._tiles:
            base = self._lanes
            assert base is not None
            series = {k: (v if v.shape[0] == 1 else np.tile(v, (K, 1)))
                      for k, v in base.series.items()}
            self._tiles[K] = (np.tile(base.S, (1, K)), np.tile(base.nsteps, K), series)
        return self._tiles[K]


def _bad_start(kind: ModelKind, exc: Exception) -> IdentificationError:
    return IdentificationError(f"output-error fit of {kind.name}: the start parameters are not "
                               f"a valid model ({exc})")


def _fd_points(x: np.ndarray, nf: int, ni: int, B: int, hi: np.ndarray
               ) -> tuple[list[np.ndarray], np.ndarray, list[np.ndarray]]:
    """The perturbed unknowns of a forward-difference Jacobian: each of the first ``nf``
    (model parameters) alone, relative step sqrt(eps), taken backwards at an upper bound
    ``hi``; then, grouped, each of the ``ni`` window initial states of all ``B`` windows at
    once (a window's state moves only its own residuals). Returns (points, the parameters'
    steps (nf,), the states' steps: ni arrays (B,))."""
    pts: list[np.ndarray] = []
    hp = np.empty(nf)
    for j in range(nf):
        h = _EPS_FD * max(1.0, abs(x[j]))
        if x[j] + h > hi[j]:
            h = -h
        x1 = x.copy()
        x1[j] += h
        pts.append(x1)
        hp[j] = h
    hs = []
    for j in range(ni):
        sl = slice(nf + j * B, nf + (j + 1) * B)
        h = _EPS_FD * np.maximum(1.0, np.abs(x[sl]))
        x1 = x.copy()
        x1[sl] += h
        pts.append(x1)
        hs.append(h)
    return pts, hp, hs


def fd_jacobian(funs: Callable[[list[np.ndarray]], list[np.ndarray]], x: np.ndarray,
                f0: np.ndarray, nf: int, ni: int, hi: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Forward-difference Jacobian of the residuals (B, M) (``f0`` at ``x``) of the multiple-
    shooting problem: ``G`` (B, M, nf) with respect to the model parameters (the first ``nf``
    unknowns) and ``L`` (B, M, ni) with respect to each window's initial states (the next
    ``ni`` blocks of B). ``funs`` maps all the perturbed points (:func:`_fd_points`) to their
    residuals at once -- one batch of the core for output error -- so the steps and the
    differences are those of one simulation per point."""
    B, M = f0.shape
    pts, hp, hs = _fd_points(x, nf, ni, B, hi)
    F = funs(pts)
    G = np.empty((B, M, nf))
    for j in range(nf):
        G[..., j] = (F[j] - f0) / hp[j]
    L = np.empty((B, M, ni))
    for j in range(ni):
        L[:, :, j] = (F[nf + j] - f0) / hs[j][:, None]
    return G, L


def _singular(kind: str, names: tuple[str, ...]) -> IdentificationError:
    """The error of a singular Jacobian at the optimum, naming the free parameters."""
    return IdentificationError(
        f"output-error fit of {kind}: singular Jacobian (parameters {', '.join(names)} not "
        "separately identifiable from these data)")


def refine_output_error(kind: ModelKind, start: Mapping[str, float], fixed: Mapping[str, Any],
                        win: Windows, *, channels: tuple[str, ...] | None = None,
                        max_iter: int = 100, estimate_initial: bool = True,
                        reweight: bool = True, wind: WindLoadModel | None = None,
                        fit_wind_scale: bool = True,
                        disturbance: Disturbance | None = None,
                        warm: OEResult | None = None) -> OEResult:
    """Minimise weighted simulated-minus-measured outputs over all windows (multiple shooting).

    Parameters
    ----------
    kind : ModelKind
        The model kind (its right-hand side, fit space and outputs).
    start : mapping
        Starting parameters (the equation-error estimate), SI units, the kind's names.
    fixed : mapping
        The kind's particulars held fixed (thrust law, lever arm, nominal inputs, ...).
    win : Windows
        Measured windows (:func:`usvid.sim.replay.make_windows`).
    channels : tuple of str
        Outputs compared (default the kind's ``outputs``).
    estimate_initial : bool
        Estimate each window's initial state (the kind's outputs) with the parameters, from the
        smoothed measurement (true multiple shooting: noisy initial states do not bias the
        estimate and the intervals account for them).
    reweight : bool
        Two passes, the second weighting each channel by the inverse RMS of its first-pass
        residual (heading [rad] and yaw rate [rad/s] count by their own error level).
    wind : WindLoadModel, optional
        The wind-load model of the logged wind (windows with ``wind_x``, ``wind_y``): the
        windows are simulated in that wind, its ``wind_scale`` [-] estimated with the parameters
        (``fit_wind_scale``, start ``start["wind_scale"]`` or 1) or held at the start value.
    disturbance : Disturbance, optional
        A constant current and/or sway-force and yaw-moment bias per trial
        (:mod:`usvid.identify.disturbance`), estimated with the parameters (start
        ``start[name]`` or 0); their values and covariance are in ``x``/``x_cov``.
    warm : OEResult, optional
        An earlier fit of the same windows (the same fit space) to start from: each pass
        starts from that fit's optimum of the pass (its ``pass_points``: the free parameters
        and the windows' initial states; the parameters this fit holds keep their ``start``
        values), or from the previous pass's optimum when that costs less. E.g. the fit again
        with a parameter held at its neutral value (the estimator's insignificance rule): the
        same optimum to the solver's resolution (:data:`SETTLED_SE`) in a few iterations
        instead of the whole descent from the equation-error start.

    Returns
    -------
    OEResult: parameters (the kind's names) with covariance, fit-space values, diagnostics.
    """
    channels = tuple(channels) if channels is not None else tuple(
        c for c in ("psi", "r", "u", "v", *STATE_CHANNELS) if c in kind.outputs)
    prob = OEProblem(kind, fixed, win, channels, wind, fit_wind_scale, disturbance)
    try:
        x_all = prob.fit_values(start)
        prob.dynamics({k: v for k, v in start.items() if k not in prob._extra})
    except (UsvidError, ValueError, ZeroDivisionError) as exc:
        raise _bad_start(kind, exc) from None
    free = np.array([n not in prob.held for n in prob.names])
    nf = int(free.sum())
    meas = {c: win.outputs[c] for c in channels}
    B, W = meas[channels[0]].shape
    sigma = {}
    for c in channels:  # first pass: sample-to-sample scatter as a noise-level proxy
        sc = float(np.std(np.diff(meas[c], axis=1)))
        sigma[c] = max(sc, 1e-3 * float(np.std(meas[c])), 1e-9)
    inames = prob.init_names if estimate_initial else ()
    init0 = {k: np.asarray(win.init[k], float).copy() for k in prob.init_names}
    lo = np.full(nf, -np.inf)
    hi = np.full(nf, np.inf)
    free_names = list(np.array(prob.names)[free])
    if kind.fit_space is None:  # the kind's own parameters: steps never leave their bounds
        specs = {p.name: p for p in kind.dynamics.param_specs()}
        for j, n in enumerate(free_names):
            sp = specs.get(n)
            if sp is not None:
                lo[j] = max(v for v in (sp.ge, sp.gt, -np.inf) if v is not None)
                hi[j] = min(v for v in (sp.le, sp.lt, np.inf) if v is not None)
    if "wind_scale" in free_names:
        lo[free_names.index("wind_scale")] = 0.0  # a load never turned against the wind

    def unpack(x: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        xa = x_all.copy()
        xa[free] = x[:nf]
        init = {k: x[nf + j * B: nf + (j + 1) * B] for j, k in enumerate(inames)}
        return xa, init

    def errors(sim: Mapping[str, np.ndarray], sig: dict[str, float]) -> np.ndarray:
        out = []
        for c in channels:
            e = ((sim[c] - meas[c]) / sig[c])[:, 1:]
            out.append(np.where(np.isfinite(e), e, DIVERGED).ravel())
        return np.concatenate(out)

    def resid(x: np.ndarray, sig: dict[str, float]) -> np.ndarray:
        xa, init = unpack(x)
        try:
            sim = prob.simulate(xa, init)
        except (UsvidError, ValueError, ZeroDivisionError):
            return np.full(len(channels) * B * (W - 1), DIVERGED)
        return errors(sim, sig)

    per = max(1, BATCH_VALUES // (B * W * len(channels)))  # sets per core call

    def resid_many(xs: list[np.ndarray], sig: dict[str, float]) -> list[np.ndarray]:
        """:func:`resid` of each of ``xs``, the sets simulated together (a Jacobian's points:
        ``per`` sets of windows as the lanes of one core call)."""
        out = []
        for g in range(0, len(xs), per):
            grp = [unpack(x) for x in xs[g:g + per]]
            try:
                sims, ok = prob.simulate_sets([u[0] for u in grp], [u[1] for u in grp])
            except (UsvidError, ValueError, ZeroDivisionError):  # decided set by set
                out += [resid(x, sig) for x in xs[g:g + per]]
                continue
            for k in range(len(grp)):
                out.append(errors({c: sims[c][k] for c in channels}, sig) if ok[k] else
                           np.full(len(channels) * B * (W - 1), DIVERGED))
        return out

    def rms_sigma(x: np.ndarray) -> dict[str, float]:
        xa, init = unpack(x)
        try:
            sim = prob.simulate(xa, init)
        except (UsvidError, ValueError, ZeroDivisionError) as exc:
            raise _bad_start(kind, exc) from None
        return {c: max(rmse(meas[c][:, 1:], np.nan_to_num(sim[c][:, 1:])), 1e-12)
                for c in channels}

    m = B * len(channels) * (W - 1)
    ncol = nf + len(inames) * B

    def cov_of(Sinv: np.ndarray, psi_w: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, float]:
        """Covariance of the free fit-space parameters (and the inflation factor) from
        S^-1, the window scores and the residuals (B, M) (:func:`_param_covariance`)."""
        s2 = float(np.sum(f * f)) / max(m - ncol, 1)
        fac = 1.0  # (the sandwich covariance reports its own factor)
        if B < MIN_CLUSTERS:
            r = f.reshape(B, len(channels), W - 1).transpose(1, 0, 2)
            fac = max(autocorrelation_factor(b) for b in r)
        return _param_covariance(Sinv, s2, fac, B, m, ncol,
                                 lambda: Sinv @ (psi_w.T @ psi_w) @ Sinv)

    x0 = np.concatenate([x_all[free]] + [init0[k] for k in inames])
    starts = _warm_starts(warm, prob, x_all, free, inames, B)
    guesses: list = []  # the warm fit's Jacobians of its pass optima, this fit's columns
    if starts:
        x0 = starts[0]
        assert warm is not None
        if set(free_names) <= set(warm.free_names):
            cols = [list(warm.free_names).index(n) for n in free_names]
            guesses = [None if pj is None or pj[1].shape[2] != len(inames) else
                       (pj[0][:, :, cols], pj[1], pj[2]) for pj in warm.pass_jacobians]
    xs, cost, nfev, njac, success, message, sig, Sinv, psi_w, f, ends, jacs = _refine_schur(
        resid, resid_many, x0, nf, len(inames), B, len(channels), W - 1, sigma, lo, hi,
        2 if reweight else 1, max_iter, rms_sigma, kind.name, tuple(np.array(prob.names)[free]),
        lambda Si, ps, ff: cov_of(Si, ps, ff)[0], starts, guesses)
    cov_x, fac = cov_of(Sinv, psi_w, f)
    xa, init = unpack(xs)
    covx_full = np.zeros((len(x_all), len(x_all)))
    covx_full[np.ix_(free, free)] = cov_x
    params = prob.params(xa)
    pnames = tuple(n for n in kind.dynamics.fit_names() if n in params)

    def to_vec(x: np.ndarray) -> np.ndarray:
        p = prob.params(x)
        return np.array([p[n] for n in pnames], dtype=float)

    try:
        G = numerical_jacobian(to_vec, xa)
        cov_p = G @ covx_full @ G.T
    except (IdentificationError, UsvidError, ZeroDivisionError, ValueError):
        cov_p = np.full((len(pnames), len(pnames)), np.nan)
    ws, ws_se = None, 0.0
    if prob.wind is not None:
        j = prob.names.index("wind_scale")
        ws, ws_se = float(xa[j]), float(math.sqrt(max(covx_full[j, j], 0.0)))
    return OEResult(x=xa, x_names=prob.names, x_cov=covx_full,
                    params={n: float(params[n]) for n in pnames}, cov=cov_p, names=pnames,
                    cost=float(cost), nfev=int(nfev), njac=int(njac), success=bool(success),
                    message=message,
                    sigma=sig, ac_factor=float(fac), n_residuals=int(m),
                    dof=float(B - 1) if B >= MIN_CLUSTERS else math.inf,
                    init={k: np.asarray(v).copy() for k, v in init.items()},
                    wind_scale=ws, wind_scale_se=ws_se, disturbance=disturbance,
                    free_names=tuple(free_names),
                    pass_points=tuple(unpack(e) for e in ends), pass_jacobians=jacs)


def _warm_starts(warm: OEResult | None, prob: OEProblem, x_all: np.ndarray, free: np.ndarray,
                 inames: Sequence[str], B: int) -> list[np.ndarray]:
    """The unknowns (free fit values, then each initial state of all ``B`` windows) each pass
    starts from, from the pass optima of ``warm`` (:func:`refine_output_error`); the held fit
    values are those of ``x_all``. [] without a usable warm fit (another fit space, windows or
    initial states, or a point that is no valid model: a cold start)."""
    if warm is None or tuple(warm.x_names) != tuple(prob.names) or not warm.pass_points:
        return []
    out = []
    for xw, init in warm.pass_points:
        xa = np.where(free, xw, x_all)
        if any(k not in init or np.shape(init[k]) != (B,) for k in inames):
            return []
        try:
            prob.dynamics(prob.params(xa))
        except (UsvidError, ValueError, ZeroDivisionError):
            return []
        out.append(np.concatenate([xa[free]] + [np.asarray(init[k], float) for k in inames]))
    return out


def _param_covariance(Sinv: np.ndarray, s2: float, fac: float, B: int, m: int, ncol: int,
                      sandwich: Callable[[], np.ndarray]) -> tuple[np.ndarray, float]:
    """Covariance of the free fit-space parameters and the reported inflation factor.

    With ``B >= MIN_CLUSTERS`` windows the cluster-robust sandwich times
    ``B/(B-1) (m-1)/(m-ncol)`` (the factor then is its mean ratio to the white-noise
    covariance), else ``Sinv s2 fac``.
    """
    if B >= MIN_CLUSTERS:
        corr = B / (B - 1) * (m - 1) / max(m - ncol, 1)
        cov = sandwich() * corr
        with np.errstate(over="ignore", invalid="ignore"):
            fac = float(np.mean(np.diag(cov) / np.maximum(np.diag(Sinv) * s2, 1e-300)))
        return cov, fac
    return Sinv * s2 * fac, fac


def _refine_schur(resid, resid_many, x0, nf, ni, B, C, W1, sigma, lo, hi, passes, max_iter,
                  rms_sigma, kind_name, free_names, cov_of, starts=(), guesses=()):
    """Levenberg-Marquardt with the window initial states eliminated (Schur complement).

    Unknowns: model parameters theta (nf) and, per window b, its initial state s_b (ni). With
    G_b = d r_b / d theta and L_b = d r_b / d s_b (forward differences, grouped: one perturbed
    set per parameter and one per initial state, all windows at once; all the sets' windows
    the lanes of one core call, :func:`fd_jacobian`), the damped normal equations
    are solved by eliminating each s_b: S = A - sum_b B_b C_b^-1 B_b^T, A = sum G_b^T G_b,
    B_b = G_b^T L_b, C_b = L_b^T L_b. The theta block of the inverse normal matrix is S^-1 (the
    covariance); the cluster-robust score of window b is psi_b = G_b^T r_b - B_b C_b^-1 L_b^T r_b.
    A pass stops when the undamped Gauss-Newton step from the current point is below
    :data:`SETTLED_SE` (:data:`SETTLED_SE_PASS` before the last pass) of every parameter's
    standard error (``cov_of(S^-1, psi, residuals)``); that point's Jacobian gives the
    covariance. ``starts``: each pass's warm start (:func:`_warm_starts`), taken when it costs
    less than the previous pass's optimum.

    The tail (large residuals: Gauss-Newton converges linearly, about 0.6 per iteration on
    manoeuvring data, one Jacobian of 1 + nf + ni simulations an iteration):

    * Structured step (NL2SOL; Dennis, Gay & Welsch 1981; Dennis & Schnabel 1983, sec. 10.3):
      from two successive Jacobians of a pass, A approximates the second-order term
      sum_i r_i nabla^2 r_i of the Hessian by their secant update (``structured``: y# =
      (J - Jo)^T r, sized, rank two a step), and the Levenberg-Marquardt step of
      J^T J + A is tried first whenever that model predicted the cost at the new point
      better than Gauss-Newton's (their model switch); the plain step where it does not
      lower the cost.
    * Secant tail: once the Gauss-Newton step is below ``SECANT_SE`` standard errors, the
      next points come from the last Jacobian updated by the sparse Broyden update
      (Broyden 1965; Schubert 1970; Dennis & Schnabel 1983, sec. 11.3: window b's rows
      J_b = [G_b, L_b] satisfy the secant equation J_b p_b = r_b(x + p) - r_b(x) of the step
      restricted to the unknowns they depend on, the parameters and window b's initial states,
      in the norm scaled by the Jacobian's column norms), one simulation a step, until its
      Gauss-Newton step is below ``SECANT_STOP`` of the tolerance; then a finite-difference
      Jacobian at that point decides the stop as above (else the iteration continues from it).
    * Between passes the point is the same and only the channel weights change: the last
      Jacobian, rescaled by the ratio of the weights, is the next pass's first.
    * A warm fit (``guesses``: the fit again with a parameter held, from the earlier fit's
      pass optima) starts each pass with secant steps from the earlier fit's Jacobian at that
      optimum (its held parameter's column dropped, rescaled to this pass's weights).

    So the fixed point (the stop) and the covariance are those of a finite-difference
    Jacobian at the final point.
    ``guesses``: per pass, the Jacobian (G, L, its channel weights) of the warm fit at its
    optimum of the pass (another point: that fit's held parameters differ), the first
    approximation of the secant steps from the pass's warm start.
    Returns (x, cost, nfev, Jacobians, success, message, sigma, S^-1, psi, residuals (B, M),
    each pass's optimum, each pass's last Jacobian (G, L, weights) at its optimum or None).
    """
    M = C * W1

    def by_window(r):  # residuals (C, B, W1) flat -> (B, M)
        return r.reshape(C, B, W1).transpose(1, 0, 2).reshape(B, M)

    def rb(x, sig):
        return by_window(resid(x, sig))

    def jac(x, f0, sig):
        return fd_jacobian(lambda xs: [by_window(r) for r in resid_many(xs, sig)], x, f0, nf,
                           ni, hi)

    def normal(G, L, f):
        # window by window (stacked matrix products: a fifth of einsum's time on (B, M, nf)
        # Jacobians; one product over all windows goes to the threaded BLAS, slower here)
        Gt, Lt = G.transpose(0, 2, 1), L.transpose(0, 2, 1)
        A = np.matmul(Gt, G).sum(axis=0)
        g = np.matmul(Gt, f[:, :, None]).sum(axis=0)[:, 0]
        Bm = np.matmul(Gt, L)
        Cm = np.matmul(Lt, L)
        h = np.matmul(Lt, f[:, :, None])[:, :, 0]
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

    def gauss_newton(G, L, f, A, g, Bm, Cm, h):
        """The undamped Gauss-Newton step of the parameters, S^-1 and the window scores."""
        if ni:
            Ci = np.linalg.inv(Cm)
            BC = np.einsum("bik,bkl->bil", Bm, Ci)
            S = A - np.einsum("bil,bjl->ij", BC, Bm)
            psi = np.matmul(G.transpose(0, 2, 1), f[:, :, None])[:, :, 0] \
                - np.einsum("bil,bl->bi", BC, h)
            rhs = -g + np.einsum("bil,bl->i", BC, h)
        else:
            S = A
            psi = np.matmul(G.transpose(0, 2, 1), f[:, :, None])[:, :, 0]
            rhs = -g
        Sinv = np.linalg.inv(S)
        return Sinv @ rhs, Sinv, psi

    def settled(G, L, f, normal_eq, tol):
        """((S^-1, psi) at x when the Gauss-Newton step from x moves every parameter by less
        than ``tol`` of its standard error (``cov_of``), else None; the largest step in
        standard errors; the standard errors)."""
        try:
            dth, Sinv, psi = gauss_newton(G, L, f, *normal_eq)
            se = np.sqrt(np.maximum(np.diag(cov_of(Sinv, psi, f)), 0.0))
        except np.linalg.LinAlgError:
            return None, math.inf, None
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = float(np.max(np.abs(dth) / se)) if np.all(np.isfinite(dth)) else math.inf
        if np.all(np.isfinite(dth)) and np.all(np.abs(dth) < tol * se):
            return (Sinv, psi), ratio, se
        return None, ratio, se

    def lm_step(x, f, cost, normal_eq, mu, tries):
        """One Levenberg-Marquardt step from x (at most ``tries`` trial points, the damping
        raised after each rejected one): (x, f, cost, mu, simulations, improved)."""
        n = 0
        for _ in range(tries):
            try:
                dx = solve(*normal_eq, mu)
            except np.linalg.LinAlgError:
                mu *= 10
                continue
            xn = x + dx
            if np.any(xn[:nf] <= lo) or np.any(xn[:nf] > hi):
                mu *= 4
                continue
            fn = rb(xn, sigma)
            n += 1
            cn = 0.5 * float(np.sum(fn * fn))
            if np.isfinite(cn) and cn < cost:
                return xn, fn, cn, mu, n, True
            mu *= 4
        return x, f, cost, mu, n, False

    def secant(G, L, dx, df, DG, DL):
        """The Jacobian (G, L) updated by the sparse Broyden (Schubert 1970) update of each
        window's rows to satisfy the secant equation J_b p_b = df_b of the step ``dx``
        (p_b its parameter part and window b's initial states, the only unknowns window b's
        residuals depend on), in the scaled norm of the column norms (DG, DL)."""
        dth = dx[:nf]
        ds = dx[nf:].reshape(ni, B).T  # (B, ni)
        err = df - np.matmul(G, dth) - np.matmul(L, ds[:, :, None])[:, :, 0]
        wth = DG * DG * dth
        ws = DL * DL * ds
        den = float(dth @ wth) + np.sum(ds * ws, axis=1)  # (B,)
        den = np.where(den > 0, den, np.inf)
        e = err / den[:, None]
        return G + e[:, :, None] * wth, L + e[:, :, None] * ws[:, None, :]

    def secant_tail(G, L, x, f, cost, dx, df, se, tol, mu):  # dx None: (G, L) is at x
        """The tail of a pass by secant iterations: the last finite-difference Jacobian
        (G, L) carried along the steps by :func:`secant` updates, each iteration one
        simulation instead of a Jacobian's 1 + nf + ni, until its Gauss-Newton step is below
        SECANT_STOP ``tol`` of the standard errors ``se`` (or no step decreases the cost, or
        SECANT_MAX iterations). Returns (x, f, cost, mu, simulations)."""
        DG = np.sqrt(np.sum(G * G, axis=(0, 1)))
        DL = np.sqrt(np.sum(L * L, axis=1))
        n = 0
        for _ in range(SECANT_MAX):
            if dx is not None:
                G, L = secant(G, L, dx, df, DG, DL)
            neq = normal(G, L, f)
            try:
                dth = gauss_newton(G, L, f, *neq)[0]
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(dth)) or np.all(np.abs(dth) < SECANT_STOP * tol * se):
                break
            xn, fn, cn, mu, used, improved = lm_step(x, f, cost, neq, mu, 4)
            n += used
            if not improved:
                break
            dx, df = xn - x, fn - f
            x, f, cost = xn, fn, cn
            mu = max(mu / 3, 1e-12)
        return x, f, cost, mu, n

    def gradient(neq):
        """J^T r of all unknowns (parameters, then each initial state of all windows)."""
        return np.concatenate([neq[1], neq[4].T.ravel()])

    def structured(aug, xo, Go, Lo, go, x, G, L, grad, f):
        """The secant approximation ``aug`` = (U, M), U M U^T, of the residuals' second-order
        term sum_i r_i nabla^2 r_i updated from the Jacobians at xo and x (Dennis, Gay &
        Welsch 1981, eq. 2.6, with their sizing factor): s = x - xo, y = J^T r - Jo^T ro,
        y# = (J - Jo)^T r, A <- tau A + (v y^T + y v^T)/(y^T s) - (v^T s) y y^T/(y^T s)^2,
        v = y# - tau A s; kept when y^T s > 0. A rank-two term a step, so kept low rank."""
        sx = x - xo
        y = grad - go
        ys = float(y @ sx)
        if not ys > 0:
            return aug
        ysh = np.concatenate([np.einsum("bmi,bm->i", G - Go, f),
                              np.einsum("bmi,bm->bi", L - Lo, f).T.ravel()])
        if aug is None:
            U, Mc = np.zeros((len(x), 0)), np.zeros((0, 0))
        else:
            U, Mc = aug
            Us = U.T @ sx
            sAs = float(Us @ Mc @ Us)
            if sAs != 0:
                Mc = Mc * min(1.0, abs(float(sx @ ysh)) / abs(sAs))
        v = ysh - U @ (Mc @ (U.T @ sx))
        r = Mc.shape[0]
        Mn = np.zeros((r + 2, r + 2))
        Mn[:r, :r] = Mc
        Mn[r, r + 1] = Mn[r + 1, r] = 1.0 / ys
        Mn[r + 1, r + 1] = -float(v @ sx) / ys ** 2
        return np.column_stack([U, v, y]), Mn

    def better_model(prev, x, cost, aug):
        """Whether the augmented model (Gauss-Newton plus ``aug``) predicted the cost at x
        from the previous Jacobian's point better than the Gauss-Newton model (the model
        switch of Dennis, Gay & Welsch 1981, judged on the displacement since that point)."""
        xo, Go, Lo, go, co = prev
        sx = x - xo
        Js = np.matmul(Go, sx[:nf]) + np.matmul(Lo, sx[nf:].reshape(ni, B).T[:, :, None])[:, :, 0]
        gn = co + float(go @ sx) + 0.5 * float(np.sum(Js * Js))
        Us = aug[0].T @ sx
        return abs(gn + 0.5 * float(Us @ aug[1] @ Us) - cost) < abs(gn - cost)

    def aug_step(x, f, cost, neq, aug, mu):
        """The damped step of the Gauss-Newton normal matrix plus ``aug`` (Woodbury:
        (K + U M U^T)^-1 = K^-1 - K^-1 U M (I + U^T K^-1 U M)^-1 U^T K^-1, K the damped
        normal matrix, solved window by window as :func:`solve`); tried once: (x, f, cost,
        simulations, improved)."""
        A, g, Bm, Cm, h = neq
        U, Mc = aug

        def k_inv(col):  # K^-1 col
            return -solve(A, col[:nf], Bm, Cm, col[nf:].reshape(ni, B).T, mu)

        try:
            d0 = solve(A, g, Bm, Cm, h, mu)  # K^-1 (-J^T r)
            KU = np.column_stack([k_inv(U[:, j]) for j in range(U.shape[1])])
            core = np.eye(U.shape[1]) + U.T @ KU @ Mc
            dx = d0 - KU @ (Mc @ np.linalg.solve(core, U.T @ d0))
        except np.linalg.LinAlgError:
            return x, f, cost, 0, False
        xn = x + dx
        if not np.all(np.isfinite(dx)) or np.any(xn[:nf] <= lo) or np.any(xn[:nf] > hi):
            return x, f, cost, 0, False
        fn = rb(xn, sigma)
        cn = 0.5 * float(np.sum(fn * fn))
        if np.isfinite(cn) and cn < cost:
            return xn, fn, cn, 1, True
        return x, f, cost, 1, False

    x = x0.copy()
    nfev = njac = 0
    message = "maximum number of iterations reached"
    success = False
    at_x = None  # the Jacobian at x with the last pass's weights (G, L, normal equations)
    done = None  # (S^-1, psi) at x when the last pass settled
    carried = None  # the previous pass's Jacobian at x, reweighted (G, L)
    ends = []  # each pass's optimum
    jacs = []  # each pass's last Jacobian at its optimum
    for k in range(passes):
        last = k == passes - 1
        tol = SETTLED_SE if last else SETTLED_SE_PASS
        f = rb(x, sigma)
        cost = 0.5 * float(np.sum(f * f))
        if 0 < k < len(starts):  # a warm start of this pass, where it costs less
            fw = rb(starts[k], sigma)
            cw = 0.5 * float(np.sum(fw * fw))
            if np.isfinite(cw) and cw < cost:
                x, f, cost = starts[k].copy(), fw, cw
                carried = None
        mu = 1e-3
        aug = prev = None
        if k < len(guesses) and guesses[k] is not None and k < len(starts) \
                and np.array_equal(x, starts[k]):  # the warm fit's Jacobian: secant steps
            Gw, Lw, sw = guesses[k]
        else:
            Gw = sw = None
        if sw is not None and set(sw) == set(sigma) and Gw.shape[:2] == (B, C * W1):
            sc = np.repeat([sw[c] / sigma[c] for c in sigma], W1)[None, :, None]
            Gw, Lw = Gw * sc, Lw * sc
            _, _, se = settled(Gw, Lw, f, normal(Gw, Lw, f), tol)
            if se is not None and np.all(se > 0):
                x, f, cost, mu, used = secant_tail(Gw, Lw, x, f, cost, None, None, se, tol, mu)
                nfev += used
        for _ in range(max_iter):
            if carried is not None:
                (G, L), carried = carried, None
            else:
                G, L = jac(x, f, sigma)
                nfev += 1 + nf + ni
                njac += 1
            A, g, Bm, Cm, h = normal(G, L, f)
            at_x = (G, L, (A, g, Bm, Cm, h))
            done, ratio, se = settled(G, L, f, at_x[2], tol)
            if done is not None:
                message, success = ("converged (the Gauss-Newton step below "
                                    f"{tol:g} standard error of every parameter)"), True
                break
            # the structured (NL2SOL) step first, once two Jacobians of the pass give the
            # second-order term's secant approximation; Levenberg-Marquardt where it fails
            improved = use_aug = False
            grad = gradient(at_x[2])
            if prev is not None:
                aug = structured(aug, *prev[:4], x, G, L, grad, f)
                use_aug = aug is not None and better_model(prev, x, cost, aug)
            prev = (x, G, L, grad, cost)
            if use_aug and STRUCTURED:
                xn, fn, cn, used, improved = aug_step(x, f, cost, at_x[2], aug, mu)
                nfev += used
            if not improved:
                xn, fn, cn, mu, used, improved = lm_step(x, f, cost, at_x[2], mu, 20)
                nfev += used
            if not improved:  # x unchanged: its Jacobian stays valid
                message, success = "no further decrease of the cost", True
                break
            rel = (cost - cn) / max(cost, 1e-300)
            dx = xn - x
            step = float(np.max(np.abs(dx[:nf]) / np.maximum(np.abs(x[:nf]), 1e-12)))
            df = fn - f
            x, f, cost = xn, fn, cn
            at_x = done = None
            mu = max(mu / 3, 1e-12)
            if rel < 1e-10 or step < 1e-10:
                message, success = "converged (cost or step tolerance)", True
                break
            if ratio < SECANT_SE and se is not None:  # the tail: secant steps, then check
                x, f, cost, mu, used = secant_tail(G, L, x, f, cost, dx, df, se, tol, mu)
                nfev += used
        ends.append(x.copy())
        jacs.append(None if at_x is None else (at_x[0], at_x[1], dict(sigma)))
        if not last:
            new = rms_sigma(x)
            if at_x is not None:  # x's Jacobian: the residuals' weights change, not the point
                sc = np.repeat([sigma[c] / new[c] for c in sigma], W1)[None, :, None]
                carried = (at_x[0] * sc, at_x[1] * sc)
            sigma = new
            at_x = done = None
    if done is None:
        if at_x is None:
            G, L = jac(x, f, sigma)
            njac += 1
            at_x = (G, L, normal(G, L, f))
        G, L, normal_eq = at_x
        try:
            _, Sinv, psi = gauss_newton(G, L, f, *normal_eq)
        except np.linalg.LinAlgError as exc:
            raise _singular(kind_name, free_names) from exc
        done = Sinv, psi
    return (x, 0.5 * float(np.sum(f * f)), nfev, njac, success, message, sigma, *done, f,
            ends, jacs)
