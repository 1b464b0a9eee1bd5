"""``usvid autopilot``: heading-autopilot gains from an identified model, with their predicted
course-change performance, their margins and their robustness, all over one stated horizon.

Methods: ``pole-placement`` (Fossen 2021, Sec. 15.3, on the Nomoto equivalent of the model
with its steering servo; the bandwidth by default the largest keeping a 6 dB gain margin and a
45 deg phase margin) and ``itae`` (ITAE minimisation on the model itself, started from the
pole-placement design; :mod:`usvid.control.itae`). Every design is compared with the
reference gains (default: the hand-tuned kp 0.7, ki 0.00095, kd 1 of Mu et al. 2018, section
6.1) under the same horizon, disturbance and seed.

The default controller is a PD: the disturbance of Mu et al. 2018 (white noise through
0.42 s / (s^2 + 0.36 s + 0.37)) has zero mean and zero DC gain, so an integrator has no
steady offset to remove and only winds up during the 100 deg course change (the paper's own
remark 12: "the integral term should be used with caution").

With an ``environment`` (:class:`usvid.sim.Environment`: wind, current, sea state) the ITAE
search, the step metrics, the reference and the robustness are all in that environment (the
pole placement is of the linear model and does not see it), and the design reports its ITAE
and the reference's both in calm water and in the environment (``in_environment``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.control.evaluate import PAPER_GAINS, Gains, evaluate_gains
from usvid.control.itae import itae_design
from usvid.control.linear import loop_margins, nomoto_equivalent, with_servo
from usvid.control.pole_placement import default_bandwidth, natural_frequency, pole_placement
from usvid.control.robustness import robustness
from usvid.errors import UsvidError

METHODS = ("pole-placement", "itae")


@dataclass
class AutopilotDesign:
    """A design and its evidence (JSON-ready with :meth:`to_dict`); every metric is over
    ``horizon_s`` [s] of the course change 0 -> ``target_deg`` [deg]."""

    method: str
    gains: Gains
    horizon_s: float
    target_deg: float
    disturbance_deg: float
    seed: int
    nomoto: dict[str, float]
    pole_placement: dict[str, float]
    step: dict[str, Any]
    reference: dict[str, Any]
    margins: dict[str, float]
    robustness: dict[str, Any] | None = None
    itae_search: dict[str, Any] = field(default_factory=dict)
    environment: dict[str, Any] | None = None
    in_environment: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"method": self.method, **self.gains.to_dict(),
                               "horizon_s": self.horizon_s, "target_deg": self.target_deg,
                               "disturbance_deg": self.disturbance_deg, "seed": self.seed}
        out.update(nomoto=self.nomoto, pole_placement=self.pole_placement, step=self.step,
                   reference=self.reference, margins=self.margins,
                   robustness=self.robustness, itae_search=self.itae_search or None,
                   environment=self.environment, in_environment=self.in_environment)
        return out


def _step(model: Any, g: Gains, kw: dict[str, Any], realisations: int,
          environment: Any = None) -> dict[str, Any]:
    """Step metrics on stream 0 (what ``usvid simulate course-keeping --seed`` gives) and the
    mean ITAE over the realisations, in ``environment`` (None: calm water)."""
    sm, _ = evaluate_gains(model, g.kp, g.ki, g.kd, realisations=realisations,
                           environment=environment, **kw)
    out = {k: float(getattr(sm, k)[0, 0]) for k in ("itae", "iae", "overshoot_deg",
                                                     "saturation_s", "max_rudder_deg")}
    out["itae_mean"] = float(np.mean(sm.itae[0]))
    out["realisations"] = realisations
    out["diverged"] = bool(sm.diverged[0, 0])
    return out


def design_autopilot(model: Any, *, method: str = "pole-placement", controller: str = "pd",
                     bandwidth: float | None = None, zeta: float = 0.8,
                     disturbance_deg: float = 1.0, horizon: float = 100.0, seed: int = 1,
                     target_deg: float = 100.0, dt: float = 0.02, u0: Any = None,
                     reference: Gains | None = None, realisations: int = 4,
                     samples: int = 1000, uncertainty_pct: float = 10.0,
                     max_saturation_s: float | None = None,
                     environment: Any = None) -> AutopilotDesign:
    """Design PD/PID heading-autopilot gains for ``model`` (module docstring).

    Parameters: ``bandwidth`` [rad/s] closed-loop bandwidth of the pole placement (default
    :func:`default_bandwidth`), ``zeta`` its relative damping; ``disturbance_deg`` [deg] std of
    the rudder-equivalent disturbance, ``seed`` its stream, ``realisations`` how many streams
    the ITAE search averages; ``horizon`` [s] of every ITAE; ``target_deg`` [deg] the course
    change; ``samples`` parameter draws for the robustness (0: skip) with
    ``uncertainty_pct`` [%] assumed where the model has no standard errors;
    ``max_saturation_s`` [s] the ITAE search's limit on rudder saturation (default: that of
    the reference gains); ``environment`` the :class:`usvid.sim.Environment` designed for
    (None: calm water; module docstring).
    """
    if method not in METHODS:
        raise UsvidError(f"--method must be one of {', '.join(METHODS)} (got {method!r})")
    if controller not in ("pd", "pid"):
        raise UsvidError(f"--controller must be pd or pid (got {controller!r})")
    if not (math.isfinite(horizon) and horizon > 0):
        raise UsvidError(f"--horizon must be > 0 s (got {horizon!r})")
    if samples < 0:
        raise UsvidError(f"--samples must be >= 0 (got {samples!r})")
    ref = reference or Gains(*PAPER_GAINS)
    eq = nomoto_equivalent(model, u0)
    if bandwidth is None:
        bandwidth = default_bandwidth(eq, model.servo, zeta=zeta, integral=controller == "pid",
                                      dt=dt)
    K_e, T_e = with_servo(eq, model.servo)
    kp, ki, kd = pole_placement(K_e, T_e, bandwidth, zeta=zeta, integral=controller == "pid")
    pp = Gains(kp=kp, ki=ki, kd=max(kd, 0.0))
    kw = dict(target_deg=target_deg, horizon=horizon, noise_deg=disturbance_deg, seed=seed,
              dt=dt, u0=u0)
    env = environment
    ref_step = _step(model, ref, kw, realisations, env)
    gains, search = pp, {}
    if method == "itae":
        lim = ref_step["saturation_s"] if max_saturation_s is None else max_saturation_s
        res = itae_design(model, eq, pp, controller=controller, realisations=realisations,
                          max_saturation_s=lim, environment=env, **kw)
        gains = res.gains
        search = {"objective": "mean ITAE over the realisations", "itae_mean": res.itae,
                  "max_saturation_s": lim, "lanes": res.lanes, "generations": res.generations,
                  "optimiser": "differential evolution (scipy), vectorised over one batch",
                  "message": res.message}
    mg = loop_margins(eq, model.servo, gains.kp, gains.ki, gains.kd, dt=dt)
    rob = None
    if samples > 0:
        rob = robustness(model, gains, samples=samples, rel=uncertainty_pct / 100.0,
                         environment=env, **kw).to_dict()
    step = _step(model, gains, kw, realisations, env)
    env_json = in_env = None
    if env is not None:
        env_json = env.describe_for(model)
        calm = _step(model, gains, kw, realisations)
        ref_calm = _step(model, ref, kw, realisations)
        in_env = {"itae_calm": calm["itae"], "itae_environment": step["itae"],
                  "itae_mean_calm": calm["itae_mean"], "itae_mean_environment": step["itae_mean"],
                  "reference_itae_calm": ref_calm["itae"],
                  "reference_itae_environment": ref_step["itae"], "step_calm": calm,
                  "reference_step_calm": ref_calm,
                  "heading": "the low-frequency heading (an ideal wave filter: the first-order "
                             "wave motion is not fed back)"}
    return AutopilotDesign(
        method=method, gains=gains, horizon_s=float(horizon), target_deg=float(target_deg),
        disturbance_deg=float(disturbance_deg), seed=int(seed),
        nomoto={"K": float(eq.K[0]), "T": float(eq.T[0]), "K_with_servo": K_e,
                "T_with_servo": T_e},
        pole_placement={"bandwidth_rad_s": float(bandwidth), "zeta": float(zeta),
                        "omega_n_rad_s": natural_frequency(bandwidth, zeta), "kp": pp.kp,
                        "ki": pp.ki, "kd": pp.kd, "kd_unclipped": kd},
        step=step,
        reference={**ref.to_dict(), "step": ref_step},
        margins={"gain_margin_db": float(mg.gain_margin_db[0]),
                 "phase_margin_deg": float(mg.phase_margin_deg[0]),
                 "crossover_rad_s": float(mg.crossover_rad_s[0])},
        robustness=rob, itae_search=search, environment=env_json, in_environment=in_env)
