"""Response (yaw) models: Nomoto 1st and 2nd order and the Norrbin nonlinear model.

Units: K [1/s] (yaw rate per radian of rudder), time constants [s], delta0 [rad] (rudder offset).
Every parameter may be a scalar or an array over a leading batch axis.

Seed 000 prints "K = 0.332 and T = 0.707" for 0.332 r' + r = 0.707 delta. Read as an equation that
is the other way round: the coefficient of r' is the time constant T and the right-hand gain is K.
The consistent reading (also seed 001's order of magnitude) is T = 0.332 s, K = 0.707 1/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from usvid.models._validate import check_params

ArrayLike = float | np.ndarray


@dataclass
class Nomoto1:
    """Nomoto 1st order: ``T r' + r = K (delta + delta0)`` (seed 000 eq. 35 with alpha = 0).

    K [1/s], T [s] > 0, delta0 [rad].
    """

    K: ArrayLike
    T: ArrayLike
    delta0: ArrayLike = 0.0

    kind = "nomoto1"
    state_names = ("x", "y", "psi", "r")
    input_names = ("delta",)

    def __post_init__(self) -> None:
        check_params("parameters", {"K": self.K, "T": self.T, "delta0": self.delta0},
                     positive=("T",))

    def f(self, state: np.ndarray, inputs: np.ndarray, *, U: ArrayLike) -> np.ndarray:
        """State derivative, see :func:`nomoto1_f`."""
        return nomoto1_f(state, inputs, self, U=U)

    def steady_yaw_rate(self, delta: ArrayLike) -> np.ndarray:
        """Steady yaw rate [rad/s] for a constant rudder angle delta [rad]: K (delta + delta0)."""
        return np.asarray(self.K) * (np.asarray(delta) + np.asarray(self.delta0))


@dataclass
class Nomoto2:
    """Nomoto 2nd order (seed 000 eq. 29-30, seed 001 eq. 18).

    ``T1 T2 r'' + (T1 + T2) r' + r = K (delta + delta0 + T3 delta')``, i.e.
    ``r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))``. K [1/s], T1, T2 [s] > 0, T3 [s].
    """

    K: ArrayLike
    T1: ArrayLike
    T2: ArrayLike
    T3: ArrayLike = 0.0
    delta0: ArrayLike = 0.0

    kind = "nomoto2"
    state_names = ("x", "y", "psi", "z", "zdot")
    input_names = ("delta",)

    def __post_init__(self) -> None:
        check_params("parameters",
                     {"K": self.K, "T1": self.T1, "T2": self.T2, "T3": self.T3,
                      "delta0": self.delta0},
                     positive=("T1", "T2"))

    def f(self, state: np.ndarray, inputs: np.ndarray, *, U: ArrayLike) -> np.ndarray:
        """State derivative, see :func:`nomoto2_f`."""
        return nomoto2_f(state, inputs, self, U=U)

    def yaw_rate(self, state: np.ndarray) -> np.ndarray:
        """Yaw rate r [rad/s] of a state ``(x, y, psi, z, zdot)``: ``K/(T1 T2) (z + T3 zdot)``."""
        state = np.asarray(state, dtype=float)
        T1, T2 = np.asarray(self.T1), np.asarray(self.T2)
        z, zd = state[..., 3], state[..., 4]
        return np.asarray(self.K) / (T1 * T2) * (z + np.asarray(self.T3) * zd)

    def state_from_yaw_rate(self, r: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``(z, zdot)`` of the steady state with yaw rate r [rad/s] (zdot = 0)."""
        T1, T2 = np.asarray(self.T1), np.asarray(self.T2)
        return np.asarray(r) * T1 * T2 / np.asarray(self.K), np.zeros_like(np.asarray(r, float))

    def steady_yaw_rate(self, delta: ArrayLike) -> np.ndarray:
        """Steady yaw rate [rad/s] for a constant rudder angle delta [rad]: K (delta + delta0)."""
        return np.asarray(self.K) * (np.asarray(delta) + np.asarray(self.delta0))


