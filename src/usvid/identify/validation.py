"""Validation of a model on measured logs: the manoeuvre found in each log, its measured metrics,
the model's prediction of the same manoeuvre, and a free-run replay of the measured inputs.

For every trial (Mu et al. 2018, section 5.2, validate the identified models by simulating the
trials' manoeuvres and comparing them with the measured ones):

* **manoeuvre**: the first zig-zag or turning circle found by
  :func:`usvid.manoeuvres.find_manoeuvres` ("other" when there is none); **measured**: its
  metrics by :func:`usvid.manoeuvres.manoeuvre_metrics` (the keys of ``usvid metrics``).
* **predicted**: the same manoeuvre simulated on the model in closed loop, as ``usvid simulate``
  runs it (:func:`usvid.sim.run_zigzag` / :func:`usvid.sim.run_turning`; the model's own servo,
  which carries the helm rate identification chose), with the detected rudder amplitude (the
  commanded level), switching angle and first side, from the segment's measured approach
  (:func:`usvid.manoeuvres.detect.approach`: mean ``U`` over the
  :data:`~usvid.manoeuvres.detect.APPROACH_S` before the execute) and, for a model with a shaft
  speed ``n``, the measured mean shaft speed there. ``settings`` holds these values, so
  ``usvid simulate zigzag MODEL --delta-deg A --psi-deg S --speed U --t-end D`` reproduces the
  prediction (a zig-zag is simulated over the measured one's duration D). A log without a
  speed is predicted at the model's approach speed, and the row's ``messages`` say so.
* **error**: predicted minus measured, key by key (lists element by element, as long as both).
* **in its own conditions** (new keys; ``predicted`` and ``error`` stay the calm-water
  prediction): ``conditions`` the run's logged wind and the current estimated from its approach
  before the execute (:mod:`usvid.identify.conditions`: what each came from, or why it is
  missing), ``predicted_in_conditions`` the same manoeuvre simulated in them (same settings;
  with a current, from the model's speed through the water) and ``error_in_conditions``
  (predicted in conditions minus measured); both None when neither wind nor current is known.
* **replay**: the measured rudder (and shaft speed / thruster commands) replayed on the model
  as one free run from the measured initial state (:mod:`usvid.sim.replay`, servo bypassed):
  RMS of the heading error [deg], yaw-rate error [deg/s], speed error [m/s] (the free-run fit
  metrics of :func:`usvid.identify.metrics.replay_metrics`, the estimator's own definition: a
  replay that diverged has an infinite RMS and ``diverged_at_s`` says when) and the RMS and
  largest distance between the measured and the replayed track [m]
  (e_track = sqrt((x - x_hat)^2 + (y - y_hat)^2)). A log with wind is replayed in its logged
  wind through the model's wind loads, as the windowed metrics and the fit
  (:func:`usvid.sim.replay.logged_wind`; ``wind`` says which air the replay ran in and why).
* **metrics**: the windowed fit metrics of the replay (multiple shooting over ``window_s``, the
  model's identification window; per output channel rmse, nrmse, r2, max_error in SI units),
  as the estimator reports them for its training data.
* **replay_water** (a model identified with a disturbance, ``--disturbance``): the water the
  replay ran in. A training log of the fit (``identify --report``) is replayed in the current
  and biases estimated for it, as the fit's own metrics
  (:meth:`usvid.identify.estimator.ModelEstimator.water_of`); any other log in calm water:
  nothing estimates its current or biases over the whole record (a mean of the training logs'
  would assume the runs shared their water), and the row says so (``water`` "estimated" or
  "calm", ``why``, the values). The manoeuvre's ``predicted_in_conditions`` uses the current
  estimated from the run's own approach.

One :class:`TrialValidation` per trial; its :meth:`~TrialValidation.to_dict` is the JSON row of
``usvid validate``, ``usvid identify --validate``, ``usvid batch`` and the report. The trial is
prepared once (:func:`usvid.prep.as_prepared`); its segments and series are the ones the
estimator used.

Units: SI and radians inside; the dictionaries carry degrees in their key names.
"""

from __future__ import annotations

