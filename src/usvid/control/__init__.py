"""Course-keeping autopilot design from an identified model (any kind).

- :mod:`usvid.control.linear`: the yaw response linearised about straight running, its
  first-order Nomoto equivalent, and the open-loop frequency response of a PID heading loop
  (with the steering servo and its dead time) for gain and phase margins;
- :mod:`usvid.control.pole_placement`: Fossen's PID pole placement for the Nomoto form;
- :mod:`usvid.control.evaluate`: step responses of candidate gains as lanes of one batch of
  the integration core (ITAE, overshoot, rudder saturation over a stated horizon);
- :mod:`usvid.control.itae`: ITAE-optimal gains on the model itself under the disturbance,
  with the rudder angle and rate limits of its servo;
- :mod:`usvid.control.robustness`: the design over samples of the model's parameter
  uncertainty;
- :mod:`usvid.control.design`: :func:`design_autopilot`, what ``usvid autopilot`` runs.

SI units and radians; gains kp [rad/rad], ki [1/s], kd [s] of
``delta_cmd = kp e + ki int(e dt) - kd r``, e = psi_d - psi (:class:`usvid.sim.PID`).
"""

from usvid.control.design import AutopilotDesign, design_autopilot
from usvid.control.evaluate import Gains, StepMetrics, evaluate_gains
from usvid.control.itae import itae_design
from usvid.control.linear import NomotoEquivalent, loop_margins, nomoto_equivalent
from usvid.control.pole_placement import natural_frequency, pole_placement
from usvid.control.robustness import Robustness, robustness, sample_models

__all__ = ["AutopilotDesign", "Gains", "NomotoEquivalent", "Robustness", "StepMetrics",
           "design_autopilot", "evaluate_gains", "itae_design", "loop_margins",
           "natural_frequency", "nomoto_equivalent", "pole_placement", "robustness",
           "sample_models"]
