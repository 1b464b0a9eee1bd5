"""One estimator contract for every model kind: :class:`ModelEstimator` and :func:`identify`.

scikit-learn style (STYLE.md): hyper-parameters in ``__init__``; :meth:`ModelEstimator.fit` takes
one or many :class:`usvid.Trial` and returns ``self``; learned attributes end in ``_``
(``params_``, ``std_errors_``, ``ci95_``, ``cov_``, ``fit_``, ``model_``, ``result_``);
:meth:`~ModelEstimator.simulate` replays a trial's inputs on the identified model,
:meth:`~ModelEstimator.score` gives fit metrics on other trials, :meth:`~ModelEstimator.to_dict`
is exactly the model file.

**The identified model is the model file is the model that is simulated.** The kind's
parameters come from its registry entry (:mod:`usvid.models.registry`): the fitted ones from the
data, the particulars (thrust law, thruster arm, nominal shaft speed or command, ...) from the
trials' vessel particulars (the format spec's ``vessel`` block) or the user's options, or
identification stops with an error naming what is missing. Every method integrates the kind's
own right-hand side with the one core of :mod:`usvid.sim`, and the fit metrics are replays of
the final model through it, so loading the model file and replaying the training data with
:mod:`usvid.sim.replay` reproduces them.

Methods
-------
``"ls"``   equation-error least squares on the kind's regression form
           (:mod:`usvid.identify.equation_error`; Mu et al. 2018, eq. 37-40 with forgetting
           factor 1), covariance by the delta method.
``"rls"``  recursive least squares with forgetting factor ``lam``.
``"oe"``   least squares, then output error by multiple shooting over windows
           (:mod:`usvid.identify.output_error`), intervals from the Jacobian.
``"oe-zigzag"`` least squares, then closed-loop output error replaying every training zig-zag
           with its own switching logic (:mod:`usvid.identify.replay`).

Standard errors: equation-error and output-error residuals of manoeuvring data are coloured;
both inflate the white-noise covariance by the residual autocorrelation factor; the output-error
fit with enough windows uses the cluster-robust (sandwich) covariance with the windows as
clusters and Student-t intervals with (windows - 1) degrees of freedom.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import html
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from usvid.errors import IdentificationError, UsvidError
from usvid.identify import disturbance as _dist
from usvid.identify import thrust_consistency as _tc
from usvid.identify.checks import (
    ChecksFailed,
    check_data,
    check_model,
    failed,
    refusal,
    trial_speed,
)
from usvid.identify.defaults import DEFAULT_METHODS
from usvid.identify.equation_error import fit_equation_error, two_step_norrbin
from usvid.identify.ls import FittedAttributes, interval95, quantile975, standard_errors
from usvid.identify.metrics import replay_metrics
from usvid.identify.output_error import OEResult, refine_output_error
from usvid.identify.replay import helm_rate, refine_zigzag_oe, zigzag_runs
from usvid.identify.series import IdentificationWarning, Series, trial_series
from usvid.identify.servo import helm_from_zigzags, identify_second_order_servo
from usvid.identify.span import kind_channels, trim_to_logged
from usvid.identify.wind import WindFit, interval, track_wind_loads, wind_fit, wind_kinds
from usvid.io.modelfile import model_to_dict
from usvid.manoeuvres import find_manoeuvres, measured_metrics
from usvid.manoeuvres.detect import approach
from usvid.models.kind import LeftOutWarning, ModelKind
from usvid.models.model import VesselModel
from usvid.models.registry import get as get_kind
from usvid.models.registry import names as kind_names
from usvid.models.servo import IdealServo
from usvid.prep import PreparedTrial, as_prepared, prepare
from usvid.prep.segments import MIN_SEGMENT_S, split_at_breaks, time_breaks
from usvid.prep.under_way import under_way
from usvid.sim.replay import WIND_SERIES, Windows, make_windows, replay_windows
from usvid.trial import Trial, Vessel

METHODS = ("ls", "rls", "oe", "oe-zigzag")
def default_methods(kind: str) -> tuple[str, ...]:
    """The methods of ``kind`` in the order they predict held-out data
    (:data:`usvid.identify.defaults.DEFAULT_METHODS`; "ls" for a kind not measured)."""
    return tuple(DEFAULT_METHODS.get(kind, ("ls",)))


def default_method(kind: str) -> str:
    """The default identification method of ``kind``: the one that predicts best."""
    return default_methods(kind)[0]

MIN_DELTA_STD = math.radians(0.2)  # [rad] rudder scatter below which there is no excitation
REL_WEAK = 0.5  # 95 % half-width / |parameter| above which fit() warns "poorly determined"
#: Default step [s] of output error, ARX regressions and replays (or the log step if coarser).
DEFAULT_STEP = 0.1


def _sha256(path: str) -> str | None:
    p = Path(path)
    if not p.is_file():
        return None
    h = hashlib.sha256()
    with p.open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _as_list(trials: Any) -> list[Trial]:
    if trials is None:
        return []
    out = list(trials) if isinstance(trials, (list, tuple)) else [trials]
    for i, tr in enumerate(out):
        if not isinstance(tr, Trial):
            raise UsvidError(f"trials[{i}] is a {type(tr).__name__}, expected usvid.Trial")
    return out


def _is_turning(tr: Trial, psi_switch: float | None = None) -> bool:
    """A turning test: a turning circle and no zig-zag found in it (``find_manoeuvres``)."""
    kinds = {g.kind for g in find_manoeuvres(tr, psi_switch=psi_switch)}
    return "turning" in kinds and "zigzag" not in kinds


def split_discontinuities(trials: Sequence[Trial]) -> list[Trial]:
    """Trials cut at the time discontinuities their reader found (clock resets, forward jumps;
    :func:`usvid.prep.segments.split_at_breaks`), so that no fit runs across one; says so in an
    :class:`IdentificationWarning` per trial. Raises :class:`IdentificationError` when no
    segment is long enough to identify from."""
    out = []
    for tr in trials:
        segs, dropped = split_at_breaks(tr)
        if len(segs) == 1 and not dropped:
            out.append(tr)
            continue
        tb = time_breaks(tr)
        desc = ", ".join(f"{b['kind'].replace('_', ' ')} {b['step_s']:+.3g} s at t = "
                         f"{b['t']:.2f} s" for b in tb[:3]) + (", ..." if len(tb) > 3 else "")
        if not segs:
            raise IdentificationError(
                f"trial {tr.name or '?'}: {len(tb)} time discontinuit(ies) ({desc}) leave no "
                f"segment of at least {MIN_SEGMENT_S:g} s to identify from")
        warnings.warn(
            f"TIME DISCONTINUITY in trial {tr.name or '?'}: {desc}; identified on its "
            f"{len(segs)} segment(s) separately, never across a break"
            + (f" ({len(dropped)} segment(s) shorter than {MIN_SEGMENT_S:g} s left out)"
               if dropped else ""), IdentificationWarning, stacklevel=3)
        out.extend(segs)
    return out


def repair_warnings(trial: PreparedTrial, stacklevel: int = 3) -> None:
    """Say what :func:`usvid.prep.prepare` repaired in ``trial`` before identification sees
    it: a log resampled onto a uniform grid, the gaps of a single-rate log interpolated."""
    if trial.resampled_hz is not None:
        warnings.warn(f"trial {trial.name or '?'}: not on a uniform time grid; resampled to "
                      f"{trial.resampled_hz:.4g} Hz with usvid.prep.prepare",
                      IdentificationWarning, stacklevel=stacklevel)
    for ch, k in trial.filled.items():
        warnings.warn(f"trial {trial.name or '?'}: channel '{ch}' has {k} NaN samples; "
                      "interpolated linearly (usvid.prep.prepare)", IdentificationWarning,
                      stacklevel=stacklevel)


def one_grid(trials: Sequence[Trial]) -> list[PreparedTrial]:
    """Prepared trials (:func:`usvid.prep.as_prepared`: a prepared one is used as it is) on
    uniform grids of one step: logs of different rates are resampled to the coarsest one
    (never upsampled), with a warning saying so."""
    out = [as_prepared(tr, derivatives=False) for tr in trials]
    rates = [tr.sample_rate for tr in out]
    if len({round(r, 6) for r in rates}) > 1:
        target = min(rates)
        warnings.warn(f"trials have different sample rates ({', '.join(f'{r:.4g}' for r in rates)}"
                      f" Hz); resampled to {target:.4g} Hz", IdentificationWarning, stacklevel=3)
        out = [tr if abs(tr.sample_rate - target) < 1e-6 * target else
               prepare(tr, rate_hz=target, derivatives=False) for tr in out]
    return out


#: Longest stretch of a log [s] the steering servo is fitted on (its time constants are seconds).
SERVO_WINDOW_S = 120.0


def _most_active(u: np.ndarray, dt: float, window_s: float) -> slice:
    """The ``window_s`` stretch of command ``u`` with the most movement (sum of |du|)."""
    n = int(round(window_s / dt))
    if u.size <= n:
        return slice(None)
    act = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(u)))])
    k = int(np.argmax(act[n:] - act[:-n]))
    return slice(k, k + n + 1)


def _vessel(trials: Sequence[Trial]) -> Vessel:
    return next((tr.vessel for tr in trials if tr.vessel is not None and tr.vessel.to_dict()),
                Vessel())


def training_speed(trials: Sequence[Trial], psi_switch: float | None = None) -> float | None:
    """The approach speed [m/s] of the training trials: the median over their manoeuvres of
    the approach speed (:func:`usvid.manoeuvres.detect.approach`, the one definition), a trial
    without a manoeuvre counting with its first :data:`~usvid.manoeuvres.detect.APPROACH_S`;
    None when no trial logs a speed."""
    vals = []
    for tr in trials:
        segs = [g for g in find_manoeuvres(tr, psi_switch=psi_switch)
                if g.approach is not None] if tr.has("psi") else []
        aps = [g.approach for g in segs] or [approach(tr, float(tr.t[0]))]
        vals += [a.speed for a in aps if a.speed is not None]
    vals = [v for v in vals if math.isfinite(v) and v > 0]
    return float(np.median(vals)) if vals else None


def _reversal_windows(trials: Sequence[Trial], rate: float, psi_switch: float | None = None
                      ) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The rudder records around the measured zig-zag reversals of ``trials`` (for
    :func:`usvid.identify.servo.helm_from_zigzags`): from 0.5 s before each heading crossing
    until the swing at ``rate`` [rad/s] plus 2 s, or 0.5 s before the next crossing."""
    out = []
    for tr in trials:
        if not (tr.has("delta") and tr.has("psi")):
            continue
        t, d = tr.t, tr["delta"]
        for m in measured_metrics(tr, psi_switch=psi_switch):
            if m["kind"] != "zigzag":
                continue
            tc = list(m.get("reversal_times_s") or [])
            for k, c in enumerate(tc):
                i = int(np.searchsorted(t, c))
                if i >= t.size:
                    break
                t_end = c + 2.0 * abs(float(d[i])) / rate + 2.0
                if k + 1 < len(tc):
                    t_end = min(t_end, tc[k + 1] - 0.5)
                sel = (t >= c - 0.5) & (t <= t_end)
                if sel.sum() > 10:
                    out.append((t[sel], d[sel], float(c)))
    return out


