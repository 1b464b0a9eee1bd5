r"""Wind loads on the hull above water: surge and sway force, yaw and roll moment from the apparent
wind, through a published coefficient model.

Conventions (the Trial contract): apparent wind speed :math:`V_A` [m/s] and angle
:math:`\gamma_A` [rad, from the bow, clockwise, the direction the wind comes FROM, as NMEA MWV
"R"; :func:`usvid.models.environment.wind.true_to_apparent` gives them from the true wind].
Loads in the body frame: X [N, forward], Y [N, to starboard], N [N m, bow to starboard, i.e.
clockwise seen from above], K [N m, heel to starboard]. A head wind gives X < 0, a wind from
starboard Y < 0.

.. math::

    X = s\,q A_T C_X(\gamma), \quad Y = s\,q A_L C_Y(\gamma), \quad
    N = s\,q A_L L_{OA} C_N(\gamma), \quad K = s\,q A_L H_M C_K(\gamma), \qquad
    q = \tfrac12 \rho_a V_A^2,\ H_M = A_L / L_{OA},

with the published coefficients written for the angle :math:`\gamma = -\gamma_A` (measured
counter-clockwise, positive for a wind from port, so that :math:`C_Y > 0` pushes to starboard;
Fujiwara et al. 1998 and Blendermann 1994 both use that sense). :math:`s` is the dimensionless
``wind_scale`` (1 by default), one multiplier of all four loads, so that it can be identified.
:math:`\rho_a` is the air density (default :data:`AIR_DENSITY`).

Models (:func:`wind_load_model` chooses one and says why):

``fujiwara1998``
    Fujiwara, T., Ueno, M. and Nimura, T. (1998), "Estimation of wind forces and moments acting
    on ships", J. Soc. Naval Arch. Japan 183, 77-90: a regression of wind-tunnel data of many
    ships, Fourier series in the wind angle whose coefficients are linear in ratios of the
    windage particulars:

    .. math::

        C_X = X_0 + X_1 \cos\gamma + X_3 \cos 3\gamma + X_5 \cos 5\gamma, \quad
        C_Y = Y_1 \sin\gamma + Y_3 \sin 3\gamma + Y_5 \sin 5\gamma, \quad
        C_N = N_1 \sin\gamma + N_2 \sin 2\gamma + N_3 \sin 3\gamma,

    :math:`X_0 = x_{00} + x_{01} B H_{BR}/A_T + x_{02} C/H_C + x_{03} A_{OD}/L_{OA}^2`, ... (the
    full regressors in :func:`fujiwara1998_fourier`). Needs A_T, A_L, A_OD, C, C_BR, H_BR, H_C,
    L_OA, B. The regression coefficients are transcribed from the paper's table as published
    in the open MMG code of the Esso Osaka 3 m model's laboratory (Osaka University, the source
    of the Esso Osaka data; two transcriptions of theirs agree in every coefficient and differ in
    one regressor, see :data:`FUJIWARA1998_Y`). Its roll-moment regression is not used (its
    reference point is ambiguous in the sources): :math:`C_K` is NaN for this model.

    The later component model of Fujiwara, Ueno & Ikeda (2005, J. JASNAOE 2, 243-255) is not
    implemented: the open transcriptions of its table disagree in four coefficients and the
    paper itself could not be checked.

``blendermann1994``
    Blendermann, W. (1994), "Parameter identification of wind loads on ships", J. Wind Eng. Ind.
    Aerodyn. 51, 339-351, with its table of coefficients per vessel type (reproduced in Fossen,
    T. I. (2021), Handbook of Marine Craft Hydrodynamics and Motion Control, 2nd ed., ch. 10.1,
    and in Fossen's MSS ``blendermann94``):

    .. math::

        C_X = -C_{Dl,AF}(\gamma)\,\frac{\cos\gamma}{D}, \quad
        C_Y = C_{Dt}\,\frac{\sin\gamma}{D}, \quad
        C_N = \Big(\frac{s_L}{L_{OA}} - 0.18\,(|\gamma| - \tfrac{\pi}{2})\Big) C_Y, \quad
        C_K = \kappa\,\frac{s_H}{H_M}\,C_Y,

        D = 1 - \tfrac{\delta}{2}\Big(1 - \frac{C_{Dl}}{C_{Dt}}\Big)\sin^2 2\gamma, \quad
        C_{Dl} = C_{Dl,AF}\,A_T/A_L,

    :math:`C_{Dl,AF}` the head-wind value for :math:`|\gamma| \le \pi/2`, the stern-wind value
    beyond. :math:`|\gamma|` in :math:`C_N` keeps the moment odd in the angle (MSS applies the
    formula to signed angles, which is not symmetric). Needs A_T, A_L, L_OA and a vessel type
    (:data:`BLENDERMANN_TYPES`; default ``"speed_boat"``, the closest to a small USV); ``s_L``
    the lateral centroid forward of midship (default 0) and ``s_H`` its height above the
    waterline (default H_M / 2, for K only).

Numba: the loads of one sample are :func:`wind_load` (``p`` from :func:`WindLoadModel.packed`,
a float64 vector of :data:`WIND_PACK` entries, the apparent speed and angle) -> (X, Y, N, K);
:func:`wind_loads` is the array version (the same code). Code 0 in ``p[0]`` is "no wind model"
and returns zeros, so a core can always call it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.models.environment.wind import true_to_apparent_scalar
from usvid.models.hull import zhou_added_mass
from usvid.trial import Vessel

#: Air density [kg/m^3] at 15 deg C and sea-level pressure (ISO 2533 standard atmosphere).
AIR_DENSITY = 1.225

#: Model codes in ``p[0]`` of a packed wind model.
CALM, FUJIWARA1998, BLENDERMANN1994 = 0, 1, 2
MODELS = {"fujiwara1998": FUJIWARA1998, "blendermann1994": BLENDERMANN1994}
#: Length of a packed wind model: code, wind_scale, the four dimensional factors
#: (1/2 rho_a A_T, 1/2 rho_a A_L, 1/2 rho_a A_L L_OA, 1/2 rho_a A_L H_M) and ten coefficients.
WIND_PACK = 16

# Fujiwara, Ueno & Nimura (1998) regression coefficients (the paper's table as transcribed in
# the Esso Osaka laboratory's open MMG code; x_ij multiplies the j-th regressor of X_i).
FUJIWARA1998_X = {
    0: (-0.330, 0.293, 0.0193, 0.682),
    1: (-1.353, 1.700, 2.870, -0.463, -0.570, -6.640, -0.0123, 0.0202),
    3: (0.830, -0.413, -0.0827, -0.563, 0.804, -5.670, 0.0401, -0.132),
    5: (0.0372, -0.0075, -0.103, 0.0921),
}
#: The last regressor of Y_5 is C H_C / A_L in the laboratory's Fortran model and L_OA H_C / A_L
#: in its MATLAB script; the Fortran (the code their published simulations ran) is used. For the
#: Esso Osaka particulars the two give C_Y differing by less than 0.02.
FUJIWARA1998_Y = {
    1: (0.684, 0.717, -3.220, 0.0281, 0.0661, 0.298),
    3: (-0.400, 0.282, 0.307, 0.0519, 0.0526, -0.0814, 0.0582),
    5: (0.122, -0.166, -0.0054, -0.0481, -0.0136, 0.0864, -0.0297),
}
FUJIWARA1998_N = {
    1: (0.299, 1.710, 0.183, -1.090, -0.0442, -0.289, 4.240, -0.0646, 0.0306),
    2: (0.117, 0.123, -0.323, 0.0041, -0.166, -0.0109, 0.174, 0.214, -1.060),
    3: (0.0230, 0.0385, -0.0339, 0.0023),
}

#: Blendermann (1994) coefficients per vessel type: (C_Dt, C_Dl,AF(bow), C_Dl,AF(stern), delta,
#: kappa). The drilling vessel's published ranges (0.70-1.00, 0.75-1.10) are taken at their
#: middle, as in MSS.
BLENDERMANN_TYPES: dict[str, tuple[float, float, float, float, float]] = {
    "car_carrier": (0.95, 0.55, 0.60, 0.80, 1.2),
    "cargo_loaded": (0.85, 0.65, 0.55, 0.40, 1.7),
    "cargo_container_on_deck": (0.85, 0.55, 0.50, 0.40, 1.4),
    "container_loaded": (0.90, 0.55, 0.55, 0.40, 1.4),
    "destroyer": (0.85, 0.60, 0.65, 0.65, 1.1),
    "diving_support": (0.90, 0.60, 0.80, 0.55, 1.7),
    "drilling": (1.00, 0.85, 0.925, 0.10, 1.7),
    "ferry": (0.90, 0.45, 0.50, 0.80, 1.1),
    "fishing": (0.95, 0.70, 0.70, 0.40, 1.1),
    "lng_tanker": (0.70, 0.60, 0.65, 0.50, 1.1),
    "offshore_supply": (0.90, 0.55, 0.80, 0.55, 1.2),
    "passenger_liner": (0.90, 0.40, 0.40, 0.80, 1.2),
    "research": (0.85, 0.55, 0.65, 0.60, 1.4),
    "speed_boat": (0.90, 0.55, 0.60, 0.60, 1.1),
    "tanker_loaded": (0.70, 0.90, 0.55, 0.40, 3.1),
    "tanker_ballast": (0.70, 0.75, 0.55, 0.40, 2.2),
    "tender": (0.85, 0.55, 0.55, 0.65, 1.1),
}

#: Windage particulars beyond ``Vessel.frontal_area`` (A_T) and ``lateral_area`` (A_L), read from
#: ``vessel.extra`` (SI): name -> (symbol, meaning).
WINDAGE_EXTRA: dict[str, tuple[str, str]] = {
    "length_overall": ("L_OA", "length overall [m] (default vessel.length)"),
    "superstructure_area": ("A_OD", "lateral projected area of the superstructure and deck "
                                    "cargo [m^2]"),
    "superstructure_x": ("C_BR", "centroid of A_OD forward of midship [m]"),
    "superstructure_height": ("H_BR", "height of the top of the superstructure above the "
                                      "waterline [m]"),
    "lateral_centroid_x": ("C", "centroid of A_L forward of midship [m]"),
    "lateral_centroid_height": ("H_C", "height of the centroid of A_L above the waterline [m]"),
    "air_density": ("rho_a", f"air density [kg/m^3] (default {AIR_DENSITY})"),
    "wind_scale": ("s", "multiplier of the wind loads [-] (default 1)"),
}
FUJIWARA_NEEDS = ("frontal_area", "lateral_area", "superstructure_area", "lateral_centroid_x",
                  "superstructure_x", "superstructure_height", "lateral_centroid_height",
                  "length_overall", "beam")


# ---------------------------------------------------------------------------------------------
# coefficients and loads of one sample (numba) - the one place of the formulas
# ---------------------------------------------------------------------------------------------
#: Cephes ``atan`` (Moshier 1984-2000, double precision: a rational approximation of degree
#: 4/5 after reducing the argument to |x| <= 0.66): numerator and monic denominator coefficients
#: (highest power first), tan(3 pi / 8) and the low bits of pi / 2.
_ATAN_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1,
           -7.500855792314704667340e1, -1.228866684490136173410e2,
           -6.485021904942025371773e1)
_ATAN_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
           4.853903996359136964868e2, 1.945506571482613964425e2)
_T3P8 = 2.41421356237309504880
_MOREBITS = 6.123233995736765886130e-17


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def atan_ratio(y, x):
    """arctan(y / x) [rad] for x >= 0 (x = 0: +-pi/2; not both 0) without a library call:
    Cephes' ``atan`` (relative error about 1e-16) with its argument reduction written on the
    ratio's terms, so that one division forms the reduced argument, and its branches as selects:
    a loop over lanes that calls it vectorises (the library's atan has no vector form here)."""
    a = abs(y)
    big = a > _T3P8 * x  # y / x > tan(3 pi / 8): pi/2 + atan(-x / y)
    mid = a > 0.66 * x  # pi/4 + atan((y - x) / (y + x))
    xr = (-x if big else (a - x if mid else a)) / (a if big else (a + x if mid else x))
    y0 = 0.5 * math.pi if big else (0.25 * math.pi if mid else 0.0)
    extra = _MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0)
    z = xr * xr
    num = (((_ATAN_P[0] * z + _ATAN_P[1]) * z + _ATAN_P[2]) * z + _ATAN_P[3]) * z + _ATAN_P[4]
    den = ((((z + _ATAN_Q[0]) * z + _ATAN_Q[1]) * z + _ATAN_Q[2]) * z + _ATAN_Q[3]) * z \
        + _ATAN_Q[4]
    r = y0 + ((xr * (z * num / den) + xr) + extra)
    return r if y >= 0.0 else -r


