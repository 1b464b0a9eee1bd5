"""Twin-thruster catamaran, 3-DOF (seed 002; standard published MMG/Fossen form).

Seed 002's equations are mostly lost in extraction; we use the standard diagonal Fossen form
(the same reduction as seed 000 eq. 17) with a differential-thrust yaw moment::

    m11 u' = m22 v r - d11 u + tau_u
    m22 v' = -m11 u r - d22 v
    m33 r' = (m11 - m22) u v - d33 r + tau_r
    tau_u = T_port + T_stbd,   tau_r = (T_port - T_stbd) b / 2

b [m] is the distance between the two thrusters (seed 002 eq. 26-27; ARCHITECTURE.md sign
convention: more port thrust turns the vessel to starboard, r > 0). Kinematics in NED as in
:mod:`usvid.models.threedof`.

Each thruster's thrust comes from its command c (control code 0..120, PWM [us] or shaft speed):
``thrust`` is a :class:`usvid.models.thrust.TwinThrust` (code -> voltage -> thrust, seed 002) or a
number k [N per command unit] (T = k c). The manoeuvre logics of :mod:`usvid.sim` steer the
catamaran through a rudder-equivalent angle delta [rad]:
``c_port = cmd + steer_gain delta``, ``c_stbd = cmd - steer_gain delta``
(positive delta -> more port thrust -> r > 0, as for a rudder); a ``Commanded`` input may instead
give ``n_port``/``n_stbd`` directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import check_params
from usvid.models.threedof import ned_state_derivative

ArrayLike = float | np.ndarray


@dataclass
class Catamaran:
    """Twin-thruster catamaran (seed 002). SI: m11, m22 [kg], m33 [kg m^2] > 0; d11, d22 [kg/s],
    d33 [kg m^2/s]; b [m] thruster spacing; ``thrust`` TwinThrust or k [N/command unit];
    ``cmd`` nominal command per thruster; ``steer_gain`` [command units per rad]."""

    m11: ArrayLike
    m22: ArrayLike
    m33: ArrayLike
    d11: ArrayLike
    d22: ArrayLike
    d33: ArrayLike
    b: ArrayLike
    thrust: Any = 1.0
    cmd: ArrayLike = 0.0
    steer_gain: ArrayLike = 0.0

    kind = "catamaran"
    state_names = ("x", "y", "psi", "u", "v", "r")
    input_names = ("n_port", "n_stbd")

    def __post_init__(self) -> None:
        check_params("parameters",
                     {k: getattr(self, k) for k in ("m11", "m22", "m33", "d11", "d22", "d33",
                                                    "b", "cmd", "steer_gain")},
                     positive=("m11", "m22", "m33", "b"))
        if not hasattr(self.thrust, "thrust"):
            check_params("parameters", {"thrust": self.thrust})

    def thruster_thrust(self, c: ArrayLike) -> np.ndarray:
        """Thrust [N] of one thruster at command c (TwinThrust, or k c)."""
        if hasattr(self.thrust, "thrust"):
            return np.asarray(self.thrust.thrust(c), dtype=float)
        return np.asarray(self.thrust, dtype=float) * np.asarray(c, dtype=float)

    def tau(self, c_port: ArrayLike, c_stbd: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(tau_u [N], tau_r [N m]) = (T_p + T_s, (T_p - T_s) b/2) (seed 002)."""
        Tp, Ts = self.thruster_thrust(c_port), self.thruster_thrust(c_stbd)
        return Tp + Ts, (Tp - Ts) * np.asarray(self.b) / 2.0

    def f(self, state: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """See :func:`catamaran_f`."""
        return catamaran_f(state, inputs, self)

    def commands(self, delta: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(c_port, c_stbd) for a rudder-equivalent steering angle delta [rad]."""
        d = np.asarray(delta, dtype=float)
        g = np.asarray(self.steer_gain)
        return np.asarray(self.cmd) + g * d, np.asarray(self.cmd) - g * d


def catamaran_f(state: np.ndarray, inputs: np.ndarray, p: Catamaran) -> np.ndarray:
    """d(state)/dt; state ``(..., 6)`` = (x, y, psi, u, v, r), inputs ``(..., 2)`` =
    (command port, command starboard). Equations in the module docstring."""
    s = np.asarray(state, dtype=float)
    inp = np.asarray(inputs, dtype=float)
    if inp.shape[-1] != 2:
        raise UsvidError(f"catamaran inputs must have 2 columns (port, stbd), got {inp.shape}")
    tau_u, tau_r = p.tau(inp[..., 0], inp[..., 1])
    psi, u, v, r = s[..., 2], s[..., 3], s[..., 4], s[..., 5]
    m11, m22, m33 = (np.asarray(getattr(p, k), float) for k in ("m11", "m22", "m33"))
    d11, d22, d33 = (np.asarray(getattr(p, k), float) for k in ("d11", "d22", "d33"))
    du = (m22 * v * r - d11 * u + tau_u) / m11
    dv = (-m11 * u * r - d22 * v) / m22
    dr = ((m11 - m22) * u * v - d33 * r + tau_r) / m33
    return ned_state_derivative(psi, u, v, r, du, dv, dr)
