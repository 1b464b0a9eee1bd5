"""One estimator contract for every model kind: :class:`ModelEstimator` and :func:`identify`.

scikit-learn style (STYLE.md): hyper-parameters in ``__init__``; :meth:`ModelEstimator.fit` takes
one or many :class:`usvid.Trial` and returns ``self``; learned attributes end in ``_``
(``params_``, ``std_errors_``, ``ci95_``, ``cov_``, ``fit_``, ``model_``, ``result_``);
:meth:`~ModelEstimator.simulate` replays a trial's inputs on the identified model,
:meth:`~ModelEstimator.score` gives fit metrics on other trials, :meth:`~ModelEstimator.to_dict`
is exactly the model file (ARCHITECTURE.md schema plus ``identification``).

Methods
-------
``"ls"``   batch least squares on the regressors of :mod:`usvid.identify.regressors` (seed 000
           eq. 37-40 with forgetting factor 1), covariance mapped to the model parameters by the
           delta method (numerical Jacobian of the coefficient -> parameter map).
``"rls"``  recursive least squares with forgetting factor ``lam`` (seed 000 eq. 37-40).
``"oe"``   least squares, then output-error refinement by multiple shooting
           (:mod:`usvid.identify.output_error`), intervals from the Jacobian.
``"oe-zigzag"`` least squares, then closed-loop output error replaying every training zig-zag
           with its own switching logic (:mod:`usvid.identify.manoeuvre_oe`).

Standard errors: the equation-error and output-error residuals of manoeuvring data are coloured
(smoothing, disturbances); both methods inflate the white-noise covariance by the residual
autocorrelation factor ``1 + 2 sum rho_k`` (see :func:`usvid.identify.output_error.
autocorrelation_factor`); the output-error fit with enough windows uses the cluster-robust
(sandwich) covariance with the windows as clusters. Intervals are ``p +- q se`` with q = 1.96
(normal), or for the cluster-robust covariance the Student-t quantile with (windows - 1) degrees
of freedom.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.ls import (
    FittedAttributes,
    LeastSquares,
    check_collinearity,
    interval95,
    numerical_jacobian,
    quantile975,
    standard_errors,
)
from usvid.identify.metrics import fit_metrics
from usvid.identify.output_error import (
    PARAM_NAMES,
    RESPONSE_KINDS,
    OEResult,
    autocorrelation_factor,
    make_windows,
    refine_output_error,
    simulate_windows,
)
from usvid.identify.regressors import (
    KINDS,
    IdentificationWarning,
    Series,
    regressions,
    steady_thrust_speed,
    theta_to_params,
    trial_series,
)
from usvid.identify.rls import RecursiveLeastSquares

METHODS = ("ls", "rls", "oe", "oe-zigzag")
MIN_DELTA_STD = math.radians(0.2)  # [rad] rudder scatter below which there is no excitation
REL_WEAK = 0.5  # 95 % half-width / |parameter| above which fit() warns "poorly determined"


def _sha256(path: str) -> str | None:
    p = Path(path)
    if not p.is_file():
        return None
    h = hashlib.sha256()
    with p.open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _as_list(trials: Any) -> list:
    if trials is None:
        return []
    if isinstance(trials, (list, tuple)):
        out = list(trials)
    else:
        out = [trials]
    from usvid.trial import Trial

    for i, tr in enumerate(out):
        if not isinstance(tr, Trial):
            raise UsvidError(f"trials[{i}] is a {type(tr).__name__}, expected usvid.Trial")
    return out


def _is_turning(s: Series) -> bool:
    """A turning test: rudder constant (std < 0.5 deg) and non-zero over the last half."""
    d = s["delta"][len(s) // 2:]
    return bool(np.std(d) < math.radians(0.5) and abs(np.mean(d)) > math.radians(0.5))


def _norrbin_to_t1(p: np.ndarray) -> np.ndarray:
    """(K, T, n1, n3, delta0) -> the same dynamics with T = 1: (K/T, 1, n1/T, n3/T, delta0)."""
    K, T, n1, n3, d0 = p
    return np.array([K / T, 1.0, n1 / T, n3 / T, d0])


def _norrbin_from_t1(q: np.ndarray) -> np.ndarray:
    """T = 1 normalisation -> |n1| = 1 normalisation (regressors.py): T = 1/|n1'|."""
    k, _, m1, m3, d0 = q
    T = 1.0 / max(abs(m1), 1e-12)
    return np.array([k * T, T, math.copysign(1.0, m1), m3 * T, d0])