#: Squared apparent speed [m^2/s^2] below which the apparent wind is taken as still (zero
#: loads): 1e-150, i.e. 1e-75 m/s, where the fourth power of the speed in
#: :func:`wind_coefficients_body` would leave the normal double range.
STILL_V2 = 1e-150


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def wind_coefficients_body(p, ax, ay):
    r"""The coefficients times the squared apparent speed, :math:`V_A^2 (C_X, C_Y, C_N, C_K)`
    [m^2/s^2], of the packed model ``p`` for the air's velocity relative to the vessel in body
    axes ``ax`` (forward), ``ay`` (starboard) [m/s] (the apparent wind comes from
    atan2(-ay, -ax) off the bow, clockwise, with speed V_A = |a|; the published angle g has
    cos g = -ax / V_A, sin g = ay / V_A); zeros for code 0 (calm) and for a still apparent wind
    (:data:`STILL_V2`). The one place of the formulas (module docstring): the loads
    (:func:`wind_load_body`) and the coefficients at an angle (:func:`wind_coefficients_cs`)
    call it.

    Fujiwara et al. (1998): cos g and sin g (one division, 1 / V_A), the multiple angles by
    their polynomials (cos 3g = 4 c^3 - 3c, ...). Blendermann (1994), written in ax and ay
    (homogeneous: no normalisation): with :math:`\sin^2 2g = 4 a_x^2 a_y^2 / V_A^4`,

    .. math::

        V_A^2 C_X = C_{Dl,AF}\, a_x G, \quad V_A^2 C_Y = C_{Dt}\, a_y G, \quad
        G = \frac{C_{Dt} V_A^5}{C_{Dt} V_A^4 - 2\delta (C_{Dt} - C_{Dl,AF} A_T/A_L)\,
        a_x^2 a_y^2} = \frac{V_A}{D},

    :math:`C_{Dl,AF}` the bow value for a_x <= 0 (cos g >= 0), and :math:`|g| - \pi/2 =
    -\arctan(c / |s|) = -\arctan(-a_x / |a_y|)` by :func:`atan_ratio`. One square root and
    one division (Fujiwara) or three (Blendermann: G and the arctangent's two), no library
    call and every branch a select: the integration core's vector step calls it for every
    lane (a third fewer operations than the same formulas on cos g and sin g)."""
    code = int(p[0])
    ax2 = ax * ax
    ay2 = ay * ay
    v2 = ax2 + ay2
    still = v2 < STILL_V2
    va = math.sqrt(v2)
    if code == 0:
        return 0.0, 0.0, 0.0, 0.0
    if code == 1:  # Fujiwara et al. 1998
        inv = 1.0 / (1.0 if still else va)
        c = -ax * inv
        s = ay * inv
        c2, s2 = c * c, s * s
        cos3 = c * (4.0 * c2 - 3.0)
        cos5 = c * (16.0 * c2 * c2 - 20.0 * c2 + 5.0)
        sin3 = s * (3.0 - 4.0 * s2)
        sin5 = s * (16.0 * s2 * s2 - 20.0 * s2 + 5.0)
        cx = p[6] + p[7] * c + p[8] * cos3 + p[9] * cos5
        cy = p[10] * s + p[11] * sin3 + p[12] * sin5
        cn = p[13] * s + p[14] * (2.0 * s * c) + p[15] * sin3
        v2 = 0.0 if still else v2
        return v2 * cx, v2 * cy, v2 * cn, (0.0 if still else math.nan)
    # Blendermann 1994: p[6:] = C_Dt, C_Dl,AF bow, stern, delta, kappa, A_T/A_L, s_L/L_OA,
    # s_H/H_M
    cdl_af = p[7] if ax <= 0.0 else p[8]
    v4 = v2 * v2
    dh = p[6] * v4 - 2.0 * p[9] * (p[6] - cdl_af * p[11]) * (ax2 * ay2)
    g = (p[6] * va * v4) / (1.0 if still else dh)
    g = 0.0 if still else g
    qy = p[6] * ay * g
    # a still apparent wind has no direction: atan_ratio(0, 0) would be 0/0 (a NaN moment
    # times qy = 0 is still NaN: a vessel at rest over ground in the still-air term)
    qn = (p[12] + 0.18 * atan_ratio(-ax, 1.0 if still else abs(ay))) * qy
    return cdl_af * ax * g, qy, qn, p[10] * p[13] * qy


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def wind_coefficients_cs(p, c, s):
    """(C_X, C_Y, C_N, C_K) of the packed model ``p`` at the published angle g (counter-clockwise,
    positive for a wind from port: minus the apparent wind angle) given by ``c`` = cos g and
    ``s`` = sin g; zeros for code 0 (calm): :func:`wind_coefficients_body` of the unit air
    velocity (-c, s), divided by its squared length (1 to rounding)."""
    qx, qy, qn, qk = wind_coefficients_body(p, -c, s)
    v2 = c * c + s * s
    return qx / v2, qy / v2, qn / v2, qk / v2


