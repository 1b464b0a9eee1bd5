"""Mu et al. 2016 (podded USV): the turning radius (85.76 m simulated) and the 15/15 zig-zag period
(11.3 s simulated, 12.9 s measured) under each reading of the printed numbers (docs/papers.md,
"Mu et al. 2016"). About 30 s.

Run: ``.venv/bin/python examples/mu2016_pod_usv.py``. Printed:

1. the discrete models: the poles of eq. 23 (one outside the unit circle), the damping ratio of
   eq. 26 (the same for every sample time), and eq. 27's parameters recomputed from eq. 26's
   coefficients read as if they were those of a continuous polynomial;
2. the steady turning radius at 5 deg for the three readings of K and T (the text's 0.707 /
   0.332, eq. 25 as printed 225.9/332 and 106.8/332, eq. 24's 322 s term) at 9.1 and 9.14 kn,
   and the speed each needs for 85.76 m (Table 1 prints 8.91-9.21 kn);
3. the 15/15 zig-zag period for each reading and servo parameter set, and the servo natural
   frequency each needs for the simulated 11.3 s and the measured 12.9 s.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from usvid.models import VesselModel
from usvid.models.kinds.nomoto1 import Nomoto1
from usvid.models.servo import IdealServo, SecondOrderServo
from usvid.models.turning_diameter import KNOT
from usvid.sim import run_turning, run_zigzag
from usvid.trial import Vessel

#: Readings of K [1/s] and T [s].
READINGS = {"text: K 0.707, T 0.332": (0.707, 0.332),
            "eq. 25 as printed: 225.9/332, 106.8/332": (225.9 / 332.0, 106.8 / 332.0),
            "eq. 24's 322: 225.9/322, 106.8/322": (225.9 / 322.0, 106.8 / 322.0)}
#: Servo of eq. 27: the text's omega_n [rad/s], zeta, gain.
SERVO = {"omega_n": 0.958, "zeta": 0.811, "gain": 0.923}
SPEED = 9.1 * KNOT  # [m/s], "about 9.1 kn" (Table 1)


def model(K: float, T: float, **servo: float) -> VesselModel:
    """Nomoto model of the podded USV with a second-order servo (or ideal if ``ideal``)."""
    s = IdealServo() if servo.pop("ideal", False) else SecondOrderServo(**{**SERVO, **servo})
    return VesselModel(Nomoto1(K=K, T=T), s, Vessel(speed=SPEED))


def period(K: float, T: float, **servo: float) -> float:
    """15/15 zig-zag period [s]."""
    return run_zigzag(model(K, T, **servo), 15.0, 15.0)[1].period_s


def main() -> None:
    # 1. the discrete models
    print("1. eq. 23 poles:", np.round(np.roots([1.0, -0.9537, -0.5476, 0.007182]), 4))
    z = np.roots([1.0, 1.553, 0.9169])[0]
    zeta = -math.log(abs(z)) / abs(complex(math.log(abs(z)), abs(np.angle(z))))
    print(f"   eq. 26: |z| = {abs(z):.4f}, angle {math.degrees(abs(np.angle(z))):.1f} deg: "
          f"zeta = {zeta:.4f} for every sample time")
    print(f"   eq. 26's coefficients as a continuous polynomial: omega_n = sqrt(0.9169) = "
          f"{math.sqrt(0.9169):.4f}, zeta = 1.553 / (2 omega_n) = "
          f"{1.553 / (2 * math.sqrt(0.9169)):.4f}, gain = 0.8464 / 0.9169 = "
          f"{0.8464 / 0.9169:.4f}")

    # 2. turning radius at 5 deg
    print("\n2. steady turning radius at 5 deg (servo gain 0.923):")
    for name, (K, T) in READINGS.items():
        rs = [run_turning(model(K, T), 5.0, u0=kn * KNOT)[1].steady_diameter_m / 2
              for kn in (9.1, 9.14)]
        need = 85.76 * K * SERVO["gain"] * math.radians(5.0) / KNOT
        print(f"   {name}: {rs[0]:.2f} m at 9.1 kn, {rs[1]:.2f} m at 9.14 kn; "
              f"85.76 m needs {need:.2f} kn")

    # 3. zig-zag period 15/15
    print("\n3. 15/15 zig-zag period [s]:")
    for name, (K, T) in READINGS.items():
        row = {"omega_n 0.958": period(K, T), "omega_n 0.985 (eq. 27)":
               period(K, T, omega_n=0.985), "gain 1": period(K, T, gain=1.0),
               "ideal servo": period(K, T, ideal=True)}
        w113 = brentq(lambda w, K=K, T=T: period(K, T, omega_n=w) - 11.3, 1.0, 5.0, xtol=1e-3)
        w129 = brentq(lambda w, K=K, T=T: period(K, T, omega_n=w) - 12.9, 0.9, 5.0, xtol=1e-3)
        print(f"   {name}: " + ", ".join(f"{k} {v:.2f}" for k, v in row.items())
              + f"; 11.3 s needs omega_n {w113:.2f}, 12.9 s needs {w129:.2f} rad/s")


if __name__ == "__main__":
    main()