@dataclass
class IdentifiedModel:
    """An identified model: parameters [SI, the model file's names], standard errors, 95 %
    intervals, covariance, fit metrics, the model and the provenance (data files with sha256,
    method, options, diagnostics). ``to_dict()`` is the model file."""

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
    checks: list[dict[str, Any]] = field(default_factory=list)
    wind: dict[str, Any] | None = None
    disturbance: dict[str, Any] | None = None  # per-trial current / bias (output error)

    def identification(self) -> dict[str, Any]:
        """The ``identification`` entry of the model file."""
        return {
            "data": [d["file"] for d in self.data],
            "data_sha256": {d["file"]: d.get("sha256") for d in self.data},
            "method": self.method,
            "std_errors": dict(self.std_errors),
            **self._covariance(),
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "held": self.held,
            "fit": self.fit,
            "options": self.options,
            "diagnostics": self.diagnostics,
            "checks": list(self.checks),
            **({"wind": dict(self.wind)} if self.wind is not None else {}),
            **({"disturbance": dict(self.disturbance)} if self.disturbance is not None
               else {}),
        }

    def _covariance(self) -> dict[str, Any]:
        """``{"covariance": {"names", "matrix"}}`` of the fitted parameters [SI] (what
        ``usvid montecarlo --from-uncertainty`` samples), or {} when it is not available."""
        cov = np.asarray(self.cov, float)
        names = list(self.std_errors)
        if cov.shape != (len(names), len(names)) or not np.all(np.isfinite(cov)):
            return {}
        return {"covariance": {"names": names, "matrix": cov.tolist()}}

    def to_dict(self) -> dict[str, Any]:
        """The model file as a JSON-ready dict (:func:`usvid.io.modelfile.model_to_dict`)."""
        return model_to_dict(self.model)

    def _repr_html_(self) -> str:
        """A parameter table for Jupyter: estimate, standard error and 95 % interval."""
        rows = "".join(
            f"<tr><td><code>{html.escape(k)}</code></td><td>{v:.6g}</td>"
            f"<td>{self.std_errors.get(k, math.nan):.3g}</td>"
            f"<td>{self.ci95.get(k, [math.nan, math.nan])[0]:.6g} .. "
            f"{self.ci95.get(k, [math.nan, math.nan])[1]:.6g}</td></tr>"
            for k, v in self.params.items())
        return (f"<table><caption>{html.escape(self.kind)} identified by "
                f"{html.escape(self.method)}</caption><tr><th>parameter</th><th>estimate</th>"
                f"<th>std. error</th><th>95 % interval</th></tr>{rows}</table>")

    @property
    def held(self) -> list[str]:
        """Parameters of the fitted set the method kept at their prior (standard error exactly
        0: e.g. the MMG rudder lift gradient f_alpha under ``ls``, which only output error
        refines); their interval is the value itself, not a measurement."""
        return [k for k, e in self.std_errors.items() if e == 0.0]

    def summary(self) -> dict[str, Any]:
        """Parameters, std errors, intervals, the held parameters, fit metrics and the wind of
        the fit (``wind``: the model file's ``identification.wind``) (the CLI's JSON
        summary)."""
        out = {"kind": self.kind, "method": self.method, "params": self.params,
               "std_errors": self.std_errors, "ci95": self.ci95, "held": self.held,
               "fit": self.fit}
        if self.wind is not None:
            out["wind"] = dict(self.wind)
        if self.disturbance is not None:
            out["disturbance"] = dict(self.disturbance)
        return out


class _HoldAndRefit(Exception):  # noqa: N818 - a control-flow signal, not an error
    """Raised by a fit that found parameters indistinguishable from their neutral value
    (``drop``: name -> (value, why)); :meth:`ModelEstimator._fit` fits again holding them,
    the output error warm-started from this fit's (``warm``, None for other methods)."""

    def __init__(self, drop: dict[str, tuple[float, str]], warm: OEResult | None = None) -> None:
        super().__init__("hold and fit again")
        self.drop = drop
        self.warm = warm