import copy
import dataclasses
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.identify import thrust_consistency as _tc
from usvid.identify.conditions import run_conditions
from usvid.identify.disturbance import CALM, TrialWater
from usvid.identify.metrics import diverged_at, replay_metrics
from usvid.identify.series import trial_series
from usvid.identify.span import kind_channels, logged_span
from usvid.manoeuvres import find_manoeuvres, manoeuvre_metrics
from usvid.manoeuvres.detect import Segment, approach
from usvid.models.model import VesselModel
from usvid.models.registry import kind_of
from usvid.models.uncertainty import Uncertainty
from usvid.prep.prepare import PreparedTrial, as_prepared
from usvid.sim.replay import Windows, logged_wind, make_windows, replay_windows, window_lanes
from usvid.sim.runs import run_turning, run_zigzag
from usvid.sim.simulate import approach_speed
from usvid.trial import Trial

__all__ = ["TrialValidation", "ValidationResult", "validate_model", "validate_trial",
           "metric_error", "replay_band"]

#: Metric keys compared in ``error`` (those of ``usvid metrics`` and ``usvid simulate``).
ZIGZAG_KEYS = ("overshoot_deg", "period_s", "initial_turning_time_s", "time_to_check_yaw_s")
TURNING_KEYS = ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m",
                "steady_yaw_rate_rad_s", "steady_speed_m_s")
#: Step [s] of the replays (the log step when coarser): the estimator's output-error step.
REPLAY_STEP = 0.1