@dataclass
class IdentifiedModel:
    """An identified model: parameters [SI], standard errors, 95 % intervals, fit metrics,
    the model object and the provenance (data files with sha256, method, options).

    ``to_dict()`` is the model file (ARCHITECTURE.md, ``usvid_model: 1``).
    """

    kind: str
    method: str
    params: dict[str, float]
    std_errors: dict[str, float]
    ci95: dict[str, list[float]]
    cov: np.ndarray
    fit: dict[str, Any]
    model: Any  # usvid.models.model.VesselModel
    data: list[dict[str, Any]] = field(default_factory=list)
    options: dict[str, Any] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)

    def identification(self) -> dict[str, Any]:
        """The ``identification`` entry of the model file."""
        return {
            "data": [d["file"] for d in self.data],
            "data_sha256": {d["file"]: d.get("sha256") for d in self.data},
            "method": self.method,
            "std_errors": dict(self.std_errors),
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "fit": self.fit,
            "options": self.options,
            "diagnostics": self.diagnostics,
        }

    def to_dict(self) -> dict[str, Any]:
        """The model file as a JSON-ready dict (schema in ARCHITECTURE.md, written by
        :func:`usvid.modelfile.model_to_dict`; the dynamics' own parameters under
        ``parameters``, for 3-DOF/catamaran the regression coefficients under
        ``identification.diagnostics.regression``)."""
        from usvid.modelfile import model_to_dict

        return model_to_dict(self.model)

    def summary(self) -> dict[str, Any]:
        """Parameters, std errors, intervals and fit metrics (the CLI's JSON summary)."""
        return {"kind": self.kind, "method": self.method, "params": self.params,
                "std_errors": self.std_errors, "ci95": self.ci95, "fit": self.fit}


def _build_dynamics(kind: str, params: dict[str, float], x_l: float | None,
                    half_beam: float | None, thrust: Any = None) -> Any:
    """The dynamics dataclass of the identified parameters (``usvid.models``)."""
    from usvid.models import response

    try:
        if kind == "nomoto1":
            return response.Nomoto1(**params)
        if kind == "nomoto2":
            return response.Nomoto2(**params)
        if kind == "norrbin":
            return response.Norrbin(**params)
        if kind == "threedof":
            from usvid.models.threedof import ThreeDOF

            return ThreeDOF.from_regression(**params, x_l=0.0 if x_l is None else x_l,
                                            strict=False,
                                            thrust=thrust if hasattr(thrust, "thrust") else None)
        from usvid.models.catamaran import Catamaran
        from usvid.models.threedof import fossen_from_regression

        hb = 1.0 if half_beam is None else half_beam
        # c_tau was fitted on (T_p - T_s) b/2 with the given b/2: c_tau = 1/m33
        # thrust map kept when it can be written to the model file (TwinThrust or k)
        cat_thrust = thrust if (hasattr(thrust, "thrust") or isinstance(thrust, (int, float))
                                ) else 1.0
        fossen = fossen_from_regression(params["a_vr"], params["a_u"], params["a_tau"],
                                        params["b_v"], params["c_r"], params["c_tau"])
        return Catamaran(**fossen, b=2.0 * hb, thrust=cat_thrust)
    except UsvidError as exc:
        hint = (" (a negative T means a course-unstable vessel: use --model norrbin)"
                if kind == "nomoto1" and params.get("T", 1) <= 0 else "")
        raise IdentificationError(f"identified {kind} parameters are not a valid model: {exc}"
                                  f"{hint}") from exc