@numba.njit(cache=True)
def wind_coefficients_scalar(p, angle):
    """(C_X, C_Y, C_N, C_K) of the packed model ``p`` at the apparent wind angle ``angle`` [rad,
    from the bow, clockwise, coming from]; zeros for code 0 (calm). One cosine and one sine per
    call (:func:`wind_coefficients_cs`)."""
    return wind_coefficients_cs(p, math.cos(-angle), math.sin(-angle))


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def _scaled(p, v2, cx, cy, cn, ck):
    """The loads (X, Y, N, K) of the coefficients at the squared apparent speed v2 [m^2/s^2]."""
    q = p[1] * v2
    return p[2] * q * cx, p[3] * q * cy, p[4] * q * cn, p[5] * q * ck


@numba.njit(cache=True)
def wind_load(p, speed, angle):
    """Wind loads (X [N], Y [N], N [N m], K [N m]) of the packed model ``p`` for the apparent
    wind ``speed`` [m/s] and ``angle`` [rad, from the bow, clockwise, coming from]."""
    if p[0] == 0.0 or speed == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    cx, cy, cn, ck = wind_coefficients_scalar(p, angle)
    return _scaled(p, speed * speed, cx, cy, cn, ck)


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def wind_load_body(p, ax, ay):
    """:func:`wind_load` from the air's velocity relative to the vessel in body axes ``ax``
    (forward), ``ay`` (starboard) [m/s] (:func:`usvid.models.environment.wind.air_relative_body`:
    the apparent wind comes from atan2(-ay, -ax), speed |a|): (X, Y, N, K), zeros for a still
    apparent wind. The loads of :func:`wind_coefficients_body` (no library call but a square
    root): the integration core's vector step calls it for every lane."""
    qx, qy, qn, qk = wind_coefficients_body(p, ax, ay)
    return _scaled(p, 1.0, qx, qy, qn, qk)


