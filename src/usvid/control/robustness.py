"""An autopilot design over samples of the model's parameter uncertainty.

Each fitted parameter p of the model (``Dynamics.fit_names``) is drawn independently from
N(p, sigma_p^2), sigma_p the standard error the identification recorded
(``identification.std_errors`` of the model file), else ``rel`` |p| (an assumed relative
uncertainty, stated in the result); draws outside the parameter's bounds (T > 0, masses > 0,
...) are drawn again. The samples are one batch: every sample is a lane of the integration
core running the course change with the designed gains under the disturbance realisation of
stream 0 (the one the nominal design is reported on), so the spread is due to the parameters
alone; the margins are those of each sample's loop linearised about straight running
(:func:`usvid.control.linear.loop_margins`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.control.evaluate import Gains, evaluate_gains
from usvid.control.linear import loop_margins, nomoto_equivalent
from usvid.errors import UsvidError


def sample_models(model: Any, n: int, *, rel: float = 0.1, seed: int = 0
                  ) -> tuple[Any, dict[str, dict[str, Any]]]:
    """``model`` with every fitted parameter replaced by n samples (arrays (n,)); returns (the
    batch model, name -> {"value", "std", "source": "std_errors" | "assumed"}). ``rel``: the
    relative standard deviation assumed where the model file gives no standard error."""
    if n < 1:
        raise UsvidError(f"--samples must be >= 1 (got {n!r})")
    if not (math.isfinite(rel) and rel >= 0):
        raise UsvidError(f"--uncertainty-pct must be >= 0 (got {rel * 100!r})")
    rng = np.random.default_rng(seed)
    dyn = model.dynamics
    stds = dict((model.identification or {}).get("std_errors") or {})
    specs = {p.name: p for p in dyn.param_specs()}
    changes: dict[str, np.ndarray] = {}
    used: dict[str, dict[str, Any]] = {}
    for name in dyn.fit_names():
        v = getattr(dyn, name)
        if v is None or np.size(v) != 1:
            continue
        v = float(np.asarray(v, dtype=float).ravel()[0])
        sd = stds.get(name)
        source = "std_errors"
        if sd is None or not math.isfinite(float(sd)):
            sd, source = rel * abs(v), "assumed"
        sd = float(sd)
        if sd == 0.0:
            continue
        spec = specs[name]
        x = v + sd * rng.standard_normal(n)
        for _ in range(20):
            bad = np.zeros(n, dtype=bool)
            for bound, op in ((spec.gt, np.less_equal), (spec.ge, np.less),
                              (spec.lt, np.greater_equal), (spec.le, np.greater)):
                if bound is not None:
                    bad |= op(x, bound)
            if not np.any(bad):
                break
            x[bad] = v + sd * rng.standard_normal(int(bad.sum()))
        else:
            raise UsvidError(f"{model.kind}: parameter {name} = {v:g} with std {sd:g} cannot be "
                             "sampled within its bounds; lower --uncertainty-pct")
        changes[name] = x
        used[name] = {"value": v, "std": sd, "source": source}
    batch = type(model)(dynamics=dyn.replace(**changes), servo=model.servo, vessel=model.vessel,
                        identification=model.identification)
    return batch, used


@dataclass(frozen=True)
class Robustness:
    """The design over ``samples`` parameter sets: ITAE [rad s^2] (nominal, median, worst),
    worst overshoot [deg], worst saturation [s], diverged count, smallest gain margin [dB]
    and phase margin [deg] of the linearised loops, and the uncertainty used per parameter.
    Every number over the same horizon [s] as the design."""

    samples: int
    horizon_s: float
    itae_median: float
    itae_worst: float
    overshoot_worst_deg: float
    saturation_worst_s: float
    diverged: int
    gain_margin_min_db: float
    phase_margin_min_deg: float
    unstable_linear: int
    uncertainty: dict[str, dict[str, Any]]

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def robustness(model: Any, gains: Gains, *, samples: int = 1000, rel: float = 0.1,
               sample_seed: int = 0, target_deg: float = 100.0, horizon: float = 100.0,
               noise_deg: float = 1.0, seed: int = 1, dt: float = 0.02,
               u0: Any = None) -> Robustness:
    """The gains over ``samples`` draws of the model's parameters (module docstring): one
    batch of ``samples`` lanes of the course change 0 -> ``target_deg`` [deg] over
    ``horizon`` [s] (disturbance std ``noise_deg`` [deg], stream 0 of ``seed``), and the
    margins of every sample's linearised loop."""
    batch, used = sample_models(model, samples, rel=rel, seed=sample_seed)
    sm, _ = evaluate_gains(batch, gains.kp, gains.ki, gains.kd, target_deg=target_deg,
                           horizon=horizon, noise_deg=noise_deg, seed=seed, dt=dt, u0=u0)
    eq = nomoto_equivalent(batch, u0)
    mg = loop_margins(eq, model.servo, gains.kp, gains.ki, gains.kd, dt=dt)
    itae = sm.itae[:, 0]
    pm = mg.phase_margin_deg
    unstable = int(np.sum((pm < 0) | (mg.gain_margin_db < 0)))
    return Robustness(
        samples=int(samples), horizon_s=float(horizon),
        itae_median=float(np.median(itae)), itae_worst=float(np.max(itae)),
        overshoot_worst_deg=float(np.max(sm.overshoot_deg)),
        saturation_worst_s=float(np.max(sm.saturation_s)),
        diverged=int(np.sum(sm.diverged)),
        gain_margin_min_db=float(np.min(mg.gain_margin_db)),
        phase_margin_min_deg=float(np.nanmin(pm)) if np.any(np.isfinite(pm)) else math.nan,
        unstable_linear=unstable, uncertainty=used)
