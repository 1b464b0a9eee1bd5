"""Standard manoeuvre runs on a model: zig-zag, turning circle, course change (IMO MSC.137(76),
ITTC 7.5-04-02-01, Mu et al. 2018 section 6.1), each simulated with :func:`usvid.sim.simulate` and
measured with :mod:`usvid.manoeuvres.metrics`. ``usvid simulate`` and the demo call these.

Arguments in SI units; angles in degrees at this edge, named ``*_deg``; inside radians.
``environment``: an :class:`usvid.sim.Environment` (wind, current, waves; None: calm water).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from usvid.errors import SimulationError, UsvidError
from usvid.manoeuvres.logic import PID, CourseChange, Disturbance, Turning, ZigZag
from usvid.sim.result import SimResult
from usvid.sim.simulate import approach_speed, simulate

if TYPE_CHECKING:
    from usvid.manoeuvres.metrics import TurningMetrics, ZigZagMetrics

__all__ = ["MAX_T_END", "default_ki", "default_t_end", "run_course", "run_turning", "run_zigzag"]

#: Largest simulated time [s] when the run is extended automatically.
MAX_T_END = 3600.0


def default_ki(controller: str) -> float:
    """Integral gain [1/s] when none is given: Mu et al. 2018's 0.00095 for PID, 0 for PD."""
    return 0.00095 if controller == "pid" else 0.0


def default_t_end(model: Any, u0: float) -> float:
    """A first guess of the run length [s]: 20 yaw time constants (``T`` or ``T1`` [s] of the
    dynamics), 10 servo delays and 40 L/U (L [m] the vessel length, ``u0`` [m/s]), at least 60 s
    and at most :data:`MAX_T_END` (a slow vessel would otherwise ask for days)."""
    dyn = model.dynamics
    T = 0.0
    for k in ("T", "T1"):
        if hasattr(dyn, k):
            T = float(abs(getattr(dyn, k)))
            break
    delay = float(getattr(model.servo, "delay", 0.0))
    L = getattr(model.vessel, "length", None) or 0.0
    return min(MAX_T_END, max(60.0, 20.0 * T + 10.0 * delay + 40.0 * L / u0))


def _approach_speed(model: Any, u0: float | None) -> float:
    """The approach speed [m/s] (:func:`usvid.sim.simulate.approach_speed`: ``u0``, else the
    model's ``vessel.speed``, else its kind's straight-line speed), checked to be a positive
    number."""
    u = approach_speed(model, u0)
    if np.ndim(u) or not (math.isfinite(u) and u > 0):
        raise UsvidError(f"the approach speed u0 must be > 0 m/s (got {u!r})")
    return float(u)


def _run(model: Any, logic: Any, t_end: float, dt: float, u0: float,
         environment: Any = None) -> SimResult:
    """One simulation; :class:`SimulationError` when it diverged (a state not finite: an unstable
    model or an RK4 step ``dt`` [s] too large for the model's fastest mode) instead of metrics
    of a broken trajectory."""
    res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, environment=environment)
    finite = all(np.all(np.isfinite(res.channels[k])) for k in ("x", "y", "psi")
                 if k in res.channels)
    if not (res.success and finite):
        why = res.message if not res.success else "x, y or psi is not finite"
        raise SimulationError(f"the simulation diverged ({why}) with the step dt = {dt:g} s; "
                              "reduce dt (--dt) or check the model parameters")
    return res