@numba.njit(cache=True)
def wind_load_true(p, speed_true, dir_true, v_north, v_east, psi):
    """:func:`wind_load` from the true wind: ``speed_true`` [m/s], ``dir_true`` [rad, from north,
    clockwise, coming from], the vessel's ground velocity ``v_north``, ``v_east`` [m/s] and
    heading ``psi`` [rad] (the wind triangle of :mod:`usvid.models.environment.wind`).
    Returns (X, Y, N, K, apparent speed, apparent angle)."""
    va, ga = true_to_apparent_scalar(speed_true, dir_true, v_north, v_east, psi)
    x, y, n, k = wind_load(p, va, ga)
    return x, y, n, k, va, ga


@numba.njit(cache=True)
def _loads_batch(p, speed, angle, out):
    for i in range(speed.shape[0]):
        x, y, n, k = wind_load(p, speed[i], angle[i])
        out[0, i] = x
        out[1, i] = y
        out[2, i] = n
        out[3, i] = k


@numba.njit(cache=True)
def _coefficients_batch(p, angle, out):
    for i in range(angle.shape[0]):
        cx, cy, cn, ck = wind_coefficients_scalar(p, angle[i])
        out[0, i] = cx
        out[1, i] = cy
        out[2, i] = cn
        out[3, i] = ck


