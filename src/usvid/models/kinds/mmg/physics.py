"""The MMG force models and equations of motion (Yasukawa & Yoshimura 2015), 3 DOF.

Reference: Yasukawa, H. and Yoshimura, Y. (2015), "Introduction of MMG standard method for ship
maneuvering predictions", J. Mar. Sci. Technol. 20, 37-52, doi:10.1007/s00773-014-0293-y
(below "Y&Y 2015"; "eq. 4" is the paper's numbering of the equations of motion). Pure
physics: no files, no integration, no Trial. The parameters, their units and the coordinate
conventions are :mod:`usvid.models.kinds.mmg.params`; the kind ``mmg`` wraps this module
(:mod:`usvid.models.kinds.mmg`). The K_T and pod thrust laws are those of
:mod:`usvid.models.thrust` (one definition).

Model (Y&Y 2015)
----------------
Equations of motion about midship (eq. 4, with the x_G coupling; dots are time derivatives)::

    (m + m_x) u_dot - (m + m_y) v r - x_G m r^2               = X_H + X_R + X_P
    (m + m_y) v_dot + x_G m r_dot + (m + m_x) u r             = Y_H + Y_R
    (I_zG + x_G^2 m + J_z) r_dot + x_G m (v_dot + u r)        = N_H + N_R

Hull force model: ``X_H = 0.5 rho L d U^2 (-R_0 + X_vv v'^2 + X_vr v' r' + X_rr r'^2 +
X_vvvv v'^4)``, ``Y_H = 0.5 rho L d U^2 (Y_v v' + Y_r r' + Y_vvv v'^3 + Y_vvr v'^2 r' +
Y_vrr v' r'^2 + Y_rrr r'^3)``, ``N_H`` likewise with ``0.5 rho L^2 d U^2``.

Propeller force model: ``X_P = (1 - t_P) T``, ``T = rho n^2 D_p^4 K_T(J)``,
``K_T = k_0 + k_1 J + k_2 J^2``, ``J = (1 - w_P) u/(n D_p)``,
``w_P = 1 - (1 - w_P0)(1 + (1 - exp(-C_1 |beta_P|))(C_2 - 1))``, ``beta_P = beta - x_P r'``.
``wake_model='gaussian'`` replaces the last by ``w_P = w_P0 exp(-C_w beta_P^2)``, the form the
``shipmmg`` package implements (used to cross-check this module against it).

Rudder force model: ``X_R = -(1 - t_R) F_N sin delta``, ``Y_R = -(1 + a_H) F_N cos
delta``, ``N_R = -(x_R + a_H x_H) L F_N cos delta``, ``F_N = 0.5 rho A_R U_R^2 f_alpha sin
alpha_R``, ``alpha_R = delta - atan(v_R/u_R)``, ``v_R = U gamma_R beta_R``, ``beta_R = beta - l_R
r'``, ``u_R = epsilon u (1 - w_P) sqrt(eta {1 + kappa (sqrt(1 + 8 K_T/(pi J^2)) - 1)}^2 +
(1 - eta))``, ``eta = D_p/H_R``.

Port/starboard asymmetry of a single propeller (rudder and pod variants; usvid's lumped form):
``Y_P = Y_P0 T``, ``N_P = N_P0 L T`` with T the gross thrust [N] and Y_P0, N_P0 [-] constants
(0: the symmetric Y&Y 2015 model, bit for bit). A right-handed propeller going ahead pushes the
stern to starboard (the "transverse thrust" or paddle-wheel effect, Crenshaw 1975, Naval
Shiphandling, ch. 3) and its rotating slipstream meets the rudder obliquely, so a single-screw
ship holds a small rudder angle to run straight and turns differently to port and starboard.
Y&Y 2015 carry no such term; their asymmetric pairs (C_2, gamma_R by the sign of beta_P,
beta_R) change the gain of each side, not the balance at zero. Scaling with the thrust keeps
the force where the propeller's loading is (it grows as the ship slows in a turn at constant n
and vanishes with n = 0). A rudder neutral angle delta_0 (``alpha_R = delta - delta_0 -
atan(v_R/u_R)``) gives, to first order in delta_0 and delta, ``dY_R = (1 + a_H) q_R U_R u_R
delta_0`` and ``dN_R = (x_R + a_H x_H) L q_R U_R u_R delta_0`` (q_R = 0.5 rho A_R f_alpha):
U_R u_R ~ u_R^2 is the slipstream's, which grows with the thrust loading (the
``8 K_T n^2 D^2 / pi`` term of u_R), so along a manoeuvre at constant n this is a pair (Y, N)
in a fixed ratio, nearly proportional to T, that Y_P0, N_P0 span; the two cannot be told apart
from free-running data, so usvid identifies the pair Y_P0, N_P0 only (the equivalent neutral
angle is ``delta_0 = N_P0 L T / ((x_R + a_H x_H) L q_R U_R u_R)``).

Numerically safe forms used by the kernels (identical to the paper for u > 0, n > 0, U >= U_min):

* ``U_g = max(U, U_min)`` with ``U_min = 0.005 sqrt(g L)`` (Froude number 0.005; 0.04 m/s for
  L = 7 m) forms v', r' and beta = asin(-v'); the hull forces carry the true U^2, so they go to
  0 smoothly at rest instead of dividing by 0 (the polynomial is not meant for U -> 0).
* ``T = rho D^4 k_0 n|n| + rho D^3 k_1 n u_P + rho D^2 k_2 sgn(n) u_P^2`` with
  ``u_P = (1 - w_P) u`` (= rho n^2 D^4 K_T(J) for n > 0; J from |n|, thrust with the sign of n
  for n < 0; T = 0 at n = 0; no division).
* ``u_P {1 + kappa (sqrt(1 + 8 K_T/(pi J^2)) - 1)} = (1 - kappa) u_P + kappa sqrt(u_P^2 +
  8 K_T n^2 D^2 / pi)`` (the square root clipped at 0 where K_T < 0) and
  ``U_R^2 sin alpha_R = U_R (u_R sin delta - v_R cos delta)``: no J, no atan, no division.
* gamma_R and C_2 are chosen by a select on the sign (compiled to a conditional move).

Actuator variants, each a scalar numba kernel with the same
``(p, u, v, r, ...)`` convention (``p`` one lane's packed parameters, a tuple or
1-D array indexed by the ``IDX_*`` constants: the kind contract of :mod:`usvid.models.kind`):

* ``rudder`` (:func:`mmg_accelerations`): the standard rudder behind a propeller above.
* ``pod`` (:func:`mmg_pod_accelerations`): a vector/pod thruster at ``x_P`` turned by delta
  (no rudder): ``(X, Y, N)_P = (T_e cos delta, -T_e sin delta, -x_P L T_e sin delta)``
  (ARCHITECTURE.md: positive delta makes r positive since x_P < 0). ``T_e`` is ``(1 - t_P) T``
  with the K_T law above, or the pod law ``T_e = c u n + d |n| n`` (Mu et al. 2016, Mu et al. 2016
  eq. 3; ``thrust_law='pod'``; the law's identified c, d already include hull interaction).
* ``twin`` (:func:`mmg_twin_accelerations`): two thrusters at ``(x_P, -+y_P) L``, shaft speeds
  n_port, n_stbd: ``X_P = T_e,port + T_e,stbd``, ``N_P = (T_port - T_stbd) y_P L`` (more port
  thrust turns to starboard; the catamaran paper, the catamaran paper eq. 26-27; gross thrust for
  the moment since the thrust deduction is a hull-suction force near the centre line).

Pod and twin share the hull, the masses and the wake model; they have no rudder forces. The
rudder and pod variants add the asymmetry ``(Y, N)_P += (Y_P0 T, N_P0 L T)`` (above); the twin
variant has none (its asymmetry is the PWM map's ``thrust_asymmetry``).
"""

