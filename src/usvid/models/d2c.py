"""Discrete-to-continuous conversion of identified models (Mu et al. 2016, eq. 23-27).

Mu et al. 2016 identifies discrete transfer functions by RLS (eq. 23, 26) and converts them to
continuous ones (eq. 24, 27). Its printed pairs are not self-consistent (eq. 26 has complex poles at
z = -0.78 +- 0.56 j, i.e. near the Nyquist frequency, which no ZOH conversion maps to the printed
omega_n = 0.985 rad/s), so usvid implements the conversions from their definitions:

* **ZOH** (zero-order hold, the exact inverse of ``scipy.signal.cont2discrete(..., "zoh")``): with
  the augmented matrix ``M_d = [[A_d, B_d], [0, I]] = expm([[A, B], [0, 0]] dt)``,
  ``[[A, B], [0, 0]] = logm(M_d) / dt`` (principal matrix logarithm, ``scipy.linalg.logm``);
  C and D are unchanged. A negative real discrete pole has no real principal logarithm: ZOH has
  no real continuous equivalent and :class:`IdentificationError` says so.
* **Tustin** (bilinear, inverse of ``cont2discrete(..., "bilinear")``):
  ``A = (2/dt)(A_d - I)(A_d + I)^-1``, ``B = (I - A dt/2) B_d / dt``, ``C = C_d (I - A dt/2)``,
  ``D = D_d - C B_d / 2``.

Pure delays. A transfer function ``N(z) / (z^k D(z))`` (descending powers of z) with relative
degree ``R = deg(den) - deg(num)`` holds a dead time of ``R - 1`` samples under ZOH (ZOH of a
delay-free strictly proper system has relative degree 1) and ``R`` samples under Tustin; the dead
time is taken out (``z^d G(z)``) and reported in samples and seconds, and the rest converted.
Poles at z = 0 beyond that are not a pure delay and are rejected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import IdentificationError

_METHODS = ("zoh", "tustin")


def _check(dt: float, method: str) -> str:
    if not (np.isfinite(dt) and dt > 0):
        raise IdentificationError(f"d2c: sample time `dt` must be > 0 (got {dt!r})")
    m = {"bilinear": "tustin"}.get(method, method)
    if m not in _METHODS:
        raise IdentificationError(f"d2c: `method` must be 'zoh' or 'tustin' (got {method!r})")
    return m


def d2c_ss(A: Any, B: Any, C: Any, D: Any, dt: float, method: str = "zoh"
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Continuous state space ``(A, B, C, D)`` of a discrete one sampled every ``dt`` [s].

    ``method`` is ``"zoh"`` (matrix logarithm of the augmented matrix) or ``"tustin"``
    (``"bilinear"`` accepted). Raises :class:`IdentificationError` when ZOH meets a negative real
    (or zero) discrete pole, or Tustin a pole at z = -1.
    """
    m = _check(dt, method)
    Ad = np.atleast_2d(np.asarray(A, dtype=float))
    Bd = np.asarray(B, dtype=float).reshape(Ad.shape[0], -1)
    Cd = np.asarray(C, dtype=float).reshape(-1, Ad.shape[0])
    Dd = np.asarray(D, dtype=float).reshape(Cd.shape[0], Bd.shape[1])
    n, mi = Bd.shape
    poles = np.linalg.eigvals(Ad)
    if m == "zoh":
        neg = poles[(np.abs(poles.imag) <= 1e-9 * np.maximum(1.0, np.abs(poles)))
                    & (poles.real <= 0)]
        if neg.size:
            raise IdentificationError(
                "d2c (zoh): discrete pole(s) at z = "
                f"{', '.join(f'{p.real:.4g}' for p in neg)} on the non-positive real axis have no "
                "real continuous ZOH equivalent (the matrix logarithm is complex); use "
                "method='tustin' or a model of another order")
        M = np.zeros((n + mi, n + mi))
        M[:n, :n] = Ad
        M[:n, n:] = Bd
        M[n:, n:] = np.eye(mi)
        from scipy import linalg  # (on first use: importing the model kinds spares scipy)

        L = linalg.logm(M)
        if np.iscomplexobj(L):
            if np.max(np.abs(L.imag)) > 1e-8 * max(1.0, np.max(np.abs(L.real))):
                raise IdentificationError(
                    "d2c (zoh): the matrix logarithm is not real: no real continuous equivalent")
            L = L.real
        L = L / dt
        return L[:n, :n], L[:n, n:], Cd, Dd
    if np.any(np.abs(poles + 1.0) < 1e-12):
        raise IdentificationError("d2c (tustin): a discrete pole at z = -1 has no continuous "
                                  "equivalent under the bilinear map")
    eye = np.eye(n)
    Ac = (2.0 / dt) * np.linalg.solve((Ad + eye).T, (Ad - eye).T).T
    ima = eye - 0.5 * dt * Ac
    Bc = ima @ Bd / dt
    Cc = Cd @ ima
    Dc = Dd - 0.5 * Cc @ Bd
    return Ac, Bc, Cc, Dc