class ModelEstimator(FittedAttributes):
    """Identify a manoeuvring model of kind ``kind`` from one or many trials.

    Parameters
    ----------
    kind : str
        A registered kind (:func:`usvid.models.registry.names`).
    method : {"ls", "rls", "oe", "oe-zigzag"}, optional
        Default: the kind's method that predicts best
        (:data:`usvid.identify.defaults.DEFAULT_METHODS`).
    form : str
        Regression form of the equation-error step (the kind's forms, e.g. ``"continuous"``
        or ``"arx"`` for nomoto1; nomoto2 is always ARX + d2c).
    norrbin : {"joint", "two_step"}
        Norrbin: joint fit with n1 free, or Mu et al. 2018's two steps (Nomoto on the zig-zags,
        alpha from turning trials, eq. 36; ``fit(..., turning=...)``).
    smooth_s : float
        Savitzky-Golay window [s] for smoothed states and derivatives.
    window_s : float
        Multiple-shooting window [s] of the output-error fit and of the windowed fit metrics.
    overlap : float
        Overlap of successive output-error windows, in [0, 1).
    step : float, optional
        Step [s] of output error, ARX regressions and replays (default 0.1 s, or the log step
        if coarser).
    lam : float
        RLS forgetting factor (method "rls").
    cond_max : float
        Collinearity limit (condition number of the equilibrated regressors).
    servo : servo object or "auto"
        Servo of the identified model: "auto" (default) identifies a second-order servo with
        dead time when the trials log both ``delta_cmd`` and ``delta`` (on the
        :data:`SERVO_WINDOW_S` of each trial with the most rudder movement), else an ideal
        servo at the vessel's helm rate (``helm_rate_deg_s``), the rate fitted by "oe-zigzag"
        or the rate measured on the rudder ramps. For kinds with state estimation (``mmg``,
        a physics model whose rudder force follows the rudder angle itself) fitted on the
        measured rudder (not "oe-zigzag", whose replays use the ideal servo), zig-zag trials
        without a logged order give the helm instead: a critically damped second-order servo
        at that rate with the dead time after each heading crossing
        (:func:`usvid.identify.servo.helm_from_zigzags`), so that a simulated zig-zag
        reverses the rudder as the trials did.
    oe_channels : tuple of str
        Outputs the output-error fit compares (default the kind's outputs).
    particulars : dict
        The kind's particulars by name, overriding the trials' vessel particulars (e.g.
        ``{"x_l": 3.5}`` for threedof; see the kind's module).
    x_l, thrust : optional
        Shortcuts for ``particulars["x_l"]`` [m] and a thrust law object.
    wind : bool
        Fit through the logged wind (default True; :mod:`usvid.identify.wind`): where the
        trials log it and the kind takes it (:func:`usvid.identify.wind.wind_kinds`), the
        regression subtracts its loads along the measured track and the output error
        simulates in it, estimating ``wind_scale``; False: calm water (the wind's forces taken
        for hull forces).
    checks : {"error", "record"}
        What to do with a model that fails its checks (:mod:`usvid.identify.checks`: a standard
        manoeuvre inside the training envelope diverges or turns the wrong way, the training
        free run diverges, the model explains too little of the heading): "error" (default)
        raises :class:`IdentificationError` with the reason and what to do; "record" returns
        it with a warning, the failures in ``identification["checks"]`` (``checks_``).
    """

    _fit_call = "fit(trials)"

    def __init__(self, kind: str, method: str | None = None, *, form: str = "continuous",
                 norrbin: str = "joint", smooth_s: float = 1.0, window_s: float = 20.0,
                 overlap: float = 0.0, step: float | None = None, lam: float = 1.0,
                 cond_max: float = 1e8, servo: Any = "auto",
                 oe_channels: tuple[str, ...] | None = None,
                 particulars: dict[str, Any] | None = None, x_l: float | None = None,
                 thrust: Any = None, arx_step: float | None = None,
                 oe_step: float | None = None, states: str = "auto",
                 checks: str = "error", wind: bool = True,
                 disturbance: Any = None) -> None:
        if kind not in kind_names():
            raise UsvidError(f"`kind` must be one of {', '.join(kind_names())} (got {kind!r})")
        k = get_kind(kind)
        self._auto = method is None
        if method is None:
            method = default_method(kind)
        if checks not in ("error", "record"):
            raise UsvidError(f"`checks` must be 'error' or 'record' (got {checks!r})")
        self.checks = checks
        if method not in METHODS:
            raise UsvidError(f"`method` must be one of {', '.join(METHODS)} (got {method!r})")
        if k.regression is None:
            raise UsvidError(f"model '{kind}' has no regression form to start from")
        forms = k.regression.forms
        if form not in forms:
            if form == "continuous" and len(forms) == 1:
                form = forms[0]
            else:
                raise UsvidError(f"`form` must be one of {', '.join(forms)} for {kind} "
                                 f"(got {form!r})")
        if method == "oe-zigzag" and not {"psi", "r"} <= set(k.outputs):
            raise UsvidError(f"method 'oe-zigzag' replays zig-zags on heading and yaw rate; "
                             f"kind {kind!r} has outputs {', '.join(k.outputs)}")
        if norrbin not in ("joint", "two_step"):
            raise UsvidError(f"`norrbin` must be 'joint' or 'two_step' (got {norrbin!r})")
        for nm, v in (("smooth_s", smooth_s), ("window_s", window_s)):
            if not (isinstance(v, (int, float)) and v > 0):
                raise UsvidError(f"`{nm}` must be > 0 s (got {v!r})")
        if not 0 <= overlap < 1:
            raise UsvidError(f"`overlap` must be in [0, 1) (got {overlap!r})")
        self.kind = kind
        self.method = method
        self.form = form
        self.norrbin = norrbin
        self.smooth_s = float(smooth_s)
        self.window_s = float(window_s)
        self.overlap = float(overlap)
        self.step = step if step is not None else (oe_step or arx_step)
        self.lam = lam
        self.cond_max = cond_max
        self.servo = servo
        self.oe_channels = oe_channels
        self.particulars = dict(particulars or {})
        if x_l is not None:
            self.particulars["x_l"] = x_l
        self.thrust = thrust
        if states not in ("auto", "smooth", "ekf"):
            raise UsvidError(f"`states` must be 'auto', 'smooth' or 'ekf' (got {states!r})")
        self.states = states
        self.wind = bool(wind)
        # the per-trial current / force biases of the output error (usvid.identify.disturbance)
        self.disturbance = _dist.parse_disturbance(disturbance)
        if self.disturbance:
            _dist.disturbance_for(k, self.disturbance, ())  # a kind that can carry them
            other = [t for t in self.disturbance if t not in _dist.REGRESSION_TERMS]
            if not self._auto and method != "oe" and (method not in ("ls", "rls") or other):
                raise UsvidError(f"--disturbance {','.join(self.disturbance)} is estimated by "
                                 f"the output error (--method oe), not by {method}"
                                 + (f" (the regression estimates the current only: "
                                    f"--disturbance current; {','.join(other)} needs the "
                                    "output error)" if method in ("ls", "rls") else ""))

    def _estimator_label(self) -> str:
        return f"ModelEstimator({self.kind!r})"

    @property
    def kind_(self) -> ModelKind:
        return get_kind(self.kind)

    # -- data ------------------------------------------------------------------------------------
    def _options(self) -> dict[str, Any]:
        """The particulars given as options (``particulars``, ``thrust``), by name."""
        opts = {k: v for k, v in self.particulars.items() if not hasattr(v, "thrust")}
        if self.thrust is not None:
            opts["thrust"] = self.thrust
        return opts

    def _fixed(self, trials: Sequence[Trial]) -> dict[str, Any]:
        kind = self.kind_
        if kind.particulars is None:
            return {}
        opts = self._options()
        data = [{c: tr[c] for c in tr.channels} for tr in trials]
        fixed = kind.particulars(_vessel(trials), data, opts)
        if self.thrust is not None:
            fixed["thrust"] = self.thrust
        return fixed

    def _series(self, trials: Sequence[Trial], fixed: dict[str, Any]) -> list[Series]:
        return [trial_series(tr, self.kind_, smooth_s=self.smooth_s, fixed=fixed,
                             states=self.states) for tr in trials]

    def _wind(self, trials: Sequence[Trial], series: Sequence[Series]) -> WindFit:
        """The wind of the fit (:mod:`usvid.identify.wind`; ``wind=False``: none): for a kind
        whose regression takes known loads, the logged wind's loads along the measured track
        are added to each series (``ext_X``, ``ext_Y``, ``ext_N``) for the regression to
        subtract; windows keep the wind series only when the wind is in the fit."""
        names = [s.name for s in series]
        logged = [s.name for s in series if "wind_x" in s]
        reg = self.kind_.regression
        if logged and not self.wind:
            wf = WindFit(None, "the wind is left out of the fit (wind=False): calm water, the "
                               "wind's forces taken for hull forces", trials=logged)
        elif logged and (reg is None or reg.external is None):
            wf = WindFit(None, f"a {self.kind} fit does not take the wind (the kinds that do: "
                               f"{', '.join(wind_kinds())}): calm water, the wind's forces "
                               "taken for hull forces", trials=logged)
            warnings.warn(f"{self.kind}: the wind is logged in {len(logged)} trial(s) but "
                          f"{wf.reason}", IdentificationWarning, stacklevel=4)
        else:
            units = None
            if logged and reg is not None and reg.external is not None:
                units = reg.external(_vessel(trials), self._options())
            wf = wind_fit(series, names, _vessel(trials), units)
            if wf.model is None and wf.trials:
                warnings.warn(f"{self.kind}: {wf.reason}", IdentificationWarning, stacklevel=4)
        for s in series:
            if wf.model is not None and "wind_x" in s:
                X, Y, N = track_wind_loads(wf.model, s["wind_x"], s["wind_y"], s["u_s"],
                                           s["v_s"], s["psi_s"])
                s.data.update(ext_X=X, ext_Y=Y, ext_N=N)
            elif wf.model is None:
                for k in (*WIND_SERIES, "ext_X", "ext_Y", "ext_N"):
                    s.data.pop(k, None)
        return wf

    def _decimation(self, s: Series) -> int:
        target = DEFAULT_STEP if self.step is None else float(self.step)
        return max(int(round(target / s.h)), 1)

    def _windows(self, series: Sequence[Series], window_s: float | None,
                 overlap: float = 0.0) -> Windows:
        m = self._decimation(series[0])
        dec = [s.decimated(m).data for s in series]
        return make_windows(dec, series[0].h * m, window_s, overlap)

    def _check_excitation(self, series: Sequence[Series]) -> None:
        """Refuse steering inputs that do not move: the rudder angle of a response model, or
        or thrust angle of a kind with a surge equation steered by it (mmg, threedof; not
        one steered by a thruster pair), with a standard deviation below
        :data:`MIN_DELTA_STD` (a yaw moment computed from a constant angle still varies with
        the speed); a constant yaw moment."""
        kind = self.kind_
        rudder = kind.constant_speed or (
            all("delta" in s for s in series) and not any("n_port" in s for s in series))
        if rudder:
            d = np.concatenate([s["delta"] for s in series])
            if np.std(d) < MIN_DELTA_STD:
                raise IdentificationError(
                    "no excitation: the rudder angle 'delta' is constant (std "
                    f"{math.degrees(np.std(d)):.3f} deg over {', '.join(s.name for s in series)}"
                    f"); a {self.kind} model needs rudder changes (zig-zag, turning entry)")
        elif all("tau_r" in s for s in series):
            tr = np.concatenate([s["tau_r"] for s in series])
            if np.std(tr) <= 1e-12 * max(np.max(np.abs(tr)), 1e-300):
                chs = [c for c in ("n_port", "n_stbd", "delta", "n") if c in series[0]]
                raise IdentificationError(
                    "no excitation: the yaw moment input"
                    + (f" (from {', '.join(repr(c) for c in chs)})" if chs else "")
                    + f" is constant (std {np.std(tr):.3g} over "
                    f"{', '.join(s.name for s in series)}); the yaw equation cannot be "
                    "identified")

    # -- fitting ---------------------------------------------------------------------------------
    def fit(self, trials: Any, *, turning: Any = None,
            psi_switch: float | None = None) -> ModelEstimator:
        """Identify the model from ``trials`` (one :class:`usvid.Trial` or a list, each
        prepared once: :func:`usvid.prep.as_prepared`); returns self. ``turning``: extra
        turning trials for the two-step Norrbin fit; ``psi_switch`` [rad]: the zig-zag
        switching angle of the trials when known (default: detected).

        Without a ``method`` the kind's methods are tried in the order they predict held-out
        data (:data:`usvid.identify.defaults.DEFAULT_METHODS`, least squares last):
        ``oe-zigzag`` only when the trials hold zig-zags, the next one when a method cannot
        fit the data or its model fails its checks (with a warning saying so); the data are
        refused before any fit when they cannot be identified from
        (:func:`usvid.identify.checks.check_data`)."""
        given = [as_prepared(tr, derivatives=False) for tr in _as_list(trials)]
        turning = [as_prepared(tr, derivatives=False) for tr in _as_list(turning)]
        for tr in (*given, *turning):
            repair_warnings(tr)
        # sensors that start late or stop early: the part where every channel is logged
        chans = kind_channels(self.kind_)
        given = [trim_to_logged(tr, chans, stacklevel=3) for tr in given]
        turning = [trim_to_logged(tr, chans, stacklevel=3) for tr in turning]
        given = self._commanded_part(given)
        trials = one_grid(split_discontinuities(given))
        if not trials:
            raise IdentificationError("no trials given")
        turning = one_grid(split_discontinuities(turning)) if turning else []
        check_data([*trials, *turning], self.kind)  # under way, a heading that responds
        # a refusal of the model says when the logs could not show the vessel under way
        self._no_speed = [tr.name or "?" for tr in trials if trial_speed(tr)[0] is None]
        if not self._auto:
            return self._fit(trials, turning, psi_switch)
        zigzags = any(g.kind == "zigzag" for tr in trials
                      for g in (find_manoeuvres(tr, psi_switch=psi_switch)
                                if tr.has("psi") else []))
        candidates = [m for m in default_methods(self.kind) if m != "oe-zigzag" or zigzags]
        if "ls" not in candidates:
            candidates.append("ls")  # the last resort: the equation-error fit itself
        if self.disturbance:  # only the output error estimates a disturbance
            candidates = ["oe"]
        wanted, failures = self.checks, []
        for m in candidates:
            self.method, self.checks = m, "error"
            try:
                self._fit(trials, turning, psi_switch)
            except IdentificationError as exc:  # this method cannot: the next one
                failures.append((m, exc))
                continue
            finally:
                self.checks = wanted
            if failures:
                why = "; ".join(f"{f}: {getattr(e, 'reason', e)}" for f, e in failures)
                warnings.warn(f"{self.kind}: {why}; identified with {m}, the next method by "
                              "held-out prediction", IdentificationWarning, stacklevel=2)
            return self
        checked = [m for m, e in failures if isinstance(e, ChecksFailed)]
        if wanted == "record" and checked:  # no model passes: the best one, failures kept
            self.method = checked[0]
            return self._fit(trials, turning, psi_switch)
        # the models that failed their checks say most: first
        failures.sort(key=lambda f: not isinstance(f[1], ChecksFailed))
        why = "; ".join(f"{m}: {getattr(e, 'reason', e)}" for m, e in failures)
        if checked:
            text = (f"no method identifies a {self.kind} model from these data that passes its "
                    f"checks ({why}). Nothing is written: try another --model, more or richer "
                    "training data (turns to both sides, the angles you will simulate), or "
                    "--accept-failed-checks to write the best one anyway")
        else:
            text = f"no method identifies a {self.kind} model from these data ({why})"
        text += self._speed_note()
        if isinstance(failures[0][1], ChecksFailed):
            raise ChecksFailed(text, failures[0][1].reason)
        raise IdentificationError(text)

    def _commanded_part(self, trials: list[PreparedTrial]) -> list[PreparedTrial]:
        """Twin thrusters (catamaran): each trial up to :data:`~usvid.identify.
        thrust_consistency.MARGIN_S` before its first stretch of way astern under thrust ahead
        on both thrusters (:mod:`usvid.identify.thrust_consistency`: the logged commands did
        not drive the boat there), with a warning; a trial whose part before it is shorter
        than :data:`~usvid.prep.segments.MIN_SEGMENT_S` is left out; none left: refused."""
        if self.kind != "catamaran" or not trials:
            return trials
        try:
            thrust = self._fixed(trials).get("thrust")
        except IdentificationError:
            return trials  # the fit says what is missing
        if thrust is None:
            return trials
        law = thrust.thrust if hasattr(thrust, "thrust") else (lambda c: float(thrust) * c)
        out, gone = [], []
        for tr in trials:
            bad = _tc.astern_under_thrust_ahead(tr, law)
            if not bad:
                out.append(tr)
                continue
            t0 = float(tr.t[0])
            end = bad[0][0] - _tc.MARGIN_S
            what = (f"trial {tr.name or '?'}: the boat moved astern while both thrusters were "
                    f"commanded ahead at {_tc.describe(bad)} (from the start of its logged "
                    "part): the logged commands did not drive it there")
            if end < MIN_SEGMENT_S:
                gone.append(what)
                warnings.warn(f"{what}; left out (less than {MIN_SEGMENT_S:g} s before it)",
                              IdentificationWarning, stacklevel=3)
                continue
            part = tr.slice_time(t0, t0 + end)
            if under_way(part).made_way is False:  # the part before it: still leaving rest
                gone.append(what)
                warnings.warn(f"{what}; left out (the {end:.1f} s before it are not under way)",
                              IdentificationWarning, stacklevel=3)
                continue
            warnings.warn(f"{what}; only its first {end:.1f} s are used", IdentificationWarning,
                          stacklevel=3)
            out.append(part)
        if not out:
            raise IdentificationError("no trial left to identify from: " + "; ".join(gone))
        return out

    def _fit(self, trials: list[PreparedTrial], turning: list[PreparedTrial],
             psi_switch: float | None) -> ModelEstimator:
        """One fit by ``self.method`` of prepared, checked trials (see :meth:`fit`). Where the
        kind names parameters to hold when the data cannot tell them from their neutral value
        (``held_when_insignificant``, e.g. the MMG propeller asymmetry), a fit that finds such
        a parameter's 95 % interval containing it is repeated with it held there; only the
        last fit's warnings are shown, after the one saying what was held and why. The output
        error of the fit again starts from the previous fit's optimum with the held parameters
        at their value (``refine_output_error(warm=...)``: the same optimum in a few
        iterations)."""
        if getattr(self.kind_.dynamics, "held_when_insignificant", None) is None:
            return self._fit_once(trials, turning, psi_switch, {})
        held: dict[str, tuple[float, str]] = {}
        warm: OEResult | None = None
        while True:
            caught: list[warnings.WarningMessage] = []
            try:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    return self._fit_once(trials, turning, psi_switch, held, warm)
            except _HoldAndRefit as again:  # the first fit's warnings are not shown
                held.update(again.drop)
                warm = again.warm
                caught = []
                for _, why in again.drop.values():
                    warnings.warn(f"{self.kind}: {why}", IdentificationWarning, stacklevel=3)
            finally:
                for w in caught:
                    warnings.warn_explicit(w.message, w.category, w.filename, w.lineno,
                                           source=w.source)

    def _fit_once(self, trials: list[PreparedTrial], turning: list[PreparedTrial],
                  psi_switch: float | None,
                  held: Mapping[str, tuple[float, str]],
                  warm: OEResult | None = None) -> ModelEstimator:
        """:meth:`_fit` with ``held``: parameters held at a value (name -> (value, why)); the
        output error warm-started from ``warm`` (an earlier fit of the same windows)."""
        kind = self.kind_
        fixed = self._fixed(trials)
        fixed.update({k: v for k, (v, _) in held.items()})
        series = self._series(trials, fixed)
        tseries = self._series(turning, fixed) if turning else []
        if len({round(s.h, 9) for s in series + tseries}) > 1:
            raise IdentificationError("trials have different sample steps after resampling")
        self._check_excitation(series)
        wf = self.wind_ = self._wind(trials, series)
        h = series[0].h
        diag: dict[str, Any] = {}
        fit_series = series
        current = None  # the regression's current per trial (usvid.identify.disturbance)
        if self.kind == "norrbin" and self.norrbin == "two_step":
            turn = [_is_turning(tr, psi_switch) for tr in trials]
            zz = [s for s, tu in zip(series, turn, strict=True) if not tu]
            tt = list(tseries) + [s for s, tu in zip(series, turn, strict=True) if tu]
            params, cov, diag = two_step_norrbin(get_kind("nomoto1"), zz, tt, h=h,
                                                 method="rls" if self.method == "rls" else "ls",
                                                 lam=self.lam, cond_max=self.cond_max)
            names = ("K", "T", "n1", "n3", "delta0")
            fit_series = zz
        else:
            reg_series = series
            h_reg = h
            if self.form == "arx":
                m = self._decimation(series[0])
                reg_series = [s.decimated(m) for s in series]
                h_reg = h * m
            if "current" in self.disturbance:
                water, *current = _dist.regression_current(
                    kind, reg_series, fixed, form=self.form, h=h_reg, cond_max=self.cond_max)
                if self.method != "oe" or max(current[2]) <= _dist.CORR_MAX:
                    reg_series = water  # (the output error's start: only a separable one)
                else:
                    diag["disturbance_start"] = (
                        "none: the regression cannot separate the current from the hull "
                        f"(correlation {max(current[2]):.3f}); the output error starts from "
                        "no current and the calm-water regression")
                    current = None
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                ee = fit_equation_error(kind, reg_series, fixed, form=self.form, h=h_reg,
                                        method="rls" if self.method == "rls" else "ls",
                                        lam=self.lam, cond_max=self.cond_max,
                                        max_lag=max(int(self.window_s / h_reg), 1))
            left_out = self._rewarn(caught, reg_series)
            params, cov, names, diag = ee.params, ee.cov, ee.names, dict(ee.diagnostics)
            if left_out:
                diag["left_out"] = left_out
        p_ls = dict(params)
        oe: OEResult | None = None
        zz_rate = None
        if self.method == "oe":
            win = self._windows(fit_series, self.window_s, self.overlap)
            params = self._valid_start(params, fixed, fit_series, diag)
            if current is not None:  # the output error starts from the regression's current
                params = {**params, **{f"{q}[{k}]": float(current[0][k, j])
                                       for k in range(len(fit_series))
                                       for j, q in enumerate(_dist.TERMS["current"])}}
            dist = _dist.disturbance_for(kind, self.disturbance,
                                         [s.name or f"trial {i + 1}"
                                          for i, s in enumerate(fit_series)])
            oe = refine_output_error(kind, params, fixed, win, channels=self.oe_channels,
                                     wind=wf.model, disturbance=dist,
                                     warm=warm if self.method == "oe" else None)
            diag["oe"] = {"cost": oe.cost, "nfev": oe.nfev, "njac": oe.njac,
                          "success": oe.success,
                          "message": oe.message, "ac_factor": oe.ac_factor, "sigma": oe.sigma,
                          "n_residuals": oe.n_residuals, "window_s": self.window_s,
                          "fit_space": dict(zip(oe.x_names, oe.x.tolist(), strict=True))}
        elif self.method == "oe-zigzag":
            zz_trials = [t for t, s in zip(trials, series, strict=True)
                         if any(s is f for f in fit_series)]
            m = self._decimation(series[0])
            runs = zigzag_runs(zz_trials, fit_series, kind, step=h * m, psi_switch=psi_switch)
            oe = refine_zigzag_oe(kind, params, fixed, runs)
            zz_rate = float(np.median([r.rate for r in runs]))
            diag["oe_zigzag"] = {"cost": oe.cost, "nfev": oe.nfev, "success": oe.success,
                                 "message": oe.message, "ac_factor": oe.ac_factor,
                                 "sigma": oe.sigma, "n_residuals": oe.n_residuals,
                                 "n_replays": len(runs),
                                 "rudder_rate_deg_s": math.degrees(zz_rate)}
        if oe is not None:
            params, cov, names = oe.params, oe.cov, oe.names
            # symmetric as a covariance must be (the propagation through the fit space and the
            # sandwich's inverse leave rounding asymmetries that the model file refuses)
            cov = 0.5 * (np.asarray(cov, float) + np.asarray(cov, float).T)
            diag["ls_params"] = p_ls
        se = standard_errors(cov)
        q = quantile975(oe.dof if oe is not None else math.inf)
        self.params_ = {n: float(params[n]) for n in names}
        self.cov_ = cov
        self.std_errors_ = dict(zip(names, se.tolist(), strict=True))
        self.ci95_ = dict(zip(names, interval95([self.params_[n] for n in names], se,
                                                q).tolist(), strict=True))
        diag["ci95_quantile"] = q
        insignificant = getattr(kind.dynamics, "held_when_insignificant", None)
        drop = (insignificant(self.params_, self.ci95_, fixed) if insignificant is not None
                else {})
        if drop:  # e.g. the MMG propeller asymmetry: the data show none; fit without it
            raise _HoldAndRefit(drop, oe if self.method == "oe" else None)
        if held:
            diag["held_insignificant"] = {k: why for k, (_, why) in held.items()}
        weak = self._warn_weak(names, se, q)
        if weak:
            diag["warnings"] = [weak]
        self._wind_scale(wf, oe, q, diag)
        dist_out = None
        if current is not None and oe is None:  # the regression's current: reported
            dist_out = _dist.regression_report([s.name for s in fit_series], *current, q,
                                               self.kind)
            if dist_out["warning"]:
                diag.setdefault("warnings", []).append(dist_out["warning"])
        elif current is not None:  # the output error's start
            diag["disturbance_start"] = {
                s.name: dict(zip(_dist.TERMS["current"], current[0][k].tolist(), strict=True))
                for k, s in enumerate(fit_series)}
        if oe is not None and oe.disturbance is not None:
            dist_out = _dist.report(oe.disturbance, oe.x, oe.x_names, oe.x_cov, q,
                                    oe.free_names, self.kind)
            if dist_out["warning"]:
                diag.setdefault("warnings", []).append(dist_out["warning"])
        try:
            dyn = kind.dynamics(**{**fixed, **self.params_})
        except UsvidError as exc:
            hint = (" (a negative T means a course-unstable vessel: use --model norrbin)"
                    if self.kind == "nomoto1" and self.params_.get("T", 1) <= 0 else "")
            hint += self._out_of_bounds(names, se, q)
            raise IdentificationError(f"identified {self.kind} parameters are not a valid "
                                      f"model: {exc}{hint}") from exc
        vessel = _vessel(trials)
        speed = training_speed(trials, psi_switch) if vessel.speed is None else None
        if speed is not None:
            vessel = dataclasses.replace(vessel, extra=dict(vessel.extra), speed=speed)
        if wf.model is not None:  # the identified scale of the wind loads: the model's own
            vessel = dataclasses.replace(vessel, extra={**vessel.extra,
                                                        "wind_scale": wf.wind_scale})
        servo, servo_diag = self._servo(trials, zz_rate, vessel, psi_switch)
        if servo_diag:
            diag["servo"] = servo_diag
        self.series_ = series
        # (the passes' Jacobians are for a warm fit only: not kept with the model)
        self.oe_ = oe if oe is None else dataclasses.replace(oe, pass_jacobians=())
        self.fixed_ = fixed
        model = VesselModel(dyn, servo=servo, vessel=vessel)
        # the training trials replayed in the conditions they were fitted in: the logged wind
        # (the model's) and the current / biases estimated per trial
        water = None
        if oe is not None and oe.disturbance is not None:
            water = _dist.TrialWater(oe.disturbance.quantities,
                                     oe.disturbance.values(oe.x, oe.x_names))
        elif current is not None:
            water = _dist.TrialWater(_dist.TERMS["current"], current[0])
        if water is not None and len(fit_series) != len(series):
            water = None  # (no kind that carries a disturbance fits a part of the trials)
        # what score and simulate replay a training log in (usvid.identify.disturbance)
        self.water_ = water
        self.water_logs_ = [_log_key(s) for s in series]
        self.fit_ = self._metrics(model, series, water)
        # every log the model was identified from: the turning trials of the two-step Norrbin
        # fit too (its alpha comes from them)
        self.data_ = [{"file": str(src), "sha256": _sha256(str(src))}
                      for tr in [*trials, *turning] for src in (tr.sources or [tr.name])]
        opts: dict[str, Any] = {"form": self.form, "smooth_s": self.smooth_s,
                                "window_s": self.window_s, "overlap": self.overlap,
                                "step_s": series[0].h * self._decimation(series[0])}
        if self.kind == "norrbin":
            opts["norrbin"] = self.norrbin
        if self.method == "rls":
            opts["lam"] = self.lam
        if self.disturbance:
            opts["disturbance"] = list(self.disturbance)
        result = IdentifiedModel(
            kind=self.kind, method=self.method, params=self.params_,
            std_errors=self.std_errors_, ci95=self.ci95_, cov=cov, fit=self.fit_, model=None,
            data=self.data_, options=opts, diagnostics=diag,
            wind=wf.to_dict() if wf.trials else None,  # only where the logs carry the wind
            disturbance=dist_out)
        # the model identification returns: checked (usvid.identify.checks)
        self.checks_ = check_model(model, trials, self.fit_)
        result.checks = [c.to_dict() for c in self.checks_]
        model.identification = result.identification()
        self.model_ = model
        result.model = model
        self.result_ = result
        if failed(self.checks_):
            if self.checks == "error":
                raise ChecksFailed(refusal(self.kind, self.method, self.checks_)
                                   + self._speed_note(),
                                   "; ".join(c.message for c in failed(self.checks_)))
            warnings.warn(refusal(self.kind, self.method, self.checks_).split(". It is not")[0]
                          + "; written anyway (identification.checks)", IdentificationWarning,
                          stacklevel=2)
        return self

    @staticmethod
    def _rewarn(caught: Sequence[warnings.WarningMessage],
                series: Sequence[Series]) -> list[str]:
        """Warn again what the regression said, with the trial's name for its position in a
        :class:`~usvid.models.kind.LeftOutWarning` (as an :class:`IdentificationWarning`);
        returns those texts (the samples left out, for the diagnostics)."""
        out = []
        for w in caught:
            msg = str(w.message)
            if issubclass(w.category, LeftOutWarning):
                for i, s in enumerate(series):
                    msg = msg.replace(f"trial {i + 1} of {len(series)}:", f"trial {s.name}:")
                out.append(msg)
                warnings.warn(msg, IdentificationWarning, stacklevel=4)
            else:
                warnings.warn(w.message, w.category, stacklevel=4)
        return out

    def _valid_start(self, params: dict[str, float], fixed: dict[str, Any],
                     series: Sequence[Series], diag: dict[str, Any]) -> dict[str, float]:
        """The output error's start: the least-squares estimate when it is a valid model; else
        the regression's physical priors (the kind's ``Regression.priors``: for mmg Kijima et al.
        1990 and the ITTC 1957 friction line) for the coefficients the regression estimates,
        or, for a kind without priors, every parameter outside its bounds moved just inside
        them; said in a warning. The output error then fits from a valid model (it never leaves
        the bounds) instead of refusing the start."""
        specs = {p.name: p for p in self.kind_.dynamics.param_specs()}
        bad = []
        for n, v in params.items():
            try:
                if n in specs:
                    specs[n].check("parameters", v)
            except UsvidError:
                bad.append(f"{n} = {v:.4g}")
        if not bad:
            return params
        reg = self.kind_.regression
        if reg is not None and reg.priors is not None:
            pri = reg.priors([s.data for s in series], fixed)
            out = {**params, **{k: float(v) for k, v in pri.items() if k in params}}
            how = "the output error starts from the regression's priors"
        else:
            out = dict(params)
            for n, v in params.items():
                sp = specs.get(n)
                for b, side in (() if sp is None else
                                ((sp.ge, 1), (sp.gt, 1), (sp.le, -1), (sp.lt, -1))):
                    if b is not None and (v - b) * side < 0:
                        # just inside (a thousandth of the excursion): the fit space's round
                        # trip of a value on the bound may leave it by rounding
                        out[n] = float(b + side * max(1e-3 * abs(v - b),
                                                      1e-9 * max(abs(b), 1.0)))
            how = "the output error starts just inside the bounds"
        text = (f"{self.kind}: the least-squares estimate is not a valid model ({'; '.join(bad)}"
                f"); {how}")
        warnings.warn(text, IdentificationWarning, stacklevel=4)
        diag["oe_start"] = {"invalid_ls": bad, "start": how}
        return out

    def _wind_scale(self, wf: WindFit, oe: OEResult | None, q: float,
                    diag: dict[str, Any]) -> None:
        """Set ``wf``'s wind_scale from the output error (with its interval), or hold it at 1
        saying why: least squares takes the wind's loads as known (scale 1); an output-error
        interval that spans zero or is wider than the value means the data cannot separate
        the wind's loads from the hull's."""
        if wf.model is None:
            return
        held = None
        if oe is None or oe.wind_scale is None:
            held = (f"method {self.method} takes the logged wind's loads as known (wind_scale 1);"
                    " output error (method oe) estimates it")
        elif not (math.isfinite(oe.wind_scale_se) and oe.wind_scale_se > 0
                  and q * oe.wind_scale_se < abs(oe.wind_scale)):
            held = (f"the data cannot separate the wind's loads from the hull's (wind_scale "
                    f"{oe.wind_scale:.3g} +- {q * oe.wind_scale_se:.3g}, 95 %)")
        if held is None:
            wf.wind_scale, wf.std_error = float(oe.wind_scale), float(oe.wind_scale_se)
            wf.ci95 = interval(wf.wind_scale, wf.std_error, q)
            wf.held = ""
            return
        wf.wind_scale, wf.std_error, wf.ci95, wf.held = 1.0, 0.0, [1.0, 1.0], held
        if oe is not None and oe.wind_scale is not None and oe.wind_scale != 1.0:
            wf.held += "; the other parameters are those of the fit with it free"
        text = f"{self.kind}: wind_scale held at 1: {held}"
        warnings.warn(text, IdentificationWarning, stacklevel=4)
        diag.setdefault("warnings", []).append(text)

    def _speed_note(self) -> str:
        """What a refusal adds when some training logs hold no speed at all."""
        names = getattr(self, "_no_speed", [])
        if not names:
            return ""
        return (f" (no speed (u, U, sog) and no positions in {', '.join(names[:3])}"
                f"{', ...' if len(names) > 3 else ''}: usvid cannot tell that the vessel was "
                "under way; at the dock or on the bench nothing can be identified)")

    def _servo(self, trials: Sequence[Trial], zz_rate: float | None, vessel: Vessel,
               psi_switch: float | None = None) -> tuple[Any, dict[str, Any]]:
        if self.servo not in (None, "auto"):
            return self.servo, {}
        both = [tr for tr in trials if tr.has("delta_cmd") and tr.has("delta")]
        fits, errors = [], []
        # the helm's rate limit (the vessel's, else measured on the rudder's ramps): each trial's
        # servo is also fitted behind it, and the form that reproduces the rudder better kept
        # (a rate-limited helm read by a linear servo is too quick in small orders and too slow
        # in large ones: identify.servo's module docstring)
        rate_lim, rate_src = (helm_rate(vessel, [(tr.t, tr["delta"]) for tr in both]) if both
                              else (None, ""))
        for tr in both:
            dt = float(np.median(np.diff(tr.t)))
            u, y = tr["delta_cmd"], tr["delta"]
            ok = np.isfinite(u) & np.isfinite(y)
            if ok.sum() < 50 or np.ptp(u[ok]) < 2 * MIN_DELTA_STD:
                continue  # no steering to fit the servo on
            try:
                idx = np.arange(ok.size)
                u = np.interp(idx, idx[ok], u[ok])
                y = np.interp(idx, idx[ok], y[ok])
                sl = _most_active(u, dt, SERVO_WINDOW_S)
                fits.append((_servo_fit(u[sl], y[sl], dt), tr.name))
                if rate_lim is not None:
                    fits.append((_servo_fit(u[sl], y[sl], dt, rate_lim), tr.name))
            except UsvidError as exc:
                errors.append(f"{tr.name}: {exc}")
        if fits:
            # the trial the servo model fits best, relative to its rudder motion
            best, name = min(fits, key=lambda f: f[0].fit.nrmse)
            limited = ({"max_rate_deg_s": math.degrees(best.max_rate), "rate_from": rate_src}
                       if math.isfinite(best.max_rate) else {})
            return best.servo, {"identified_from": name,
                                "candidates": list(dict.fromkeys(f[1] for f in fits)),
                                **{k: v for k, v in best.to_dict().items()
                                   if k in ("omega_n", "zeta", "gain", "delay", "std_errors",
                                            "fit")}, **limited}
        if errors:
            warnings.warn(f"servo not identified ({'; '.join(errors)}); an ideal servo is used",
                          IdentificationWarning, stacklevel=3)
        if zz_rate is not None:
            rate, source = zz_rate, "zig-zag replay fit"
        else:
            rate, source = helm_rate(vessel, [(tr.t, tr["delta"]) for tr in trials
                                              if tr.has("delta")])
        if rate is None:
            return IdealServo(), {}
        if self.kind_.state_estimation and zz_rate is None:
            helm = helm_from_zigzags(_reversal_windows(trials, rate, psi_switch), rate)
            if helm is not None:
                s = helm.servo
                return s, {"kind": "second_order", "max_rate_deg_s": math.degrees(rate),
                           "rate_from": source, "omega_n": s.omega_n, "zeta": s.zeta,
                           "delay": s.delay, "identified_from": "zig-zag reversals",
                           "n_reversals": helm.n_reversals,
                           "rms_deg": math.degrees(helm.rms)}
        return IdealServo(max_rate=rate), {"kind": "ideal", "max_rate_deg_s": math.degrees(rate),
                                           "rate_from": source}

    def _out_of_bounds(self, names: Sequence[str], se: np.ndarray, q: float) -> str:
        """Why identified parameters break their bounds (a negative mass, inertia or
        damping): each with its 95 % interval, which says whether the data determine it."""
        specs = {p.name: p for p in self.kind_.dynamics.param_specs()}
        bad = []
        for n, e in zip(names, se, strict=True):
            v = self.params_[n]
            try:
                specs[n].check("parameters", v)
            except (UsvidError, KeyError):
                wide = not math.isfinite(e) or q * e > abs(v)
                bad.append(f"{n} = {v:.4g} +- {q * e:.3g} (95 %): "
                           + ("the data do not determine it (its interval spans zero)" if wide
                              else "the data contradict the model's form (e.g. a sway or yaw "
                              "equation without excitation, or the wrong kind)"))
        if not bad:
            return ""
        return ("; " + "; ".join(bad) + "; it is not returned: give more excitation (turns to "
                "both sides, speed changes) or fix the particulars")

    def _warn_weak(self, names: Sequence[str], se: np.ndarray, q: float) -> str | None:
        """Warn when a parameter's 95 % half-width ``q se`` exceeds half its magnitude
        (REL_WEAK): nearly collinear regressors or too little excitation leave it
        undetermined. The offset ``delta0`` and the sign ``n1`` are not checked. Returns the
        warning's text (kept in the diagnostics for the report), None when there is none."""
        weak = []
        for n, e in zip(names, se, strict=True):
            v = self.params_[n]
            if n in ("delta0", "n1") or not math.isfinite(e):
                continue
            if q * e > REL_WEAK * abs(v):
                weak.append(f"{n} = {v:.4g} +- {q * e:.3g}")
        if weak:
            text = (f"{self.kind}: poorly determined parameter(s) {'; '.join(weak)} (95 %): the "
                    "data do not separate their effects (nearly collinear regressors or too "
                    "little excitation); use sharper rudder changes (zig-zags) or a simpler "
                    "model")
            warnings.warn(text, IdentificationWarning, stacklevel=3)
            return text
        return None

    # -- use -------------------------------------------------------------------------------------
    def _metrics(self, model: VesselModel, series: Sequence[Series],
                 water: _dist.TrialWater | None = None) -> dict[str, Any]:
        """Windowed (``window_s``) and free-run fit metrics of ``model`` on ``series``: replays
        through the integration core (:func:`usvid.sim.replay.replay_windows`), each trial in
        its logged wind and, with ``water`` (the current and biases estimated per trial,
        :class:`usvid.identify.disturbance.TrialWater`), in its estimated current and biases,
        as the fit simulated it (the windows started from the velocities through the
        water)."""
        if water is not None:
            series = water.through(series)
        env = None if water is None else water.environment
        out: dict[str, Any] = {"window_s": self.window_s}
        out.update(_replay_metrics(model, self._windows(series, self.window_s), env))
        out["free_run"] = _replay_metrics(model, self._windows(series, None), env)
        return out

    def water_of(self, series: Sequence[Series]
                 ) -> tuple[_dist.TrialWater | None, list[dict[str, Any]]]:
        """The water the trials of ``series`` (:func:`usvid.identify.series.trial_series`) are
        replayed in after this fit (:func:`usvid.identify.disturbance.water_for`): a training
        log (the same record, or the same name over the part the fit used) in the current and
        biases estimated for it, any other (a held-out log) in calm water; with one row per
        trial saying which (none after a fit without a disturbance: all calm, as fitted)."""
        fitted = getattr(self, "water_", None)
        if fitted is None:
            return None, []
        return _dist.water_for([_log_key(t) for t in series], fitted, self.water_logs_)

    def score(self, trials: Any, *, window_s: float | None = -1.0) -> dict[str, Any]:
        """Fit metrics (RMSE, NRMSE, R^2, max error per output channel) on ``trials``; RMSE and
        max error in the channel's SI unit (psi [rad], r [rad/s], u, v [m/s]).

        ``window_s``: -1 (default) the estimator's multiple-shooting window; ``None`` a free run
        over each whole trial from its measured initial state; a number that window [s].

        After a fit with a disturbance (``disturbance="current"``, ``"bias"``) each training log
        is replayed in the current and biases estimated for it, as the fit's own metrics are,
        and any other log in calm water (:meth:`water_of`); ``replay_water`` then holds one row
        per trial saying which (``trial``, ``water``: "estimated" or "calm", ``why``, the
        values).
        """
        model = self.model_
        series = self._series(one_grid(_as_list(trials)), self.fixed_)
        w = self.window_s if window_s == -1.0 else window_s
        out: dict[str, Any] = {"window_s": w}
        water, rows = self.water_of(series)
        if water is not None:
            series = water.through(series)
        win = self._windows(series, w)
        out.update(replay_metrics(replay_windows(
            model, win, wind=self.wind_.model is not None,
            environment=None if water is None else water.environment(win)), win.outputs))
        if rows:
            out["replay_water"] = rows
        return out

    def simulate(self, trial: Any, *, window_s: float | None = None) -> Trial:
        """Replay ``trial``'s measured inputs on the identified model (a free run from its
        measured initial state, or re-initialised every ``window_s`` seconds). Returns a
        :class:`usvid.Trial` with the simulated outputs on the replay grid and the measured
        inputs; ``meta["measured"]`` holds the measured outputs. After a fit with a disturbance
        a training log is replayed in its estimated current and biases, another log in calm
        water, as :meth:`score`; ``meta["replay_water"]`` says which."""
        model = self.model_
        tr = one_grid(_as_list(trial))[0]
        s = self._series([tr], self.fixed_)
        water, rows = self.water_of(s)
        win = self._windows(s if water is None else water.through(s), window_s)
        sim = replay_windows(model, win, wind=self.wind_.model is not None,
                             environment=None if water is None else water.environment(win))
        m = self._decimation(s[0])
        t = s[0]["t"][::m]
        cols: dict[str, np.ndarray] = {"t": t}
        W = win.width
        for ch, arr in sim.items():
            full = np.full(len(t), np.nan)
            for b, k in enumerate(win.start):
                full[k:k + W] = arr[b][:len(t) - k]
            cols[ch] = full
        for k in win.inputs:
            cols[k] = s[0][k][::m]
        meas = {ch: s[0][ch][::m] for ch in sim}
        meta: dict[str, Any] = {"measured": meas, "params": self.params_}
        if rows:
            meta["replay_water"] = rows[0]
        return Trial(data=pd.DataFrame(cols), vessel=tr.vessel, sources=list(tr.sources),
                     name=f"sim:{tr.name}", meta=meta)

    def to_dict(self) -> dict[str, Any]:
        """The model file (dict) of the fitted model."""
        return self.result_.to_dict()


