"""Open-water propeller thrust and torque, and twin-screw hull-propeller interaction factors
(the catamaran paper's section 2.1, eq. 19-25; its equations are lost in the extracted text,
so the standard published forms it names are used).

* Dimensional analysis of the open propeller (the catamaran paper, eq. 19-22; Carlton 2019,
  ch. 6): thrust ``T = rho n^2 D^4 K_T(J)`` [N] and absorbed torque ``Q = rho n^2 D^5 K_Q(J)``
  [N m], with the advance ratio ``J = u_P / (n D)`` and the open-water curves as quadratic
  regressions ``K_T = a0 + a1 J + a2 J^2``, ``K_Q = b0 + b1 J + b2 J^2`` ("the regression
  coefficients of the propeller open water characteristic curve", eq. 23).
* Open-water efficiency ``eta_0 = J K_T / (2 pi K_Q)`` (Carlton 2019, eq. 6.5).
* Twin-screw thrust deduction by Heckscher's formula, the one the catamaran paper's text keeps
  legible ("for a double propeller boat ... = 0.5 C_p - 0.18"): ``t = 0.5 C_p - 0.18``, and
  Heckscher's twin-screw wake fraction ``w = 0.7 C_p - 0.30`` (both as tabulated by Harvald
  1983, "Resistance and Propulsion of Ships", sec. 5.3); C_p [-] the prismatic coefficient
  (the text's "rhombic coefficient" is a mistranslation of it). The paper's Norrbin wake
  formula (its eq. 24) cannot be reconstructed from the extracted text and is not provided.
* Effective thrust of one thruster ``T_e = (1 - t) T`` and the steady balance with the drag
  ``R`` at low speed: ``T_e = R`` (eq. 25-26).

Units: n [rps], D [m], rho [kg/m^3], u [m/s]; K_T, K_Q, J, t, w, C_p dimensionless.
Vectorised: arguments broadcast (numpy rules).
"""

from __future__ import annotations

import math

import numpy as np

from usvid.errors import UsvidError

ArrayLike = float | np.ndarray

#: Sea-water density [kg/m^3] used when none is given.
RHO_SEA = 1025.0


def open_water_coefficient(J: ArrayLike, coeffs: tuple[float, float, float]) -> np.ndarray:
    """K_T or K_Q [-] as the quadratic regression ``c0 + c1 J + c2 J^2`` of the open-water curve
    (the catamaran paper, eq. 23) at advance ratio J [-]; ``coeffs`` = (c0, c1, c2)."""
    c = tuple(float(x) for x in coeffs)
    if len(c) != 3:
        raise UsvidError(f"open-water coefficients must be (c0, c1, c2) (got {coeffs!r})")
    J = np.asarray(J, dtype=float)
    return np.asarray(c[0] + J * (c[1] + J * c[2]))[()]


def open_water_thrust(n: ArrayLike, D: ArrayLike, KT: ArrayLike,
                      rho: ArrayLike = RHO_SEA) -> np.ndarray:
    """Open-water thrust ``T = rho n |n| D^4 K_T`` [N] (the catamaran paper, eq. 20; sign of n
    kept for a reversing shaft); n [rps], D [m], K_T [-], rho [kg/m^3]."""
    n = np.asarray(n, dtype=float)
    return np.asarray(np.asarray(rho, float) * n * np.abs(n) * np.asarray(D, float) ** 4
                      * np.asarray(KT, float))[()]


def propeller_torque(n: ArrayLike, D: ArrayLike, KQ: ArrayLike,
                     rho: ArrayLike = RHO_SEA) -> np.ndarray:
    """Torque absorbed by the propeller ``Q = rho n |n| D^5 K_Q`` [N m] (the catamaran paper,
    eq. 21-22); n [rps], D [m], K_Q [-], rho [kg/m^3]."""
    n = np.asarray(n, dtype=float)
    return np.asarray(np.asarray(rho, float) * n * np.abs(n) * np.asarray(D, float) ** 5
                      * np.asarray(KQ, float))[()]


def open_water_efficiency(J: ArrayLike, KT: ArrayLike, KQ: ArrayLike) -> np.ndarray:
    """``eta_0 = J K_T / (2 pi K_Q)`` [-] (delivered thrust power over shaft power, Carlton
    2019, eq. 6.5)."""
    return np.asarray(np.asarray(J, float) * np.asarray(KT, float)
                      / (2.0 * math.pi * np.asarray(KQ, float)))[()]


def heckscher_twin_screw(C_p: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(wake fraction w, thrust deduction t) [-] of a twin-screw hull by Heckscher's formulas:
    ``w = 0.7 C_p - 0.30``, ``t = 0.5 C_p - 0.18`` (Harvald 1983, sec. 5.3; the catamaran
    paper, eq. 24-25); C_p [-] the prismatic coefficient in (0, 1]. Both are clipped at 0
    (slender hulls: no wake, no deduction)."""
    Cp = np.asarray(C_p, dtype=float)
    if not np.all((Cp > 0) & (Cp <= 1)):
        raise UsvidError(f"the prismatic coefficient C_p must be in (0, 1] (got {C_p!r})")
    w = np.maximum(0.0, 0.7 * Cp - 0.30)
    t = np.maximum(0.0, 0.5 * Cp - 0.18)
    return np.asarray(w)[()], np.asarray(t)[()]


def effective_thrust(T: ArrayLike, t: ArrayLike) -> np.ndarray:
    """Effective thrust of one thruster ``T_e = (1 - t) T`` [N] (the catamaran paper, eq. 25:
    t = (T - T_e) / T, the thrust deduction factor); T [N], t [-]."""
    return np.asarray((1.0 - np.asarray(t, float)) * np.asarray(T, float))[()]
