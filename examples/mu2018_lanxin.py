"""Mu et al. 2018 (the Lanxin USV): the response model of the 3-DOF model, its Norrbin alpha,
the turning radius at 10 deg, and what Table 1's 0.35 m would do as the thruster arm
(docs/papers.md, "Mu et al. 2018"). About 10 s.

Run: ``.venv/bin/python examples/mu2018_lanxin.py``. Printed:

1. K, T1, T2, T3 and T = T1 + T2 - T3 of the 3-DOF model of eq. 37 at 10 kn in closed form
   (eq. 29-33, ``usvid.models.response_params.threedof_response``);
2. the Norrbin alpha of the 3-DOF model: eq. 36 fitted to its steady turns at 5-35 deg;
3. the steady turning radius at 10 and 11 deg of the 3-DOF, Nomoto and Norrbin examples
   against the measured radius the paper implies (1.5 m = 3.8 % of it: 39.47 m);
4. the 3-DOF model with the thruster arm x_l = 0.35 m (Table 1's "distance between gravity and
   center") instead of 3.5 m: K and the radius at 10 deg.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from usvid.io.modelfile import load_model
from usvid.models import VesselModel
from usvid.models.response_params import norrbin_alpha, threedof_response
from usvid.sim import run_turning

HERE = Path(__file__).resolve().parent
U10 = 10 * 1852.0 / 3600.0  # 10 kn [m/s]


def main() -> None:
    m3 = load_model(HERE / "lanxin_threedof.json")
    d = m3.dynamics
    rp = threedof_response(d, U10, d.d11 * U10)
    print(f"1. eq. 37 at 10 kn: K {rp.K:.4f} 1/s, T1 {rp.T1:.4f} s, T2 {rp.T2:.4f} s, "
          f"T3 {rp.T3:.4f} s, T = T1 + T2 - T3 = {rp.T:.4f} s (eq. 38: 0.332 s)")
    degs = (5.0, 15.0, 25.0, 35.0)
    r = [run_turning(m3, x)[1].steady_yaw_rate_rad_s for x in degs]
    K, alpha = norrbin_alpha(r, np.radians(degs))
    print(f"2. eq. 36 on the 3-DOF model's steady turns (5-35 deg): K {K:.3f} 1/s, alpha "
          f"{alpha:.3f} s^2 (the paper's alpha from the measured turns: 1.102)")
    print(f"3. measured radius at 10 deg: 1.5 / 0.038 = {1.5 / 0.038:.2f} m")
    for name in ("lanxin_threedof", "lanxin", "lanxin_norrbin"):
        m = load_model(HERE / f"{name}.json")
        R = [run_turning(m, x)[1].steady_diameter_m / 2 for x in (10.0, 11.0)]
        print(f"   {name}: {R[0]:.2f} m at 10 deg ({100 * (R[0] / (1.5 / 0.038) - 1):+.1f} %), "
              f"{R[1]:.2f} m at 11 deg")
    d35 = d.replace(x_l=0.35)
    R35 = run_turning(VesselModel(d35, m3.servo, m3.vessel), 10.0)[1].steady_diameter_m / 2
    print(f"4. x_l = 0.35 m: K {threedof_response(d35, U10, d35.d11 * U10).K:.5f} 1/s, radius "
          f"{R35:.1f} m at 10 deg (x_l = {d.x_l:g} m: {rp.K:.4f} 1/s)")
    print(f"   steady Nomoto radius U / (K delta) = {U10:.4f} / (0.707 x "
          f"{math.radians(10.0):.5f}) = {U10 / (0.707 * math.radians(10.0)):.2f} m")


if __name__ == "__main__":
    main()