from __future__ import annotations

import math
from typing import Any, Literal, NamedTuple

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.models import vmath
from usvid.models._validate import check_params
from usvid.models.hull import (
    clarke83_added_mass,
    kijima1990_linear_derivatives,
    zhou_added_mass,
)
from usvid.models.kinds.mmg.params import (
    ASYMMETRY,
    FIELD_NAMES,
    FIELDS,
    HULL_COEFFICIENTS,
    THRUST_LAWS,
    VARIANTS,
    WAKE_MODELS,
    FieldInfo,
    MMGParameters,
)
from usvid.models.thrust import kt_thrust_nb, pod_thrust_nb

G = 9.80665
#: U_min = U_MIN_FROUDE sqrt(g L): below it v', r' are formed with U_min (module docstring)
U_MIN_FROUDE = 0.005


def fujii_f_alpha(aspect_ratio: float) -> float:
    """Rudder lift gradient ``f_alpha = 6.13 Lambda / (Lambda + 2.25)`` [-] (Fujii & Tsuda 1961,
    "Experimental research on rudder performance (2)", J. Soc. Naval Arch. Japan 110, as quoted
    by Y&Y 2015), Lambda = H_R^2 / A_R the rudder aspect ratio [-]."""
    lam = float(aspect_ratio)
    if not lam > 0.0:
        raise UsvidError(f"rudder aspect ratio must be > 0 (got {lam!r})")
    return 6.13 * lam / (lam + 2.25)


# ---------------------------------------------------------------------------------------------
# Published KVLCC2 model
# ---------------------------------------------------------------------------------------------

#: Y&Y 2015, KVLCC2 tables (model L_pp 7.00 m): the published non-dimensional coefficients.
KVLCC2_COEFFICIENTS: dict[str, float] = {
    "m_x": 0.022, "m_y": 0.223, "J_z": 0.011,
    "R_0": 0.022, "X_vv": -0.040, "X_vr": 0.002, "X_rr": 0.011, "X_vvvv": 0.771,
    "Y_v": -0.315, "Y_r": 0.083, "Y_vvv": -1.607, "Y_vvr": 0.379, "Y_vrr": -0.391,
    "Y_rrr": 0.008,
    "N_v": -0.137, "N_r": -0.049, "N_vvv": -0.030, "N_vvr": -0.294, "N_vrr": 0.055,
    "N_rrr": -0.013,
    "k_0": 0.2931, "k_1": -0.2753, "k_2": -0.1385, "t_P": 0.220, "w_P0": 0.40, "x_P": -0.48,
    "C_1": 2.0, "C_2_plus": 1.6, "C_2_minus": 1.1,
    "t_R": 0.387, "a_H": 0.312, "x_H": -0.464, "x_R": -0.5, "epsilon": 1.09, "kappa": 0.50,
    "l_R": -0.710, "gamma_R_plus": 0.640, "gamma_R_minus": 0.395, "f_alpha": 2.747,
}

#: Y&Y 2015: the KVLCC2 model of the paper (displacement 3.27 m^3, C_b 0.810).
KVLCC2_PAPER_PARTICULARS: dict[str, float] = {
    "L": 7.00, "B": 1.27, "d": 0.46, "x_G": 0.25, "D_p": 0.216, "H_R": 0.345, "A_R": 0.0539,
    "rho": 1025.0, "m": 1025.0 * 3.27, "I_zG": 1025.0 * 3.27 * (0.25 * 7.00) ** 2,
}

#: The HSVA free-running model (SIMMAN 2008, 1:45.7), ``../shared/data/kvlcc2_hsva/ship_data.yml``,
#: except D_p (see :func:`kvlcc2`).
KVLCC2_HSVA_PARTICULARS: dict[str, float] = {
    "L": 7.00, "B": 1.2688, "d": 0.455, "x_G": 0.2436, "D_p": 0.216, "H_R": 0.345,
    "A_R": 0.0539, "rho": 1000.0, "m": 3272.0, "I_zG": 9908.58464288,
}


def kvlcc2(model: Literal["hsva", "paper"] = "hsva") -> MMGParameters:
    """The published KVLCC2 MMG model (Y&Y 2015, its KVLCC2 tables), ``variant='rudder'``.

    The non-dimensional coefficients (:data:`KVLCC2_COEFFICIENTS`, including x_P = -0.48,
    x_R = -0.5, f_alpha = 2.747) are the paper's. ``model`` picks the particulars they are
    scaled to: ``"hsva"`` (default) the HSVA free-running model of the SIMMAN 2008 zig-zags
    (``ship_data.yml``: L 7.00 m, B 1.2688 m, d 0.455 m, m 3272 kg, x_G 0.2436 m, I_zG
    9908.6 kg m^2 i.e. k_zz = 0.2486 L, fresh water 1000 kg/m^3) or ``"paper"`` the paper's model
    (L 7.00 m, B 1.27 m, d 0.46 m, 3.27 m^3 at 1025 kg/m^3, x_G 0.25 m, k_zz = 0.25 L as
    shipmmg uses). Both use D_p = 0.216 m, the paper's propeller whose K_T(J) this is (the
    full-scale 9.86 m at 1:45.7): ``ship_data.yml`` says 0.204 m, but with 0.204 m the K_T
    law under-predicts the thrust the HSVA logs measure by about 23 % (Z_35_05: mean 39 N
    against 50 N), with 0.216 m it matches within 1 % (and 44.5 N against 44.3 N at 1.18 m/s,
    10.23 rps, the start of Z_20_05).

    The published resistance R_0 = 0.022 gives 48.8 N at 1.18 m/s, more than the
    (1 - t_P) T = 34.7 N the HSVA model's propeller delivers at 10.23 rps: with these
    coefficients the model settles at 1.02 m/s at 10.23 rps and needs 11.9 rps for 1.18 m/s.
    The HSVA runs imply R_0 of about 0.016 (or a friction-correction tow force); identification
    should fit R_0 to the data rather than hold it.
    """
    if model == "hsva":
        part = KVLCC2_HSVA_PARTICULARS
    elif model == "paper":
        part = KVLCC2_PAPER_PARTICULARS
    else:
        raise UsvidError(f"kvlcc2: model must be 'hsva' or 'paper' (got {model!r})")
    return MMGParameters(variant="rudder", thrust_law="kt", **part, **KVLCC2_COEFFICIENTS)


