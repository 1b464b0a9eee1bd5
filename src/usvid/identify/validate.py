"""Validation of identified models: held-out metrics, leave-one-trial-out cross-validation,
comparison of model kinds, and simulated-vs-measured manoeuvre metrics (Mu et al. 2018 section 5.2).

Mu et al. 2018 validates its identified models by simulating the manoeuvres of the trials (zig-zag,
turning) and comparing with the measured ones. :func:`zigzag_check` does that for a zig-zag
trial: it reads the trial's rudder amplitude, switching angle and first side from the record,
simulates the same zig-zag on the model with :mod:`usvid.sim` (its ``ZigZag`` logic, closed
loop on the heading, rudder rate limited) and compares the overshoot angles
(``usvid.manoeuvres.metrics.zigzag_metrics`` on both, same definitions).

Units: radians and seconds inside; the metric dictionaries carry degrees in their key names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.estimator import ModelEstimator, _as_list, compare_kinds
from usvid.manoeuvres import find_manoeuvres, rudder_amplitude, rudder_rate, zigzag_metrics
from usvid.models.model import VesselModel
from usvid.models.registry import get as get_kind
from usvid.models.servo import IdealServo
from usvid.prep.filters import unwrap_angle
from usvid.sim import ZigZag, simulate

__all__ = ["zigzag_response", "zigzag_check", "cross_validate", "compare_kinds",
           "validation_table"]


def zigzag_response(model: VesselModel, delta_amp: float, psi_switch: float, *,
                    first: int = 1, rate: float | None = None, t_end: float = 200.0,
                    h: float = 0.05, u0: float | None = None) -> dict[str, np.ndarray]:
    """Simulate a ``delta_amp``/``psi_switch`` zig-zag [rad] on ``model`` (any kind).

    Starts from a straight approach at ``u0`` [m/s] (default the model's approach speed) with
    the first rudder order at t = 0 towards ``first`` (+1 starboard); ``rate`` [rad/s] replaces
    an ideal servo's rate limit (a dynamic servo is kept as identified). The simulation is
    :func:`usvid.sim.simulate` with its ``ZigZag`` logic, as ``usvid simulate zigzag``.
    Returns ``t`` [s], ``psi`` [rad], ``r`` [rad/s], ``delta`` [rad] (1-D arrays).
    """
    servo = model.servo
    if isinstance(servo, IdealServo) and rate is not None:
        servo = IdealServo(max_angle=max(float(servo.max_angle), float(delta_amp)),
                           max_rate=float(rate) if rate > 0 else math.inf)
    m = VesselModel(model.dynamics, servo=servo, vessel=model.vessel)
    res = simulate(m, ZigZag(float(delta_amp), float(psi_switch), first=1 if first >= 0
                             else -1), t_end=float(t_end), dt=float(h), u0=u0,
                   channels=("psi", "r", "delta"))
    return {"t": np.asarray(res.t), "psi": res.channels["psi"][0], "r": res.channels["r"][0],
            "delta": res.channels["delta"][0]}


def zigzag_check(est: ModelEstimator, trial: Any, *, rate: float | None = None,
                 t_end: float | None = None, psi_switch: float | None = None
                 ) -> dict[str, Any]:
    """Simulated versus measured zig-zag metrics of one zig-zag trial (Mu et al. 2018 sec. 5.2).

    The trial's amplitude [rad], first side (sign of the first large rudder) and
    switching angle define the simulated zig-zag; the switching angle is ``psi_switch`` [rad], else
    ``trial.meta["psi_switch"]``, else found by :func:`usvid.prep.find_manoeuvres` (measured and
    rounded to a standard angle). ``rate`` [rad/s] is the rudder rate limit (default: the
    model servo's finite ``max_rate``, so the servo matches the fit's; else the measured
    rate, median of the smoothed |d delta/dt| on the rudder ramps). The amplitude is
    the median plateau |delta| (samples above 80 % of the largest). Returns
    measured and simulated overshoots [deg], their differences and periods.
    """
    tr = _as_list(trial)[0]
    t = tr.t
    d = tr["delta"]
    psi = unwrap_angle(tr["psi"])
    segs = [g for g in find_manoeuvres(tr) if g.kind == "zigzag"]
    if not segs:
        raise IdentificationError(f"trial {tr.name}: no zig-zag found in the record")
    t_exec, first = segs[0].t_execute, segs[0].side
    amp = rudder_amplitude(t, d, t_exec, segs[0].t_end)
    if amp < math.radians(0.5):
        raise IdentificationError(f"trial {tr.name}: no rudder movement, not a zig-zag")
    sw = tr.meta.get("psi_switch", segs[0].psi_switch)
    if psi_switch is not None:
        sw = psi_switch
    sw = float(sw)
    servo_rate = float(getattr(getattr(vars(est).get("model_"), "servo", None), "max_rate",
                               math.inf))
    if rate is None and math.isfinite(servo_rate):
        rate = servo_rate  # the model's servo (the rate its fit used, or the vessel's helm rate)
    if rate is None:
        rate = rudder_rate(t, d)
    meas = zigzag_metrics(t, psi, d, delta_amp=amp, psi_switch=sw, t_execute=t_exec,
                          first=first)
    t_end = t_end or float(t[-1] - meas.execute_time_s)
    sim = zigzag_response(est.model_, amp, sw, first=first, rate=rate, t_end=t_end)
    simm = zigzag_metrics(sim["t"], sim["psi"], sim["delta"], delta_amp=amp, psi_switch=sw,
                          t_execute=0.0, first=first)
    n = min(len(meas.overshoot_deg), len(simm.overshoot_deg))
    return {
        "trial": tr.name,
        "delta_amp_deg": math.degrees(amp),
        "psi_switch_deg": math.degrees(sw),
        "first_side": "starboard" if first > 0 else "port",
        "rudder_rate_deg_s": math.degrees(rate),
        "measured_overshoot_deg": meas.overshoot_deg,
        "simulated_overshoot_deg": simm.overshoot_deg,
        "overshoot_error_deg": [simm.overshoot_deg[i] - meas.overshoot_deg[i] for i in range(n)],
        "measured_period_s": meas.period_s,
        "simulated_period_s": simm.period_s,
        "measured_initial_turning_time_s": meas.initial_turning_time_s,
        "simulated_initial_turning_time_s": simm.initial_turning_time_s,
    }


def cross_validate(trials: Sequence[Any], kind: str, method: str = "ls", *,
                   window_s: float | None = -1.0, **options: Any) -> dict[str, Any]:
    """Leave-one-trial-out cross-validation.

    For each trial i: fit on all others, score on trial i (multiple-shooting windows of the
    estimator, or a free run with ``window_s=None``). Returns ``folds`` (held-out trial, params,
    metrics) and the mean held-out RMSE, NRMSE, R^2 and max error per output channel (RMSE and max
    error in the channel's SI unit: psi [rad], r [rad/s], u, v [m/s]).
    """
    trials = _as_list(list(trials))
    if len(trials) < 2:
        raise IdentificationError("cross-validation needs at least two trials")
    folds = []
    for i, held in enumerate(trials):
        train = [t for j, t in enumerate(trials) if j != i]
        try:
            est = ModelEstimator(kind, method, **options).fit(train)
            sc = est.score(held, window_s=window_s)
            folds.append({"held_out": held.name, "params": est.params_, "metrics": sc})
        except UsvidError as exc:
            folds.append({"held_out": held.name, "error": str(exc)})
    ok = [f for f in folds if "metrics" in f]
    mean: dict[str, Any] = {}
    if ok:
        for ch in ok[0]["metrics"]:
            if ch == "window_s":
                continue
            mean[ch] = {m: float(np.mean([f["metrics"][ch][m] for f in ok]))
                        for m in ("rmse", "nrmse", "r2", "max_error")}
    return {"kind": kind, "method": method, "folds": folds, "mean": mean}


def validation_table(est: ModelEstimator, trials: Sequence[Any], *,
                     window_s: float | None = -1.0) -> list[dict[str, Any]]:
    """Per-trial fit metrics of a fitted estimator (training or held-out trials), plus the
    zig-zag overshoot comparison for response models when the trial is a zig-zag."""
    rows = []
    for tr in _as_list(list(trials)):
        row: dict[str, Any] = {"trial": tr.name,
                               "file": tr.sources[0] if tr.sources else tr.name,
                               "metrics": est.score(tr, window_s=window_s)}
        if {"psi", "r"} <= set(get_kind(est.kind).outputs) and tr.has("delta"):
            try:
                row["zigzag"] = zigzag_check(est, tr)
            except UsvidError as exc:
                row["zigzag_error"] = str(exc)
        rows.append(row)
    return rows
