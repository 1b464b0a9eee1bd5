"""Steering servo (rudder / vector-thruster angle) models with angle and rate limits.

Angles [rad], rates [rad/s], time constants [s], natural frequency [rad/s]. Default limits are
+-35 deg (the Lanxin vector thruster, seed 000 section 2.2) and no rate limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from usvid.models._validate import check_params

DEFAULT_MAX_ANGLE = math.radians(35.0)


@dataclass
class IdealServo:
    """delta = saturate(delta_cmd): no dynamics, only the angle limit (and rate limit if finite)."""

    max_angle: float = DEFAULT_MAX_ANGLE
    max_rate: float = math.inf

    kind = "ideal"

    def __post_init__(self) -> None:
        check_params("servo", {"max_angle": self.max_angle}, positive=("max_angle",))
        if not self.max_rate > 0:
            raise_bad_rate(self.max_rate)


@dataclass
class FirstOrderServo:
    """First order: ``T delta' = delta_cmd - delta`` (seed 000 eq. 11), then the limits.

    T [s] >= 0 (T = 0 is the ideal servo).
    """

    T: float
    max_angle: float = DEFAULT_MAX_ANGLE
    max_rate: float = math.inf

    kind = "first_order"

    def __post_init__(self) -> None:
        check_params("servo", {"T": self.T, "max_angle": self.max_angle},
                     nonnegative=("T",), positive=("max_angle",))
        if not self.max_rate > 0:
            raise_bad_rate(self.max_rate)


@dataclass
class SecondOrderServo:
    """Second order with gain and dead time (seed 000 eq. 12 and section 5.1.3; seed 001 eq. 22).

    ``delta'' + 2 zeta omega_n delta' + omega_n^2 delta = gain omega_n^2 delta_cmd(t - delay)``.
    Seed 000 identified 1.95 / (s^2 + 2.38125 s + 1.95) e^{-s}: omega_n = sqrt(1.95) = 1.3964 rad/s,
    zeta = 2.38125 / (2 omega_n) = 0.8526, gain = 1, delay = 1 s.
    omega_n [rad/s] > 0, zeta >= 0, gain [-], delay [s] >= 0.
    """

    omega_n: float
    zeta: float
    gain: float = 1.0
    delay: float = 0.0
    max_angle: float = DEFAULT_MAX_ANGLE
    max_rate: float = math.inf

    kind = "second_order"

    def __post_init__(self) -> None:
        check_params("servo",
                     {"omega_n": self.omega_n, "zeta": self.zeta, "gain": self.gain,
                      "delay": self.delay, "max_angle": self.max_angle},
                     positive=("omega_n", "gain", "max_angle"),
                     nonnegative=("zeta", "delay"))
        if not self.max_rate > 0:
            raise_bad_rate(self.max_rate)


def raise_bad_rate(value: float) -> None:
    from usvid.errors import UsvidError

    raise UsvidError(f"servo.max_rate must be > 0 (got {value!r})")


Servo = IdealServo | FirstOrderServo | SecondOrderServo
