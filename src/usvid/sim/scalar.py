"""Scalar numba helpers of the integration core, shared by its per-lane and vector paths and
its chunk driver: the noise generator, clipping, angle rotation, the dead-time queue and the
ideal servo's ramp. None of them reads the chunk layout (:mod:`usvid.sim.layout`), so they are
compiled and cached once for every kind.
"""

from __future__ import annotations

import math

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort

#: fast-math flags: FMA contraction and reassociation, NaN/inf semantics kept (np.isnan; but
#: not ``np.isfinite``, see :func:`_fin`)
_FM = {"nsz", "arcp", "contract", "afn", "reassoc"}

#: The largest finite float64: ``abs(x) <= FMAX`` is False for NaN and +-inf (:func:`_fin`).
FMAX = 1.7976931348623157e308


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, forceinline=True)
def _fin(x: float) -> bool:
    """x is finite (not NaN, not +-inf), also in a function compiled with the fast-math flags
    :data:`_FM`: an ordered comparison of |x| with the largest float, False for NaN and inf.

    numba's ``np.isfinite`` and ``math.isfinite`` test whether ``x - x`` is ordered, and with
    ``reassoc`` and ``nsz`` LLVM folds ``x - x`` of a computed x to 0.0: a NaN tested
    finite. In the vector step a lane whose heading base was NaN (the heading had moved more
    than 0.05 rad over the previous step) then got x, y NaN without being flagged for the
    per-lane step, and kept them: a zig-zag of a USV turning at 0.06-0.12 rad a step came out
    with NaN tracks on the vectorised path alone. A comparison is not folded without ``nnan``
    and ``ninf``, which :data:`_FM` leaves out."""
    return abs(x) <= FMAX


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _splitmix(state: np.uint64) -> tuple[np.uint64, np.uint64]:
    state = state + np.uint64(0x9E3779B97F4A7C15)
    z = state
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return state, z


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _normal(state: np.uint64) -> tuple[np.uint64, float]:
    """One standard normal by Box-Muller from two splitmix64 uniforms."""
    state, a = _splitmix(state)
    state, b = _splitmix(state)
    u1 = ((a >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = (b >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return state, math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _clip(x: float, lim: float) -> float:
    if x > lim:
        return lim
    if x < -lim:
        return -lim
    return x


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _rot(a: float, a0: float, c0: float, s0: float) -> tuple[float, float]:
    """(cos a, sin a) from (c0, s0) = (cos a0, sin a0): for |a - a0| <= 0.05 rad by the
    angle-sum formula with the Taylor series of cos h, sin h to h^7 (error < 1e-16 there),
    else the library functions (a lane's code is scalar: the branch is predictable)."""
    h = a - a0
    if abs(h) > 0.05:
        return math.cos(a), math.sin(a)
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    return c0 * ch - s0 * sh, s0 * ch + c0 * sh


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, forceinline=True)
def _rot_nan(a: float, a0: float, c0: float, s0: float) -> tuple[float, float]:
    """:func:`_rot` without the library branch, for the vectorised step: (NaN, NaN) where
    |a - a0| > 0.05 rad (that lane's step is then integrated again by :func:`_rot`)."""
    h = a - a0
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    bad = np.nan if abs(h) > 0.05 else 0.0  # (added, not selected: with a select of the
    # results LLVM loads c0, s0 only where they are used, masked)
    return (c0 * ch - s0 * sh) + bad, (s0 * ch + c0 * sh) + bad


@numba.njit(cache=True, error_model="numpy", fastmath=_FM, forceinline=True)
def _rotv(a: float, a0: float, c0: float, s0: float) -> tuple[float, float, float]:
    """:func:`_rot` without the library branch, for the vector step: (cos a, sin a, |a - a0|);
    the caller flags the lane when |a - a0| > 0.05 rad (the series is then not accurate)."""
    h = a - a0
    h2 = h * h
    ch = 1.0 - h2 * (0.5 - h2 * (1.0 / 24.0 - h2 * (1.0 / 720.0)))
    sh = h * (1.0 - h2 * (1.0 / 6.0 - h2 * (1.0 / 120.0 - h2 * (1.0 / 5040.0))))
    return c0 * ch - s0 * sh, s0 * ch + c0 * sh, abs(h)


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _push(qt, qv, b, head, n, tr, value):
    """Queue a command taking effect at time tr in lane b's dead-time ring buffer (rows
    ``qt[b]``, ``qv[b]``); returns the new (head, n). A newer command due at the same time
    replaces the older one."""
    cap = qt.shape[1]
    if n > 0:
        last = (head + n - 1) % cap
        if qt[b, last] == tr:
            qv[b, last] = value
            return head, n
    if n == cap:  # full (the driver sizes the buffer so that this cannot happen)
        head = (head + 1) % cap
        n -= 1
    slot = (head + n) % cap
    qt[b, slot] = tr
    qv[b, slot] = value
    return head, n + 1


@numba.njit(cache=True, error_model="numpy", fastmath=_FM)
def _start_ramp(t, target, d, rate):
    """An ideal servo at angle d [rad] gets a new target at time t: (angle now, ramp rate
    [rad/s], ramp end time [s]) -- a jump without a rate limit."""
    gap = target - d
    if gap == 0.0:
        return d, 0.0, math.inf
    if math.isinf(rate):
        return target, 0.0, math.inf
    return d, (rate if gap > 0.0 else -rate), t + abs(gap) / rate
