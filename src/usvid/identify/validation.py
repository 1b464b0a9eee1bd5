"""Validation of a model on measured logs: the manoeuvre found in each log, its measured metrics,
the model's prediction of the same manoeuvre, and a free-run replay of the measured inputs.

For every trial (Mu et al. 2018, section 5.2, validate the identified models by simulating the
trials' manoeuvres and comparing them with the measured ones):

* **manoeuvre**: the first zig-zag or turning circle found by
  :func:`usvid.manoeuvres.find_manoeuvres` ("other" when there is none); **measured**: its
  metrics by :func:`usvid.manoeuvres.manoeuvre_metrics` (the keys of ``usvid metrics``).
* **predicted**: the same manoeuvre simulated on the model in closed loop, as ``usvid simulate``
  runs it (:func:`usvid.sim.run_zigzag` / :func:`usvid.sim.run_turning`), with the detected
  rudder amplitude, switching angle and first side, from the measured approach speed (mean
  ``U`` over the :data:`~usvid.manoeuvres.detect.APPROACH_S` before the execute) and, for a
  model with a shaft speed ``n``, the measured mean shaft speed there. ``settings`` holds these
  values, so ``usvid simulate zigzag MODEL --delta-deg A --psi-deg S --speed U --t-end D``
  reproduces the prediction (a zig-zag is simulated over the measured one's duration D).
* **error**: predicted minus measured, key by key (lists element by element, as long as both).
* **replay**: the measured rudder (and shaft speed / thruster commands) replayed on the model
  as one free run from the measured initial state (:mod:`usvid.sim.replay`, servo bypassed):
  RMS of the heading error [deg], yaw-rate error [deg/s], speed error [m/s] and the RMS and
  largest distance between the measured and the replayed track [m]
  (e_track = sqrt((x - x_hat)^2 + (y - y_hat)^2)).

Units: SI and radians inside; the dictionaries carry degrees in their key names.
"""

from __future__ import annotations

import dataclasses
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.identify.estimator import DEFAULT_STEP, pwm_commands
from usvid.identify.series import trial_series
from usvid.manoeuvres import find_manoeuvres, manoeuvre_metrics
from usvid.manoeuvres.detect import APPROACH_S, Segment
from usvid.models.model import VesselModel
from usvid.models.registry import kind_of
from usvid.prep.prepare import prepare
from usvid.sim.replay import Windows, make_windows, window_lanes
from usvid.sim.runs import run_turning, run_zigzag
from usvid.trial import Trial

__all__ = ["TrialValidation", "ValidationResult", "validate_model", "validate_trial",
           "metric_error", "replay_band"]

#: Metric keys compared in ``error`` (those of ``usvid metrics`` and ``usvid simulate``).
ZIGZAG_KEYS = ("overshoot_deg", "period_s", "initial_turning_time_s", "time_to_check_yaw_s")
TURNING_KEYS = ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m",
                "steady_yaw_rate_rad_s", "steady_speed_m_s")


@dataclass
class TrialValidation:
    """The validation of a model on one trial (module docstring). ``series`` holds the time
    series for figures (``t`` [s], measured and replayed ``psi`` [rad], ``r`` [rad/s], ``x``,
    ``y`` [m]; predicted manoeuvre ``t_pred``, ``psi_pred``, ``x_pred``, ``y_pred``); it is not
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
    series: dict[str, Any] = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The JSON row: ``trial``, ``file``, ``manoeuvre``, ``measured``, ``predicted``,
        ``error``, ``replay``, ``settings``, ``messages``."""
        d = {k: v for k, v in dataclasses.asdict(self).items() if k != "series"}
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


def _approach_mean(trial: Trial, ch: str, t_execute: float) -> float | None:
    if not trial.has(ch):
        return None
    t = trial.t
    sel = (t >= t_execute - APPROACH_S) & (t <= t_execute)
    if not sel.any():
        sel = t <= t[min(len(t) - 1, int(np.searchsorted(t, t_execute)))]
    v = trial[ch][sel]
    v = v[np.isfinite(v)]
    return float(np.mean(v)) if v.size else None


