"""Reading Mu et al. 2018, Table 3: what the integral term of the course-keeping PID can do.

Mu et al. 2018, section 6.1 compare a PID (kp 0.7, ki 0.00095 1/s, kd 1 s) with the PD of the
same kp and kd on the course change 0 -> 100 deg under a rudder-equivalent disturbance (white
noise through 0.42 s / (s^2 + 0.36 s + 0.37)) and print ITAE = int t |psi - psi_d| dt: PID 37.98,
PD 38.6 (Table 3), "the integral item played a positive role". They state neither the noise
intensity, nor the horizon, nor the error unit, nor whether the numbers are one realisation or
an average. This module holds the two computations that settle what a reading can give:

* :func:`paired_itae`: the PID and the PD ITAE of the same disturbance realisations (common
  random numbers) over several horizons, from one batch of the integration core;
* :func:`integral_effect`: in calm water, the decomposition of ``ITAE_PID(H) - ITAE_PD(H)``
  into the part where the integral term lowers the heading error (the approach) and the part
  where it raises it (the slowly decaying offset it leaves), and the largest rudder angle the
  integral term ever adds.

Why the calm benefit bounds every seed-averaged reading: both loops see the same disturbance,
and at the disturbance filter's frequencies (sqrt(0.37) = 0.61 rad/s) the integral changes the
controller by ``|ki / (j w (kp + j w kd))| = 0.0017`` (0.17 %), so the PID error is the PD error
plus the calm difference ``Delta(t) = e_PID(t) - e_PD(t)``. For a Gaussian zero-mean disturbance
response n, ``h(c) = E|c + n|`` is even, non-decreasing in ``|c|`` and 1-Lipschitz, so at each
instant ``E|e_PD + Delta| - E|e_PD|`` is >= 0 where the calm ``|e_PD + Delta| >= |e_PD|`` and >=
``|e_PID| - |e_PD|`` (calm) elsewhere. Hence ``E[ITAE_PID - ITAE_PD] >= -B(H)`` with the calm
benefit ``B(H) = int_0^H t (|e_PD| - |e_PID|)^+ dt`` (:attr:`IntegralEffect.benefit`): averaged
over realisations, the integral term can lower the ITAE by at most B, whatever the noise
intensity. Single realisations differ from their mean by much more than B (the PID and PD
errors are |c + n| weighted by t; the offset the integrator leaves adds or removes a little
depending on the sign of the noise at late times).

ITAE [rad s^2] as the integration core accumulates it (:class:`usvid.sim.CourseChange`): the
trapezoid over the integration steps of t |wrap(psi_d - psi)|, from t = 0 (the course order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import cumulative_trapezoid

from usvid.errors import UsvidError
from usvid.manoeuvres.logic import PID, CourseChange, Disturbance
from usvid.sim.simulate import simulate

#: Mu et al. 2018 Table 3: ITAE of the PID and of the PD course change (units not printed).
TABLE3_ITAE = {"pid": 37.98, "pd": 38.6}
#: Mu et al. 2018 section 6.1 gains: kp [rad/rad], ki [1/s] (PID only), kd [s].
TABLE3_GAINS = (0.7, 0.00095, 1.0)


def _horizon_index(t: np.ndarray, horizons: np.ndarray) -> np.ndarray:
    idx = np.searchsorted(t, horizons - 1e-9 * np.maximum(1.0, horizons))
    if np.any(idx >= t.size) or np.any(np.abs(t[np.minimum(idx, t.size - 1)] - horizons) >
                                       1e-6 * np.maximum(1.0, horizons)):
        raise UsvidError(f"horizons must be whole numbers of steps within the run "
                         f"(got {horizons.tolist()})")
    return idx


def _course_errors(model: Any, ki: np.ndarray, *, noise_deg: float, seeds: np.ndarray,
                   t_end: float, target_deg: float, gains: tuple[float, float, float],
                   dt: float, u0: Any) -> tuple[np.ndarray, np.ndarray]:
    """Heading errors |wrap(psi_d - psi)| [rad] (lanes, steps) of course changes with integral
    gains ``ki`` (one per lane) under the realisations ``seeds`` (stream 0 each: the one
    ``usvid simulate course-keeping --seed s`` uses), and the time grid [s]."""
    kp, _, kd = gains
    B = ki.size
    target = math.radians(target_deg)
    dist = (Disturbance(intensity=math.radians(noise_deg), seed=seeds, stream=np.zeros(B))
            if noise_deg > 0 else None)
    logic = CourseChange(target=target, controller=PID(kp=np.full(B, kp), ki=ki,
                                                       kd=np.full(B, kd)), disturbance=dist)
    res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, channels=("psi",))
    if not res.success:
        raise UsvidError(f"course change diverged: {res.message}")
    err = np.abs((target - res["psi"] + math.pi) % (2.0 * math.pi) - math.pi)
    return err, res.t


@dataclass(frozen=True)
class PairedItae:
    """ITAE [rad s^2] of the PID and of the PD course change, each (S, H): S realisations
    (``seeds``) x H horizons [s]; PID and PD of a row share the realisation."""

    pid: np.ndarray
    pd: np.ndarray
    seeds: np.ndarray
    horizons: np.ndarray
    noise_deg: float

    @property
    def difference(self) -> np.ndarray:
        """ITAE_PID - ITAE_PD per realisation and horizon (S, H) [rad s^2]."""
        return self.pid - self.pd


def paired_itae(model: Any, *, noise_deg: float, seeds: Any, horizons: Any,
                target_deg: float = 100.0, gains: tuple[float, float, float] = TABLE3_GAINS,
                dt: float = 0.02, u0: Any = None,
                from_arrival_deg: float | None = None) -> PairedItae:
    """PID and PD ITAE of the course change 0 -> ``target_deg`` [deg] of ``model`` under the
    rudder-equivalent disturbance of std ``noise_deg`` [deg] (0: calm), realisation ``seeds``
    (whole numbers; realisation s is ``usvid simulate course-keeping --seed s``), for each
    horizon in ``horizons`` [s] (whole numbers of ``dt``), gains ``(kp, ki, kd)`` (the PD drops
    ki). One batch of 2 S lanes run to the longest horizon.

    ``from_arrival_deg``: the ITAE of the course-keeping phase only, ``int_ta^H (t - ta) |e|
    dt`` with ta [s] the first instant the error is below that many degrees (each lane its
    own); default: from the course order, t = 0."""
    seeds = np.atleast_1d(np.asarray(seeds, dtype=float))
    horizons = np.atleast_1d(np.asarray(horizons, dtype=float))
    if seeds.ndim != 1 or horizons.ndim != 1 or not np.all(horizons > 0):
        raise UsvidError("paired_itae: seeds and horizons must be 1-D, horizons > 0 s")
    if not (math.isfinite(noise_deg) and noise_deg >= 0):
        raise UsvidError(f"paired_itae: noise_deg must be >= 0 deg (got {noise_deg!r})")
    S = seeds.size
    ki = np.concatenate([np.full(S, gains[1]), np.zeros(S)])
    err, t = _course_errors(model, ki, noise_deg=noise_deg, seeds=np.tile(seeds, 2),
                            t_end=float(horizons.max()), target_deg=target_deg, gains=gains,
                            dt=dt, u0=u0)
    if from_arrival_deg is None:
        w = t * err
    else:
        ta = t[np.argmax(err < math.radians(from_arrival_deg), axis=1)]
        w = np.where(t[None, :] >= ta[:, None], (t[None, :] - ta[:, None]) * err, 0.0)
    cum = cumulative_trapezoid(w, t, axis=1, initial=0.0)[:, _horizon_index(t, horizons)]
    return PairedItae(pid=cum[:S], pd=cum[S:], seeds=seeds, horizons=horizons,
                      noise_deg=float(noise_deg))


@dataclass(frozen=True)
class IntegralEffect:
    """The PID's integral term in calm water, over ``horizons`` [s] (each array (H,)):

    ``difference`` ITAE_PID - ITAE_PD [rad s^2]; ``benefit`` B(H) = int_0^H t (|e_PD| -
    |e_PID|)^+ dt [rad s^2] (what the integral term gains during the approach; bounds the
    seed-averaged gain of any noisy reading, module docstring); ``max_integral_rudder`` the
    largest |ki int e dt| [rad] within the longest horizon; ``offset`` the heading error the
    PID leaves at each horizon [rad] (psi beyond psi_d: negative); ``min_difference`` and
    ``t_min_difference`` [s] the most negative D(H) over the run's grid and where it is."""

    horizons: np.ndarray
    difference: np.ndarray
    benefit: np.ndarray
    offset: np.ndarray
    max_integral_rudder: float
    min_difference: float
    t_min_difference: float