@dataclass
class TrialValidation:
    """The validation of a model on one trial (module docstring). ``series`` holds the time
    series for figures (``t`` [s], measured and replayed ``psi`` [rad], ``r`` [rad/s], ``x``,
    ``y`` [m]; predicted manoeuvre ``t_pred``, ``psi_pred``, ``x_pred``, ``y_pred``; predicted
    in the run's conditions ``t_env``, ``psi_env``, ``x_env``, ``y_env``; the logged true wind
    ``t_wind`` [s from the execute], ``speed_wind`` [m/s], ``dir_wind`` [rad, from]); it is not
    part of :meth:`to_dict`."""

    trial: str
    manoeuvre: str
    measured: dict[str, Any] = field(default_factory=dict)
    predicted: dict[str, Any] = field(default_factory=dict)
    error: dict[str, Any] = field(default_factory=dict)
    replay: dict[str, Any] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    file: str | None = None
    messages: list[str] = field(default_factory=list)
    metrics: dict[str, Any] = field(default_factory=dict)
    series: dict[str, Any] = field(default_factory=dict, repr=False)
    conditions: dict[str, Any] | None = None
    predicted_in_conditions: dict[str, Any] | None = None
    error_in_conditions: dict[str, Any] | None = None
    replay_water: dict[str, Any] | None = None
    #: The current and biases the replay ran in (None: calm water); not part of to_dict.
    water: Any = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The JSON row: ``trial``, ``file``, ``manoeuvre``, ``measured``, ``predicted``,
        ``error``, ``replay``, ``settings``, ``messages``, ``conditions``,
        ``predicted_in_conditions``, ``error_in_conditions``, when a window is known,
        ``metrics`` (the windowed fit metrics, labelled by their ``window_s``) and, for a model
        identified with a disturbance, ``replay_water``."""
        d = {f.name: copy.deepcopy(getattr(self, f.name)) for f in dataclasses.fields(self)
             if f.name not in ("series", "water")}
        if not d["metrics"]:
            del d["metrics"]
        if d["replay_water"] is None:
            del d["replay_water"]
        return d


@dataclass
class ValidationResult:
    """The validation of a model on several trials: ``rows`` (one :class:`TrialValidation`
    each). ``to_dict()`` is the ``--json`` object of ``usvid validate``."""

    rows: list[TrialValidation]
    model_kind: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"validation": [r.to_dict() for r in self.rows]}

    def _repr_html_(self) -> str:
        head = ("<tr><th>trial</th><th>manoeuvre</th><th>metric</th><th>measured</th>"
                "<th>predicted</th><th>error</th></tr>")
        body = []
        for r in self.rows:
            keys = ZIGZAG_KEYS if r.manoeuvre == "zigzag" else TURNING_KEYS
            for k in keys:
                if k in r.measured:
                    body.append("<tr>" + "".join(
                        f"<td>{html.escape(short_value(v))}</td>" for v in (
                            r.trial, r.manoeuvre, k, r.measured.get(k), r.predicted.get(k),
                            r.error.get(k))) + "</tr>")
            for k, v in r.replay.items():
                if isinstance(v, float):
                    body.append(f"<tr><td>{html.escape(r.trial)}</td><td>replay</td>"
                                f"<td>{html.escape(k)}</td><td colspan=3>"
                                f"{short_value(v)}</td></tr>")
        return (f"<table><caption>validation of a {html.escape(self.model_kind)} model"
                f"</caption>{head}{''.join(body)}</table>")


def short_value(v: Any) -> str:
    """A metric value for a table: 4 significant digits, the first 3 items of a list, "-" for
    None or a non-finite number."""
    if isinstance(v, float):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    if isinstance(v, list):
        return ", ".join(short_value(x) for x in v[:3]) + (" ..." if len(v) > 3 else "")
    return "-" if v is None else str(v)


def metric_error(predicted: dict[str, Any], measured: dict[str, Any],
                 keys: Sequence[str]) -> dict[str, Any]:
    """Predicted minus measured for each of ``keys`` present in both (lists element by
    element, as long as the shorter one; NaN where either is not a finite number)."""
    out: dict[str, Any] = {}
    for k in keys:
        if k not in predicted or k not in measured:
            continue
        p, m = predicted[k], measured[k]
        if isinstance(p, list) and isinstance(m, list):
            out[k] = [float(a) - float(b) for a, b in zip(p, m, strict=False)]
        elif isinstance(p, int | float) and isinstance(m, int | float):
            out[k] = float(p) - float(m) if math.isfinite(p) and math.isfinite(m) else math.nan
    return out


def _with_inputs(model: VesselModel, n: float | None) -> VesselModel:
    """``model`` with its nominal shaft speed ``n`` [rps] replaced by the measured one."""
    dyn = model.dynamics
    if n is None or not hasattr(dyn, "n") or not math.isfinite(n) or n <= 0:
        return model
    return VesselModel(dataclasses.replace(dyn, n=float(n)), servo=model.servo,
                       vessel=model.vessel)


def _predict(model: VesselModel, seg: Segment, out: TrialValidation,
             trial: PreparedTrial | None = None) -> None:
    ap = seg.approach
    u0 = ap.speed if ap is not None and ap.speed is not None and ap.speed > 0 else None
    if u0 is None:
        u0 = float(approach_speed(model, None))
        out.messages.append(f"no speed logged before the execute: predicted at the model's "
                            f"approach speed {u0:.4g} m/s")
    n = ap.shaft_speed if ap is not None else None
    m = _with_inputs(model, n)
    rudder = seg.command.startswith("delta") and seg.level is not None
    if not rudder:
        out.messages.append("no rudder command: the manoeuvre is not predicted")
        return
    amp_deg = math.degrees(float(seg.level))
    rate = float(model.servo.max_rate)
    out.settings = {"delta_deg": amp_deg, "first": seg.side, "speed_m_s": u0,
                    "shaft_speed_rps": n if m is not model else None,
                    "rudder_rate_deg_s": math.degrees(rate) if math.isfinite(rate) else None}
    if seg.kind == "zigzag":
        psi_deg = math.degrees(float(seg.psi_switch))
        # over the measured manoeuvre's duration, so both show the same cycles (a mean period
        # over more cycles would differ by the first cycle's transient)
        t_end = round(seg.t_end - seg.t_execute, 2)
        out.settings.update(psi_deg=psi_deg, t_end_s=t_end)
        res, zm = run_zigzag(m, amp_deg, psi_deg, first=seg.side, u0=u0, t_end=t_end)
        out.predicted = zm.to_dict()
        keys = ZIGZAG_KEYS
        psi = res["psi"][0]
        out.series.update(t_pred=np.asarray(res.t), psi_pred=seg.side * psi)
    else:
        res, tm = run_turning(m, seg.side * amp_deg, u0=u0)
        out.predicted = tm.to_dict()
        keys = TURNING_KEYS
        out.series.update(t_pred=np.asarray(res.t), psi_pred=res["psi"][0])
    if "x" in res.channels:
        out.series.update(x_pred=res["x"][0], y_pred=res["y"][0])
    out.error = metric_error(out.predicted, out.measured, keys)
    if trial is not None:
        _predict_in_conditions(m, seg, out, trial, u0, keys)


def _predict_in_conditions(m: VesselModel, seg: Segment, out: TrialValidation,
                           trial: PreparedTrial, u0: float, keys: Sequence[str]) -> None:
    """The prediction in the run's own conditions (module docstring) beside the calm one."""
    cond = run_conditions(trial, float(seg.t_execute), m)
    out.conditions = cond.to_dict()
    if not cond.known:
        return
    psi = trial["psi"]
    ok = np.isfinite(psi)
    psi0 = float(np.interp(seg.t_execute, trial.t[ok], np.unwrap(psi[ok])))
    env = cond.environment(psi0)
    if cond.current is not None:
        u0 = float(cond.current["water_speed_m_s"])
    s = out.settings
    try:
        if seg.kind == "zigzag":
            res, zm = run_zigzag(m, s["delta_deg"], s["psi_deg"], first=seg.side, u0=u0,
                                 t_end=s["t_end_s"], environment=env)
            out.predicted_in_conditions = zm.to_dict()
            out.series.update(t_env=np.asarray(res.t), psi_env=seg.side * res["psi"][0])
        else:
            res, tm = run_turning(m, seg.side * s["delta_deg"], u0=u0, environment=env)
            out.predicted_in_conditions = tm.to_dict()
            out.series.update(t_env=np.asarray(res.t), psi_env=res["psi"][0])
    except UsvidError as exc:
        out.messages.append(f"prediction in the run's conditions: {exc}")
        return
    if "x" in res.channels:
        out.series.update(x_env=res["x"][0], y_env=res["y"][0])
    if cond.wind_speed is not None:  # [s from the execute], [m/s], [rad, from]
        out.series.update(t_wind=cond.t, speed_wind=cond.wind_speed,
                          dir_wind=np.remainder(cond.wind_dir, 2 * np.pi))
    out.conditions["speed_m_s"] = u0
    out.conditions["heading_at_execute_deg"] = math.degrees(psi0) % 360.0
    out.error_in_conditions = metric_error(out.predicted_in_conditions, out.measured, keys)


