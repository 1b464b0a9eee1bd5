"""The physics of a surface vessel under a rudder step: one probe, one set of rules.

A model outside the physics of a surface vessel gives numbers that look like results (a
"turning circle" to port under starboard rudder, the tactical diameter of a vessel backing). Two
places judge a model by what it does under a rudder step: identification, before it writes a
model (:mod:`usvid.identify.checks`, turning circles to both sides inside the training
envelope), and the commands that simulate or design with a model file
(``usvid.commands._physics``, a probe at the manoeuvre's rudder angle). Both run
:func:`turn_probe` and read its :class:`TurnProbe`; what counts as turning to the wrong side,
going astern or diverging is defined here only:

* **wrong side**: usvid's sign convention is that a positive rudder angle makes the yaw rate
  positive (Fossen 2021, ch. 2: a rudder to starboard turns the bow to starboard for an ordinary
  vessel, K > 0 in Nomoto's model). The side of the turn is read when the heading has first
  changed by :data:`TURN_DEG` from its start (the first sustained response, before any later
  oscillation of an unstable model);
* **astern**: the last finite surge speed u [m/s] of the probe is not positive (kinds with a
  surge equation; a constant-speed kind records its constant u);
* **diverged**: the heading is not finite somewhere in the probe, or the core stopped the run
  (a yaw rate beyond :data:`usvid.sim.layout.R_MAX`, which no vessel reaches).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.manoeuvres.logic import Turning
from usvid.sim.simulate import simulate

__all__ = ["TURN_DEG", "TurnProbe", "turn_probe"]

#: Heading change [deg] that shows the side of a turn.
TURN_DEG = 1.0


@dataclass(frozen=True)
class TurnProbe:
    """What a model does under a rudder step ``delta`` [rad] (positive: to starboard).

    ``t`` [s] and ``psi`` [rad] the recorded heading (NaN after a divergence); ``diverged_at``
    [s] the first time the heading is not finite (None: finite throughout); ``success`` the
    core's verdict (False: a lane stopped); ``side_turn`` [rad] the heading change when it first
    exceeded :data:`TURN_DEG` (None: it never did); ``side_at`` [s] that time; ``turn`` [rad] the
    heading change at the last finite sample; ``u_end`` [m/s] the last finite surge speed (None:
    the run records no u)."""

    delta: float
    t: np.ndarray
    psi: np.ndarray
    success: bool
    diverged_at: float | None
    side_turn: float | None
    side_at: float | None
    turn: float
    u_end: float | None

    @property
    def diverged(self) -> bool:
        """The heading is not finite somewhere, or the core stopped the run."""
        return self.diverged_at is not None or not self.success

    @property
    def wrong_side(self) -> bool:
        """The first sustained turn is to the side opposite the rudder (a positive rudder
        angle must make the yaw rate positive)."""
        return self.side_turn is not None and self.side_turn * self.delta < 0.0

    @property
    def astern(self) -> bool:
        """The surge speed ends not positive: the model stops or runs astern."""
        return self.u_end is not None and not self.u_end > 0.0


def turn_probe(model: Any, delta: float, u0: float, *, t_end: float, dt: float) -> TurnProbe:
    """Simulate ``model`` under a rudder step to ``delta`` [rad] from the approach speed ``u0``
    [m/s] for ``t_end`` [s] at step ``dt`` [s] (:func:`usvid.sim.simulate`, a turning test) and
    read what it shows (:class:`TurnProbe`; the rules in the module docstring)."""
    with np.errstate(all="ignore"):
        # x and y recorded though unused: the vector-step variant of the manoeuvre that
        # follows (it records the track), so a first run with an empty cache compiles one
        # variant fewer (~10 % of its compile time)
        res = simulate(model, Turning(delta=delta), t_end=t_end, dt=dt, u0=u0,
                       channels=("x", "y", "psi", "r", "u", "v", "delta"))
    t = np.asarray(res.t, float)
    psi = np.asarray(res["psi"][0], float)
    ok = np.isfinite(psi)
    diverged_at = None if ok.all() else float(t[int(np.argmax(~ok))])
    idx = np.flatnonzero(ok)
    dpsi = psi[idx] - psi[idx[0]] if idx.size else np.zeros(0)
    past = np.flatnonzero(np.abs(dpsi) > math.radians(TURN_DEG))
    side_turn = float(dpsi[past[0]]) if past.size else None
    side_at = float(t[idx[past[0]]]) if past.size else None
    u_end = None
    if "u" in res.channels:
        u = np.asarray(res["u"][0], float)
        u = u[np.isfinite(u)]
        u_end = float(u[-1]) if u.size else None
    return TurnProbe(delta=float(delta), t=t, psi=psi, success=bool(res.success),
                     diverged_at=diverged_at, side_turn=side_turn, side_at=side_at,
                     turn=float(dpsi[-1]) if dpsi.size else 0.0, u_end=u_end)