@dataclass
class Norrbin:
    """Norrbin nonlinear response: ``T r' + n1 r + n3 r^3 = K (delta + delta0)``.

    Seed 000 eq. 34-35 is the case n1 = 1, n3 = alpha [s^2/rad^2]. n1 < 0 describes a
    course-unstable vessel (its stable turns are held by n3 > 0). K [1/s], T [s] > 0.
    """

    K: ArrayLike
    T: ArrayLike
    n1: ArrayLike = 1.0
    n3: ArrayLike = 0.0
    delta0: ArrayLike = 0.0

    kind = "norrbin"
    state_names = ("x", "y", "psi", "r")
    input_names = ("delta",)

    def __post_init__(self) -> None:
        check_params("parameters",
                     {"K": self.K, "T": self.T, "n1": self.n1, "n3": self.n3,
                      "delta0": self.delta0},
                     positive=("T",))

    def f(self, state: np.ndarray, inputs: np.ndarray, *, U: ArrayLike) -> np.ndarray:
        """State derivative, see :func:`norrbin_f`."""
        return norrbin_f(state, inputs, self, U=U)

    def steady_yaw_rate(self, delta: float) -> float:
        """Steady yaw rate [rad/s]: the real root of ``n1 r + n3 r^3 = K (delta + delta0)``.

        Scalars only. With n1 < 0 and n3 > 0 there may be three roots (the loop of a
        course-unstable vessel); the one with the sign of ``K (delta + delta0)`` and the largest
        magnitude is returned (the stable turn), as a simulation settles on it. With
        n1 = n3 = 0 there is none: +-inf (0 for a zero right-hand side).
        """
        rhs = float(self.K) * (float(delta) + float(self.delta0))
        n1, n3 = float(self.n1), float(self.n3)
        if n3 == 0.0:
            if n1 == 0.0:  # T r' = K delta: r grows without bound, no steady turn
                return math.copysign(math.inf, rhs) if rhs != 0.0 else 0.0
            return rhs / n1
        roots = np.roots([n3, 0.0, n1, -rhs])
        real = roots[np.abs(roots.imag) < 1e-9 * max(1.0, np.max(np.abs(roots)))].real
        same = real[np.sign(real) == np.sign(rhs)] if rhs != 0 else real
        pick = same if same.size else real
        return float(pick[np.argmax(np.abs(pick))])


# --- dynamics (numpy, vectorised over leading axes) --------------------------------------------
def _split(state: np.ndarray, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    state = np.asarray(state, dtype=float)
    inputs = np.asarray(inputs, dtype=float)
    return state, inputs[..., 0]


def _kinematics(psi: np.ndarray, U: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Constant-speed kinematics in NED: ``x' = U cos psi``, ``y' = U sin psi`` [m/s]."""
    U = np.asarray(U, dtype=float)
    return U * np.cos(psi), U * np.sin(psi)


def nomoto1_f(state: np.ndarray, inputs: np.ndarray, p: Nomoto1, *, U: ArrayLike) -> np.ndarray:
    """Nomoto 1st order with constant-speed kinematics (seed 000 eq. 35, alpha = 0).

    state ``(..., 4)`` = (x [m], y [m], psi [rad], r [rad/s]); inputs ``(..., 1)`` = (delta [rad]);
    U [m/s] the constant speed. Returns d(state)/dt:
    ``x' = U cos psi, y' = U sin psi, psi' = r, r' = (K (delta + delta0) - r) / T``.
    Parameters broadcast against ``state[..., 0]``.
    """
    s, d = _split(state, inputs)
    psi, r = s[..., 2], s[..., 3]
    dx, dy = _kinematics(psi, U)
    dr = (np.asarray(p.K) * (d + np.asarray(p.delta0)) - r) / np.asarray(p.T)
    return np.stack(np.broadcast_arrays(dx, dy, r, dr), axis=-1)


def norrbin_f(state: np.ndarray, inputs: np.ndarray, p: Norrbin, *, U: ArrayLike) -> np.ndarray:
    """Norrbin nonlinear response (seed 000 eq. 35 with n1 = 1, n3 = alpha) and kinematics.

    ``T r' + n1 r + n3 r^3 = K (delta + delta0)``; state (x, y, psi, r), inputs (delta,), U [m/s].
    """
    s, d = _split(state, inputs)
    psi, r = s[..., 2], s[..., 3]
    dx, dy = _kinematics(psi, U)
    dr = (np.asarray(p.K) * (d + np.asarray(p.delta0)) - np.asarray(p.n1) * r
          - np.asarray(p.n3) * r**3) / np.asarray(p.T)
    return np.stack(np.broadcast_arrays(dx, dy, r, dr), axis=-1)


def nomoto2_f(state: np.ndarray, inputs: np.ndarray, p: Nomoto2, *, U: ArrayLike) -> np.ndarray:
    """Nomoto 2nd order (seed 000 eq. 29-30, seed 001 eq. 18) realised without delta'.

    ``r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))`` is realised as
    ``z'' + a1 z' + a0 z = delta + delta0`` with ``a1 = (T1 + T2)/(T1 T2)``, ``a0 = 1/(T1 T2)`` and
    ``r = K a0 (z + T3 z')``; state (x, y, psi, z [rad s^2], zdot [rad s]), inputs (delta,).
    """
    s, d = _split(state, inputs)
    T1, T2 = np.asarray(p.T1), np.asarray(p.T2)
    a0 = 1.0 / (T1 * T2)
    a1 = (T1 + T2) * a0
    psi, z, zd = s[..., 2], s[..., 3], s[..., 4]
    r = np.asarray(p.K) * a0 * (z + np.asarray(p.T3) * zd)
    dx, dy = _kinematics(psi, U)
    dzd = d + np.asarray(p.delta0) - a1 * zd - a0 * z
    return np.stack(np.broadcast_arrays(dx, dy, r, zd, dzd), axis=-1)


ResponseModel = Nomoto1 | Nomoto2 | Norrbin