@dataclass(frozen=True)
class ContinuousTF:
    """Result of :func:`d2c`: ``G(s) e^{-s delay_s}`` with ``G = num(s) / den(s)``.

    ``num``, ``den`` descending powers of s, ``den[0] == 1``; ``delay_samples`` the dead time taken
    out of the discrete model and ``delay_s = delay_samples * dt`` [s]; ``A, B, C, D`` a
    continuous state-space realisation of G (without the delay); ``dt`` [s] the sample time and
    ``method`` the conversion used.
    """

    num: np.ndarray
    den: np.ndarray
    delay_samples: int
    delay_s: float
    dt: float
    method: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray

    @property
    def poles(self) -> np.ndarray:
        """Continuous poles [1/s]."""
        return np.roots(self.den)

    @property
    def dc_gain(self) -> float:
        """Steady-state gain ``G(0)`` (inf for a pole at s = 0)."""
        return float(self.num[-1] / self.den[-1]) if self.den[-1] != 0 else float("inf")

    def to_control(self) -> Any:
        """The python-control ``TransferFunction`` of G (the dead time is in ``delay_s``)."""
        import control

        return control.tf(self.num, self.den)


def _trim(c: np.ndarray) -> np.ndarray:
    nz = np.flatnonzero(c != 0)
    return c[nz[0]:] if nz.size else np.zeros(1)


def split_delay(num: Any, den: Any, method: str = "zoh", variable: str = "z"
                ) -> tuple[np.ndarray, np.ndarray, int]:
    """Take the pure dead time out of a discrete transfer function.

    ``num``, ``den``: coefficients in descending powers of z (``variable="z"``, scipy's
    convention) or ascending powers of z^-1 (``variable="z^-1"``, the ARX convention
    ``(b0 + b1 z^-1 + ...) / (1 + a1 z^-1 + ...)``, where leading zeros of ``num`` are delay).
    Returns ``(num_z, den_z, d)`` with ``z^d G(z) = num_z / den_z`` delay-free (relative degree
    1 for ZOH, 0 for Tustin) and ``d`` the dead time in samples. See the module docstring.
    """
    m = _check(1.0, method)
    b = np.atleast_1d(np.asarray(num, dtype=float))
    a = np.atleast_1d(np.asarray(den, dtype=float))
    for nm, c in (("numerator", b), ("denominator", a)):
        if c.ndim != 1 or not np.all(np.isfinite(c)):
            raise IdentificationError(f"d2c: the {nm} must be a finite 1-D coefficient vector")
    if not np.any(a != 0):
        raise IdentificationError("d2c: the denominator is zero")
    if variable in ("z^-1", "z-1", "q^-1"):
        L = max(b.size, a.size)
        b = np.concatenate([b, np.zeros(L - b.size)])
        a = np.concatenate([a, np.zeros(L - a.size)])
    elif variable != "z":
        raise IdentificationError(f"d2c: `variable` must be 'z' or 'z^-1' (got {variable!r})")
    b, a = _trim(b), _trim(a)
    # cancel common roots at z = 0 (trailing zeros of both)
    while b.size > 1 and a.size > 1 and b[-1] == 0 and a[-1] == 0:
        b, a = b[:-1], a[:-1]
    if not np.any(b != 0):
        raise IdentificationError("d2c: the numerator is zero (no input-output relation)")
    R = (a.size - 1) - (b.size - 1)
    if R < 0:
        raise IdentificationError(
            f"d2c: improper discrete transfer function (numerator degree {b.size - 1} > "
            f"denominator degree {a.size - 1})")
    d = max(R - 1, 0) if m == "zoh" else R
    b = np.concatenate([b, np.zeros(d)])  # z^d N(z)
    while d and b[-1] == 0 and a[-1] == 0:
        b, a = b[:-1], a[:-1]
    a0 = a[0]
    return b / a0, a / a0, d


def d2c(num: Any, den: Any, dt: float, method: str = "zoh", *, variable: str = "z"
        ) -> ContinuousTF:
    """Continuous transfer function (and dead time) of a discrete one sampled every ``dt`` [s].

    Implements Mu et al. 2016 eq. 23 -> 24 and 26 -> 27 (see the module docstring for the method and
    the dead-time rule). ``num``/``den`` in descending powers of z (``variable="z"``) or ascending
    powers of z^-1 (``variable="z^-1"``). Raises :class:`IdentificationError` for a negative real
    pole under ZOH, poles at z = 0 that are not a pure delay, or an improper model.
    """
    m = _check(dt, method)
    b, a, d = split_delay(num, den, m, variable)
    if a.size > 1 and abs(a[-1]) == 0:
        raise IdentificationError(
            "d2c: pole(s) at z = 0 that are not a pure dead time (relative degree too small)")
    if a.size == 1:  # static gain
        A = np.zeros((0, 0))
        B = np.zeros((0, 1))
        C = np.zeros((1, 0))
        D = np.array([[b[-1] / a[0]]])
        return ContinuousTF(np.array([D[0, 0]]), np.ones(1), d, d * dt, float(dt), m, A, B, C, D)
    from scipy import signal  # (on first use, as in d2c_ss)

    Ad, Bd, Cd, Dd = signal.tf2ss(b, a)
    A, B, C, D = d2c_ss(Ad, Bd, Cd, Dd, dt, m)
    numc, denc = signal.ss2tf(A, B, C, D)
    numc = np.atleast_1d(np.asarray(numc, dtype=float).ravel())
    denc = np.asarray(denc, dtype=float)
    # logm round-off: a discrete pole at z = 1 gives |den[-1]| ~ 1e-14 instead of an exact
    # integrator; coefficients below 1e-12 of the largest are set to zero
    denc = np.where(np.abs(denc) < 1e-12 * np.max(np.abs(denc)), 0.0, denc)
    scale = np.max(np.abs(numc)) if numc.size else 1.0
    numc = np.where(np.abs(numc) < 1e-10 * max(scale, 1e-300), 0.0, numc)
    numc = _trim(numc)
    return ContinuousTF(numc / denc[0], denc / denc[0], d, d * float(dt), float(dt), m, A, B, C, D)
