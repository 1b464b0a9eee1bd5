"""Reference integration for the tests: a kind's right-hand side (``ModelKind.derivatives``, the
one copy of its equations) with the kinematics, for ``scipy.integrate.solve_ivp``.

The integration core (:mod:`usvid.sim.core`) is checked against an independent integrator of the
same equations: adaptive Runge-Kutta at tight tolerances, inputs evaluated exactly at any time.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from usvid.models.registry import kind_of


def joint_rhs(dynamics: Any, inputs: Callable[[float], Mapping[str, float]],
              speed: float = 1.0) -> Callable[[float, np.ndarray], list[float]]:
    """``f(t, z)`` of the state z = (x, y, psi, the kind's states); ``inputs(t)`` gives the
    kind's inputs by name (``delta`` [rad], ``n`` [rps], ``n_port``, ``n_stbd``); ``speed`` the
    constant speed U [m/s] of a response kind."""
    kind = kind_of(dynamics)

    def f(t: float, z: np.ndarray) -> list[float]:
        u, v, r, dz = kind.derivatives(dynamics, z[3:], speed=speed, **inputs(t))
        c, s = math.cos(z[2]), math.sin(z[2])
        u, v = float(u), float(v)
        return [u * c - v * s, u * s + v * c, float(r), *np.asarray(dz, float).tolist()]

    return f


def reference_run(dynamics: Any, inputs: Callable[[float], Mapping[str, float]],
                  z0: Any, t_eval: np.ndarray, speed: float = 1.0) -> np.ndarray:
    """(3 + n_states, len(t_eval)) states from solve_ivp (RK45, rtol 1e-10, atol 1e-12)."""
    sol = solve_ivp(joint_rhs(dynamics, inputs, speed), (0.0, float(t_eval[-1])),
                    np.asarray(z0, float), t_eval=t_eval, rtol=1e-10, atol=1e-12)
    assert sol.success, sol.message
    return sol.y
