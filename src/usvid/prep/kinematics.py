"""Body-frame velocities from positions or from course/speed over ground, and heading.

NED earth frame (x north, y east), body frame (x forward, y starboard), psi clockwise positive
(ARCHITECTURE.md). The rotation is the planar part of Fossen's R(psi) (Mu et al. 2018, eq. 13
kinematics eta' = R(psi) nu read for 3 DOF):

    x' = u cos psi - v sin psi,   y' = u sin psi + v cos psi
    u  = x' cos psi + y' sin psi, v  = -x' sin psi + y' cos psi
"""

from __future__ import annotations

import numpy as np

from usvid.prep.filters import savgol_derivative


def earth_to_body(
    xdot: np.ndarray, ydot: np.ndarray, psi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Body velocities ``(u, v)`` [m/s] from earth velocities (north, east) [m/s], psi [rad]."""
    c, s = np.cos(psi), np.sin(psi)
    return xdot * c + ydot * s, -xdot * s + ydot * c


def body_to_earth(u: np.ndarray, v: np.ndarray, psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Earth velocities ``(x', y')`` [m/s, north, east] from body ``u, v`` [m/s], psi [rad]."""
    c, s = np.cos(psi), np.sin(psi)
    return u * c - v * s, u * s + v * c


def body_velocity_from_positions(
    x: np.ndarray, y: np.ndarray, psi: np.ndarray, dt: float, window_s: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(u, v)`` [m/s] from uniform-grid positions x, y [m] (step ``dt`` [s]) and heading [rad].

    d(x, y)/dt by a zero-phase Savitzky-Golay derivative over ``window_s`` [s], then rotated into
    the body frame (module docstring). The velocity is that of the position reference point.
    """
    xd = savgol_derivative(x, dt, window_s)
    yd = savgol_derivative(y, dt, window_s)
    return earth_to_body(xd, yd, psi)


def body_velocity_from_cog(
    sog: np.ndarray, cog: np.ndarray, psi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(u, v)`` [m/s] from speed over ground [m/s], course over ground [rad] and heading [rad].

    u = SOG cos(COG - psi), v = SOG sin(COG - psi) (the drift angle is COG - psi).
    """
    beta = np.asarray(cog, dtype=float) - np.asarray(psi, dtype=float)
    return sog * np.cos(beta), sog * np.sin(beta)