# ---------------------------------------------------------------------------------------------
# Priors from the particulars
# ---------------------------------------------------------------------------------------------

#: Where each prior of :func:`priors` comes from.
PRIOR_SOURCES: dict[str, str] = {
    "m_x": "Zhou et al. 1983 (hull.zhou_added_mass) or Soding 1982 (added_mass='clarke83')",
    "m_y": "Zhou et al. 1983 or Clarke et al. 1983 (hull.clarke83_added_mass)",
    "J_z": "Zhou et al. 1983 or Clarke et al. 1983",
    "Y_v": "Kijima et al. 1990 (hull.kijima1990_linear_derivatives)",
    "Y_r": "Kijima et al. 1990",
    "N_v": "Kijima et al. 1990",
    "N_r": "Kijima et al. 1990",
    "I_zG": "rule of thumb k_zz = 0.25 L (not a regression)",
}


def priors(L: float, B: float, d: float, C_b: float, m: float, *, rho: float = 1025.0,
           added_mass: Literal["zhou", "clarke83"] = "zhou") -> dict[str, float]:
    """Prior values of the MMG parameters that published regressions give from the particulars.

    Added masses, non-dimensional as in Y&Y 2015 (by 0.5 rho L^2 d and 0.5 rho L^4 d):
    ``added_mass="zhou"`` (default) Zhou et al. (1983) regression of Motora's charts,
    ``"clarke83"`` Clarke, Gedling & Hine (1983) for m_y, J_z and Soding (1982) for m_x (both
    from :mod:`usvid.models.hull`; the Clarke cross terms Y_rdot, N_vdot have no place in the
    MMG equations and are dropped). Linear hull derivatives Y_v, Y_r, N_v, N_r from Kijima,
    Katsuno, Nakiri & Furukawa (1990) (:func:`usvid.models.hull.kijima1990_linear_derivatives`,
    Y_r with the m' + m_x' of the same call). I_zG from k_zz = 0.25 L, a rule of thumb.
    The nonlinear hull coefficients, R_0 and the propeller/rudder parameters have no prior here
    (no regression in usvid); :data:`PRIOR_SOURCES` names each source.

    L, B, d [m], C_b [-], m [kg], rho [kg/m^3]. For KVLCC2 (Y&Y 2015 particulars) Zhou gives
    m_x 0.023, m_y 0.223, J_z 0.011 (published 0.022, 0.223, 0.011) and Kijima Y_v -0.412,
    Y_r 0.093, N_v -0.131, N_r -0.054 (published -0.315, 0.083, -0.137, -0.049).
    """
    check_params("priors", {"L": L, "B": B, "d": d, "C_b": C_b, "m": m, "rho": rho},
                 positive=("L", "B", "d", "C_b", "m", "rho"))
    q = 0.5 * rho * L ** 2 * d
    if added_mass == "zhou":
        z = zhou_added_mass(L, B, d, C_b, m)
        mx, my, jz = float(z.m_x) / q, float(z.m_y) / q, float(z.J_zz) / (q * L ** 2)
    elif added_mass == "clarke83":
        a = clarke83_added_mass(L, B, d, C_b, rho=rho, volume=m / rho)
        mx, my, jz = -float(a.X_udot) / q, -float(a.Y_vdot) / q, -float(a.N_rdot) / (q * L ** 2)
    else:
        raise UsvidError(f"priors: added_mass must be 'zhou' or 'clarke83' (got {added_mass!r})")
    lin = kijima1990_linear_derivatives(L, B, d, C_b, m_prime=m / q, m_x_prime=mx)
    return {"m_x": mx, "m_y": my, "J_z": jz, "Y_v": float(lin.Y_v), "Y_r": float(lin.Y_r),
            "N_v": float(lin.N_v), "N_r": float(lin.N_r), "I_zG": m * (0.25 * L) ** 2}


# ---------------------------------------------------------------------------------------------
# Flat packing for the numba core: one lane's parameters p[IDX_*]
# ---------------------------------------------------------------------------------------------

IDX_VARIANT = 0          # 0 rudder, 1 pod, 2 twin
IDX_THRUST_LAW = 1       # 0 K_T law, 1 pod law
IDX_WAKE_MODEL = 2       # 0 Y&Y 2015 (C_1, C_2), 1 gaussian
IDX_L = 3                # L [m]
IDX_QF = 4               # 0.5 rho L d [kg/m]: force scale (times U^2)
IDX_QN = 5               # 0.5 rho L^2 d [kg]: moment scale (times U^2)
IDX_U_MIN = 6            # U_min [m/s]
IDX_R_0 = 7
IDX_X_VV = 8
IDX_X_VR = 9
IDX_X_RR = 10
IDX_X_VVVV = 11
IDX_Y_V = 12
IDX_Y_R = 13
IDX_Y_VVV = 14
IDX_Y_VVR = 15
IDX_Y_VRR = 16
IDX_Y_RRR = 17
IDX_N_V = 18
IDX_N_R = 19
IDX_N_VVV = 20
IDX_N_VVR = 21
IDX_N_VRR = 22
IDX_N_RRR = 23
IDX_M_MY = 24            # m + m_y [kg] (dimensional)
IDX_M_MX = 25            # m + m_x [kg]
IDX_XGM = 26             # x_G m [kg m]
IDX_INV11 = 27           # 1/(m + m_x) [1/kg]
IDX_INV22 = 28           # inverse of [[m + m_y, x_G m], [x_G m, I_zG + x_G^2 m + J_z]]
IDX_INV23 = 29
IDX_INV33 = 30
IDX_D_P = 31             # D_p [m]
IDX_RHO_D4 = 32          # rho D_p^4 [kg m]
IDX_RHO_D3 = 33          # rho D_p^3 [kg]
IDX_RHO_D2 = 34          # rho D_p^2 [kg/m]
IDX_K_0 = 35
IDX_K_1 = 36
IDX_K_2 = 37
IDX_T_P = 38
IDX_W_P0 = 39
IDX_X_P = 40             # x_P [-] (fraction of L, as in beta_P)
IDX_C_1 = 41
IDX_C_2_PLUS = 42
IDX_C_2_MINUS = 43
IDX_C_W = 44
IDX_POD_C = 45
IDX_POD_D = 46
IDX_XP_M = 47            # x_P L [m]
IDX_YP_M = 48            # y_P L [m]
IDX_T_R = 49
IDX_A_H = 50
IDX_XRH_M = 51           # (x_R + a_H x_H) L [m]
IDX_Q_R = 52             # 0.5 rho A_R f_alpha [kg/m]
IDX_EPSILON = 53
IDX_KAPPA = 54
IDX_ETA = 55             # D_p / H_R
IDX_L_R = 56
IDX_GAMMA_PLUS = 57
IDX_GAMMA_MINUS = 58
IDX_Y_P0 = 59            # Y_P0 [-]: propeller-induced side force per unit gross thrust
IDX_N_P0_M = 60          # N_P0 L [m]: propeller-induced yaw moment per unit gross thrust
N_PACKED = 61

