"""Response-model parameters of the 3-DOF model in closed form (Mu et al. 2018, eq. 29-34).

Linearised about straight running at speed U [m/s] (v = r = delta = 0; Mu et al. 2018 eq. 26,
surge decoupled), the sway-yaw equations of :mod:`usvid.models.kinds.threedof` (Assumption 1:
m23 = m32 = d23 = d32 = 0) read, in the paper's derivative notation,

    m22 v' - Y_v v + (m11 U - Y_r) r = Y_delta delta,
    m33 r' - N_v v - N_r r = N_delta delta,

with Y_v = -d22, Y_r = 0, N_v = -(m22 - m11) U (the Munk moment of C(nu)), N_r = -d33,
N_delta = x_l T and Y_delta = -T (only with ``sway_force``, else 0), T [N] the thrust. Laplace
transformation gives eq. 29, ``r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))``, with (the
extracted text lost the signs and the primes; restored here in dimensional form):

    C = Y_v N_r - (Y_r - m11 U) N_v = d22 d33 - m11 (m22 - m11) U^2      (stability index)
    T1 T2 = m22 m33 / C,   T1 + T2 = (m22 d33 + m33 d22) / C,
    K = (N_v Y_delta - N_delta Y_v) / C = (x_l T d22 + (m22 - m11) U T_y) / C,
    K T3 = m22 N_delta / C  (with T_y = T when the sway force counts, else 0).

C > 0: course stable (eq. 30-31); eq. 30 is the linear second-order response
``T1 T2 r'' + (T1 + T2) r' + r = K (delta + T3 delta')``; eq. 34 adds Nomoto's cubic
``alpha r^3`` (C = C0 + varpi r^2, alpha = varpi / C0), and eq. 35 is its first-order (Norrbin)
form with ``T = T1 + T2 - T3``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import UsvidError


@dataclass(frozen=True)
class ResponseParams:
    """K [1/s], T1, T2, T3 [s] of eq. 29, the stability index C [kg^2/s^2] (dimensional;
    > 0 course stable), and the first-order equivalent T = T1 + T2 - T3 [s] (eq. 35)."""

    K: float
    T1: float
    T2: float
    T3: float
    C: float

    @property
    def T(self) -> float:
        """First-order (Nomoto/Norrbin) time constant T1 + T2 - T3 [s] (Mu et al. 2018 eq. 35)."""
        return self.T1 + self.T2 - self.T3

    @property
    def course_stable(self) -> bool:
        return self.C > 0


def threedof_response(dyn: Any, U: float, thrust: float) -> ResponseParams:
    """Mu et al. 2018 eq. 29 in closed form (module docstring) for a ``ThreeDOF`` parameter
    set at speed ``U`` [m/s] with thrust ``thrust`` [N]. T1 >= T2 are the roots of
    ``T1 T2 = a``, ``T1 + T2 = b`` (real for this damped model; complex ones raise)."""
    m11, m22, m33 = (float(getattr(dyn, k)) for k in ("m11", "m22", "m33"))
    d22, d33 = float(dyn.d22), float(dyn.d33)
    if any(float(getattr(dyn, k, 0.0) or 0.0) != 0.0 for k in ("m23", "m32", "d23", "d32")):
        raise UsvidError("threedof_response: eq. 29 assumes m23 = m32 = d23 = d32 = 0 "
                         "(Mu et al. 2018, Assumption 1)")
    C = d22 * d33 - m11 * (m22 - m11) * U * U
    if C == 0:
        raise UsvidError("threedof_response: C = 0 (critically stable): K is not defined")
    a = m22 * m33 / C
    b = (m22 * d33 + m33 * d22) / C
    disc = b * b - 4 * a
    if disc < 0:
        raise UsvidError("threedof_response: complex time constants (T1 T2 = "
                         f"{a:.4g}, T1 + T2 = {b:.4g})")
    T1 = (b + math.sqrt(disc)) / 2
    T2 = (b - math.sqrt(disc)) / 2
    Ty = thrust if bool(getattr(dyn, "sway_force", False)) else 0.0
    Nd = float(dyn.x_l) * thrust
    K = (Nd * d22 + (m22 - m11) * U * Ty) / C
    T3 = m22 * Nd / (C * K) if K != 0 else math.nan
    return ResponseParams(K=K, T1=T1, T2=T2, T3=T3, C=C)


def second_order_nonlinear_rhs(r: Any, rdot: Any, delta: Any, delta_dot: Any, K: float,
                               T1: float, T2: float, T3: float, alpha: float) -> np.ndarray:
    """r'' [rad/s^3] of Mu et al. 2018 eq. 34,
    ``T1 T2 r'' + (T1 + T2) r' + r + alpha r^3 = K delta + K T3 delta'``
    (r [rad/s], r' [rad/s^2], delta [rad], delta' [rad/s]; alpha [s^2])."""
    r = np.asarray(r, dtype=float)
    return (K * (np.asarray(delta) + T3 * np.asarray(delta_dot)) - r - alpha * r**3
            - (T1 + T2) * np.asarray(rdot)) / (T1 * T2)


def norrbin_alpha(r: Any, delta: Any) -> tuple[float, float]:
    """(K [1/s], alpha [s^2]) of the steady turning relation ``r + alpha r^3 = K delta`` (Mu et
    al. 2018 eq. 36) by least squares on steady yaw rates r [rad/s] at rudder angles delta
    [rad]: ``r = K delta - alpha r^3`` is linear in (K, alpha)."""
    r = np.asarray(r, dtype=float)
    d = np.asarray(delta, dtype=float)
    if r.size < 2:
        raise UsvidError("norrbin_alpha needs at least two steady turns")
    A = np.column_stack([d, -r**3])
    (K, alpha), *_ = np.linalg.lstsq(A, r, rcond=None)
    return float(K), float(alpha)