@dataclass
class _FreeRun:
    """A trial's replay material: the kind, the decimated series, its windows (one free run,
    or ``window_s`` windows) and the speed [m/s] a constant-speed kind is packed with."""

    kind: Any
    dec: dict[str, np.ndarray]
    h: float
    speed: float
    water: TrialWater | None = None

    def environment(self, win: Windows) -> dict[str, np.ndarray] | None:
        """The core series of ``win`` in the replay's water (None: calm)."""
        return None if self.water is None else self.water.environment(win)


def _series(model: VesselModel, trial: PreparedTrial) -> Any:
    """The trial's series for ``model``'s kind (:func:`usvid.identify.series.trial_series`,
    remembered by the prepared trial), with the model's fixed particulars."""
    fixed = {p.name: getattr(model.dynamics, p.name)
             for p in type(model.dynamics).param_specs() if not p.fit}
    return trial_series(trial, kind_of(model.dynamics), fixed=fixed)


def _free_run(model: VesselModel, trial: PreparedTrial,
              water: TrialWater | None = None) -> _FreeRun:
    """The replay material of ``trial``; ``water``: its current and biases (None: calm), the
    windows then start from the velocities through the water
    (:meth:`usvid.identify.disturbance.TrialWater.through`)."""
    kind = kind_of(model.dynamics)
    s = _series(model, trial)
    if water is not None:
        s = water.through([s])[0]
    step = max(int(round(REPLAY_STEP / s.h)), 1)
    dec = s.decimated(step).data
    speed = None
    if kind.constant_speed:  # the measured speed carries the track (psi, r do not need it)
        speed = float(dec["u_s"][0]) if "u_s" in dec else None
        if speed is None or not math.isfinite(speed):
            ap = approach(trial, float(trial.t[0]))
            speed = ap.speed if ap.speed is not None and ap.speed > 0 else None
    if speed is None:  # the model's own (its inputs set the speed of the other kinds)
        speed = float(approach_speed(model, None))
    return _FreeRun(kind, dec, s.h * step, float(speed), water)


def _windows(fr: _FreeRun, window_s: float | None) -> Windows:
    return make_windows([fr.dec], fr.h, window_s)