#: Names of the packed rows, in index order (``PACKED_NAMES[IDX_L] == "L"``).
PACKED_NAMES: tuple[str, ...] = (
    "variant", "thrust_law", "wake_model", "L", "qF", "qN", "U_min", *HULL_COEFFICIENTS,
    "m+m_y", "m+m_x", "x_G m", "inv11", "inv22", "inv23", "inv33",
    "D_p", "rho D^4", "rho D^3", "rho D^2", "k_0", "k_1", "k_2", "t_P", "w_P0", "x_P", "C_1",
    "C_2_plus", "C_2_minus", "C_w", "pod_c", "pod_d", "x_P L", "y_P L",
    "t_R", "a_H", "(x_R + a_H x_H) L", "0.5 rho A_R f_alpha", "epsilon", "kappa", "eta", "l_R",
    "gamma_R_plus", "gamma_R_minus", "Y_P0", "N_P0 L",
)
assert len(PACKED_NAMES) == N_PACKED


def pack(p: MMGParameters) -> np.ndarray:
    """One lane of the flat parameter array: float64 ``(N_PACKED,)``, rows ``IDX_*``.

    Includes the derived constants the kernel needs (dimensional mass terms and the inverse of
    the eq. 4 mass matrix, rho D^k, the force scales 0.5 rho L d, 0.5 rho L^2 d, U_min,
    (x_R + a_H x_H) L, 0.5 rho A_R f_alpha, eta). Stack lanes as columns:
    ``np.stack([pack(a), pack(b)], axis=1)`` or :func:`pack_lanes`.
    """
    q = p.q_mass
    M = p.mass_matrix()
    inv = np.linalg.inv(M[1:, 1:])
    row = np.empty(N_PACKED)
    row[IDX_VARIANT] = VARIANTS.index(p.variant)
    row[IDX_THRUST_LAW] = THRUST_LAWS.index(p.thrust_law)
    row[IDX_WAKE_MODEL] = WAKE_MODELS.index(p.wake_model)
    row[IDX_L] = p.L
    row[IDX_QF] = 0.5 * p.rho * p.L * p.d
    row[IDX_QN] = 0.5 * p.rho * p.L ** 2 * p.d
    row[IDX_U_MIN] = U_MIN_FROUDE * math.sqrt(G * p.L)
    for k, name in enumerate(HULL_COEFFICIENTS):
        row[IDX_R_0 + k] = getattr(p, name)
    row[IDX_M_MY] = p.m + p.m_y * q
    row[IDX_M_MX] = p.m + p.m_x * q
    row[IDX_XGM] = p.x_G * p.m
    row[IDX_INV11] = 1.0 / M[0, 0]
    row[IDX_INV22] = inv[0, 0]
    row[IDX_INV23] = inv[0, 1]
    row[IDX_INV33] = inv[1, 1]
    row[IDX_D_P] = p.D_p
    row[IDX_RHO_D4] = p.rho * p.D_p ** 4
    row[IDX_RHO_D3] = p.rho * p.D_p ** 3
    row[IDX_RHO_D2] = p.rho * p.D_p ** 2
    row[IDX_K_0] = p.k_0
    row[IDX_K_1] = p.k_1
    row[IDX_K_2] = p.k_2
    row[IDX_T_P] = p.t_P
    row[IDX_W_P0] = p.w_P0
    row[IDX_X_P] = p.x_P
    row[IDX_C_1] = p.C_1
    row[IDX_C_2_PLUS] = p.C_2_plus
    row[IDX_C_2_MINUS] = p.C_2_minus
    row[IDX_C_W] = p.C_w
    row[IDX_POD_C] = p.pod_c
    row[IDX_POD_D] = p.pod_d
    row[IDX_XP_M] = p.x_P * p.L
    row[IDX_YP_M] = p.y_P * p.L
    row[IDX_T_R] = p.t_R
    row[IDX_A_H] = p.a_H
    row[IDX_XRH_M] = (p.x_R + p.a_H * p.x_H) * p.L
    row[IDX_Q_R] = 0.5 * p.rho * p.A_R * p.f_alpha
    row[IDX_EPSILON] = p.epsilon
    row[IDX_KAPPA] = p.kappa
    row[IDX_ETA] = p.eta
    row[IDX_L_R] = p.l_R
    row[IDX_GAMMA_PLUS] = p.gamma_R_plus
    row[IDX_GAMMA_MINUS] = p.gamma_R_minus
    row[IDX_Y_P0] = p.Y_P0
    row[IDX_N_P0_M] = p.N_P0 * p.L
    return row


def pack_lanes(params: list[MMGParameters] | tuple[MMGParameters, ...]) -> np.ndarray:
    """``(N_PACKED, n_lanes)`` float64, C-contiguous: one :func:`pack` column per parameter set."""
    return np.ascontiguousarray(np.stack([pack(p) for p in params], axis=1))


# ---------------------------------------------------------------------------------------------
# numba scalar kernels
# ---------------------------------------------------------------------------------------------

_EIGHT_PI = 8.0 / math.pi


@numba.njit(cache=True, inline="always")
def _hull_nb(p: Any, u: float, v: float,
             r: float) -> tuple[float, float, float, float, float, float, float]:
    """(X_H, Y_H, N_H [N, N m], U [m/s], beta [rad], v', r') of the Y&Y 2015 hull force model."""
    L = p[IDX_L]
    U2 = u * u + v * v
    U = vmath.sqrt(U2)
    Umin = p[IDX_U_MIN]
    Ug = max(U, Umin)
    # 1/U_g = U_g / U_g^2 with U_g^2 = max(U^2, U_min^2): the division waits on U^2 only, side
    # by side with the square root, not after it (the vector step's lanes wait on this chain)
    iUg = Ug / max(U2, Umin * Umin)
    vp = min(1.0, max(-1.0, v * iUg))
    rp = r * L * iUg
    vp2 = vp * vp
    rp2 = rp * rp
    qf = p[IDX_QF] * U2
    XH = qf * (-p[IDX_R_0] + p[IDX_X_VV] * vp2 + p[IDX_X_VR] * vp * rp
               + p[IDX_X_RR] * rp2 + p[IDX_X_VVVV] * vp2 * vp2)
    YH = qf * (p[IDX_Y_V] * vp + p[IDX_Y_R] * rp + p[IDX_Y_VVV] * vp2 * vp
               + p[IDX_Y_VVR] * vp2 * rp + p[IDX_Y_VRR] * vp * rp2
               + p[IDX_Y_RRR] * rp2 * rp)
    NH = p[IDX_QN] * U2 * (p[IDX_N_V] * vp + p[IDX_N_R] * rp
                              + p[IDX_N_VVV] * vp2 * vp + p[IDX_N_VVR] * vp2 * rp
                              + p[IDX_N_VRR] * vp * rp2 + p[IDX_N_RRR] * rp2 * rp)
    beta = vmath.asin(-vp)  # (branch-free: the kernels' lane loops vectorise)
    return XH, YH, NH, U, beta, vp, rp


