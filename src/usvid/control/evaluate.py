"""Course-change step responses of candidate autopilot gains, as lanes of one batch.

Every candidate (and every disturbance realisation of it) is one lane of the integration core
(:func:`usvid.sim.simulate` with a :class:`usvid.sim.CourseChange`): the model's own
equations, servo (dynamics, dead time, angle and rate limits) and the rudder-equivalent
disturbance of Mu et al. 2018, section 6.1 (white noise through 0.42 s / (s^2 + 0.36 s +
0.37)). Realisation j of every candidate uses the noise stream (seed, j) (common random
numbers): candidates are compared under the same disturbance, and stream 0 is the one
``usvid simulate course-keeping --seed SEED`` uses.

Metrics over the stated horizon H [s] (the run is 0 .. H):

* ITAE = int_0^H t |psi_d - psi| dt [rad s^2] (Mu et al. 2018, section 6.1; the core's
  trapezoid at the step points), IAE = int_0^H |psi_d - psi| dt [rad s];
* overshoot [deg]: the largest heading excursion beyond the target, max(0, max_t
  sign(psi_d) (psi - psi_d));
* saturation [s]: the time the rudder angle is at its limit (|delta| >= max_angle);
* max rudder [deg].

In an environment (:class:`usvid.sim.Environment`: wind, current, sea state) the wind and the
mean wave drift act inside every step; the autopilot steers on the low-frequency heading (an
ideal wave filter: the first-order wave motion, which does not feed back, is not added to the
runs), and the metrics are of that heading.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.manoeuvres.logic import PID, CourseChange, Disturbance
from usvid.sim.simulate import simulate

#: Mu et al. 2018, section 6.1: the hand-tuned PID gains (kp [rad/rad], ki [1/s], kd [s]).
PAPER_GAINS = (0.7, 0.00095, 1.0)


@dataclass(frozen=True)
class Gains:
    """PID heading-autopilot gains: kp [rad/rad], ki [1/s], kd [s] of
    ``delta_cmd = kp e + ki int(e dt) - kd r`` (Mu et al. 2018, eq. 41; :class:`PID`)."""

    kp: float
    ki: float
    kd: float

    @property
    def controller(self) -> str:
        """"pid" with an integral gain, else "pd"."""
        return "pid" if self.ki != 0 else "pd"

    def to_dict(self) -> dict[str, Any]:
        return {"kp": self.kp, "ki": self.ki, "kd": self.kd, "controller": self.controller}


@dataclass(frozen=True)
class StepMetrics:
    """Metrics of a batch of course changes, each (B, R): B candidates x R disturbance
    realisations (module docstring for the definitions). ``diverged`` lanes have inf ITAE."""

    itae: np.ndarray
    iae: np.ndarray
    overshoot_deg: np.ndarray
    saturation_s: np.ndarray
    max_rudder_deg: np.ndarray
    diverged: np.ndarray
    horizon_s: float

    def summary(self, i: int = 0) -> dict[str, Any]:
        """Candidate i's metrics, averaged over the realisations (JSON-ready)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            if f.name in ("horizon_s", "diverged"):
                continue
            out[f.name] = float(np.mean(getattr(self, f.name)[i]))
        out["itae_by_realisation"] = [float(x) for x in self.itae[i]]
        out["diverged"] = bool(np.any(self.diverged[i]))
        out["horizon_s"] = self.horizon_s
        return out


def _numeric(v: Any) -> bool:
    """A number or an array of numbers (not None, not a sub-model such as a thrust law)."""
    return isinstance(v, (int, float, np.ndarray, np.number)) and not isinstance(v, bool)


