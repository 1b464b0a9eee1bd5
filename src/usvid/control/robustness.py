"""An autopilot design over samples of the model's parameter uncertainty.

The fitted parameters of the model are drawn by the one sampler of the stored uncertainty
(:class:`usvid.models.uncertainty.Uncertainty`): jointly from the identification covariance when
the model file has one, else independently from its standard errors; a fitted parameter without
either gets ``rel`` |p| (an assumed relative uncertainty, stated in the result). A draw outside
the parameters' bounds (T > 0, masses > 0, ...) is drawn again; a sample with no draw within
them is left out and counted (``failed_draws``). The samples are one batch: every sample is a
lane of the integration core running the course change with the designed gains under the
disturbance realisation of stream 0 (the one the nominal design is reported on), so the spread
is due to the parameters alone; the margins are those of each sample's loop linearised about
straight running (:func:`usvid.control.linear.loop_margins`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.control.evaluate import Gains, evaluate_gains
from usvid.control.linear import loop_margins, nomoto_equivalent
from usvid.errors import UsvidError
from usvid.models.uncertainty import Sample, Uncertainty


def sample_models(model: Any, n: int, *, rel: float = 0.1, seed: int = 0
                  ) -> tuple[Any, dict[str, dict[str, Any]], Sample]:
    """``model`` with its uncertain parameters replaced by the valid ones of n draws (arrays;
    fewer than n when some draws fail); returns (the batch model, name -> {"value", "std",
    "source": "covariance" | "std_errors" | "assumed"}, the :class:`Sample`). ``rel``: the
    relative standard deviation assumed where the model file gives no uncertainty."""
    if n < 1:
        raise UsvidError(f"--samples must be >= 1 (got {n!r})")
    if not (math.isfinite(rel) and rel >= 0):
        raise UsvidError(f"--uncertainty-pct must be >= 0 (got {rel * 100!r})")
    unc = Uncertainty.from_model(model, rel=rel)
    used = unc.to_dict()["parameters"]
    if not unc.names:
        return model, used, Sample({}, np.zeros(n, dtype=int), np.zeros(n, dtype=bool))
    sample = unc.sample(0, n, seed)
    ok = ~sample.failed
    if not ok.any():
        raise UsvidError(f"{model.kind}: no draw of the parameters within their bounds (e.g. "
                         f"{', '.join(f'{k} = {v:g}' for k, v in sample.mean.items())} with "
                         "the stored uncertainty); lower --uncertainty-pct")
    changes = {k: v[ok] for k, v in sample.values.items()}
    batch = type(model)(dynamics=model.dynamics.replace(**changes), servo=model.servo,
                        vessel=model.vessel, identification=model.identification)
    return batch, used, sample


@dataclass(frozen=True)
class Robustness:
    """The design over ``samples`` parameter sets (the valid draws): ITAE [rad s^2] (nominal,
    median, worst), worst overshoot [deg], worst saturation [s], diverged count, smallest gain
    margin [dB] and phase margin [deg] of the linearised loops, the uncertainty used per
    parameter, and how many draws were redrawn within the bounds or failed.
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
    redrawn: int = 0
    failed_draws: int = 0

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def robustness(model: Any, gains: Gains, *, samples: int = 1000, rel: float = 0.1,
               sample_seed: int = 0, target_deg: float = 100.0, horizon: float = 100.0,
               noise_deg: float = 1.0, seed: int = 1, dt: float = 0.02,
               u0: Any = None, environment: Any = None) -> Robustness:
    """The gains over ``samples`` draws of the model's parameters (module docstring): one
    batch of ``samples`` lanes of the course change 0 -> ``target_deg`` [deg] over
    ``horizon`` [s] (disturbance std ``noise_deg`` [deg], stream 0 of ``seed``), and the
    margins of every sample's linearised loop; in ``environment`` (None: calm water)."""
    batch, used, drawn = sample_models(model, samples, rel=rel, seed=sample_seed)
    sm, _ = evaluate_gains(batch, gains.kp, gains.ki, gains.kd, target_deg=target_deg,
                           horizon=horizon, noise_deg=noise_deg, seed=seed, dt=dt, u0=u0,
                           environment=environment)
    eq = nomoto_equivalent(batch, u0)
    mg = loop_margins(eq, model.servo, gains.kp, gains.ki, gains.kd, dt=dt)
    itae = sm.itae[:, 0]
    pm = mg.phase_margin_deg
    unstable = int(np.sum((pm < 0) | (mg.gain_margin_db < 0)))
    return Robustness(
        samples=int(samples - drawn.n_failed), horizon_s=float(horizon),
        itae_median=float(np.median(itae)), itae_worst=float(np.max(itae)),
        overshoot_worst_deg=float(np.max(sm.overshoot_deg)),
        saturation_worst_s=float(np.max(sm.saturation_s)),
        diverged=int(np.sum(sm.diverged)),
        gain_margin_min_db=float(np.min(mg.gain_margin_db)),
        phase_margin_min_deg=float(np.nanmin(pm)) if np.any(np.isfinite(pm)) else math.nan,
        unstable_linear=unstable, uncertainty=used, redrawn=drawn.redrawn,
        failed_draws=drawn.n_failed)
