"""Steering servo (rudder / vector-thruster angle) models with angle and rate limits.

Angles [rad], rates [rad/s], time constants [s], natural frequency [rad/s]. Default limits are
+-35 deg (the Lanxin vector thruster, Mu et al. 2018 section 2.2) and no rate limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import check_params

DEFAULT_MAX_ANGLE = math.radians(35.0)


class _Limits:
    """The angle and rate limits every servo has (checked with its own parameters)."""

    max_angle: float
    max_rate: float

    def _check(self, values: dict[str, float], positive: tuple[str, ...] = (),
               nonnegative: tuple[str, ...] = ()) -> None:
        check_params("servo", {**values, "max_angle": self.max_angle},
                     positive=(*positive, "max_angle"), nonnegative=nonnegative)
        if not np.all(np.asarray(self.max_rate) > 0):
            raise UsvidError(f"servo.max_rate must be > 0 (got {self.max_rate!r})")

    def delay_samples(self, dt: float) -> int:
        """Dead time in whole samples of dt [s] (0 without a dead time)."""
        return 0


@dataclass
class IdealServo(_Limits):
    """delta = saturate(delta_cmd): no dynamics, only the angle limit (and rate limit if finite)."""

    max_angle: float = DEFAULT_MAX_ANGLE
    max_rate: float = math.inf

    kind = "ideal"

    def __post_init__(self) -> None:
        self._check({})


@dataclass
class FirstOrderServo(_Limits):
    """First order: ``T delta' = delta_cmd - delta`` (Mu et al. 2018 eq. 11), then the limits.

    T [s] >= 0 (T = 0 is the ideal servo).
    """

    T: float
    max_angle: float = DEFAULT_MAX_ANGLE
    max_rate: float = math.inf

    kind = "first_order"

    def __post_init__(self) -> None:
        self._check({"T": self.T}, nonnegative=("T",))


@dataclass
class SecondOrderServo(_Limits):
    """Second order with gain and dead time (Mu et al. 2018 eq. 12 and section 5.1.3; Mu et al. 2016
    eq. 22).

    ``delta'' + 2 zeta omega_n delta' + omega_n^2 delta = gain omega_n^2 delta_cmd(t - delay)``.
    Mu et al. 2018 identified 1.95 / (s^2 + 2.38125 s + 1.95) e^{-s}: omega_n = sqrt(1.95) = 1.3964
    rad/s, zeta = 2.38125 / (2 omega_n) = 0.8526, gain = 1, delay = 1 s.
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
        self._check({"omega_n": self.omega_n, "zeta": self.zeta, "gain": self.gain,
                     "delay": self.delay}, positive=("omega_n", "gain"),
                    nonnegative=("zeta", "delay"))

    @classmethod
    def from_transfer_function(cls, b0: float, a1: float, a0: float, delay: float = 0.0,
                               **limits: float) -> SecondOrderServo:
        """From ``b0 / (s^2 + a1 s + a0) e^{-delay s}`` (Mu et al. 2018 section 5.1.3 form).

        omega_n = sqrt(a0), zeta = a1 / (2 omega_n), gain = b0 / a0.
        """
        wn = math.sqrt(a0)
        return cls(omega_n=wn, zeta=a1 / (2.0 * wn), gain=b0 / a0, delay=delay, **limits)

    def delay_samples(self, dt: float) -> int:
        """Dead time in whole samples of dt [s]: ``round(delay / dt)``."""
        return int(round(float(self.delay) / dt))

    def overshoot(self) -> float:
        """Fractional step overshoot ``exp(-zeta pi / sqrt(1 - zeta^2))`` (0 when zeta >= 1)."""
        z = float(self.zeta)
        return math.exp(-z * math.pi / math.sqrt(1.0 - z * z)) if z < 1.0 else 0.0

    def peak_time(self) -> float:
        """Step-response peak time after the dead time [s]: ``pi / (omega_n sqrt(1-zeta^2))``."""
        z = float(self.zeta)
        return math.pi / (float(self.omega_n) * math.sqrt(1.0 - z * z)) if z < 1.0 else math.inf


#: Mu et al. 2018 section 5.1.3: 1.95 / (s^2 + 2.38125 s + 1.95) e^{-s} (Lanxin vector thruster).
def mu2018_servo() -> SecondOrderServo:
    """The identified Lanxin servo of Mu et al. 2018 (section 5.1.3, +-35 deg, 1 s dead time)."""
    return SecondOrderServo.from_transfer_function(1.95, 2.38125, 1.95, delay=1.0)


Servo = IdealServo | FirstOrderServo | SecondOrderServo