#: Servo fits by their input (digest of the command and response windows and the step):
#: several kinds fitted to the same trials (the demo, :func:`compare_kinds`) fit the servo once.
_SERVO_FITS: dict[bytes, Any] = {}
_SERVO_FITS_MAX = 32


def _servo_fit(u: np.ndarray, y: np.ndarray, dt: float, max_rate: float = math.inf) -> Any:
    """:func:`identify_second_order_servo` of ``(u, y, dt)`` behind the rate limit
    ``max_rate`` [rad/s] (a copy of an earlier fit of the same arrays when there is one: the
    fit is deterministic)."""
    key = hashlib.sha256(np.ascontiguousarray(u, dtype=float).tobytes() + b"|"
                         + np.ascontiguousarray(y, dtype=float).tobytes() + b"|"
                         + np.float64(dt).tobytes() + np.float64(max_rate).tobytes()).digest()
    fit = _SERVO_FITS.get(key)
    if fit is None:
        fit = identify_second_order_servo(u, y, dt, max_rate=max_rate)
        while len(_SERVO_FITS) >= _SERVO_FITS_MAX:
            _SERVO_FITS.pop(next(iter(_SERVO_FITS)))
        _SERVO_FITS[key] = fit
    return copy.deepcopy(fit)


def _log_key(series: Series) -> tuple[str, float, float, str]:
    """:func:`usvid.identify.disturbance.log_key` of a trial's series."""
    return _dist.log_key(series.name, series["t"], series["psi"])


def _replay_metrics(model: VesselModel, win: Windows,
                    environment: Any = None) -> dict[str, Any]:
    """RMSE, NRMSE, R^2, max error per output of ``model`` replaying ``win``
    (:func:`usvid.identify.metrics.replay_metrics`: a replay that diverged gives infinite
    errors); ``environment`` (None: none) maps the windows to their further core series
    (:func:`usvid.sim.replay.replay_windows`)."""
    extra = None if environment is None else environment(win)
    return replay_metrics(replay_windows(model, win, environment=extra), win.outputs)


def identify(trials: Any, kind: str, method: str | None = None, *, turning: Any = None,
             **options: Any) -> IdentifiedModel:
    """Functional form: ``ModelEstimator(kind, method, **options).fit(trials).result_``."""
    return ModelEstimator(kind, method, **options).fit(trials, turning=turning).result_


#: ``usvid.identify.fit(trials, kind, method) -> IdentifiedModel``.
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