def run_zigzag(model: Any, delta_deg: float, psi_deg: float, *, first: int = 1,
               t_end: float | None = None, dt: float = 0.02, u0: float | None = None,
               environment: Any = None) -> tuple[SimResult, ZigZagMetrics]:
    """Zig-zag ``delta_deg/psi_deg`` (rudder amplitude / switching angle [deg]) to the ``first``
    side (+1 starboard), from a straight approach at ``u0`` [m/s] (default the model's
    ``vessel.speed``), step ``dt`` [s].

    Returns the :class:`SimResult` and its :class:`ZigZagMetrics`. Without ``t_end`` [s] the run
    is doubled until it shows the third overshoot and one full period (four reversals), up to
    :data:`MAX_T_END`.
    """
    if not 0 < delta_deg <= 90:
        raise SimulationError(f"delta_deg must be in (0, 90] deg (got {delta_deg!r})")
    if not 0 < psi_deg <= 180:
        raise SimulationError(f"psi_deg must be in (0, 180] deg (got {psi_deg!r})")
    u0 = _approach_speed(model, u0)
    logic = ZigZag(delta_amp=math.radians(delta_deg), psi_switch=math.radians(psi_deg),
                   first=first)
    auto = t_end is None
    te = default_t_end(model, u0) if auto else float(t_end)
    while True:
        res = _run(model, logic, te, dt, u0, environment)
        m = res.zigzag_metrics()[0]
        if not auto or (len(m.reversal_times_s) >= 4 and len(m.overshoot_deg) >= 3) \
                or te >= MAX_T_END:
            return res, m
        te = min(2 * te, MAX_T_END)


def run_turning(model: Any, delta_deg: float, *, t_end: float | None = None, dt: float = 0.02,
                u0: float | None = None, environment: Any = None
                ) -> tuple[SimResult, TurningMetrics]:
    """Turning circle with the rudder at ``delta_deg`` [deg] (negative: to port) from a straight
    approach at ``u0`` [m/s] (default the model's ``vessel.speed``), step ``dt`` [s].

    Returns the :class:`SimResult` and its :class:`TurningMetrics`. Without ``t_end`` [s] the run
    is doubled until the heading has changed by 540 deg (180 deg for the tactical diameter plus a
    whole steady circle), up to :data:`MAX_T_END`.
    """
    if not 0 < abs(delta_deg) <= 90:
        raise SimulationError(f"delta_deg must be non-zero and within +-90 deg "
                              f"(got {delta_deg!r})")
    u0 = _approach_speed(model, u0)
    logic = Turning(delta=math.radians(delta_deg))
    auto = t_end is None
    te = default_t_end(model, u0) if auto else float(t_end)
    while True:
        res = _run(model, logic, te, dt, u0, environment)
        psi = res["psi"][0]
        if not auto or abs(float(psi[-1] - psi[0])) >= 3 * math.pi or te >= MAX_T_END:
            return res, res.turning_metrics()[0]
        te = min(2 * te, MAX_T_END)


def run_course(model: Any, *, controller: str = "pd", kp: float = 0.7, ki: float | None = None,
               kd: float = 1.0, target_deg: float = 100.0, noise_deg: float = 1.0,
               seed: int = 1, t_end: float = 100.0, dt: float = 0.02, u0: float | None = None,
               environment: Any = None) -> tuple[SimResult, dict[str, float]]:
    """Course change 0 -> ``target_deg`` [deg] with a PD or PID autopilot (Mu et al. 2018
    section 6.1) from a straight approach at ``u0`` [m/s] (default the model's ``vessel.speed``),
    ``t_end`` [s] long, step ``dt`` [s].

    Gains kp [rad/rad], ki [1/s], kd [s] (Mu et al. 2018: kp = 0.7, ki = 0.00095, kd = 1; PD: ki =
    0, the default for ``controller="pd"``). ``noise_deg``: std [deg] of the Mu et al. 2018
    rudder-equivalent disturbance (0 = calm), stream ``seed``. Returns the :class:`SimResult`
    and ``{"itae" [rad s^2], "iae" [rad s], "max_rudder_deg" [deg]}``.
    """
    u0 = _approach_speed(model, u0)
    if ki is None:
        ki = default_ki(controller)
    if controller == "pd" and ki != 0:
        raise UsvidError("controller 'pd' takes no integral gain ki (use 'pid')")
    if not (math.isfinite(noise_deg) and noise_deg >= 0):
        raise UsvidError(f"noise_deg must be >= 0 deg (got {noise_deg!r})")
    dist = Disturbance(intensity=math.radians(noise_deg), seed=seed) if noise_deg > 0 else None
    logic = CourseChange(target=math.radians(target_deg), controller=PID(kp=kp, ki=ki, kd=kd),
                         disturbance=dist)
    res = _run(model, logic, t_end, dt, u0, environment)
    return res, res.course_metrics()[0]
