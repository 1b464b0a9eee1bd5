"""ITAE-optimal autopilot gains on the model itself (any kind, nonlinear ones included).

Minimise the mean ITAE of the course change 0 -> psi_d over the horizon H under R
realisations of the disturbance (common random numbers: every candidate sees the same R noise
streams), simulated by the integration core with the model's servo dynamics, dead time and
rudder angle/rate limits (:func:`usvid.control.evaluate.evaluate_gains`), subject to

* rudder saturation time <= ``max_saturation_s`` (mean over the realisations);
* gain margin >= ``min_gain_margin_db`` and phase margin >= ``min_phase_margin_deg`` of the
  loop linearised about straight running (:func:`usvid.control.linear.loop_margins`).

Constraints enter as penalties (ITAE of the reference + 1e3 per unit of violation), so the
objective stays continuous. Optimiser: differential evolution (Storn & Price 1997;
``scipy.optimize.differential_evolution`` with ``vectorized=True``): each generation's whole
population is one batch of the integration core (population x realisations lanes), seeded
(reproducible).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import differential_evolution

from usvid.control.evaluate import Gains, evaluate_gains
from usvid.control.linear import NomotoEquivalent, loop_margins


@dataclass(frozen=True)
class ItaeResult:
    """The optimum, its objective [rad s^2] (mean ITAE), the number of simulated lanes and
    generations, and the optimiser's message."""

    gains: Gains
    itae: float
    lanes: int
    generations: int
    message: str


def itae_design(model: Any, eq: NomotoEquivalent, start: Gains, *, controller: str = "pd",
                target_deg: float = 100.0, horizon: float = 100.0, noise_deg: float = 1.0,
                seed: int = 1, realisations: int = 4, max_saturation_s: float = np.inf,
                min_gain_margin_db: float = 6.0, min_phase_margin_deg: float = 45.0,
                dt: float = 0.02, u0: Any = None, maxiter: int = 30, popsize: int = 12,
                rng_seed: int = 0, environment: Any = None) -> ItaeResult:
    """ITAE-optimal PD (``controller="pd"``) or PID gains (module docstring), searched within
    0 .. 4x the pole-placement gains ``start`` (kp [rad/rad], ki [1/s], kd [s]; kd at least
    4 m omega with m = T/K of the Nomoto equivalent ``eq``, ki at least kp / 50 s), over the
    horizon ``horizon`` [s] with disturbance std ``noise_deg`` [deg] (streams 0 .. R-1 of
    ``seed``), in ``environment`` (None: calm water). ``rng_seed`` seeds the optimiser;
    ``start`` is in the first generation, so the result's objective is never above the
    start's."""
    pid = controller == "pid"
    m_ = float(np.asarray(eq.m).ravel()[0])
    kp_hi = 4.0 * max(start.kp, 1e-3)
    kd_hi = 4.0 * max(start.kd, m_ * np.sqrt(max(start.kp, 1e-3) / abs(m_)), 1e-3)
    bounds = [(1e-4, kp_hi), (0.0, kd_hi)]
    if pid:
        bounds.append((0.0, 4.0 * max(start.ki, start.kp / 50.0)))
    lanes = 0

    def split(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x = np.atleast_2d(x.T).T if x.ndim == 1 else x
        ki = x[2] if pid else np.zeros(x.shape[1])
        return x[0], ki, x[1]

    def cost(x: np.ndarray) -> np.ndarray:
        nonlocal lanes
        kp, ki, kd = split(x)
        sm, _ = evaluate_gains(model, kp, ki, kd, target_deg=target_deg, horizon=horizon,
                               noise_deg=noise_deg, seed=seed, realisations=realisations,
                               dt=dt, u0=u0, environment=environment)
        lanes += kp.size * realisations
        itae = np.mean(sm.itae, axis=1)
        mg = loop_margins(eq, model.servo, kp, ki, kd, dt=dt)
        pm = np.nan_to_num(mg.phase_margin_deg, nan=-180.0)
        viol = (np.maximum(0.0, np.mean(sm.saturation_s, axis=1) - max_saturation_s)
                + np.maximum(0.0, min_gain_margin_db - mg.gain_margin_db) / 10.0
                + np.maximum(0.0, min_phase_margin_deg - pm) / 30.0)
        big = 1e6
        return np.where(np.isfinite(itae), itae, big) + 1e3 * viol

    x0 = [min(max(start.kp, bounds[0][0]), bounds[0][1]),
          min(max(start.kd, bounds[1][0]), bounds[1][1])]
    if pid:
        x0.append(min(max(start.ki, bounds[2][0]), bounds[2][1]))
    # the start is a member of the first generation: the result is never worse than it
    res = differential_evolution(cost, bounds, vectorized=True, updating="deferred",
                                 maxiter=maxiter, popsize=popsize, seed=rng_seed, tol=1e-4,
                                 polish=False, init="sobol", x0=np.array(x0))
    kp, ki, kd = (float(v[0]) for v in split(np.asarray(res.x)[:, None]))
    return ItaeResult(gains=Gains(kp=kp, ki=ki, kd=kd), itae=float(res.fun), lanes=lanes,
                      generations=int(res.nit), message=str(res.message))
