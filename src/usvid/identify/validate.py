"""Leave-one-trial-out cross-validation, comparison of model kinds, and a zig-zag of a model
at a given rudder rate.

The validation of a model on a held-out trial (the manoeuvre measured and predicted, the free-run
replay, Mu et al. 2018 section 5.2) is :func:`usvid.identify.validation.validate_trial`, the one
definition every command uses.

Units: radians and seconds inside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.estimator import ModelEstimator, _as_list, compare_kinds
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo
from usvid.sim import ZigZag, simulate

__all__ = ["zigzag_response", "cross_validate", "compare_kinds"]


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
        for ch, m0 in ok[0]["metrics"].items():
            if not (isinstance(m0, dict) and "rmse" in m0):  # window_s, replay_water
                continue
            mean[ch] = {m: float(np.mean([f["metrics"][ch][m] for f in ok]))
                        for m in ("rmse", "nrmse", "r2", "max_error")}
    return {"kind": kind, "method": method, "folds": folds, "mean": mean}