# ---------------------------------------------------------------------------------------------
# particulars, the model and its selection
# ---------------------------------------------------------------------------------------------
def fujiwara1998_fourier(A_T: float, A_L: float, A_OD: float, C: float, C_BR: float,
                         H_BR: float, H_C: float, L_OA: float, B: float) -> dict[str, float]:
    """Fourier coefficients X0, X1, X3, X5, Y1, Y3, Y5, N1, N2, N3 of Fujiwara et al. (1998) from
    the windage particulars (areas [m^2], lengths [m]; C and C_BR positive forward of midship,
    heights above the waterline). Each is ``c_i0 + sum_j c_ij r_j`` over the regressors below."""
    L, Bm = L_OA, B
    reg = {
        "X0": (1.0, Bm * H_BR / A_T, C / H_C, A_OD / L**2),
        "X1": (1.0, A_L / (L * Bm), L * H_C / A_L, L * H_BR / A_L, A_OD / A_L, A_T / (L * Bm),
               L**2 / A_T, L / H_C),
        "X3": (1.0, A_L / (L * H_BR), A_L / A_T, L * H_C / A_L, A_OD / A_L, A_OD / L**2, C / H_C,
               C_BR / L),
        "X5": (1.0, A_L / A_OD, C_BR / L, A_L / (L * Bm)),
        "Y1": (1.0, C_BR / L, C / L, A_L / A_OD, C / H_C, A_T / (Bm * H_BR)),
        "Y3": (1.0, A_L / (L * Bm), L * H_C / A_L, C_BR / L, Bm / H_BR, A_OD / A_L,
               A_T / (Bm * H_BR)),
        "Y5": (1.0, A_L / (L * Bm), L / H_BR, C_BR / L, Bm**2 / A_T, C / L, C * H_C / A_L),
        "N1": (1.0, C / L, L * H_C / A_L, A_T / A_L, C / H_C, A_L / (L * Bm), A_T / L**2,
               Bm**2 / A_T, C_BR / L),
        "N2": (1.0, C_BR / L, C / L, A_L / A_OD, A_T / Bm**2, L / H_BR, A_T / (Bm * H_BR),
               A_L / (L * Bm), A_L / L**2),
        "N3": (1.0, C_BR / L, A_T / (Bm * H_BR), A_L / A_T),
    }
    table = {**{f"X{k}": v for k, v in FUJIWARA1998_X.items()},
             **{f"Y{k}": v for k, v in FUJIWARA1998_Y.items()},
             **{f"N{k}": v for k, v in FUJIWARA1998_N.items()}}
    return {name: float(np.dot(table[name], r)) for name, r in reg.items()}


