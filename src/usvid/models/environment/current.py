r"""Ocean current: the water-relative velocity the hydrodynamics see (Fossen 2021, ch. 10.3).

Conventions: a current is its speed :math:`V_c` [m/s] and the direction :math:`\beta_c` it flows
TOWARDS [rad, from north, clockwise] (the oceanographic convention, the Trial contract), uniform
in space, constant or slowly varying in time (any argument may be an array over time or a
batch). Body frame x forward, y starboard; heading :math:`\psi` [rad, NED, clockwise].

Fossen (2021), ch. 10.3 (irrotational current in the horizontal plane):

.. math::

    v_c^n = V_c (\cos\beta_c, \sin\beta_c), \qquad
    u_c = V_c \cos(\beta_c - \psi), \quad v_c = V_c \sin(\beta_c - \psi),

    \nu_r = \nu - \nu_c = (u - u_c,\ v - v_c,\ r),

where :math:`\nu = (u, v, r)` is the velocity over ground in the body frame. The hydrodynamic
(and propeller, rudder) forces see :math:`\nu_r`; the kinematics integrate the velocity over
ground :math:`\dot\eta = R(\psi)\,\nu = R(\psi)\,\nu_r + v_c^n`. A vessel whose model is written
in :math:`\nu_r` therefore moves on its calm-water track drifted by :math:`v_c^n t` when the
current is uniform and constant: that is why the drift of positions 360 deg of heading apart
measures the current (:mod:`usvid.manoeuvres.drift`).

The scalar functions are numba-compiled for the integration core; the array versions call the
same code.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort


@numba.njit(cache=True)
def current_body(speed, direction, psi):
    """Current velocity in the body frame (u_c, v_c) [m/s] from its ``speed`` [m/s], the
    ``direction`` it flows towards [rad, from north, clockwise] and the heading ``psi`` [rad]."""
    a = direction - psi
    return speed * math.cos(a), speed * math.sin(a)


@numba.njit(cache=True)
def water_relative_scalar(u, v, speed, direction, psi):
    """Water-relative body velocity (u_r, v_r) [m/s] = (u - u_c, v - v_c) from the velocity over
    ground in the body frame ``u``, ``v`` [m/s] and the current (see :func:`current_body`)."""
    uc, vc = current_body(speed, direction, psi)
    return u - uc, v - vc


@numba.njit(cache=True)
def ground_velocity_scalar(u_r, v_r, speed, direction, psi):
    """Velocity over ground (v_north, v_east) [m/s, NED] of a vessel moving with the
    water-relative body velocity ``u_r``, ``v_r`` [m/s] in the current: R(psi) nu_r + v_c^n."""
    c, s = math.cos(psi), math.sin(psi)
    return (c * u_r - s * v_r + speed * math.cos(direction),
            s * u_r + c * v_r + speed * math.sin(direction))


@numba.njit(cache=True)
def _relative_batch(u, v, speed, direction, psi, out):
    for i in range(u.shape[0]):
        a, b = water_relative_scalar(u[i], v[i], speed[i], direction[i], psi[i])
        out[0, i] = a
        out[1, i] = b


@numba.njit(cache=True)
def _ground_batch(u, v, speed, direction, psi, out):
    for i in range(u.shape[0]):
        a, b = ground_velocity_scalar(u[i], v[i], speed[i], direction[i], psi[i])
        out[0, i] = a
        out[1, i] = b


def _apply(kernel, *args: Any) -> tuple[np.ndarray, np.ndarray]:
    arrs = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    shape = arrs[0].shape
    flat = [np.ascontiguousarray(a).ravel() for a in arrs]
    out = np.empty((2, flat[0].size))
    kernel(*flat, out)
    return out[0].reshape(shape), out[1].reshape(shape)


def current_ned(speed: Any, direction: Any) -> tuple[np.ndarray, np.ndarray]:
    """Current velocity over ground (v_north, v_east) [m/s] from its ``speed`` [m/s] and the
    ``direction`` it flows towards [rad, from north, clockwise]."""
    s, d = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(direction, dtype=float))
    return s * np.cos(d), s * np.sin(d)


def water_relative_velocity(u: Any, v: Any, psi: Any, speed: Any, direction: Any
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Water-relative body velocity (u_r, v_r) [m/s] from the body velocity over ground ``u``,
    ``v`` [m/s], the heading ``psi`` [rad] and the current ``speed`` [m/s], ``direction`` [rad,
    towards, from north, clockwise]; arrays broadcast (batch axis first stays first). Same code
    as :func:`water_relative_scalar`."""
    return _apply(_relative_batch, u, v, speed, direction, psi)


def ground_velocity(u_r: Any, v_r: Any, psi: Any, speed: Any, direction: Any
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Velocity over ground (v_north, v_east) [m/s] of a vessel with the water-relative body
    velocity ``u_r``, ``v_r`` [m/s] at heading ``psi`` [rad] in the current ``speed`` [m/s],
    ``direction`` [rad, towards]; same code as :func:`ground_velocity_scalar`."""
    return _apply(_ground_batch, u_r, v_r, speed, direction, psi)