@numba.njit(cache=True, inline="always")
def _wake_nb(p: Any, beta: float, rp: float) -> float:
    """Effective wake fraction w_P [-], beta_P = beta - x_P r' (Y&Y 2015 wake model).

    wake_model 0: ``w_P = 1 - (1 - w_P0)(1 + (1 - exp(-C_1 |beta_P|))(C_2 - 1))`` (Y&Y 2015,
    C_2 by the sign of beta_P); 1: ``w_P = w_P0 exp(-C_w beta_P^2)`` (shipmmg's form). The
    model's argument, C_2 and the result chosen by selects (no branch, no arithmetic blend of
    the two models: fewer multiplies in the vector step's chain): one exponential."""
    bP = beta - p[IDX_X_P] * rp
    C2 = p[IDX_C_2_PLUS] if bP > 0.0 else p[IDX_C_2_MINUS]
    gauss = p[IDX_WAKE_MODEL] != 0.0
    e = vmath.exp(-p[IDX_C_W] * bP * bP if gauss else -p[IDX_C_1] * abs(bP))
    wy = 1.0 - (1.0 - p[IDX_W_P0]) * (1.0 + (1.0 - e) * (C2 - 1.0))
    wg = p[IDX_W_P0] * e
    return wg if gauss else wy


@numba.njit(cache=True, inline="always")
def _kt_thrust_nb(p: Any, n: float, uP: float) -> float:
    """Open-water thrust ``T = rho n^2 D^4 K_T(J)`` [N] (Y&Y 2015 propeller model) of the lane's
    K_T law: :func:`usvid.models.thrust.kt_thrust_nb`, u_P = (1 - w_P) u."""
    return kt_thrust_nb(n, uP, p[IDX_RHO_D4], p[IDX_RHO_D3], p[IDX_RHO_D2], p[IDX_K_0],
                        p[IDX_K_1], p[IDX_K_2])


@numba.njit(cache=True, inline="always")
def _thrust_nb(p: Any, n: float, u: float, uP: float) -> tuple[float, float]:
    """(gross thrust T [N], effective surge force T_e [N]) of one propeller/thruster.

    K_T law: T from :func:`_kt_thrust_nb`, T_e = (1 - t_P) T (Y&Y 2015); pod law (Mu et
    al. 2016, :func:`usvid.models.thrust.pod_thrust_nb`): T = T_e = c u n + d |n| n. Blended
    by the 0/1 law flag (no branch)."""
    law = p[IDX_THRUST_LAW]
    Tk = _kt_thrust_nb(p, n, uP)
    Tpod = pod_thrust_nb(u, n, p[IDX_POD_C], p[IDX_POD_D])
    T = (1.0 - law) * Tk + law * Tpod
    Te = (1.0 - law) * (1.0 - p[IDX_T_P]) * Tk + law * Tpod
    return T, Te


@numba.njit(cache=True, inline="always")
def _rudder_nb(p: Any, U: float, beta: float, rp: float, uP: float, n: float,
               cd: float, sd: float) -> tuple[float, float, float, float, float, float]:
    """(X_R, Y_R, N_R [N, N m], u_R, v_R [m/s], F_N [N]) of the Y&Y 2015 rudder model.

    ``u_R = eps sqrt(eta ((1 - kappa) u_P + kappa sqrt(u_P^2 + 8 K_T n^2 D^2/pi))^2
    + (1 - eta) u_P^2)`` (the paper's u_R rewritten without J), ``v_R = U gamma_R beta_R``,
    ``F_N = 0.5 rho A_R f_alpha U_R (u_R sin delta - v_R cos delta)`` (= the paper's
    0.5 rho A_R U_R^2 f_alpha sin alpha_R with alpha_R = delta - atan(v_R/u_R)).
    """
    D = p[IDX_D_P]
    an = abs(n)
    ktn2d2 = (p[IDX_K_0] * n * n * D * D + p[IDX_K_1] * an * D * uP
              + p[IDX_K_2] * uP * uP)
    uP2 = uP * uP
    a = max(0.0, uP2 + _EIGHT_PI * ktn2d2)
    s = vmath.sqrt(a)
    kap = p[IDX_KAPPA]
    eta = p[IDX_ETA]
    eps = p[IDX_EPSILON]
    # (u_R / eps)^2 = eta w^2 + (1 - eta) u_P^2 with w = (1 - kappa) u_P + kappa s, expanded
    # with s^2 = a: the terms without s are formed beside the square root, one multiply-add
    # after it (the root of b waits on s); b >= 0 (a sum of squares), kept so where rounding
    # of the expanded form could take it below (u_P < 0 with w near 0 and eta = 1)
    ek = eta * kap
    b0 = (eta * (1.0 - kap) * (1.0 - kap) + (1.0 - eta)) * uP2 + ek * kap * a
    b = max(0.0, b0 + 2.0 * ek * (1.0 - kap) * uP * s)
    uR = eps * vmath.sqrt(b)
    bR = beta - p[IDX_L_R] * rp
    gam = p[IDX_GAMMA_PLUS] if bR > 0.0 else p[IDX_GAMMA_MINUS]
    vR = U * gam * bR
    # U_R from u_R^2 = eps^2 b, not from u_R: the two square roots side by side, not in series
    UR = vmath.sqrt(eps * eps * b + vR * vR)
    FN = p[IDX_Q_R] * UR * (uR * sd - vR * cd)
    XR = -(1.0 - p[IDX_T_R]) * FN * sd
    YR = -(1.0 + p[IDX_A_H]) * FN * cd
    NR = -p[IDX_XRH_M] * FN * cd
    return XR, YR, NR, uR, vR, FN


@numba.njit(cache=True, inline="always")
def _solve_nb(p: Any, u: float, v: float, r: float, X: float, Y: float,
              N: float) -> tuple[float, float, float]:
    """(du, dv, dr) [m/s^2, m/s^2, rad/s^2] from Y&Y 2015 eq. 4 for the total forces X, Y [N]
    and moment N [N m] about midship."""
    fx = X + p[IDX_M_MY] * v * r + p[IDX_XGM] * r * r
    fy = Y - p[IDX_M_MX] * u * r
    fn = N - p[IDX_XGM] * u * r
    du = p[IDX_INV11] * fx
    dv = p[IDX_INV22] * fy + p[IDX_INV23] * fn
    dr = p[IDX_INV23] * fy + p[IDX_INV33] * fn
    return du, dv, dr


