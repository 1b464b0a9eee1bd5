"""The catamaran paper's turn (codes 20 port / 15 starboard from rest): the measured turn (about
8 m at 0.246 m/s) predicted by the paper's own model (docs/papers.md, "Catamaran paper"). 5 s.

Run: ``.venv/bin/python examples/catamaran_turn.py``. ``examples/catamaran.json`` carries the
damping of the paper's model (identified by the paper from its speed/thrust runs) as its
simulated turn (7.38 m at 0.209 m/s) shows it; the measured turn is not used. Printed:

1. the prediction of the measured turn and its error;
2. that the steady turn at these codes does not depend on the assumed masses once the model
   reproduces the paper's simulated turn (d11 and d33 re-solved for halved and doubled masses);
3. what matching the measured speed instead would do: the thrust per code times, or the surge
   damping divided by, 0.246 / 0.209 = 1.177 (each uses one number of the measured turn to
   predict the other);
4. the arm read as the spacing b (the former reading).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from usvid.io.modelfile import load_model
from usvid.models import VesselModel
from usvid.sim import Commanded, simulate

HERE = Path(__file__).resolve().parent
MEASURED = {"diameter_m": 8.0, "speed_m_s": 0.246}
PAPER = {"diameter_m": 7.38, "speed_m_s": 0.209}


def turn(model: VesselModel) -> tuple[float, float]:
    """Steady diameter [m] and speed [m/s] of codes 20 (port) / 15 (starboard) from rest."""
    t = np.array([0.0, 1.0])
    res = simulate(model, Commanded(t, n_port=np.array([20.0, 20.0]),
                                    n_stbd=np.array([15.0, 15.0])),
                   t_end=600.0, dt=0.05, u0=0.0)
    m = res.turning_metrics()[0]
    return m.steady_diameter_m, m.steady_speed_m_s


def resolve(model: VesselModel, scale: float) -> VesselModel:
    """The model with masses times ``scale`` and d11, d33 re-solved from the paper's simulated
    steady turn (steady surge and yaw balance at its speed and yaw rate)."""
    d = model.dynamics
    m11, m22, m33 = d.m11 * scale, d.m22 * scale, d.m33 * scale
    u = PAPER["speed_m_s"]
    r = 2.0 * u / PAPER["diameter_m"]
    v = -m11 * u * r / d.d22  # sway balance: m11 u r + d22 v = 0
    tu, tr = d.tau(20.0, 15.0)
    d11 = (tu + m22 * v * r) / u  # surge balance: -d11 u + m22 v r + tau_u = 0
    d33 = ((m11 - m22) * u * v + tr) / r  # yaw balance: (m11 - m22) u v - d33 r + tau_r = 0
    return VesselModel(d.replace(m11=m11, m22=m22, m33=m33, d11=d11, d33=d33), model.servo,
                       model.vessel)


def main() -> None:
    m = load_model(HERE / "catamaran.json")
    D, U = turn(m)
    print(f"1. predicted {D:.2f} m at {U:.3f} m/s; measured about {MEASURED['diameter_m']:g} m "
          f"at {MEASURED['speed_m_s']} m/s: diameter {D - MEASURED['diameter_m']:+.2f} m "
          f"({100 * (D / MEASURED['diameter_m'] - 1):+.1f} %), speed "
          f"{100 * (U / MEASURED['speed_m_s'] - 1):+.1f} %")
    for s in (0.5, 2.0):
        ms = resolve(m, s)
        Ds, Us = turn(ms)
        print(f"2. masses x{s:g} (d11 {ms.dynamics.d11:.3f}, d33 {ms.dynamics.d33:.3f}): "
              f"{Ds:.2f} m at {Us:.3f} m/s")
    k = MEASURED["speed_m_s"] / PAPER["speed_m_s"]
    d = m.dynamics
    variants = {f"3. thrust per code x{k:.3f}": d.replace(thrust=d.thrust * k),
                f"   d11 / {k:.3f}": d.replace(d11=d.d11 / k),
                "4. 0.25 m read as the spacing b": d.replace(arm=None, b=0.25)}
    for label, dyn in variants.items():
        Dv, Uv = turn(VesselModel(dyn, m.servo, m.vessel))
        print(f"{label}: {Dv:.2f} m at {Uv:.3f} m/s")

if __name__ == "__main__":
    main()
