"""3-DOF surge-sway-yaw model with a single stern vector thruster (seed 000 section 4.1).

Fossen form (seed 000 eq. 13): ``M nu' + C(nu) nu + D nu = tau`` with nu = (u, v, r) and

::

    M = [[m11, 0, 0], [0, m22, m23], [0, m32, m33]]
    C(nu) = [[0, 0, -(m22 v + m23 r)], [0, 0, m11 u], [m22 v + m23 r, -m11 u, 0]]
    D = [[d11, 0, 0], [0, d22, d23], [0, d32, d33]]

(m11 = m - X_u', m22 = m - Y_v', m23 = m x_g - Y_r', m32 = m x_g - N_v', m33 = I_z - N_r',
d11 = -X_u, d22 = -Y_v, d23 = -Y_r, d32 = -N_v, d33 = -N_r; seed 000 eq. 15 written out).
Under Assumption 1 (m23 = m32 = d23 = d32 = 0) it reduces to seed 000 eq. 17 (signs restored):

::

    u' = (m22/m11) v r - (d11/m11) u + tau_u/m11
    v' = -(m11/m22) u r - (d22/m22) v
    r' = ((m11 - m22)/m33) u v - (d33/m33) r + tau_r/m33

Seed 000 eq. 37 (the identified Lanxin model, signs lost in extraction) reads
``u' = 1.065245 v r - 0.3197455 u + 0.000377 tau_u``, ``v' = -0.938753 u r - 3.5 v``,
``r' = -0.041187 u v - 5.407752 r + 0.000238 tau_r``. It is consistent with eq. 17:
m11 = 1/0.000377 = 2652.5 kg, m22 = 1.065245 m11 = 2825.6 kg, and then
m11/m22 = 0.938753 and (m22 - m11)/m33 = 173.06 * 0.000238 = 0.04119 (printed 0.041187), which
is how we read the signs (checked in ``tests/test_threedof.py``).

Vector thruster at x_l [m] behind the pivot, angle delta [rad] (our convention: positive delta
makes r positive): ``tau = (T cos delta, -T sin delta, x_l T sin delta)`` with exact
trigonometry (seed 000 eq. 14 with the sign of tau_v/tau_r mapped to our convention). Seed 000
neglects tau_v (x_l > 1 m, eq. 17); so do we unless ``sway_force=True``.
Kinematics (NED): ``x' = u cos psi - v sin psi``, ``y' = u sin psi + v cos psi``, ``psi' = r``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import check_params

ArrayLike = float | np.ndarray

#: Seed 000 eq. 37 (Lanxin USV, 7.02 m), our sign reading; x_l is not printed in the seed.
SEED000_EQ37 = {
    "a_vr": 1.065245, "a_u": -0.3197455, "a_tau": 0.000377,
    "b_ur": -0.938753, "b_v": -3.5,
    "c_uv": -0.041187, "c_r": -5.407752, "c_tau": 0.000238,
}


@dataclass
class ThreeDOF:
    """3-DOF vector-thruster model (seed 000 eq. 13-17), SI units.

    m11, m22, m33 [kg, kg, kg m^2] > 0; d11, d22 [kg/s], d33 [kg m^2/s]; x_l [m] thruster arm
    behind the pivot; m23, m32 [kg m], d23, d32 [kg m/s] coupling terms (0 under Assumption 1).
    ``thrust``: a constant thrust T [N], or an object with a thrust method
    (``usvid.models.thrust.Propeller`` -> ``.thrust(n, u)``, ``PodThrust`` -> ``.thrust(V, n)``)
    evaluated at shaft speed ``n`` [rps]; ``None`` means "the thrust that holds the initial speed"
    (T = d11 u0, chosen by the simulator). ``sway_force``: include tau_v = -T sin delta.
    """

    m11: ArrayLike
    m22: ArrayLike
    m33: ArrayLike
    d11: ArrayLike
    d22: ArrayLike
    d33: ArrayLike
    x_l: ArrayLike
    m23: ArrayLike = 0.0
    m32: ArrayLike = 0.0
    d23: ArrayLike = 0.0
    d32: ArrayLike = 0.0
    thrust: Any = None
    n: ArrayLike | None = None
    sway_force: bool = False

    kind = "threedof"
    state_names = ("x", "y", "psi", "u", "v", "r")
    input_names = ("delta", "n")

    def __post_init__(self) -> None:
        check_params("parameters",
                     {k: getattr(self, k) for k in ("m11", "m22", "m33", "d11", "d22", "d33",
                                                    "x_l", "m23", "m32", "d23", "d32")},
                     positive=("m11", "m22", "m33"))
        det = np.asarray(self.m22) * np.asarray(self.m33) - np.asarray(self.m23) * np.asarray(
            self.m32)
        if not np.all(det > 0):
            raise UsvidError("parameters: m22 m33 - m23 m32 must be > 0 (singular inertia)")
        if self.thrust is not None and not hasattr(self.thrust, "thrust"):
            check_params("parameters", {"thrust": self.thrust})
        if self.n is not None:
            check_params("parameters", {"n": self.n})

    # --- regression form (seed 000 eq. 37) ----------------------------------------------------
    @classmethod
    def from_regression(cls, a_vr: float, a_u: float, a_tau: float, b_ur: float, b_v: float,
                        c_uv: float, c_r: float, c_tau: float, x_l: float, *,
                        rtol: float = 0.01, strict: bool = True, **kw: Any) -> ThreeDOF:
        """From ``u' = a_vr v r + a_u u + a_tau tau_u``, ``v' = b_ur u r + b_v v``,
        ``r' = c_uv u v + c_r r + c_tau tau_r`` (seed 000 eq. 37).

        m11 = 1/a_tau, d11 = -a_u m11, m22 = a_vr m11, d22 = -b_v m22, m33 = 1/c_tau,
        d33 = -c_r m33. The two remaining coefficients are implied (b_ur = -m11/m22,
        c_uv = (m11 - m22)/m33); with ``strict`` a relative mismatch above ``rtol`` raises
        :class:`UsvidError` (the 8-coefficient form is then not a Fossen model).
        """
        model = cls(**fossen_from_regression(a_vr, a_u, a_tau, b_v, c_r, c_tau), x_l=x_l, **kw)
        if strict:
            implied = model.regression_coefficients()
            for name, given in (("b_ur", b_ur), ("c_uv", c_uv)):
                want = implied[name]
                if abs(given - want) > rtol * max(abs(want), 1e-12):
                    raise UsvidError(
                        f"regression coefficient {name}={given!r} is inconsistent with the other "
                        f"coefficients (Fossen form implies {want:.6g}; rtol {rtol})")
        return model

    def regression_coefficients(self) -> dict[str, float]:
        """The seed 000 eq. 37 coefficients of this model (requires m23 = m32 = d23 = d32 = 0)."""
        if any(np.any(np.asarray(getattr(self, k)) != 0) for k in ("m23", "m32", "d23", "d32")):
            raise UsvidError("regression form needs m23 = m32 = d23 = d32 = 0 (Assumption 1)")
        m11, m22, m33 = (np.asarray(getattr(self, k), float) for k in ("m11", "m22", "m33"))
        out = {
            "a_vr": m22 / m11, "a_u": -np.asarray(self.d11) / m11, "a_tau": 1.0 / m11,
            "b_ur": -m11 / m22, "b_v": -np.asarray(self.d22) / m22,
            "c_uv": (m11 - m22) / m33, "c_r": -np.asarray(self.d33) / m33, "c_tau": 1.0 / m33,
        }
        return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in out.items()}

    # --- thrust and dynamics ------------------------------------------------------------------
    def thrust_at(self, u: np.ndarray, n: ArrayLike | None = None) -> np.ndarray:
        """Thrust T [N] at surge speed u [m/s] and shaft speed n [rps] (default ``self.n``)."""
        return thrust_value(self.thrust, u, self.n if n is None else n)

    def f(self, state: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """See :func:`threedof_f`."""
        return threedof_f(state, inputs, self)

    def f_tau(self, state: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """See :func:`threedof_f_tau`."""
        return threedof_f_tau(state, tau, self)

    def steady_speed(self, T: float) -> float:
        """Straight-line speed [m/s] under constant thrust T [N]: T / d11."""
        return float(T) / float(self.d11)


def fossen_from_regression(a_vr: float, a_u: float, a_tau: float, b_v: float, c_r: float,
                           c_tau: float) -> dict[str, float]:
    """Diagonal Fossen masses and dampings of seed 000 eq. 37 regression coefficients (also the
    catamaran's, seed 002): m11 = 1/a_tau, m22 = a_vr m11, m33 = 1/c_tau [kg, kg, kg m^2],
    d11 = -a_u m11, d22 = -b_v m22 [kg/s], d33 = -c_r m33 [kg m^2/s]."""
    m11 = 1.0 / a_tau
    m22 = a_vr * m11
    m33 = 1.0 / c_tau
    return {"m11": m11, "m22": m22, "m33": m33, "d11": -a_u * m11, "d22": -b_v * m22,
            "d33": -c_r * m33}


def ned_state_derivative(psi: np.ndarray, u: np.ndarray, v: np.ndarray, r: np.ndarray,
                         du: np.ndarray, dv: np.ndarray, dr: np.ndarray) -> np.ndarray:
    """d(x, y, psi, u, v, r)/dt ``(..., 6)`` from the body-frame accelerations: NED position rates
    ``x' = u cos psi - v sin psi``, ``y' = u sin psi + v cos psi`` [m/s], ``psi' = r``."""
    c, sn = np.cos(psi), np.sin(psi)
    return np.stack(np.broadcast_arrays(u * c - v * sn, u * sn + v * c, r, du, dv, dr), axis=-1)


def thrust_value(thrust: Any, u: np.ndarray, n: ArrayLike | None) -> np.ndarray:
    """Evaluate a thrust spec: a number [N], ``Propeller`` (``.thrust(n, u)``) or
    ``PodThrust`` (``.thrust(V, n)``), at surge speed u [m/s] and shaft speed n [rps]."""
    u = np.asarray(u, dtype=float)
    if thrust is None:
        raise UsvidError("parameters.thrust is not set (give a thrust [N] or a thrust model)")
    if not hasattr(thrust, "thrust"):
        return np.broadcast_to(np.asarray(thrust, dtype=float), u.shape) + 0.0
    if n is None:
        raise UsvidError("parameters.n (shaft speed [rps]) is needed by the thrust model")
    if type(thrust).__name__ == "PodThrust":
        return np.asarray(thrust.thrust(u, n), dtype=float)
    return np.asarray(thrust.thrust(n, u), dtype=float)


def threedof_f_tau(state: np.ndarray, tau: np.ndarray, p: ThreeDOF) -> np.ndarray:
    """d(state)/dt of the Fossen 3-DOF model (seed 000 eq. 13/15) for given forces.

    state ``(..., 6)`` = (x, y [m], psi [rad], u, v [m/s], r [rad/s]);
    tau ``(..., 3)`` = (tau_u [N], tau_v [N], tau_r [N m]). Parameters broadcast against
    ``state[..., 0]``.
    """
    s = np.asarray(state, dtype=float)
    tau = np.asarray(tau, dtype=float)
    psi, u, v, r = s[..., 2], s[..., 3], s[..., 4], s[..., 5]
    m11, m22, m33, m23, m32 = (np.asarray(getattr(p, k), float)
                               for k in ("m11", "m22", "m33", "m23", "m32"))
    d11, d22, d33, d23, d32 = (np.asarray(getattr(p, k), float)
                               for k in ("d11", "d22", "d33", "d23", "d32"))
    a = m22 * v + m23 * r
    f1 = tau[..., 0] + a * r - d11 * u
    f2 = tau[..., 1] - m11 * u * r - d22 * v - d23 * r
    f3 = tau[..., 2] - a * u + m11 * u * v - d32 * v - d33 * r
    det = m22 * m33 - m23 * m32
    du = f1 / m11
    dv = (m33 * f2 - m23 * f3) / det
    dr = (m22 * f3 - m32 * f2) / det
    return ned_state_derivative(psi, u, v, r, du, dv, dr)


def vector_thrust_tau(T: np.ndarray, delta: np.ndarray, x_l: ArrayLike,
                      sway_force: bool = False) -> np.ndarray:
    """tau = (T cos delta, -T sin delta, x_l T sin delta) (seed 000 eq. 14, our signs)
    ``(..., 3)``; tau_v is 0 unless ``sway_force``."""
    T = np.asarray(T, float)
    delta = np.asarray(delta, float)
    sd = np.sin(delta)
    tv = -T * sd if sway_force else np.zeros_like(T * sd)
    return np.stack(np.broadcast_arrays(T * np.cos(delta), tv, np.asarray(x_l) * T * sd), axis=-1)


def threedof_f(state: np.ndarray, inputs: np.ndarray, p: ThreeDOF) -> np.ndarray:
    """d(state)/dt with the vector thruster: inputs ``(..., 1 or 2)`` = (delta [rad], n [rps]).

    The thrust comes from ``p.thrust`` (constant, or the thrust model at n and u); when inputs
    has one column, n = ``p.n``.
    """
    s = np.asarray(state, dtype=float)
    inp = np.asarray(inputs, dtype=float)
    n = inp[..., 1] if inp.shape[-1] > 1 else p.n
    T = thrust_value(p.thrust, s[..., 3], n)
    tau = vector_thrust_tau(T, inp[..., 0], p.x_l, p.sway_force)
    return threedof_f_tau(s, tau, p)


def seed000_threedof(x_l: float = 3.5, **kw: Any) -> ThreeDOF:
    """The Lanxin model of seed 000 eq. 37 (x_l [m] is not printed; ~half the 7.02 m length)."""
    return ThreeDOF.from_regression(**SEED000_EQ37, x_l=x_l, **kw)