@numba.njit(cache=True, inline="always")
def mmg_hull_accelerations(p: Any, u: float, v: float, r: float, X: float,
                           Y: float, N: float) -> tuple[float, float, float]:
    """(du, dv, dr) of the hull (Y&Y 2015 eq. 4 and the hull force model) under given external
    actuator forces X, Y [N] and moment N [N m] about midship: for thrust maps computed outside
    this module."""
    XH, YH, NH, U, beta, vp, rp = _hull_nb(p, u, v, r)
    return _solve_nb(p, u, v, r, XH + X, YH + Y, NH + N)


@numba.njit(cache=True, inline="always")
def mmg_accelerations_cs(p: Any, u: float, v: float, r: float, cd: float,
                         sd: float, n: float) -> tuple[float, float, float]:
    """:func:`mmg_accelerations` with ``cd, sd = cos(delta), sin(delta)`` given."""
    XH, YH, NH, U, beta, vp, rp = _hull_nb(p, u, v, r)
    uP = (1.0 - _wake_nb(p, beta, rp)) * u
    T = _kt_thrust_nb(p, n, uP)
    XP = (1.0 - p[IDX_T_P]) * T
    XR, YR, NR, uR, vR, FN = _rudder_nb(p, U, beta, rp, uP, n, cd, sd)
    return _solve_nb(p, u, v, r, XH + XR + XP, YH + YR + p[IDX_Y_P0] * T,
                     NH + NR + p[IDX_N_P0_M] * T)


@numba.njit(cache=True, inline="always")
def mmg_accelerations(p: Any, u: float, v: float, r: float, delta: float,
                      n: float) -> tuple[float, float, float]:
    """Rudder-behind-propeller MMG model (Y&Y 2015): ``(du, dv, dr)`` [m/s^2, m/s^2, rad/s^2].

    p: one lane's packed parameters (:func:`pack`, a tuple or 1-D array). u [m/s] surge,
    v [m/s] sway at midship, r [rad/s], delta [rad] (positive turns to starboard: r > 0),
    n [rps] shaft speed.
    Forces: the Y&Y 2015 hull, propeller and rudder models (module docstring); eq. 4 with the
    x_G coupling. Safe at u = 0, n = 0, J < 0 (module docstring).
    """
    return mmg_accelerations_cs(p, u, v, r, math.cos(delta), math.sin(delta), n)


@numba.njit(cache=True, inline="always")
def mmg_pod_accelerations(p: Any, u: float, v: float, r: float, delta: float,
                          n: float) -> tuple[float, float, float]:
    """Pod / vector thruster variant: ``(du, dv, dr)`` [m/s^2, m/s^2, rad/s^2].

    Hull and masses as Y&Y 2015; one thruster at x_P L turned by delta [rad] (positive turns to
    starboard) with effective thrust T_e [N] (K_T law with w_P and t_P, or the pod law):
    ``X_P = T_e cos delta``, ``Y_P = -T_e sin delta``, ``N_P = x_P L Y_P``. n [rps].
    """
    return mmg_pod_accelerations_cs(p, u, v, r, math.cos(delta), math.sin(delta), n)


@numba.njit(cache=True, inline="always")
def mmg_pod_accelerations_cs(p: Any, u: float, v: float, r: float, cd: float, sd: float,
                             n: float) -> tuple[float, float, float]:
    """:func:`mmg_pod_accelerations` with ``cd, sd = cos(delta), sin(delta)`` given."""
    XH, YH, NH, U, beta, vp, rp = _hull_nb(p, u, v, r)
    uP = (1.0 - _wake_nb(p, beta, rp)) * u
    T, Te = _thrust_nb(p, n, u, uP)
    YP = -Te * sd
    return _solve_nb(p, u, v, r, XH + Te * cd, YH + YP + p[IDX_Y_P0] * T,
                     NH + p[IDX_XP_M] * YP + p[IDX_N_P0_M] * T)


@numba.njit(cache=True, inline="always")
def mmg_twin_accelerations(p: Any, u: float, v: float, r: float, n_port: float,
                           n_stbd: float) -> tuple[float, float, float]:
    """Twin thrusters with differential thrust: ``(du, dv, dr)`` [m/s^2, m/s^2, rad/s^2].

    Hull and masses as Y&Y 2015; thrusters at (x_P, -y_P) L (port) and (x_P, +y_P) L
    (starboard), shaft speeds n_port, n_stbd [rps or the thrust law's command unit]:
    ``X_P = T_e,port + T_e,stbd``, ``N_P = (T_port - T_stbd) y_P L`` (more port thrust turns
    to starboard, r > 0; the catamaran paper eq. 26-27, ARCHITECTURE.md).
    """
    XH, YH, NH, U, beta, vp, rp = _hull_nb(p, u, v, r)
    uP = (1.0 - _wake_nb(p, beta, rp)) * u
    Tp, Tep = _thrust_nb(p, n_port, u, uP)
    Ts, Tes = _thrust_nb(p, n_stbd, u, uP)
    return _solve_nb(p, u, v, r, XH + Tep + Tes, YH, NH + (Tp - Ts) * p[IDX_YP_M])


@numba.njit(cache=True, inline="always")
def mmg_accelerations_any(p: Any, u: float, v: float, r: float, a0: float,
                          a1: float) -> tuple[float, float, float]:
    """Dispatch on ``p[IDX_VARIANT]``: rudder and pod take ``(a0, a1) = (delta, n)``, twin
    ``(a0, a1) = (n_port, n_stbd)``. One predictable branch per lane."""
    var = p[IDX_VARIANT]
    if var == 0.0:
        return mmg_accelerations(p, u, v, r, a0, a1)
    if var == 1.0:
        return mmg_pod_accelerations(p, u, v, r, a0, a1)
    return mmg_twin_accelerations(p, u, v, r, a0, a1)


#: Columns of the diagnostic component array (:func:`forces` keys, in this order).
COMPONENTS = ("X_H", "Y_H", "N_H", "X_R", "Y_R", "N_R", "X_P", "Y_P", "N_P", "U", "beta",
              "v_prime", "r_prime", "w_P", "J", "K_T", "T", "T_stbd", "u_R", "v_R", "U_R",
              "alpha_R", "F_N", "du", "dv", "dr")
_NC = len(COMPONENTS)