def _with_inputs(model: VesselModel, n: float | None) -> VesselModel:
    """``model`` with its nominal shaft speed ``n`` [rps] replaced by the measured one."""
    dyn = model.dynamics
    if n is None or not hasattr(dyn, "n") or not math.isfinite(n) or n <= 0:
        return model
    return VesselModel(dataclasses.replace(dyn, n=float(n)), servo=model.servo,
                       vessel=model.vessel)


def _predict(model: VesselModel, trial: Trial, seg: Segment, out: TrialValidation) -> None:
    u0 = _approach_mean(trial, "U", seg.t_execute)
    if u0 is None or not u0 > 0:
        u0 = model.vessel.speed if model.vessel is not None else None
    n = _approach_mean(trial, "n", seg.t_execute)
    m = _with_inputs(model, n)
    rudder = seg.command.startswith("delta") and seg.level is not None
    if not rudder:
        out.messages.append("no rudder command: the manoeuvre is not predicted")
        return
    amp_deg = math.degrees(float(seg.level))
    out.settings = {"delta_deg": amp_deg, "first": seg.side, "speed_m_s": u0,
                    "shaft_speed_rps": n if m is not model else None}
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


def _free_run(model: VesselModel, trial: Trial) -> tuple[Any, dict[str, np.ndarray], Windows,
                                                         float]:
    """The kind, the decimated series, the one free-run window of ``trial`` and the speed
    [m/s] a constant-speed kind is packed with."""
    kind = kind_of(model.dynamics)
    fixed = {p.name: getattr(model.dynamics, p.name)
             for p in type(model.dynamics).param_specs() if not p.fit}
    s = trial_series(trial, kind, fixed=fixed)
    step = max(int(round(DEFAULT_STEP / s.h)), 1)
    dec = s.decimated(step).data
    win = make_windows([dec], s.h * step, None)
    speed = win.init.get("u") if kind.constant_speed else None
    if kind.constant_speed and speed is None:
        u = _approach_mean(trial, "U", float(trial.t[0]) + APPROACH_S)
        speed = u if u is not None else model.vessel.speed
    return kind, dec, win, float(np.mean(speed)) if speed is not None else 1.0


def replay_band(model: VesselModel, trial: Trial, names: Sequence[str], cov: Any, *,
                draws: int = 40, seed: int = 0, level: float = 0.95) -> dict[str, np.ndarray]:
    """Prediction band of the free-run replay from the parameter uncertainty.

    Parameters ``names`` (attributes of the model's dynamics) are drawn ``draws`` times from
    N(theta_hat, ``cov``) (seeded by ``seed``; draws that are not a valid model, e.g. T <= 0,
    are left out), each draw replays the measured inputs from the measured initial state (one
    batch of the integration core), and the band is the (1 - level)/2 .. (1 + level)/2
    quantile at each instant. Returns ``psi_lo``, ``psi_hi`` [rad], ``r_lo``, ``r_hi``
    [rad/s] on the replay grid (empty when no draw is valid)."""
    kind, dec, win, speed = _free_run(model, trial)
    names = [n for n in names if hasattr(model.dynamics, n)]
    c = np.asarray(cov, dtype=float)[:len(names), :len(names)]
    theta = np.array([float(getattr(model.dynamics, n)) for n in names])
    rng = np.random.default_rng(seed)
    cols = []
    for th in rng.multivariate_normal(theta, c, size=draws, method="eigh"):
        try:
            dyn = dataclasses.replace(model.dynamics, **dict(zip(names, th.tolist(),
                                                               strict=True)))
        except (UsvidError, ValueError, TypeError):
            continue
        cols.append(np.asarray(kind.pack(dyn, speed), dtype=float).reshape(-1, 1))
    if not cols:
        return {}
    B = len(cols)
    rep = Windows(h=win.h, inputs={k: np.repeat(v, B, 0) for k, v in win.inputs.items()},
                  outputs={k: np.repeat(v, B, 0) for k, v in win.outputs.items()},
                  init={k: np.repeat(v, B) for k, v in win.init.items()},
                  trial_index=np.zeros(B, dtype=int), start=np.zeros(B, dtype=int))
    sim = window_lanes(kind, np.hstack(cols), model.dynamics, rep,
                       channels=("psi", "r")).run().channels
    q = [100 * (1 - level) / 2, 100 * (1 + level) / 2]
    out = {}
    for ch in ("psi", "r"):
        lo, hi = np.nanpercentile(sim[ch], q, axis=0)
        out[f"{ch}_lo"], out[f"{ch}_hi"] = lo, hi
    return out