@dataclass
class WindLoadModel:
    """A wind-load model with its particulars, ready for :func:`wind_loads` and the core.

    ``name`` ``"fujiwara1998"`` or ``"blendermann1994"``; ``reason`` why it was chosen;
    ``particulars`` the values used (SI, by the names of :data:`WINDAGE_EXTRA` and Vessel);
    ``coefficients`` the model's own (Fourier coefficients, or Blendermann's table row);
    ``assumed`` the defaults taken for what was not given; ``air_density`` [kg/m^3];
    ``wind_scale`` [-].
    """

    name: str
    reason: str
    particulars: dict[str, float]
    coefficients: dict[str, float]
    air_density: float = AIR_DENSITY
    wind_scale: float = 1.0
    assumed: list[str] = field(default_factory=list)

    def packed(self, wind_scale: float | None = None) -> np.ndarray:
        """The float64 vector of :data:`WIND_PACK` entries :func:`wind_load` reads; ``wind_scale``
        overrides the model's own (the multiplier sits in ``p[1]``, so a fit can set it there)."""
        pt, c = self.particulars, self.coefficients
        q = 0.5 * self.air_density
        A_T, A_L, L = pt["frontal_area"], pt["lateral_area"], pt["length_overall"]
        p = np.zeros(WIND_PACK)
        p[0] = MODELS[self.name]
        p[1] = self.wind_scale if wind_scale is None else float(wind_scale)
        p[2:6] = (q * A_T, q * A_L, q * A_L * L, q * A_L * (A_L / L))
        if self.name == "fujiwara1998":
            p[6:16] = [c[k] for k in ("X0", "X1", "X3", "X5", "Y1", "Y3", "Y5", "N1", "N2", "N3")]
        else:
            H_M = A_L / L
            p[6:14] = (c["C_Dt"], c["C_Dl_AF_bow"], c["C_Dl_AF_stern"], c["delta"], c["kappa"],
                       A_T / A_L, pt["lateral_centroid_x"] / L,
                       pt["lateral_centroid_height"] / H_M)
        return p

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (model, reason, particulars, coefficients, assumptions)."""
        return {"model": self.name, "reason": self.reason, "air_density": self.air_density,
                "wind_scale": self.wind_scale, "particulars": dict(self.particulars),
                "coefficients": dict(self.coefficients), "assumed": list(self.assumed)}


def _positive(where: str, name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsvidError(f"{where}: {name} must be a number (got {value!r})") from None
    if not (math.isfinite(v) and v > 0):
        raise UsvidError(f"{where}: {name} must be > 0 (got {value!r})")
    return v


def _finite(where: str, name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsvidError(f"{where}: {name} must be a number (got {value!r})") from None
    if not math.isfinite(v):
        raise UsvidError(f"{where}: {name} must be finite (got {value!r})")
    return v


def windage(vessel: Vessel) -> dict[str, float]:
    """The windage particulars a vessel carries: ``frontal_area``, ``lateral_area``,
    ``length_overall`` (``extra.length_overall``, else ``length``), ``beam`` and the
    :data:`WINDAGE_EXTRA` keys found in ``vessel.extra``; absent ones are left out."""
    ex = dict(vessel.extra or {})
    out: dict[str, float] = {}
    for k in ("frontal_area", "lateral_area", "beam"):
        if getattr(vessel, k, None) is not None:
            out[k] = float(getattr(vessel, k))
    L = ex.get("length_overall", vessel.length)
    if L is not None:
        out["length_overall"] = float(L)
    for k in WINDAGE_EXTRA:
        if k in ex and k != "length_overall":
            out[k] = float(ex[k])
    return out


def wind_load_model(vessel: Vessel, *, model: str = "auto",
                    vessel_type: str = "speed_boat", air_density: float | None = None,
                    wind_scale: float | None = None) -> WindLoadModel:
    """Choose and set up the wind-load model for ``vessel`` (see the module docstring).

    ``model="auto"``: Fujiwara et al. (1998) when every particular it needs is given
    (:data:`FUJIWARA_NEEDS`: A_T, A_L in ``vessel.frontal_area``/``lateral_area``, B in
    ``vessel.beam``, L_OA, A_OD, C, C_BR, H_BR, H_C in ``vessel.extra``, see
    :data:`WINDAGE_EXTRA`), because it resolves the superstructure's size and position; else
    Blendermann (1994) for ``vessel_type`` (a key of :data:`BLENDERMANN_TYPES`), which needs only
    A_T, A_L and L_OA. ``model="fujiwara1998"`` or ``"blendermann1994"`` forces one (and fails
    naming what is missing). ``air_density`` [kg/m^3] and ``wind_scale`` [-] default to
    ``vessel.extra`` values, else 1.225 and 1. Raises :class:`UsvidError` naming the missing or
    bad particular.
    """
    where = "wind loads"
    pt = windage(vessel)
    ex = dict(vessel.extra or {})
    rho = air_density if air_density is not None else ex.get("air_density", AIR_DENSITY)
    rho = _positive(where, "air_density", rho)
    scale = wind_scale if wind_scale is not None else ex.get("wind_scale", 1.0)
    scale = _finite(where, "wind_scale", scale)
    if scale < 0:
        raise UsvidError(f"{where}: wind_scale must be >= 0 (got {scale!r})")
    if model not in ("auto", *MODELS):
        raise UsvidError(f"{where}: model must be 'auto', 'fujiwara1998' or 'blendermann1994' "
                         f"(got {model!r})")
    basic = ("frontal_area", "lateral_area", "length_overall")
    missing_basic = [k for k in basic if k not in pt]
    if missing_basic:
        names = {"frontal_area": "vessel.frontal_area (A_T) [m^2]",
                 "lateral_area": "vessel.lateral_area (A_L) [m^2]",
                 "length_overall": "vessel.length or vessel.extra.length_overall [m]"}
        raise UsvidError(f"{where} need the windage areas and the length: give "
                         + ", ".join(names[k] for k in missing_basic))
    for k in basic:
        pt[k] = _positive(where, k, pt[k])
    missing_f = [k for k in FUJIWARA_NEEDS if k not in pt]
    if model == "fujiwara1998" and missing_f:
        raise UsvidError(f"{where}: Fujiwara et al. (1998) needs "
                         + ", ".join(("vessel." if k == "beam" else "vessel.extra.") + k
                                     for k in missing_f))
    if model == "fujiwara1998" or (model == "auto" and not missing_f):
        for k in ("superstructure_area", "superstructure_height", "lateral_centroid_height",
                  "beam"):
            pt[k] = _positive(where, k, pt[k])
        for k in ("lateral_centroid_x", "superstructure_x"):
            pt[k] = _finite(where, k, pt[k])
        coef = fujiwara1998_fourier(pt["frontal_area"], pt["lateral_area"],
                                    pt["superstructure_area"], pt["lateral_centroid_x"],
                                    pt["superstructure_x"], pt["superstructure_height"],
                                    pt["lateral_centroid_height"], pt["length_overall"],
                                    pt["beam"])
        reason = ("forced" if model == "fujiwara1998" else
                  "every particular of Fujiwara et al. (1998) is given")
        keep = {k: pt[k] for k in (*basic, *FUJIWARA_NEEDS)}
        return WindLoadModel("fujiwara1998", reason, keep, coef, rho, scale)
    if vessel_type not in BLENDERMANN_TYPES:
        raise UsvidError(f"{where}: vessel_type must be one of {', '.join(BLENDERMANN_TYPES)} "
                         f"(got {vessel_type!r})")
    assumed: list[str] = []
    H_M = pt["lateral_area"] / pt["length_overall"]
    if "lateral_centroid_x" in pt:
        pt["lateral_centroid_x"] = _finite(where, "lateral_centroid_x", pt["lateral_centroid_x"])
    else:
        pt["lateral_centroid_x"] = 0.0
        assumed.append("lateral_centroid_x = 0 m (centroid of A_L at midship)")
    if "lateral_centroid_height" in pt:
        pt["lateral_centroid_height"] = _positive(where, "lateral_centroid_height",
                                                  pt["lateral_centroid_height"])
    else:
        pt["lateral_centroid_height"] = 0.5 * H_M
        assumed.append(f"lateral_centroid_height = A_L / (2 L_OA) = {0.5 * H_M:.4g} m")
    row = BLENDERMANN_TYPES[vessel_type]
    coef = dict(zip(("C_Dt", "C_Dl_AF_bow", "C_Dl_AF_stern", "delta", "kappa"), row,
                    strict=True))
    if model == "blendermann1994":
        reason = f"forced (vessel type {vessel_type})"
    else:
        reason = (f"Fujiwara et al. (1998) needs {', '.join(missing_f)}; Blendermann (1994) needs "
                  f"only A_T, A_L and L_OA (vessel type {vessel_type})")
    keep = {k: pt[k] for k in (*basic, "lateral_centroid_x", "lateral_centroid_height")}
    return WindLoadModel("blendermann1994", reason, keep, coef, rho, scale, assumed)


# ---------------------------------------------------------------------------------------------
# array API
# ---------------------------------------------------------------------------------------------
@dataclass
class WindLoads:
    """Wind loads of :func:`wind_loads` (arrays of the broadcast input shape): X, Y [N, body
    forward, starboard], N [N m, bow to starboard], K [N m, heel to starboard]."""

    X: np.ndarray
    Y: np.ndarray
    N: np.ndarray
    K: np.ndarray


def _pack_of(model: WindLoadModel | np.ndarray) -> np.ndarray:
    if isinstance(model, WindLoadModel):
        return model.packed()
    p = np.ascontiguousarray(model, dtype=float)
    if p.shape != (WIND_PACK,):
        raise UsvidError(f"wind loads: a packed model has {WIND_PACK} entries (got shape "
                         f"{p.shape})")
    return p


def wind_loads(model: WindLoadModel | np.ndarray, speed: Any, angle: Any) -> WindLoads:
    """Wind loads for apparent wind ``speed`` [m/s] and ``angle`` [rad, from the bow, clockwise,
    coming from] (arrays broadcast; a batch axis first stays first). ``model`` a
    :class:`WindLoadModel` or its packed vector. Same code as :func:`wind_load`."""
    p = _pack_of(model)
    s, a = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(angle, dtype=float))
    out = np.empty((4, s.size))
    _loads_batch(p, np.ascontiguousarray(s).ravel(), np.ascontiguousarray(a).ravel(), out)
    X, Y, N, K = (out[i].reshape(s.shape) for i in range(4))
    return WindLoads(X, Y, N, K)


def wind_coefficients(model: WindLoadModel | np.ndarray, angle: Any
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(C_X, C_Y, C_N, C_K) at the apparent wind angle ``angle`` [rad, from the bow, clockwise,
    coming from], in the sign convention of the loads (module docstring)."""
    p = _pack_of(model)
    a = np.asarray(angle, dtype=float)
    out = np.empty((4, a.size))
    _coefficients_batch(p, np.ascontiguousarray(a).ravel(), out)
    cx, cy, cn, ck = (out[i].reshape(a.shape) for i in range(4))
    return cx, cy, cn, ck