def _tile_model(model: Any, B: int, R: int) -> Any:
    """The model with every (B,) parameter array repeated R times (lane b * R + j)."""
    if R == 1:
        return model
    changes = {}
    for name, v in model.dynamics.values().items():
        if not _numeric(v):
            continue
        a = np.asarray(v, dtype=float)
        if a.ndim == 1 and a.size == B:
            changes[name] = np.repeat(a, R)
    if not changes:
        return model
    return type(model)(dynamics=model.dynamics.replace(**changes), servo=model.servo,
                       vessel=model.vessel, identification=model.identification)


def evaluate_gains(model: Any, kp: Any, ki: Any, kd: Any, *, target_deg: float = 100.0,
                   horizon: float = 100.0, noise_deg: float = 1.0, seed: int = 1,
                   realisations: int = 1, dt: float = 0.02, u0: Any = None,
                   keep: bool = False, environment: Any = None) -> tuple[StepMetrics, Any]:
    """Course change 0 -> ``target_deg`` [deg] over ``horizon`` [s] for a batch of gains
    (kp [rad/rad], ki [1/s], kd [s], scalars or (B,) arrays; the model's parameters may be
    (B,) arrays too), each under ``realisations`` disturbance realisations (streams 0 .. R-1 of
    ``seed``) of std ``noise_deg`` [deg] (0: calm), step ``dt`` [s], approach speed ``u0``
    [m/s] (default ``vessel.speed``), in ``environment`` (None: calm water; module docstring).

    Returns (:class:`StepMetrics` (B, R), the :class:`usvid.sim.SimResult` when ``keep`` else
    None). B*R lanes in one call of the integration core.
    """
    if not (math.isfinite(horizon) and horizon > 0):
        raise UsvidError(f"--horizon must be > 0 s (got {horizon!r})")
    if not (math.isfinite(noise_deg) and noise_deg >= 0):
        raise UsvidError(f"--disturbance-deg must be >= 0 deg (got {noise_deg!r})")
    R = int(realisations)
    if R < 1:
        raise UsvidError(f"realisations must be >= 1 (got {realisations!r})")
    gains = [np.atleast_1d(np.asarray(g, dtype=float)) for g in (kp, ki, kd)]
    sizes = [g.size for g in gains] + [np.size(v) for v in model.dynamics.values().values()
                                       if _numeric(v)]
    B = max(sizes)
    gains = [np.repeat(np.broadcast_to(g, (B,)), R) for g in gains]
    streams = np.tile(np.arange(R, dtype=float), B)
    target = math.radians(target_deg)
    dist = (Disturbance(intensity=math.radians(noise_deg), seed=seed, stream=streams)
            if noise_deg > 0 else None)
    logic = CourseChange(target=target, controller=PID(kp=gains[0], ki=gains[1], kd=gains[2]),
                         disturbance=dist)
    if environment is not None and environment.sea is not None:
        environment = dataclasses.replace(environment, wave_motion=False)
    res = simulate(_tile_model(model, B, R), logic, t_end=horizon, dt=dt, u0=u0,
                   channels=("psi", "delta"), environment=environment)
    psi = res["psi"]
    delta = res["delta"]
    ma = float(np.max(np.asarray(model.servo.max_angle, dtype=float)))
    sgn = 1.0 if target >= 0 else -1.0
    over = np.degrees(np.maximum(0.0, np.nanmax(sgn * (psi - target), axis=1)))
    sat = np.sum(np.abs(delta[:, :-1]) >= ma * (1 - 1e-9), axis=1) * dt \
        if math.isfinite(ma) else np.zeros(B * R)
    bad = np.asarray(res.status) != 0
    itae = np.where(bad, np.inf, res.course["itae"])
    m = StepMetrics(itae=itae.reshape(B, R), iae=np.where(bad, np.inf, res.course["iae"])
                    .reshape(B, R), overshoot_deg=over.reshape(B, R),
                    saturation_s=sat.reshape(B, R),
                    max_rudder_deg=np.degrees(res.course["max_rudder"]).reshape(B, R),
                    diverged=bad.reshape(B, R), horizon_s=float(horizon))
    return m, (res if keep else None)