def integral_effect(model: Any, horizons: Any, *, target_deg: float = 100.0,
                    gains: tuple[float, float, float] = TABLE3_GAINS, dt: float = 0.02,
                    u0: Any = None) -> IntegralEffect:
    """Calm-water PID vs PD course change 0 -> ``target_deg`` [deg] (module docstring)."""
    horizons = np.atleast_1d(np.asarray(horizons, dtype=float))
    ki = np.array([gains[1], 0.0])
    target = math.radians(target_deg)
    kp, _, kd = gains
    logic = CourseChange(target=target, controller=PID(kp=np.full(2, kp), ki=ki,
                                                       kd=np.full(2, kd)))
    res = simulate(model, logic, t_end=float(horizons.max()), dt=dt, u0=u0, channels=("psi",))
    if not res.success:
        raise UsvidError(f"course change diverged: {res.message}")
    t = res.t
    e = (target - res["psi"] + math.pi) % (2.0 * math.pi) - math.pi
    a = np.abs(e)
    idx = _horizon_index(t, horizons)
    itae = cumulative_trapezoid(t * a, t, axis=1, initial=0.0)
    diff = itae[0] - itae[1]
    gain = cumulative_trapezoid(t * np.maximum(a[1] - a[0], 0.0), t, initial=0.0)
    # the integrator as the core runs it: the sum of e dt at the step starts (conditional
    # integration stops it only while the rudder is saturated, when it adds nothing anyway)
    integral = np.cumsum(e[0]) * dt
    k = int(np.argmin(diff))
    return IntegralEffect(horizons=horizons, difference=diff[idx], benefit=gain[idx],
                          offset=e[0][idx], max_integral_rudder=float(gains[1] *
                                                                      np.max(np.abs(integral))),
                          min_difference=float(diff[k]), t_min_difference=float(t[k]))
