"""The yaw response of any model kind linearised about straight running, its Nomoto
equivalent, and the gain and phase margins of a PID heading loop.

Linearisation: the kind's own right-hand side (the equations the simulator integrates) is
differentiated by central differences about straight running at the approach speed U
(``r = v = 0``, ``delta = 0``, surge ``u = U``): ``x' = A x + b delta``, ``r = c x`` over the
kind's states. Its yaw-rate transfer function ``G(s) = c (sI - A)^-1 b`` has the low-frequency
expansion ``G(s) = K (1 - T s + ...)`` with

    K = -c A^-1 b   [1/s],      T = -G'(0) / K = c A^-2 b / K   [s]

which for Nomoto's second-order model ``K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))`` is the
classical first-order equivalent ``T = T1 + T2 - T3`` (Nomoto et al. 1957; Fossen 2011,
Sec. 7.2) and for the 3-DOF model the closed form of Mu et al. 2018, eq. 29-33
(:func:`usvid.models.response_params.threedof_response`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.registry import kind_of
from usvid.sim.simulate import approach_speed


@dataclass(frozen=True)
class NomotoEquivalent:
    """``m r' + d r = delta`` with m = T/K [s^2], d = 1/K [s] (Fossen 2021, Sec. 15.3): the
    first-order Nomoto form ``T r' + r = K delta`` (K [1/s], T [s]; T < 0 or K d < 0: course
    unstable) of a model, with the full linear response ``num/den`` (r/delta, highest power
    first) it was reduced from. Arrays of shape (B,) for a batch of parameter sets."""

    K: np.ndarray
    T: np.ndarray
    num: list[np.ndarray]
    den: list[np.ndarray]

    @property
    def m(self) -> np.ndarray:
        """Yaw inertia per unit rudder moment m = T / K [s^2]."""
        return self.T / self.K

    @property
    def d(self) -> np.ndarray:
        """Yaw damping per unit rudder moment d = 1 / K [s]."""
        return 1.0 / self.K


def _state_space(model: Any, u0: Any = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A (B, n, n), b (B, n), c (n,)) of the kind's states about straight running."""
    dyn = model.dynamics
    kind = kind_of(dyn)
    U = approach_speed(model, u0)
    x0 = np.asarray(kind.initial(dyn, {"u": U, "v": 0.0, "r": 0.0}), dtype=float)  # (n, B)
    n = kind.n_states
    B = max(x0.shape[1], int(np.size(U)), *(np.size(v) for v in dyn.values().values()
                                             if v is not None and not hasattr(v, "kind")))
    x0 = np.broadcast_to(x0, (n, B)).T.copy()  # (B, n)

    def f(x: np.ndarray, delta: float) -> np.ndarray:
        return kind.derivatives(dyn, x, delta=delta, speed=U)[3]

    A = np.empty((B, n, n))
    for j in range(n):
        h = 1e-6 * max(1.0, float(np.max(np.abs(x0[:, j]))))
        xp, xm = x0.copy(), x0.copy()
        xp[:, j] += h
        xm[:, j] -= h
        A[:, :, j] = (f(xp, 0.0) - f(xm, 0.0)) / (2 * h)
    hd = 1e-6
    b = (f(x0, hd) - f(x0, -hd)) / (2 * hd)
    c = np.zeros(n)
    c[kind.body[2]] = 1.0
    return A, b, c


def nomoto_equivalent(model: Any, u0: Any = None) -> NomotoEquivalent:
    """The first-order Nomoto equivalent (K [1/s], T [s]) of ``model`` (a :class:`VesselModel`
    of any kind; parameters may be (B,) arrays) at the approach speed ``u0`` [m/s] (default
    ``vessel.speed``): ``K = -c A^-1 b``, ``T = c A^-2 b / K`` of the linearisation (module
    docstring). Raises :class:`UsvidError` when the steering has no yaw effect (K = 0)."""
    A, b, c = _state_space(model, u0)
    Ainv_b = np.linalg.solve(A, b[..., None])[..., 0]            # (B, n)
    Ainv2_b = np.linalg.solve(A, Ainv_b[..., None])[..., 0]
    K = -(Ainv_b @ c)
    if np.any(~np.isfinite(K)) or np.any(K == 0):
        raise UsvidError(f"{model.kind}: the linearised yaw response has no steady gain "
                         "(K = 0 or not finite); cannot design a heading autopilot")
    T = (Ainv2_b @ c) / K
    num, den = [], []
    for i in range(A.shape[0]):
        # r/delta = c adj(sI - A) b / det(sI - A)
        den_i = np.poly(A[i])
        num_i = np.poly(A[i] - np.outer(b[i], c)) - den_i
        num.append(np.trim_zeros(np.where(np.abs(num_i) < 1e-12 * np.max(np.abs(num_i)), 0.0,
                                          num_i), "f"))
        den.append(den_i)
    return NomotoEquivalent(K=K, T=T, num=num, den=den)


def servo_lag(servo: Any) -> tuple[float, float]:
    """(gain, lag [s]) of the steering servo's low-frequency expansion ``S(s) = gain (1 - lag s
    + ...)``: ideal (1, 0) (its rate limit is not linear); first order ``1/(T s + 1)``: (1, T);
    second order with dead time (Mu et al. 2018, eq. 12 and section 5.1.3) ``gain omega_n^2
    e^{-s delay} / (s^2 + 2 zeta omega_n s + omega_n^2)``: (gain, 2 zeta / omega_n + delay).
    The same first-order reduction as Nomoto's ``T = T1 + T2 - T3``: lags in series add."""
    kind = getattr(servo, "kind", "ideal")
    if kind == "first_order":
        return 1.0, float(servo.T)
    if kind == "second_order":
        return (float(servo.gain),
                2.0 * float(servo.zeta) / float(servo.omega_n) + float(servo.delay))
    return 1.0, 0.0