@numba.njit(cache=True)
def _components_nb(p: np.ndarray, u: np.ndarray, v: np.ndarray, r: np.ndarray,
                   delta: np.ndarray, n: np.ndarray, n2: np.ndarray) -> np.ndarray:
    out = np.zeros((u.shape[0], _NC))
    var = p[IDX_VARIANT]
    for i in range(u.shape[0]):
        XH, YH, NH, U, beta, vp, rp = _hull_nb(p, u[i], v[i], r[i])
        wP = _wake_nb(p, beta, rp)
        uP = (1.0 - wP) * u[i]
        T, Te = _thrust_nb(p, n[i], u[i], uP)
        cd = math.cos(delta[i])
        sd = math.sin(delta[i])
        XR = YR = NR = uR = vR = FN = alpha = 0.0
        T2 = 0.0
        if var == 0.0:
            XR, YR, NR, uR, vR, FN = _rudder_nb(p, U, beta, rp, uP, n[i], cd, sd)
            alpha = delta[i] - math.atan2(vR, uR)
            XP, YP, NP = Te, p[IDX_Y_P0] * T, p[IDX_N_P0_M] * T
        elif var == 1.0:
            XP, YP = Te * cd, -Te * sd
            NP = p[IDX_XP_M] * YP + p[IDX_N_P0_M] * T
            YP += p[IDX_Y_P0] * T
        else:
            T2, Te2 = _thrust_nb(p, n2[i], u[i], uP)
            XP, YP, NP = Te + Te2, 0.0, (T - T2) * p[IDX_YP_M]
        an = abs(n[i])
        J = uP / (an * p[IDX_D_P]) if an * p[IDX_D_P] > 0.0 else 0.0
        KT = p[IDX_K_0] + p[IDX_K_1] * J + p[IDX_K_2] * J * J
        du, dv, dr = _solve_nb(p, u[i], v[i], r[i], XH + XR + XP, YH + YR + YP,
                               NH + NR + NP)
        vals = (XH, YH, NH, XR, YR, NR, XP, YP, NP, U, beta, vp, rp, wP, J, KT, T, T2, uR, vR,
                math.sqrt(uR * uR + vR * vR), alpha, FN, du, dv, dr)
        for k in range(_NC):
            out[i, k] = vals[k]
    return out


# ---------------------------------------------------------------------------------------------
# numpy wrappers (tests, diagnostics, regression)
# ---------------------------------------------------------------------------------------------

def _inputs(p: MMGParameters, u: Any, v: Any, r: Any, delta: Any, n: Any, n_port: Any,
            n_stbd: Any) -> tuple[tuple[int, ...], list[np.ndarray]]:
    if p.variant == "twin":
        if n_port is None or n_stbd is None:
            raise UsvidError("variant 'twin' needs n_port and n_stbd (delta and n are unused)")
        a, a2 = n_port, n_stbd
    else:
        a, a2 = n, 0.0
    arrs = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (u, v, r, delta, a, a2)))
    shape = arrs[0].shape
    return shape, [np.ascontiguousarray(x.ravel()) for x in arrs]


def forces(params: MMGParameters, u: Any, v: Any, r: Any, delta: Any = 0.0, n: Any = 0.0, *,
           n_port: Any = None, n_stbd: Any = None) -> dict[str, np.ndarray]:
    """Force components and intermediate quantities of the MMG model (Y&Y 2015 force models).

    Arguments broadcast (numpy rules): u, v [m/s] (v at midship), r [rad/s], delta [rad], n
    [rps]; the twin variant takes ``n_port``, ``n_stbd`` instead of delta, n. Returns arrays of
    the broadcast shape, keyed by :data:`COMPONENTS`: X_H, Y_H, X_R, Y_R, X_P, Y_P [N]; N_H,
    N_R, N_P [N m] (about midship); U [m/s], beta [rad], v_prime, r_prime, w_P, J, K_T [-],
    T, T_stbd [N] gross thrust (T_stbd: twin only), u_R, v_R, U_R [m/s], alpha_R [rad], F_N [N],
    du, dv [m/s^2], dr [rad/s^2]. Rudder quantities are 0 for the pod/twin variants; X_P is the
    effective thrust (1 - t_P) T (K_T law) resolved along x.
    """
    shape, (uu, vv, rr, dd, nn, n2) = _inputs(params, u, v, r, delta, n, n_port, n_stbd)
    out = _components_nb(pack(params), uu, vv, rr, dd, nn, n2)
    return {k: out[:, i].reshape(shape) for i, k in enumerate(COMPONENTS)}