def replay_band(model: VesselModel, trial: Trial, uncertainty: Uncertainty, *,
                draws: int = 40, seed: int = 0, level: float = 0.95,
                water: TrialWater | None = None) -> dict[str, Any]:
    """Prediction band of the free-run replay from the parameter uncertainty.

    ``draws`` parameter sets from ``uncertainty`` (:meth:`usvid.models.uncertainty.Uncertainty.
    sample`, seeded by ``seed``; a draw outside the parameters' bounds is drawn again, one
    still outside after that is left out and counted), each replaying the measured inputs from
    the measured initial state (one batch of the integration core); the band is the
    (1 - level)/2 .. (1 + level)/2 quantile at each instant. Returns ``psi_lo``, ``psi_hi``
    [rad], ``r_lo``, ``r_hi`` [rad/s] on the replay grid, ``draws``, ``redrawn`` and
    ``failed`` (empty when no draw is valid). ``water``: the current and biases the replay runs
    in, as the trial's validation row (:attr:`TrialValidation.water`; None: calm); the logged
    wind as the row's replay (:func:`usvid.sim.replay.logged_wind`)."""
    trial = as_prepared(trial, derivatives=False)
    fr = _free_run(model, trial, water)
    win = _windows(fr, None)
    sample = uncertainty.sample(0, draws, seed)
    ok = ~sample.failed
    if not ok.any():
        return {}
    params = {n: v[ok] for n, v in sample.values.items()}
    try:
        dyn = dataclasses.replace(model.dynamics, **params)
    except (UsvidError, ValueError, TypeError):
        return {}
    B = int(ok.sum())
    P = np.asarray(fr.kind.pack(dyn, fr.speed), dtype=float)
    rep = Windows(h=win.h, inputs={k: np.repeat(v, B, 0) for k, v in win.inputs.items()},
                  outputs={k: np.repeat(v, B, 0) for k, v in win.outputs.items()},
                  init={k: np.repeat(v, B) for k, v in win.init.items()},
                  trial_index=np.zeros(B, dtype=int), start=np.zeros(B, dtype=int))
    sim = window_lanes(fr.kind, P, model.dynamics, rep, channels=("psi", "r"),
                       env_block=logged_wind(model, rep)[0],
                       environment=fr.environment(rep)).run().channels
    q = [100 * (1 - level) / 2, 100 * (1 + level) / 2]
    out: dict[str, Any] = {"draws": int(draws), "redrawn": sample.redrawn,
                           "failed": sample.n_failed}
    with np.errstate(invalid="ignore"):
        for ch in ("psi", "r"):
            lo, hi = np.nanpercentile(sim[ch], q, axis=0)
            out[f"{ch}_lo"], out[f"{ch}_hi"] = lo, hi
    return out


def _replay(model: VesselModel, trial: PreparedTrial, out: TrialValidation,
            window_s: float | None, water: Any = None) -> None:
    fr = _free_run(model, trial, _water(model, trial, out, water))
    win = _windows(fr, None)
    chans = ["psi", "r", "x", "y"] + [c for c in ("u", "v") if c in win.outputs]
    P = fr.kind.pack(model.dynamics, fr.speed)
    env, wind = logged_wind(model, win)
    sim = window_lanes(fr.kind, P, model.dynamics, win, channels=chans, env_block=env,
                       environment=fr.environment(win)).run().channels
    t = fr.dec["t"]
    fit = replay_metrics({c: sim[c] for c in win.outputs if c in sim}, win.outputs)
    rep: dict[str, Any] = {"duration_s": float(t[-1] - t[0]), "wind": wind}
    rep["psi_rms_deg"] = math.degrees(fit["psi"]["rmse"])
    rep["r_rms_deg_s"] = math.degrees(fit["r"]["rmse"])
    if "u" in fit:
        rep["u_rms_m_s"] = fit["u"]["rmse"]
    gone = diverged_at(t, sim["psi"][0], win.outputs["psi"][0])
    if gone is not None:
        rep["diverged_at_s"] = gone - float(t[0])
        out.messages.append(f"replay: the free run diverged {gone - float(t[0]):.1f} s into the "
                            f"{rep['duration_s']:.1f} s record (its errors are infinite)")
    if trial.has("x") and trial.has("y"):
        ok = np.isfinite(trial["x"]) & np.isfinite(trial["y"])
        tx = trial.t[ok]
        xm = np.interp(t, tx, trial["x"][ok])
        ym = np.interp(t, tx, trial["y"][ok])
        e = np.hypot(sim["x"][0] + xm[0] - xm, sim["y"][0] + ym[0] - ym)
        e = np.where(np.isfinite(e), e, np.inf)
        rep["track_rms_m"] = float(np.sqrt(np.mean(e * e)))
        rep["track_max_m"] = float(np.max(e))
        out.series.update(x=xm, y=ym, x_replay=sim["x"][0] + xm[0], y_replay=sim["y"][0] + ym[0])
    out.replay = rep
    out.series.update(t=t, psi=fr.dec["psi"], r=fr.dec["r"], psi_replay=sim["psi"][0],
                      r_replay=sim["r"][0], delta=fr.dec.get("delta"))
    if window_s is not None:  # as the estimator scores its training data
        wwin = _windows(fr, window_s)
        out.metrics = {"window_s": float(window_s), **replay_metrics(
            replay_windows(model, wwin, environment=fr.environment(wwin)), wwin.outputs)}