class ModelEstimator(FittedAttributes):
    """Identify a manoeuvring model of kind ``kind`` from one or many trials.

    Parameters
    ----------
    kind : {"nomoto1", "nomoto2", "norrbin", "threedof", "catamaran"}
    method : {"ls", "rls", "oe", "oe-zigzag"}
        ``"oe-zigzag"``: least squares, then closed-loop zig-zag replay output error
        (:mod:`usvid.identify.manoeuvre_oe`; zig-zag trials, response models; the model's servo
        gets the rudder rate limit used, the vessel's helm rate when known).
    form : {"continuous", "arx"}
        Regression form for nomoto1 (nomoto2 is always ARX(2,2) + d2c).
    norrbin : {"joint", "two_step"}
        Norrbin: joint fit with n1 free (default), or seed 000's two steps (Nomoto on the
        zig-zag trials, alpha from the mean steady yaw rate of turning trials, eq. 36).
    smooth_s : float
        Savitzky-Golay window [s] for smoothed states and derivatives.
    window_s : float
        Multiple-shooting window [s] of the output-error fit and of the fit metrics.
    arx_step : float or None
        Decimated step [s] for ARX regressions (default: 0.1 s or the log step if coarser).
    lam : float
        RLS forgetting factor (method "rls").
    oe_step : float
        Simulation/residual step [s] of the output-error fit (data decimated to it; default
        0.1 s or the log step if coarser).
    thrust, x_l, half_beam :
        Thrust source for threedof (``thrust(n, u) -> T [N]``, lever x_l [m]) and catamaran
        half spacing b/2 [m] (see :func:`usvid.identify.regressors.trial_series`).
    cond_max : float
        Collinearity limit (condition number of the equilibrated regressors).
    servo : usvid.models.servo servo object
        Servo of the identified model (default ``IdealServo``: 35 deg limit, rate limit [rad/s]
        the one fitted by "oe-zigzag", else the vessel's ``helm_rate_deg_s`` when known, else
        none).
    oe_channels : tuple of str
        Outputs the output-error fit compares (default psi and r; u, v, r, psi for 3-DOF).
    overlap : float
        Overlap of successive output-error windows, in [0, 1) (see ``make_windows``).
    """

    def __init__(self, kind: str, method: str = "ls", *, form: str = "continuous",
                 norrbin: str = "joint", smooth_s: float = 1.0, window_s: float = 20.0,
                 arx_step: float | None = None, lam: float = 1.0, oe_step: float | None = None,
                 thrust: Callable | None = None, x_l: float | None = None,
                 half_beam: float | None = None, cond_max: float = 1e8,
                 servo: Any = None,
                 oe_channels: tuple[str, ...] | None = None, overlap: float = 0.0) -> None:
        if kind not in KINDS:
            raise UsvidError(f"`kind` must be one of {', '.join(KINDS)} (got {kind!r})")
        if method not in METHODS:
            raise UsvidError(f"`method` must be one of {', '.join(METHODS)} (got {method!r})")
        if form not in ("continuous", "arx"):
            raise UsvidError(f"`form` must be 'continuous' or 'arx' (got {form!r})")
        if method == "oe-zigzag" and kind not in RESPONSE_KINDS:
            raise UsvidError("method 'oe-zigzag' (zig-zag replay) fits response models "
                             f"(nomoto1, nomoto2, norrbin), not {kind!r}")
        if norrbin not in ("joint", "two_step"):
            raise UsvidError(f"`norrbin` must be 'joint' or 'two_step' (got {norrbin!r})")
        for nm, v in (("smooth_s", smooth_s), ("window_s", window_s)):
            if not (isinstance(v, (int, float)) and v > 0):
                raise UsvidError(f"`{nm}` must be > 0 s (got {v!r})")
        self.kind = kind
        self.method = method
        self.form = form
        self.norrbin = norrbin
        self.smooth_s = float(smooth_s)
        self.window_s = float(window_s)
        self.arx_step = arx_step
        self.lam = lam
        self.oe_step = oe_step
        self.thrust = thrust
        self.x_l = x_l
        self.half_beam = half_beam
        self.cond_max = cond_max
        self.servo = servo
        self.oe_channels = oe_channels
        self.overlap = float(overlap)

    _fit_call = "fit(trials)"

    def _estimator_label(self) -> str:
        return f"ModelEstimator({self.kind!r})"

    # -- data ------------------------------------------------------------------------------------
    def _series(self, trials: list) -> list[Series]:
        out = []
        for tr in trials:
            if not tr.is_uniform:
                # a multi-rate or jittered log (NMEA, virtual sensors): put it on one grid first
                import warnings

                from usvid.prep import prepare

                warnings.warn(f"trial {tr.name or '?'}: not on a uniform time grid; resampled "
                              "with usvid.prep.prepare", IdentificationWarning, stacklevel=3)
                tr = prepare(tr, derivatives=False)
            out.append(trial_series(tr, self.kind, smooth_s=self.smooth_s, thrust=self.thrust,
                                    x_l=self.x_l, half_beam=self.half_beam))
        return out

    def _check_excitation(self, series: list[Series]) -> None:
        if self.kind in RESPONSE_KINDS:
            d = np.concatenate([s["delta"] for s in series])
            if np.std(d) < MIN_DELTA_STD:
                raise IdentificationError(
                    "no excitation: the rudder angle is constant (std "
                    f"{math.degrees(np.std(d)):.3f} deg over {', '.join(s.name for s in series)}"
                    "); a response model needs rudder changes (zig-zag, turning entry)")
        else:
            tu = np.concatenate([s["tau_r"] for s in series])
            if np.std(tu) <= 1e-12 * max(np.max(np.abs(tu)), 1e-300):
                raise IdentificationError("no excitation: the yaw moment input tau_r is constant;"
                                          " the yaw equation cannot be identified")

    def _step(self, s: Series, want: float | None) -> tuple[int, float]:
        target = 0.1 if want is None else want
        m = max(int(round(target / s.h)), 1)
        return m, m * s.h

    def _windows(self, series: list[Series], window_s: float | None, overlap: float = 0.0):
        m, h = self._step(series[0], self.oe_step)
        hs = {round(s.h, 9) for s in series}
        if len(hs) > 1:
            raise IdentificationError(f"trials have different sample steps {sorted(hs)} s; "
                                      "resample them to one rate first (usvid.prep.prepare)")
        keys = ["delta", "psi", "r", "r_s", "rdot_s", "psi_s"]
        if self.kind not in RESPONSE_KINDS:
            keys = ["tau_u", "tau_r", "psi", "r", "u", "v", "r_s", "psi_s", "u_s", "v_s"]
        ser = [{k: s[k][::m] for k in keys} for s in series]
        if window_s is None:
            window_s = max(len(x["psi"]) for x in ser) * h
        return make_windows(ser, h, window_s, overlap)

    # -- fitting ---------------------------------------------------------------------------------
    def _solve(self, reg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.method == "rls":
            est = RecursiveLeastSquares(lam=self.lam, p0=1e6).fit(reg.Phi, reg.y, reg.names,
                                                                  y_name=f"d{reg.block}/dt")
            theta = est.coef_
            cov = est.P_ * est.sigma2_
            res = reg.y - reg.Phi @ theta
            # RLS does not test collinearity itself: run the same check as batch LS
            check_collinearity(reg.Phi, list(reg.names), self.cond_max)
        else:
            est = LeastSquares(cond_max=self.cond_max).fit(reg.Phi, reg.y, reg.names,
                                                           y_name=f"d{reg.block}/dt")
            theta, cov, res = est.coef_, est.cov_, est.residuals_
        return theta, cov, res

    def _ls_params(self, series: list[Series]) -> tuple[dict[str, float], np.ndarray, dict]:
        kind = self.kind
        form = "arx" if kind == "nomoto2" else self.form
        step = self.arx_step
        if form == "arx" and step is None:
            step = max(0.1, series[0].h)
        regs = regressions(kind, series, form=form, arx_step=step)
        thetas, covs, diag = [], [], {}
        lag = max(int(self.window_s / series[0].h), 1)
        for reg in regs:
            theta, cov, res = self._solve(reg)
            fac = autocorrelation_factor(res, max_lag=min(lag, max(len(res) // 4, 1)))
            thetas.append(theta)
            covs.append(cov * fac)
            diag[f"ls_{reg.block}_ac_factor"] = fac
            ss = float(np.sum((reg.y - reg.y.mean()) ** 2))
            diag[f"ls_{reg.block}_r2"] = 1 - float(res @ res) / ss if ss > 0 else float("nan")
        theta = np.concatenate(thetas)
        names = tuple(n for r in regs for n in r.names)
        ntot = len(theta)
        cov_t = np.zeros((ntot, ntot))
        i = 0
        for c in covs:
            k = c.shape[0]
            cov_t[i:i + k, i:i + k] = c
            i += k
        h = step if form == "arx" else series[0].h
        m = max(int(round((step or series[0].h) / series[0].h)), 1) if form == "arx" else 1
        h = m * series[0].h

        def mapping(th: np.ndarray) -> np.ndarray:
            p = theta_to_params(kind, form, names, th, h)
            return np.array(list(p.values()))

        params = theta_to_params(kind, form, names, theta, h)
        pnames = list(params.keys())
        try:
            G = numerical_jacobian(mapping, theta)
            cov_p = G @ cov_t @ G.T
        except IdentificationError:
            cov_p = np.full((len(pnames), len(pnames)), np.nan)
        # order as PARAM_NAMES
        order = [pnames.index(n) for n in PARAM_NAMES[kind]]
        params = {n: float(params[n]) for n in PARAM_NAMES[kind]}
        cov_p = cov_p[np.ix_(order, order)]
        diag["regression"] = {"form": form, "coefficients": dict(zip(names, theta.tolist(),
                                                                      strict=True))}
        return params, cov_p, diag

    def _two_step_norrbin(self, series: list[Series], turning: list[Series]):
        zz = [s for s in series if not _is_turning(s)]
        tt = list(turning) + [s for s in series if _is_turning(s)]
        if not zz:
            raise IdentificationError("two-step Norrbin: no zig-zag (varying rudder) trial for "
                                      "the Nomoto step")
        if not tt:
            raise IdentificationError(
                "two-step Norrbin (seed 000 eq. 36) needs turning trials (constant rudder over "
                "their second half); pass them as fit(..., turning=[...]) or use the joint fit")
        kind0 = self.kind
        self.kind = "nomoto1"
        try:
            p1, cov1, diag = self._ls_params(zz)
        finally:
            self.kind = kind0
        K, T, d0 = p1["K"], p1["T"], p1["delta0"]
        rr, dd = [], []
        for s in tt:
            half = len(s) // 2
            rr.append(float(np.mean(s["r"][half:])))  # remark 5: average r over the steady turn
            dd.append(float(np.mean(s["delta"][half:])))
        r_ = np.array(rr)
        d_ = np.array(dd)
        y = K * (d_ + d0) - r_
        alpha = float(np.sum(r_ ** 3 * y) / np.sum(r_ ** 6))
        if len(tt) > 1:
            res = y - alpha * r_ ** 3
            se_a = math.sqrt(float(res @ res) / max(len(tt) - 1, 1) / float(np.sum(r_ ** 6)))
        else:
            se_a = float("nan")
        params = {"K": K, "T": T, "n1": 1.0, "n3": alpha, "delta0": d0}
        cov = np.zeros((5, 5))
        idx = [0, 1, 4]
        cov[np.ix_(idx, idx)] = cov1
        cov[3, 3] = se_a ** 2
        diag["two_step"] = {"turning_trials": [s.name for s in tt],
                            "mean_r": rr, "mean_delta": dd}
        return params, cov, diag, zz

    def fit(self, trials: Any, *, turning: Any = None) -> ModelEstimator:
        """Identify the model from ``trials`` (one :class:`usvid.Trial` or a list); returns self.

        ``turning``: extra turning-test trials for the two-step Norrbin fit.
        """
        trials = _as_list(trials)
        if not trials:
            raise IdentificationError("no trials given")
        series = self._series(trials)
        tseries = self._series(_as_list(turning)) if turning is not None else []
        self._check_excitation(series)
        fit_series = series
        if self.kind == "norrbin" and self.norrbin == "two_step":
            params, cov, diag, fit_series = self._two_step_norrbin(series, tseries)
        else:
            params, cov, diag = self._ls_params(series)
        names = PARAM_NAMES[self.kind]
        p_ls = dict(params)
        if self.kind in ("threedof", "catamaran"):
            st = steady_thrust_speed(series)
            if st is not None:  # seed 002: damping from steady runs, a check on -a_u/a_tau
                st["d11_from_regression"] = -params["a_u"] / params["a_tau"]
                diag["steady_runs"] = st
        oe: OEResult | None = None
        if self.method == "oe":
            win = self._windows(fit_series, self.window_s, self.overlap)
            free = np.ones(len(names), bool)
            p0 = np.array([params[n] for n in names])
            if self.kind == "norrbin":
                # OE in the T = 1 normalisation (n1 continuous through 0, so the fit can cross
                # from course-stable to course-unstable), then back to |n1| = 1.
                free[names.index("T")] = False
                p0 = _norrbin_to_t1(p0)
            oe = refine_output_error(self.kind, p0, win, free=free, channels=self.oe_channels)
            pe, cov = oe.params, oe.cov
            if self.kind == "norrbin":
                G = numerical_jacobian(_norrbin_from_t1, pe)
                pe, cov = _norrbin_from_t1(pe), G @ cov @ G.T
            params = dict(zip(names, pe.tolist(), strict=True))
            diag["oe"] = {"cost": oe.cost, "nfev": oe.nfev, "success": oe.success,
                          "message": oe.message, "ac_factor": oe.ac_factor,
                          "sigma": oe.sigma, "n_residuals": oe.n_residuals,
                          "window_s": self.window_s}
            diag["ls_params"] = p_ls
        zz_rate = None
        if self.method == "oe-zigzag":  # closed-loop zig-zag replay (manoeuvre_oe.py)
            from usvid.identify.manoeuvre_oe import fit_zigzag_params

            zz_trials = [t for t, s in zip(trials, series, strict=True) if any(
                s is f for f in fit_series)]
            params, cov, diag["oe_zigzag"], oe, zz_rate = fit_zigzag_params(
                self.kind, params, zz_trials, fit_series)
            diag["ls_params"] = p_ls
        se = standard_errors(cov)
        q = quantile975(oe.dof if oe is not None else math.inf)
        self.params_ = {n: float(params[n]) for n in names}
        self.cov_ = cov
        self.std_errors_ = dict(zip(names, se.tolist(), strict=True))
        ci = interval95([self.params_[n] for n in names], se, q)
        self.ci95_ = dict(zip(names, ci.tolist(), strict=True))
        diag["ci95_quantile"] = q
        self._warn_weak(names, se, q)
        self.series_ = series
        self.oe_ = oe
        self.fit_ = self._metrics(series, self.window_s)
        self.data_ = [{"file": str(src), "sha256": _sha256(str(src))}
                      for tr in trials for src in (tr.sources or [tr.name])]
        vessel = next((tr.vessel for tr in trials if tr.vessel is not None
                       and tr.vessel.to_dict()), None)
        opts: dict[str, Any] = {"form": "arx" if self.kind == "nomoto2" else self.form,
                                "smooth_s": self.smooth_s, "window_s": self.window_s}
        if self.kind == "norrbin":
            opts["norrbin"] = self.norrbin
        if self.method == "rls":
            opts["lam"] = self.lam
        if self.method == "oe":
            opts["overlap"] = self.overlap
        dyn = _build_dynamics(self.kind, self.params_, self.x_l, self.half_beam, self.thrust)
        from usvid.models.model import VesselModel
        from usvid.models.servo import IdealServo
        from usvid.trial import Vessel

        result = IdentifiedModel(
            kind=self.kind, method=self.method, params=self.params_,
            std_errors=self.std_errors_, ci95=self.ci95_, cov=cov, fit=self.fit_,
            model=None, data=self.data_, options=opts, diagnostics=diag)
        if self.servo is None and zz_rate is None and vessel is not None:
            from usvid.identify.manoeuvre_oe import helm_rate

            zz_rate = helm_rate(vessel)  # the vessel's helm rate, for simulations of the model
        self.model_ = VesselModel(dyn, servo=self.servo or IdealServo(
            max_rate=math.inf if zz_rate is None else zz_rate),
                                  vessel=vessel or Vessel(),
                                  identification=result.identification())
        result.model = self.model_
        self.result_ = result
        return self

    def _warn_weak(self, names: Sequence[str], se: np.ndarray, q: float) -> None:
        """Warn when a parameter's 95 % half-width ``q se`` exceeds half its magnitude
        (REL_WEAK): near-collinear regressors or too little excitation (e.g. a rudder varying so
        slowly that r ~ K delta) leave it undetermined even below ``cond_max``. The offset
        ``delta0`` and the fixed ``n1`` are not checked (zero is their usual value)."""
        weak = []
        for n, e in zip(names, se, strict=True):
            v = self.params_[n]
            if n in ("delta0", "n1") or not math.isfinite(e):
                continue
            if q * e > REL_WEAK * abs(v):
                weak.append(f"{n} = {v:.4g} +- {q * e:.3g}")
        if weak:
            import warnings

            warnings.warn(
                f"{self.kind}: poorly determined parameter(s) {'; '.join(weak)} (95 %): the "
                "data do not separate their effects (nearly collinear regressors or too little "
                "excitation); use sharper rudder changes (zig-zags) or a simpler model",
                IdentificationWarning, stacklevel=3)

    # -- use -------------------------------------------------------------------------------------
    def _metrics(self, series: list[Series], window_s: float | None) -> dict[str, Any]:
        win = self._windows(series, window_s)
        sim = simulate_windows(self.kind, np.array(list(self.params_.values())), win)
        out: dict[str, Any] = {"window_s": window_s}
        for ch, s in sim.items():
            fm = fit_metrics(win.outputs[ch][:, 1:].ravel(), s[:, 1:].ravel()).to_dict()
            out[ch] = fm
        return out

    def score(self, trials: Any, *, window_s: float | None = -1.0) -> dict[str, Any]:
        """Fit metrics (RMSE, NRMSE, R^2, max error per output channel) on ``trials``; RMSE and
        max error in the channel's SI unit (psi [rad], r [rad/s], u, v [m/s]), NRMSE, R^2 [-].

        ``window_s``: -1 (default) uses the estimator's multiple-shooting window; ``None`` a free
        run over each whole trial from its measured initial state; a number that window [s].
        """
        _ = self.params_
        series = self._series(_as_list(trials))
        return self._metrics(series, self.window_s if window_s == -1.0 else window_s)

    def simulate(self, trial: Any, *, window_s: float | None = None) -> Any:
        """Replay ``trial``'s inputs on the identified model (free run from its measured initial
        state, or re-initialised every ``window_s`` seconds). Returns a :class:`usvid.Trial`
        with the simulated ``psi``, ``r`` (and ``u``, ``v``) on the decimated grid and the
        measured ``delta``/``tau`` inputs; ``meta["measured"]`` holds the measured outputs."""
        _ = self.params_
        s = self._series(_as_list(trial))
        win = self._windows(s, window_s)
        sim = simulate_windows(self.kind, np.array(list(self.params_.values())), win)
        m, h = self._step(s[0], self.oe_step)
        t = s[0]["t"][::m]
        cols: dict[str, np.ndarray] = {"t": t}
        W = win.outputs["psi"].shape[1]
        starts = list(range(0, len(t) - W + 1, W - 1))
        if starts[-1] + W < len(t):
            starts.append(len(t) - W)
        for ch, arr in sim.items():
            full = np.full(len(t), np.nan)
            for b, k in enumerate(starts):
                full[k:k + W] = arr[b]
            cols[ch] = full
        for k in win.inputs:
            cols[k] = s[0][k][::m]
        from usvid.trial import Trial

        src = _as_list(trial)[0]
        meas = {ch: s[0][ch][::m] for ch in sim}
        return Trial(data=pd.DataFrame(cols), vessel=src.vessel, sources=list(src.sources),
                     name=f"sim:{src.name}", meta={"measured": meas, "params": self.params_})

    def to_dict(self) -> dict[str, Any]:
        """The model file (dict) of the fitted model."""
        return self.result_.to_dict()


def identify(trials: Any, kind: str, method: str = "ls", *, turning: Any = None,
             **options: Any) -> IdentifiedModel:
    """Functional form: ``ModelEstimator(kind, method, **options).fit(trials).result_``."""
    return ModelEstimator(kind, method, **options).fit(trials, turning=turning).result_


#: API.md name: ``usvid.identify.fit(trials, kind, method) -> IdentifiedModel``.
fit = identify


def compare_kinds(trials: Any, kinds: Sequence[str] = ("nomoto1", "nomoto2", "norrbin"),
                  method: str = "oe", validate: Any = None, **options: Any) -> list[dict]:
    """Fit several model kinds to the same trials; one row per kind with training (and
    validation) metrics, or the error that stopped the kind."""
    rows = []
    for k in kinds:
        try:
            est = ModelEstimator(k, method, **options).fit(trials)
        except UsvidError as exc:
            rows.append({"kind": k, "error": str(exc)})
            continue
        row: dict[str, Any] = {"kind": k, "params": est.params_, "train": est.fit_}
        if validate is not None:
            row["validation"] = est.score(validate)
        rows.append(row)
    return rows
