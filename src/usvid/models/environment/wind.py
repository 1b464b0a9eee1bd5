r"""The wind triangle: apparent wind <-> true wind, given the vessel's ground velocity and heading.

Conventions (the Trial contract, NED earth frame, body x forward, y starboard):

* true wind: speed :math:`V_T` [m/s] and direction :math:`\beta_T` [rad, from north, clockwise,
  the direction the wind comes FROM, as NMEA 0183 MWD], result in [0, 2 pi);
* apparent wind (what an anemometer on board measures): speed :math:`V_A` [m/s] and angle
  :math:`\gamma_A` [rad, from the bow, clockwise, the direction it comes FROM, as NMEA 0183 MWV
  with reference "R"], result in (-pi, pi] (positive: from starboard);
* the vessel's velocity over ground :math:`(v_N, v_E)` [m/s] and heading :math:`\psi` [rad].

A wind coming from :math:`\beta` with speed :math:`V` moves the air with the earth-frame velocity
:math:`w = -V (\cos\beta, \sin\beta)`. The air relative to the vessel moves with :math:`a = w - v`
(Fossen 2021, ch. 10.1, eq. 10.4: :math:`u_{rw} = u - u_w`, written here for the air instead of
the vessel), so

.. math::

    V_A = |a|, \qquad \gamma_A = \operatorname{atan2}(-a_E, -a_N) - \psi,

and the inverse adds the vessel's velocity back: :math:`w = a + v`. The true wind here is the wind
over ground (the vessel's velocity over ground is used); with the velocity through the water the
same formulas give the wind over the water surface. When a speed is zero its direction is
undefined and returned as 0.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort

TWO_PI = 2.0 * np.pi


def _wrap_pi(a: np.ndarray) -> np.ndarray:
    """Angle [rad] wrapped into (-pi, pi]."""
    w = np.remainder(a + np.pi, TWO_PI) - np.pi
    return np.where(w == -np.pi, np.pi, w)


def _air_relative(vt, bt, vn, ve):
    """Air velocity relative to the vessel ``a = w - v`` [m/s, NED] from the true wind (speed
    ``vt``, direction ``bt`` it comes from) and the vessel's ground velocity. The one place of the
    formula: numpy calls it on arrays, :func:`true_to_apparent_scalar` on floats (numba)."""
    return -vt * np.cos(bt) - vn, -vt * np.sin(bt) - ve


_air_relative_jit = numba.njit(cache=True)(_air_relative)


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def air_relative_body(w_north, w_east, v_north, v_east, cpsi, spsi):
    r"""The air's velocity relative to the vessel in body axes (forward, starboard) [m/s] from
    the air's velocity over ground ``w_north``, ``w_east`` [m/s] (a wind from beta moves the air
    towards beta + pi), the vessel's ground velocity ``v_north``, ``v_east`` [m/s] and the cosine
    and sine of its heading: :math:`a = R(\psi)^T (w - v)`. The apparent wind comes from
    :math:`\gamma_A = \operatorname{atan2}(-a_y, -a_x)` off the bow, clockwise, with speed
    :math:`|a|` (no library call: the integration core's vector step calls it)."""
    a_n = w_north - v_north
    a_e = w_east - v_east
    return a_n * cpsi + a_e * spsi, a_e * cpsi - a_n * spsi


@numba.njit(cache=True)
def true_to_apparent_scalar(speed_true, dir_true, v_north, v_east, psi):
    """:func:`true_to_apparent` for one sample (numba, for the integration core): floats in,
    ``(speed [m/s], angle [rad, from the bow, clockwise, where it comes from, in (-pi, pi]])``
    out, the angle 0 when the apparent speed is 0."""
    a_n, a_e = _air_relative_jit(speed_true, dir_true, v_north, v_east)
    speed = math.hypot(a_n, a_e)
    if speed == 0.0:
        return 0.0, 0.0
    w = (math.atan2(-a_e, -a_n) - psi + math.pi) % TWO_PI - math.pi
    return speed, (math.pi if w == -math.pi else w)


def true_to_apparent(speed_true, dir_true, v_north, v_east, psi):
    """Apparent wind from the true wind and the vessel's ground velocity and heading.

    Parameters
    ----------
    speed_true : float or array
        True wind speed [m/s].
    dir_true : float or array
        True wind direction [rad, from north, clockwise, where the wind comes from].
    v_north, v_east : float or array
        Vessel velocity over ground [m/s, NED].
    psi : float or array
        Vessel heading [rad, from north, clockwise].

    Returns
    -------
    (speed, angle) : arrays
        Apparent wind speed [m/s] and angle [rad, from the bow, clockwise, where it comes from,
        in (-pi, pi]]. Arguments broadcast.
    """
    a_n, a_e = _air_relative(np.asarray(speed_true, dtype=float),
                             np.asarray(dir_true, dtype=float),
                             np.asarray(v_north, dtype=float), np.asarray(v_east, dtype=float))
    speed = np.hypot(a_n, a_e)
    angle = _wrap_pi(np.arctan2(-a_e, -a_n) - np.asarray(psi, dtype=float))
    return speed, np.where(speed > 0.0, angle, 0.0)


def apparent_to_true(speed, angle, v_north, v_east, psi):
    """True wind from the apparent wind and the vessel's ground velocity and heading.

    Parameters
    ----------
    speed : float or array
        Apparent wind speed [m/s].
    angle : float or array
        Apparent wind angle [rad, from the bow, clockwise, where the wind comes from].
    v_north, v_east : float or array
        Vessel velocity over ground [m/s, NED].
    psi : float or array
        Vessel heading [rad, from north, clockwise].

    Returns
    -------
    (speed_true, dir_true) : arrays
        True wind speed [m/s] and direction [rad, from north, clockwise, where it comes from, in
        [0, 2 pi)]. Arguments broadcast.
    """
    va = np.asarray(speed, dtype=float)
    gam = np.asarray(angle, dtype=float) + np.asarray(psi, dtype=float)
    w_n = -va * np.cos(gam) + np.asarray(v_north, dtype=float)
    w_e = -va * np.sin(gam) + np.asarray(v_east, dtype=float)
    vt = np.hypot(w_n, w_e)
    bt = np.remainder(np.arctan2(-w_e, -w_n), TWO_PI)
    return vt, np.where(vt > 0.0, bt, 0.0)