def accelerations(params: MMGParameters, u: Any, v: Any, r: Any, delta: Any = 0.0,
                  n: Any = 0.0, *, n_port: Any = None,
                  n_stbd: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorised ``(du, dv, dr)`` [m/s^2, m/s^2, rad/s^2] of the variant in ``params``
    (Y&Y 2015 eq. 4); arguments as :func:`forces`."""
    f = forces(params, u, v, r, delta, n, n_port=n_port, n_stbd=n_stbd)
    return f["du"], f["dv"], f["dr"]


# ---------------------------------------------------------------------------------------------
# Regression form for identification
# ---------------------------------------------------------------------------------------------

class RegressionBlock(NamedTuple):
    """One equation of the linear-in-the-hull-coefficients regression: ``y ~ Phi @ theta``.

    equation 'X', 'Y' or 'N'; Phi ``(N, k)`` non-dimensional regressors; y ``(N,)`` the
    non-dimensional hull force implied by the measurements; names the k coefficient names
    (fields of :class:`MMGParameters`, theta in that order).
    """

    equation: str
    Phi: np.ndarray
    y: np.ndarray
    names: tuple[str, ...]


X_REGRESSORS = ("R_0", "X_vv", "X_vr", "X_rr", "X_vvvv")
Y_REGRESSORS = ("Y_v", "Y_r", "Y_vvv", "Y_vvr", "Y_vrr", "Y_rrr")
N_REGRESSORS = ("N_v", "N_r", "N_vvv", "N_vvr", "N_vrr", "N_rrr")

#: Coefficients that free-running data determine only in combination (see hull_regression).
CONFOUNDED: dict[str, str] = {
    "X_vr": "exactly collinear with the (m' + m_y') v' r' inertia term: X_vr absorbs an error "
            "in m_y (only X_vr + m' + m_y' enters the surge acceleration)",
    "X_rr": "exactly collinear with the x_G m r^2 term (x_G' m' r'^2, x_G' = x_G/L): only "
            "X_rr + x_G' m' is determined; absorbs an error in x_G",
    "Y_r": "collinear with the (m' + m_x') r' u/U inertia term (u/U = cos beta ~ 1): only "
           "Y_r - m' - m_x' is determined (the Y_r / Y_ur cancellation); the small remainder "
           "(1 - cos beta) r' ~ v'^2 r'/2 leaks into Y_vvr",
    "N_r": "collinear with the x_G' m' r' u/U term: only N_r - x_G' m' is determined; absorbs "
           "an error in x_G",
    "R_0": "with nearly constant n and U the constant regressor is collinear with the thrust: "
           "R_0 absorbs errors of t_P, w_P0 and K_T",
    "Y_v,N_v,Y_r,N_r": "the rudder's flow-straightening term (gamma_R, l_R) is linear in v', "
                       "r': errors in gamma_R, l_R, epsilon, kappa shift the linear hull "
                       "derivatives",
    "cubic": "in zig-zags and turns v' and r' move together (v' ~ -c r'), so the four cubic "
             "terms of Y (and of N) and, to a lesser degree, the linear pair are nearly "
             "collinear: only their combination along the manoeuvre is determined",
}


def hull_regression(params: MMGParameters, u: Any, v: Any, r: Any, udot: Any, vdot: Any,
                    rdot: Any, delta: Any = 0.0, n: Any = 0.0, *, n_port: Any = None,
                    n_stbd: Any = None, external: Any = None,
                    asymmetry: tuple[str, ...] = ()) -> list[RegressionBlock]:
    """Regression form of Y&Y 2015 eq. 4: the hull forces are linear in the hull coefficients.

    With the particulars, masses, added masses and propeller/rudder/thruster parameters of
    ``params`` held fixed, for each sample (1-D arrays, or anything that broadcasts)::

        y_X = [(m + m_x) udot - (m + m_y) v r - x_G m r^2 - X_R - X_P] / (0.5 rho L d U^2)
            = -R_0 + X_vv v'^2 + X_vr v' r' + X_rr r'^2 + X_vvvv v'^4
        y_Y = [(m + m_y) vdot + x_G m rdot + (m + m_x) u r - Y_R - Y_P] / (0.5 rho L d U^2)
            = Y_v v' + Y_r r' + Y_vvv v'^3 + Y_vvr v'^2 r' + Y_vrr v' r'^2 + Y_rrr r'^3
        y_N = [(I_zG + x_G^2 m + J_z) rdot + x_G m (vdot + u r) - N_R - N_P]
              / (0.5 rho L^2 d U^2)
            = N_v v' + N_r r' + ...

    (v' = v/U, r' = r L/U non-dimensional). ``external``: known loads (X, Y [N], N [N m]
    about midship, body axes; e.g. the wind's along the measured track) subtracted from the
    measured forces like the rudder's and the propeller's. u, v [m/s] (v at midship), r
    [rad/s], udot, vdot [m/s^2], rdot [rad/s^2] from state estimation; delta [rad], n [rps]
    (twin: n_port, n_stbd).
    Returns three :class:`RegressionBlock` (X: regressors ``(-1, v'^2, v'r', r'^2, v'^4)`` for
    ``(R_0, X_vv, X_vr, X_rr, X_vvvv)``; Y and N: ``(v', r', v'^3, v'^2 r', v' r'^2, r'^3)``).
    Below U_min the kernel's U^2/U_min^2 scaling multiplies Phi, so ``Phi @ theta = y`` holds
    exactly for the model at every sample; such samples carry little information.
    ``asymmetry`` (rudder and pod variants): the names among ``("Y_P0", "N_P0")`` of the
    propeller-induced side force and yaw moment ``Y_P = Y_P0 T``, ``N_P = N_P0 L T`` (module
    docstring) to estimate too: one more regressor ``T / (0.5 rho L d U^2)`` (T the gross
    thrust [N]) appended to the Y block for Y_P0 and to the N block for N_P0; the others are
    held at the values of ``params`` (subtracted with the propeller's force like the other
    held loads).

    Separability (:data:`CONFOUNDED`): X_vr is exactly collinear with the m_y inertia term and
    X_rr with the x_G one; Y_r (N_r) is collinear with (m' + m_x') r' cos beta (x_G' m' r'
    cos beta): only Y_r - m' - m_x' is determined from free-running data, so m_x, m_y, x_G are
    held at their priors; R_0 trades with the thrust parameters; the rudder's
    flow-straightening terms trade with the linear derivatives; the cubic terms are nearly
    collinear along the manoeuvre.
    """
    f = forces(params, u, v, r, delta, n, n_port=n_port, n_stbd=n_stbd)
    shape = f["U"].shape
    ud, vd, rd, uu, vv, rr = (np.broadcast_to(np.asarray(x, dtype=float), shape)
                              for x in (udot, vdot, rdot, u, v, r))
    q = params.q_mass
    mmx = params.m + params.m_x * q
    mmy = params.m + params.m_y * q
    xgm = params.x_G * params.m
    U = f["U"]
    Umin = U_MIN_FROUDE * math.sqrt(G * params.L)
    Ug2 = np.maximum(U, Umin) ** 2
    scale = U ** 2 / Ug2
    qf = 0.5 * params.rho * params.L * params.d * Ug2
    qn = qf * params.L
    vp, rp = f["v_prime"], f["r_prime"]
    yX = (mmx * ud - mmy * vv * rr - xgm * rr ** 2 - f["X_R"] - f["X_P"]) / qf
    yY = (mmy * vd + xgm * rd + mmx * uu * rr - f["Y_R"] - f["Y_P"]) / qf
    yN = (params.Iz_total * rd + xgm * (vd + uu * rr) - f["N_R"] - f["N_P"]) / qn
    if external is not None:
        eX, eY, eN = (np.broadcast_to(np.asarray(x, dtype=float), shape) for x in external)
        yX = yX - eX / qf
        yY = yY - eY / qf
        yN = yN - eN / qn
    one = np.ones_like(vp)
    PhiX = np.stack([-one, vp ** 2, vp * rp, rp ** 2, vp ** 4], axis=-1) * scale[..., None]
    lat = np.stack([vp, rp, vp ** 3, vp ** 2 * rp, vp * rp ** 2, rp ** 3],
                   axis=-1) * scale[..., None]
    k = lat.shape[-1]
    lat = lat.reshape(-1, k)
    if asymmetry and params.variant == "twin":
        raise UsvidError("the propeller asymmetry Y_P0, N_P0 belongs to the rudder and pod "
                         "variants (twin thrusters: thrust_asymmetry)")
    col = (f["T"] / qf).reshape(-1, 1)
    latY = np.hstack([lat, col]) if "Y_P0" in asymmetry else lat
    latN = np.hstack([lat, col]) if "N_P0" in asymmetry else lat.copy()
    return [RegressionBlock("X", PhiX.reshape(-1, 5), yX.reshape(-1), X_REGRESSORS),
            RegressionBlock("Y", latY, yY.reshape(-1),
                            (*Y_REGRESSORS, *(("Y_P0",) if "Y_P0" in asymmetry else ()))),
            RegressionBlock("N", latN, yN.reshape(-1),
                            (*N_REGRESSORS, *(("N_P0",) if "N_P0" in asymmetry else ())))]


__all__ = [
    "ASYMMETRY", "COMPONENTS", "CONFOUNDED", "FIELDS", "FIELD_NAMES", "HULL_COEFFICIENTS",
    "KVLCC2_COEFFICIENTS", "KVLCC2_HSVA_PARTICULARS", "KVLCC2_PAPER_PARTICULARS", "N_PACKED",
    "PACKED_NAMES", "PRIOR_SOURCES", "THRUST_LAWS", "VARIANTS", "WAKE_MODELS", "FieldInfo",
    "MMGParameters", "RegressionBlock", "accelerations", "forces", "fujii_f_alpha",
    "hull_regression", "kvlcc2", "mmg_accelerations", "mmg_accelerations_any",
    "mmg_accelerations_cs", "mmg_hull_accelerations", "mmg_pod_accelerations",
    "mmg_twin_accelerations", "pack", "pack_lanes", "priors",
]