# ---------------------------------------------------------------------------------------------
# response kinds: the yaw moment as a rudder angle
# ---------------------------------------------------------------------------------------------
@dataclass
class RudderEquivalent:
    r"""Conversion of a yaw moment into a rudder angle for a response kind:
    ``delta_eq = gain * N`` [rad] for a moment N [N m].

    ``N_delta`` [N m/rad] the rudder's yaw moment per radian, ``m66`` [kg m^2] the yaw inertia
    with the added inertia, ``T_eff`` [s] the kind's effective time constant, ``assumed`` the
    defaults taken.
    """

    gain: float
    N_delta: float
    m66: float
    T_eff: float
    assumed: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"gain_rad_per_N_m": self.gain, "N_delta_N_m_per_rad": self.N_delta,
                "m66_kg_m2": self.m66, "T_eff_s": self.T_eff, "assumed": list(self.assumed)}


def yaw_inertia(vessel: Vessel, *, rho: float = 1025.0) -> tuple[float, list[str]]:
    """Yaw moment of inertia with the added inertia, ``m66 = I_z + J_z`` [kg m^2], and the
    assumptions made.

    ``I_z``: ``vessel.extra.yaw_inertia`` [kg m^2], else ``m (0.25 L)^2`` (radius of gyration a
    quarter of the length, the rule of :func:`usvid.models.mmg.priors`). ``J_z``: the added yaw
    inertia of Zhou et al.'s regression of Motora's charts
    (:func:`usvid.models.hull.zhou_added_mass`, as :func:`usvid.models.mmg.priors` uses it) when
    length, beam, draft and mass are known; else ``J_z = I_z`` (an assumption: for ships the
    regressions give J_z / I_z of about 0.5-1.5). The mass is ``vessel.mass`` [kg], else ``rho *
    vessel.displacement`` [m^3]. Raises :class:`UsvidError` when neither mass nor yaw inertia is
    given.
    """
    ex = dict(vessel.extra or {})
    assumed: list[str] = []
    L = vessel.length
    m = vessel.mass
    if m is None and vessel.displacement is not None:
        m = rho * float(vessel.displacement)
        assumed.append(f"mass = rho * displacement = {m:.4g} kg")
    Iz = ex.get("yaw_inertia")
    if Iz is None:
        if m is None or L is None:
            raise UsvidError("the rudder-equivalent wind moment needs the vessel's yaw inertia: "
                             "give vessel.yaw_inertia [kg m^2], or vessel.mass [kg] and "
                             "vessel.length [m]")
        Iz = m * (0.25 * L) ** 2
        assumed.append(f"yaw_inertia = m (0.25 L)^2 = {Iz:.4g} kg m^2")
    Iz = _positive("yaw inertia", "yaw_inertia", Iz)
    B, d = vessel.beam, vessel.draft
    if None not in (L, B, d, m):
        Cb = vessel.block_coefficient or m / (rho * L * B * d)
        Jz = float(zhou_added_mass(L, B, d, Cb, m).J_zz)
    else:
        Jz = Iz
        assumed.append("added yaw inertia J_z = I_z (length, beam, draft or mass unknown)")
    return float(Iz + Jz), assumed