def with_servo(eq: NomotoEquivalent, servo: Any, i: int = 0) -> tuple[float, float]:
    """(K [1/s], T [s]) of the Nomoto form of vessel i *with its steering servo* in series:
    ``K_e = gain K``, ``T_e = T + lag`` (:func:`servo_lag`). The autopilot commands the servo,
    so this is the plant the pole placement sees (the dead time of Mu et al. 2018, section
    5.1.3 is 1 s, three times the Lanxin's T)."""
    g, lag = servo_lag(servo)
    return float(np.ravel(eq.K)[i]) * g, float(np.ravel(eq.T)[i]) + lag


def servo_response(servo: Any, w: np.ndarray) -> np.ndarray:
    """Frequency response delta/delta_cmd of the steering servo at w [rad/s] (limits not
    represented): ideal 1; first order ``1/(T s + 1)``; second order ``gain omega_n^2 /
    (s^2 + 2 zeta omega_n s + omega_n^2)`` (Mu et al. 2018, eq. 11-12) times the exact dead time
    ``exp(-s delay)``."""
    s = 1j * np.asarray(w, dtype=float)
    kind = getattr(servo, "kind", "ideal")
    if kind == "first_order":
        return 1.0 / (float(servo.T) * s + 1.0)
    if kind == "second_order":
        wn, z, g = float(servo.omega_n), float(servo.zeta), float(servo.gain)
        return g * wn * wn / (s * s + 2 * z * wn * s + wn * wn) * np.exp(-s * float(servo.delay))
    return np.ones_like(s)


def loop_response(eq: NomotoEquivalent, servo: Any, kp: Any, ki: Any, kd: Any,
                  w: np.ndarray, dt: float = 0.02) -> np.ndarray:
    """Open-loop frequency response (B, W) of the heading loop at w [rad/s]:

        L(jw) = (kp + ki / s + kd s) S(s) G(s) / s * exp(-s dt / 2)

    cut at the heading: the PID of :class:`usvid.sim.PID` (kd on r = s psi), the servo S
    (:func:`servo_response`), the linearised yaw response G = r/delta (``eq.num/eq.den``), the
    integrator psi = r / s, and the controller's zero-order hold at the step dt [s] as a half
    step of delay."""
    s = 1j * np.asarray(w, dtype=float)
    kp, ki, kd = (np.atleast_1d(np.asarray(g, dtype=float))[:, None] for g in (kp, ki, kd))
    G = np.array([np.polyval(n_, s) / np.polyval(d_, s) for n_, d_ in zip(eq.num, eq.den,
                                                                            strict=True)])
    C = kp + ki / s + kd * s
    return C * servo_response(servo, w)[None, :] * G / s * np.exp(-s * dt / 2)


@dataclass(frozen=True)
class Margins:
    """Gain margin [dB] (inf: the phase never reaches -180 deg), phase margin [deg] and the
    gain-crossover frequency [rad/s], each (B,)."""

    gain_margin_db: np.ndarray
    phase_margin_deg: np.ndarray
    crossover_rad_s: np.ndarray


def loop_margins(eq: NomotoEquivalent, servo: Any, kp: Any, ki: Any, kd: Any, *,
                 dt: float = 0.02, w: np.ndarray | None = None) -> Margins:
    """Classical stability margins of the heading loop (:func:`loop_response`) for a batch,
    vectorised on a logarithmic frequency grid ``w`` [rad/s] (default 1e-3 .. 1e3, 4000
    points) with linear interpolation at the crossings: the phase margin at the first gain
    crossover (|L| falling through 1), the gain margin at the first phase crossover of -180
    deg above it (the dead time makes the phase fall without bound). Unwrapped phase; Nyquist
    (Ogata 2010, Sec. 7-6)."""
    w = np.logspace(-3, 3, 4000) if w is None else np.asarray(w, dtype=float)
    L = loop_response(eq, servo, kp, ki, kd, w, dt)
    mag = np.abs(L)
    ph = np.degrees(np.unwrap(np.angle(L), axis=1))
    # the integrators put the low-frequency phase near -180 (PID: -270 + 90): shift the
    # unwrapped phase so that it starts in (-360, 0]
    ph = ph - 360.0 * np.ceil(ph[:, :1] / 360.0)
    B = L.shape[0]
    pm = np.full(B, np.nan)
    wc = np.full(B, np.nan)
    gm = np.full(B, np.inf)
    lm = np.log(mag)
    lw = np.log(w)
    for i in range(B):  # per parameter set: a few vector operations, no time loop
        down = np.nonzero((lm[i, :-1] >= 0) & (lm[i, 1:] < 0))[0]
        if down.size:
            k = down[-1]
            f = lm[i, k] / (lm[i, k] - lm[i, k + 1])
            wc[i] = math.exp(lw[k] + f * (lw[k + 1] - lw[k]))
            pm[i] = 180.0 + ph[i, k] + f * (ph[i, k + 1] - ph[i, k])
        cross = np.nonzero((ph[i, :-1] > -180.0) & (ph[i, 1:] <= -180.0))[0]
        if down.size:
            cross = cross[cross >= down[-1]]
        if cross.size:
            k = cross[0]
            f = (ph[i, k] + 180.0) / (ph[i, k] - ph[i, k + 1])
            gm[i] = -20.0 * (math.log10(mag[i, k]) + f * (math.log10(mag[i, k + 1])
                                                          - math.log10(mag[i, k])))
    return Margins(gain_margin_db=gm, phase_margin_deg=pm, crossover_rad_s=wc)
