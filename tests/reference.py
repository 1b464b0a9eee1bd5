"""Reference solutions for the tests, independent of the integration core.

* :func:`joint_rhs`, :func:`reference_run`: a kind's right-hand side (``ModelKind.derivatives``,
  the one copy of its equations) with the kinematics, for ``scipy.integrate.solve_ivp``: the
  core (:mod:`usvid.sim.core`) is checked against an adaptive Runge-Kutta (DOP853) at tight
  tolerances, inputs evaluated exactly at any time.
* :func:`nomoto_zoh_zigzag`: a noise-free Nomoto 1 zig-zag record by the exact zero-order-hold
  recursion.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from usvid.models.registry import kind_of
from usvid.trial import Trial, Vessel


def joint_rhs(dynamics: Any, inputs: Callable[[float], Mapping[str, float]],
              speed: float = 1.0) -> Callable[[float, np.ndarray], list[float]]:
    """``f(t, z)`` of the state z = (x, y, psi, the kind's states); ``inputs(t)`` gives the
    kind's inputs by name (``delta`` [rad], ``n`` [rps], ``n_port``, ``n_stbd``); ``speed`` the
    constant speed U [m/s] of a response kind.

    The kind's right-hand side ``kind.rhs`` is called as ``ModelKind.derivatives`` calls it,
    with the parameters packed once (``derivatives`` packs them at every call: ~0.4 ms, 90 %
    of a reference run's time); ``f`` is checked against ``derivatives`` on its first call."""
    kind = kind_of(dynamics)
    P = tuple(np.asarray(kind.pack(dynamics, speed), float)[:, 0].tolist())
    checked = False

    def f(t: float, z: np.ndarray) -> list[float]:
        nonlocal checked
        ins = inputs(t)
        d = float(ins.get("delta", 0.0))
        a = (d, math.cos(d), math.sin(d), float(ins.get("n", math.nan)),
             float(ins.get("n_port", math.nan)), float(ins.get("n_stbd", math.nan)))
        u, v, r, ds = kind.rhs(P, tuple(float(v) for v in z[3:]), a, (0.0, 0.0, 0.0, 0.0))
        u, v, r = float(u), float(v), float(r)
        dz = [float(x) for x in ds]
        if not checked:  # the same numbers as the kind's numpy right-hand side
            want = kind.derivatives(dynamics, z[3:], speed=speed, **ins)
            np.testing.assert_array_equal([u, v, r, *dz],
                                          [*map(float, want[:3]), *np.ravel(want[3])])
            checked = True
        c, sn = math.cos(z[2]), math.sin(z[2])
        return [u * c - v * sn, u * sn + v * c, r, *dz]

    return f


def reference_run(dynamics: Any, inputs: Callable[[float], Mapping[str, float]],
                  z0: Any, t_eval: np.ndarray, speed: float = 1.0) -> np.ndarray:
    """(3 + n_states, len(t_eval)) states from solve_ivp (DOP853, rtol 1e-10, atol 1e-12: on
    the 40 s 3-DOF runs of test_threedof within 1.5e-12 of a run at rtol 1e-12, where RK45 at
    the same tolerances is within 1.1e-11 and takes 1.5 times the steps)."""
    sol = solve_ivp(joint_rhs(dynamics, inputs, speed), (0.0, float(t_eval[-1])),
                    np.asarray(z0, float), t_eval=t_eval, rtol=1e-10, atol=1e-12,
                    method="DOP853")
    assert sol.success, sol.message
    return sol.y


def nomoto_zoh_zigzag(K: float = 0.3, T: float = 5.0, h: float = 0.05, n: int = 8000) -> Trial:
    """Noise-free Nomoto 1 response (``T r' + r = K delta``, exact ZOH recursion) to a +-10 deg
    square wave of 40 s period, at step ``h`` [s]: a Trial (SI) of a 7 m vessel at 1.18 m/s."""
    t = np.arange(n) * h
    delta = math.radians(10) * np.sign(np.sin(2 * np.pi * t / 40) + 1e-9)
    a = math.exp(-h / T)
    r = np.zeros(n)
    for k in range(n - 1):
        r[k + 1] = a * r[k] + K * (1 - a) * delta[k]
    psi = np.concatenate([[0.0], np.cumsum(0.5 * h * (r[1:] + r[:-1]))])
    return Trial(data=pd.DataFrame({"t": t, "psi": psi, "r": r, "delta": delta}),
                 vessel=Vessel(length=7.0, speed=1.18), name="zoh")
