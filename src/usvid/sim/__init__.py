"""usvid.sim: fixed-step batch simulation of vessel models under manoeuvre logics.

Public API
----------
- :func:`simulate` ``(model, logic, *, t_end, dt=0.02, u0=None, record_every=1, seed=0,
  psi0=0, disturbance=None, environment=None, channels=None, initial=None) -> SimResult`` --
  RK4 over a batch (numba, parallel over runs). Any model/servo/logic parameter may be a (B,)
  array. Units: SI and radians (t_end, dt [s], u0 [m/s], psi0 [rad]). :class:`Environment`: a
  current and an external force on the hull, for every kind.
- Logics (:mod:`usvid.manoeuvres.logic`, re-exported here): :class:`Turning`,
  :class:`ZigZag`, :class:`CourseChange` with :class:`PID`, :class:`Disturbance` (white noise
  through 0.42 s/(s^2 + 0.36 s + 0.37), Mu et al. 2018), :class:`Commanded` (time series).
- :class:`SimResult` (:mod:`usvid.sim.result`): ``t``, ``channels`` (B, N) arrays,
  ``batch_size``, ``zigzag_metrics()``, ``turning_metrics()``, ``course_metrics()``,
  ``to_trial(i)``, ``course`` and ``zigzag_online`` accumulators.
- Standard manoeuvre runs with their metrics (:mod:`usvid.sim.runs`, what ``usvid simulate``
  runs): :func:`run_zigzag`, :func:`run_turning`, :func:`run_course` (angles in degrees, named
  ``*_deg``).
- :mod:`usvid.sim.virtual` (sensor models, virtual trials) is a separate module; the IMO
  criteria are in :mod:`usvid.manoeuvres.imo`.
"""

from usvid.manoeuvres.logic import PID, Commanded, CourseChange, Disturbance, Turning, ZigZag
from usvid.sim.result import CHANNEL_UNITS, SimResult
from usvid.sim.runs import run_course, run_turning, run_zigzag
from usvid.sim.simulate import Environment, simulate

__all__ = [
    "CHANNEL_UNITS", "PID", "Commanded", "CourseChange", "Disturbance", "Environment",
    "SimResult", "Turning", "ZigZag", "run_course", "run_turning", "run_zigzag", "simulate",
]