def _water(model: VesselModel, trial: PreparedTrial, out: TrialValidation,
           water: Any) -> TrialWater | None:
    """The current and biases ``trial`` is replayed in (None: calm water), said in
    ``out.replay_water`` for a model identified with a disturbance: ``water`` (the fit's
    :meth:`usvid.identify.estimator.ModelEstimator.water_of`; None: none known) decides."""
    ident = getattr(model, "identification", None) or {}
    if not ident.get("disturbance"):  # identified without one: calm, as fitted
        return None
    if water is None:
        out.replay_water = {"trial": out.trial, "water": "calm",
                            "why": f"no current or biases are known for this log: {CALM}"}
        return None
    tw, rows = water([_series(model, trial)])
    out.replay_water = rows[0] if rows else None
    out.water = tw
    return tw


def model_window(model: VesselModel) -> float | None:
    """The output-error window [s] the model was identified with (its identification
    ``options.window_s``), None when the model file does not say."""
    opts = (getattr(model, "identification", None) or {}).get("options") or {}
    w = opts.get("window_s") if isinstance(opts, dict) else None
    return float(w) if isinstance(w, int | float) and math.isfinite(w) and w > 0 else None


def validate_trial(model: VesselModel, trial: Trial, *, psi_switch: float | None = None,
                   replay: bool = True, window_s: float | None = None,
                   water: Any = None) -> TrialValidation:
    """Validate ``model`` on one trial (module docstring); ``psi_switch`` [rad] overrides the
    detected zig-zag switching angle; ``window_s`` [s] the window of the windowed fit metrics
    (default: the model's identification window, none when unknown); ``water`` the fit's
    :meth:`usvid.identify.estimator.ModelEstimator.water_of` (a training log is replayed in
    the current and biases estimated for it; None: calm water). A step that cannot be
    done (no manoeuvre, a channel the model needs is missing) leaves its part empty and says
    why in ``messages``."""
    name = trial.name or (trial.sources[0] if trial.sources else "?")
    trial = as_prepared(trial, derivatives=False)
    out = TrialValidation(trial=name, manoeuvre="other",
                          file=str(trial.sources[0]) if trial.sources else None)
    segs = [s for s in find_manoeuvres(trial, psi_switch=psi_switch)
            if s.kind in ("zigzag", "turning") and s.execute_from == "command"] \
        if trial.has("psi") else []
    if segs:
        seg = segs[0]
        out.manoeuvre = seg.kind
        out.measured = manoeuvre_metrics(trial, seg)
        try:
            _predict(model, seg, out, trial)
        except UsvidError as exc:
            out.messages.append(f"prediction: {exc}")
    else:
        out.messages.append("no zig-zag or turning circle found: replay only")
    if replay:
        # the part where every channel the replay reads is logged (sensors that start late)
        span = logged_span(trial, kind_channels(kind_of(model.dynamics)))
        if span is not None:
            t0 = float(trial.t[0])
            out.messages.append(f"replay: {span[0] - t0:.1f}-{span[1] - t0:.1f} s only (from "
                                f"the log's start): {', '.join(map(repr, span[2]))} not logged "
                                "before or after")
            trial = trial.slice_time(span[0], span[1])
        law = getattr(model.dynamics, "thruster_thrust", None)  # twin thrusters (catamaran)
        bad = _tc.astern_under_thrust_ahead(trial, law) if law is not None else []
        if bad:
            out.messages.append(f"replay: the boat moved astern while both thrusters were "
                                f"commanded ahead at {_tc.describe(bad)} (from the replay's "
                                "start): the logged commands did not drive it there, and the "
                                "replay cannot follow")
        try:
            _replay(model, trial, out, window_s if window_s is not None else model_window(model),
                    water)
        except UsvidError as exc:
            out.messages.append(f"replay: {exc}")
    return out


def validate_model(model: VesselModel, trials: Sequence[Trial], *,
                   psi_switch: float | None = None,
                   window_s: float | None = None, water: Any = None) -> ValidationResult:
    """Validate ``model`` on each of ``trials`` (each prepared once,
    :func:`usvid.prep.as_prepared`); see :func:`validate_trial`."""
    rows = [validate_trial(model, tr, psi_switch=psi_switch, window_s=window_s, water=water)
            for tr in trials]
    return ValidationResult(rows, model_kind=kind_of(model.dynamics).name)