#: Effective first-order time constant of each response kind from its parameters.
_T_EFF = {
    "nomoto1": lambda p: p["T"],
    "norrbin": lambda p: p["T"],
    "nomoto2": lambda p: p["T1"] + p["T2"] - p["T3"],
}


def rudder_equivalent(kind: str, params: Mapping[str, Any], vessel: Vessel, *,
                      rho: float = 1025.0) -> RudderEquivalent:
    r"""How a yaw moment N [N m] enters a response kind (Nomoto, Norrbin) as a rudder angle.

    The yaw equation of a vessel at constant speed, linear in r and delta, is
    :math:`m_{66} \dot r = N_r r + N_\delta \delta + N_{ext}` with :math:`m_{66} = I_z + J_z`
    (rigid and added yaw inertia). Divided by :math:`-N_r` it is Nomoto's first-order model
    :math:`T \dot r + r = K (\delta + N_{ext}/N_\delta)` with :math:`T = m_{66}/(-N_r)` and
    :math:`K = N_\delta/(-N_r)` (Nomoto et al. 1957; Fossen 2021, ch. 7.1), so

    .. math::

        N_\delta = \frac{K\,m_{66}}{T}, \qquad \delta_{eq} = \frac{N_{ext}}{N_\delta}
        = \frac{T}{K\,m_{66}}\,N_{ext}.

    Norrbin's model has the same inertia term (``T r' + n1 r + n3 r^3 = K delta``, the cubic
    replaces N_r r), so the same conversion holds. For the second-order Nomoto model the
    first-order equivalent :math:`T = T_1 + T_2 - T_3` is used (the low-frequency
    approximation, Nomoto et al. 1957). Assumed: the external moment acts like the rudder's
    (same dynamics, no sway coupling: a response kind has no sway, so the wind's side force is
    not represented), speed constant, and ``m66`` from :func:`yaw_inertia` (its assumptions are
    listed). ``kind`` ``"nomoto1"``, ``"norrbin"`` or ``"nomoto2"``; ``params`` the kind's SI
    parameters (K [1/s], T [s], ...).
    """
    if kind not in _T_EFF:
        raise UsvidError(f"rudder equivalent: kind {kind!r} is not a response kind "
                         f"({', '.join(_T_EFF)}); force kinds take the wind loads directly")
    try:
        T_eff = float(_T_EFF[kind](params))
        K = float(params["K"])
    except KeyError as exc:
        raise UsvidError(f"rudder equivalent: {kind} parameters lack {exc.args[0]}") from None
    if not (math.isfinite(K) and K != 0.0):
        raise UsvidError(f"rudder equivalent: K must be finite and non-zero (got {K!r})")
    if not (math.isfinite(T_eff) and T_eff > 0.0):
        raise UsvidError(f"rudder equivalent: the effective time constant must be > 0 s "
                         f"(got {T_eff!r})")
    m66, assumed = yaw_inertia(vessel, rho=rho)
    N_delta = K * m66 / T_eff
    return RudderEquivalent(gain=1.0 / N_delta, N_delta=N_delta, m66=m66, T_eff=T_eff,
                            assumed=assumed)