def _replay(model: VesselModel, trial: Trial, out: TrialValidation) -> None:
    kind, dec, win, speed = _free_run(model, trial)
    chans = ["psi", "r", "x", "y"] + [c for c in ("u", "v") if c in win.outputs]
    P = kind.pack(model.dynamics, speed)
    sim = window_lanes(kind, P, model.dynamics, win, channels=chans).run().channels
    t = dec["t"]
    rep: dict[str, Any] = {"duration_s": float(t[-1] - t[0])}

    def rms(a: np.ndarray) -> float:
        a = a[np.isfinite(a)] if np.isfinite(a).any() else np.array([math.inf])
        return float(np.sqrt(np.mean(a * a)))

    rep["psi_rms_deg"] = math.degrees(rms(sim["psi"][0] - dec["psi"]))
    rep["r_rms_deg_s"] = math.degrees(rms(sim["r"][0] - dec["r"]))
    meas_u = dec.get("u")
    if "u" in sim and meas_u is not None:
        rep["u_rms_m_s"] = rms(sim["u"][0] - meas_u)
    if trial.has("x") and trial.has("y"):
        ok = np.isfinite(trial["x"]) & np.isfinite(trial["y"])
        tx = trial.t[ok]
        xm = np.interp(t, tx, trial["x"][ok])
        ym = np.interp(t, tx, trial["y"][ok])
        e = np.hypot(sim["x"][0] + xm[0] - xm, sim["y"][0] + ym[0] - ym)
        rep["track_rms_m"] = rms(e)
        rep["track_max_m"] = float(np.nanmax(e)) if np.isfinite(e).any() else math.inf
        out.series.update(x=xm, y=ym, x_replay=sim["x"][0] + xm[0], y_replay=sim["y"][0] + ym[0])
    out.replay = rep
    out.series.update(t=t, psi=dec["psi"], r=dec["r"], psi_replay=sim["psi"][0],
                      r_replay=sim["r"][0], delta=dec.get("delta"))


def validate_trial(model: VesselModel, trial: Trial, *, psi_switch: float | None = None,
                   replay: bool = True) -> TrialValidation:
    """Validate ``model`` on one trial (module docstring); ``psi_switch`` [rad] overrides the
    detected zig-zag switching angle. A step that cannot be done (no manoeuvre, a channel the
    model needs is missing) leaves its part empty and says why in ``messages``."""
    name = trial.name or (trial.sources[0] if trial.sources else "?")
    trial = pwm_commands(trial)  # PWM-commanded thrusters: the commands the model replays
    if not trial.is_uniform or (trial.has("lat") and not trial.has("x")) or not trial.has("U"):
        trial = prepare(trial, derivatives=False)
    out = TrialValidation(trial=name, manoeuvre="other",
                          file=str(trial.sources[0]) if trial.sources else None)
    segs = [s for s in find_manoeuvres(trial, psi_switch=psi_switch)
            if s.kind in ("zigzag", "turning") and s.execute_from == "command"]
    if segs:
        seg = segs[0]
        out.manoeuvre = seg.kind
        out.measured = manoeuvre_metrics(trial, seg)
        try:
            _predict(model, trial, seg, out)
        except UsvidError as exc:
            out.messages.append(f"prediction: {exc}")
    else:
        out.messages.append("no zig-zag or turning circle found: replay only")
    if replay:
        try:
            _replay(model, trial, out)
        except UsvidError as exc:
            out.messages.append(f"replay: {exc}")
    return out


def validate_model(model: VesselModel, trials: Sequence[Trial], *,
                   psi_switch: float | None = None) -> ValidationResult:
    """Validate ``model`` on each of ``trials`` (each prepared onto its own uniform grid when
    it is not on one); see :func:`validate_trial`."""
    rows = [validate_trial(model, tr, psi_switch=psi_switch) for tr in trials]
    return ValidationResult(rows, model_kind=kind_of(model.dynamics).name)
