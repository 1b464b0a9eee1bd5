"""Thruster models: open propeller (Mu et al. 2018 section 3.1), POD (Mu et al. 2016 eq. 3), twin
thrusters (the catamaran paper), plus the hull-propeller interaction factors (thrust deduction, wake
fraction).

Units everywhere: thrust [N], shaft speed n [rps = rev/s], speed [m/s], lengths [m], density
[kg/m^3]; advance ratio J, K_T and the interaction factors are dimensionless.

Every function is vectorised: arguments broadcast against each other (numpy rules), a scalar in
gives a numpy scalar out. Parameter dataclasses accept arrays over a leading batch axis.

For the integration core (numba) each thrust law has a scalar twin taking plain floats
(:func:`kt_nb`, :func:`propeller_thrust_nb`, :func:`pod_thrust_nb`); :func:`thrust_nb` evaluates
any law from its packed form (:func:`thrust_row`), which is how the model kinds read them.
:func:`kt_thrust_nb` (thrust of a K_T law quadratic in J) and :func:`pod_thrust_nb` are the one
definition of those laws in numba: the MMG kind's propeller and pod thrusters use them too.

Mu et al. 2018 equation numbers as counted in the paper (the extracted text drops them): (1) thrust,
(2) t_P = (P - R)/P, (3) Hollo/Holtrop t_P, (4) C_10, (5) C_stern, (6) K_T double sum (J_P defined
inline), (7) wake fraction, (8) Delta_w, (9) Lagrange interpolation over the disk ratio,
(10) the first-quadrant regression whose coefficients are Table 2; (11)-(12) are the servo models.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.models._validate import check_params

ArrayLike = float | np.ndarray

G = 9.81  # [m/s^2] gravity used for Froude numbers (Mu et al. 2018 eq. 8, Ma et al.)

# ---------------------------------------------------------------------------------------------
# K_T regression (Mu et al. 2018 eq. 6, 9, 10 and Table 2)
# ---------------------------------------------------------------------------------------------

#: Disk (blade area) ratios of the three regressions of Mu et al. 2018 Table 2.
KT_DISK_RATIOS: tuple[float, float, float] = (0.5, 0.8, 1.1)

#: Order of the coefficients in each row of :data:`MU2018_TABLE2`.
KT_TERMS: tuple[str, ...] = ("A00", "A01", "A02", "A10", "A20", "A30", "A11", "A12", "A21", "A22")

#: Mu et al. 2018 Table 2 (signs as printed except one): disk ratio theta -> (A00, A01, A02, A10,
# A20,
#: A30, A11, A12, A21, A22). Index i is the power of the pitch ratio P/D, j the power of J.
#: Correction: A10 for theta = 1.1 is printed -0.8502, while it is positive (0.8042, 0.5853) for
#: the two other disk ratios. As printed, K_T(J=0, P/D=1, theta=1.1) = -1.18 (a propeller that
#: pulls backwards at bollard pull), which is not physical; with +0.8502 the bollard K_T is
#: 0.4928, 0.4310, 0.5231 for theta = 0.5, 0.8, 1.1, the order of magnitude of every B-series
#: chart. We read the minus sign as a typesetting error and use +0.8502 (tested in
#: tests/test_thrust.py). It matters little for the Lanxin (theta = 0.516: weight -0.025).
MU2018_TABLE2: dict[float, tuple[float, ...]] = {
    0.5: (-0.1677, 0.1747, -0.6720, 0.8042, -0.1437, 0.0, -0.8853, 0.9130, 0.3422, -0.3276),
    0.8: (-0.0517, -0.0315, -0.5822, 0.5853, -0.1026, 0.0, -0.3381, 0.6654, 0.1417, -0.2215),
    1.1: (-0.2191, 0.3013, -0.7309, 0.8502, -0.1080, 0.0, -1.0738, 0.9908, 0.3481, -0.3322),
}

_KT = np.array([MU2018_TABLE2[th] for th in KT_DISK_RATIOS], dtype=float)  # (3, 10)


def kt_regression(J: ArrayLike, pitch_ratio: ArrayLike, coeffs: np.ndarray) -> np.ndarray:
    """One K_T regression of Mu et al. 2018 eq. 10 for one disk ratio (dimensionless).

    ``K_T = A00 + A01 J + A02 J^2 + A10 P + A20 P^2 + A30 P^3 + A11 J P + A12 J^2 P
    + A21 J P^2 + A22 J^2 P^2`` with P = pitch ratio P/D [-], J = advance ratio [-] and
    ``coeffs`` the ten A's in the order of :data:`KT_TERMS`.
    """
    J = np.asarray(J, dtype=float)
    P = np.asarray(pitch_ratio, dtype=float)
    a = np.asarray(coeffs, dtype=float)
    J2 = J * J
    return (a[0] + a[1] * J + a[2] * J2 + a[3] * P + a[4] * P * P + a[5] * P ** 3
            + a[6] * J * P + a[7] * J2 * P + a[8] * J * P * P + a[9] * J2 * P * P)


def lagrange_weights(disk_ratio: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quadratic Lagrange weights over the disk ratios 0.5, 0.8, 1.1 (Mu et al. 2018 eq. 9, read
    as).

    The extracted text lost the minus signs: ``w_0.5 = (theta - 0.8)(theta - 1.1) / 0.18``,
    ``w_0.8 = (theta - 0.5)(theta - 1.1) / (-0.09)``, ``w_1.1 = (theta - 0.5)(theta - 0.8) / 0.18``,
    the denominators being (0.5-0.8)(0.5-1.1) = 0.18, (0.8-0.5)(0.8-1.1) = -0.09 and
    (1.1-0.5)(1.1-0.8) = 0.18. The weights sum to 1 for every theta and are (1,0,0), (0,1,0),
    (0,0,1) at the nodes. theta [-] outside [0.5, 1.1] extrapolates.
    """
    th = np.asarray(disk_ratio, dtype=float)
    w05 = (th - 0.8) * (th - 1.1) / 0.18
    w08 = (th - 0.5) * (th - 1.1) / -0.09
    w11 = (th - 0.5) * (th - 0.8) / 0.18
    return w05, w08, w11


def kt(J: ArrayLike, pitch_ratio: ArrayLike, disk_ratio: ArrayLike) -> np.ndarray:
    """Thrust coefficient K_T(J, P/D, theta) [-] of Mu et al. 2018 eq. 9 and 10 with Table 2.

    ``K_T = w_0.5(theta) K_T0.5(J, P/D) + w_0.8(theta) K_T0.8 + w_1.1(theta) K_T1.1``
    (:func:`lagrange_weights`, :func:`kt_regression`). J = advance ratio [-], pitch_ratio = P/D
    [-], disk_ratio = expanded blade area ratio theta [-]. First quadrant regression (J >= 0); a
    negative J is evaluated as the polynomial says. Vectorised (broadcasting).
    """
    w = lagrange_weights(disk_ratio)
    out = w[0] * kt_regression(J, pitch_ratio, _KT[0])
    out = out + w[1] * kt_regression(J, pitch_ratio, _KT[1])
    out = out + w[2] * kt_regression(J, pitch_ratio, _KT[2])
    return np.asarray(out)[()]


def advance_ratio(n: ArrayLike, u: ArrayLike, D: ArrayLike, w_P: ArrayLike = 0.0) -> np.ndarray:
    """Advance ratio ``J = (1 - w_P) u / (|n| D)`` [-] (Mu et al. 2018, after eq. 6).

    n [rps], u [m/s] (surge speed), D [m], w_P wake fraction [-]. For n = 0 the ratio is
    undefined; 0 is returned there (the thrust is 0 anyway, see :meth:`Propeller.thrust`).
    ``|n|`` is used so that a reversing shaft (n < 0) gets the J of the mirrored propeller.
    """
    n = np.asarray(n, dtype=float)
    u = np.asarray(u, dtype=float)
    an = np.abs(n)
    safe = np.where(an > 0.0, an, 1.0)
    J = np.where(an > 0.0, (1.0 - np.asarray(w_P, dtype=float)) * u / (safe * D), 0.0)
    return np.asarray(J)[()]


@dataclass
class Propeller:
    """Open propeller behind the hull: ``T = (1 - t_P) rho n^2 D^4 K_T(J)`` (Mu et al. 2018 eq. 1).

    ``J = (1 - w_P) u / (n D)``; K_T from :func:`kt` (Mu et al. 2018 eq. 9, 10, Table 2).

    Parameters
    ----------
    D : propeller diameter [m] (> 0). Lanxin: 0.46 m (Mu et al. 2018 Table 1).
    pitch_ratio : P/D [-] (> 0). Lanxin: 0.3.
    disk_ratio : expanded blade-area ratio theta [-] (> 0). Lanxin: 0.516.
    t_P : thrust deduction factor [-] in [0, 1) (see :func:`hollo_thrust_deduction`).
    w_P : wake fraction [-] < 1 (see :func:`wake_fraction`).
    rho : water density [kg/m^3] (> 0), default 1025 (sea water).
    """

    D: ArrayLike
    pitch_ratio: ArrayLike
    disk_ratio: ArrayLike
    t_P: ArrayLike = 0.0
    w_P: ArrayLike = 0.0
    rho: ArrayLike = 1025.0

    def __post_init__(self) -> None:
        check_params("propeller",
                     {"D": self.D, "pitch_ratio": self.pitch_ratio, "disk_ratio": self.disk_ratio,
                      "t_P": self.t_P, "w_P": self.w_P, "rho": self.rho},
                     positive=("D", "pitch_ratio", "disk_ratio", "rho"), nonnegative=("t_P",))
        if not np.all(np.asarray(self.t_P, dtype=float) < 1.0):
            raise UsvidError(f"propeller.t_P must be < 1 (got {self.t_P!r})")
        if not np.all(np.asarray(self.w_P, dtype=float) < 1.0):
            raise UsvidError(f"propeller.w_P must be < 1 (got {self.w_P!r})")

    def advance_ratio(self, n: ArrayLike, u: ArrayLike) -> np.ndarray:
        """``J = (1 - w_P) u / (|n| D)`` [-]; n [rps], u [m/s]; 0 where n = 0."""
        return advance_ratio(n, u, self.D, self.w_P)

    def kt(self, J: ArrayLike) -> np.ndarray:
        """K_T(J) [-] for this propeller's pitch and disk ratio (Mu et al. 2018 eq. 9, 10)."""
        return kt(J, self.pitch_ratio, self.disk_ratio)

    def thrust(self, n: ArrayLike, u: ArrayLike) -> np.ndarray:
        """Effective thrust ``T = (1 - t_P) rho n |n| D^4 K_T(J)`` [N] (Mu et al. 2018 eq. 1).

        n [rps] shaft speed, u [m/s] surge speed. n = 0 gives T = 0 exactly (J is not evaluated).
        The regression is a first-quadrant one (n > 0, u >= 0, Mu et al. 2018 Remark 2 excludes
        reversing). Outside it: u < 0 with n > 0 evaluates the polynomial at J < 0; n < 0 is
        treated as the mirrored propeller (J from |n|, thrust sign of n) -- an extrapolation
        only. K_T(J) < 0 at large J (windmilling) gives a negative thrust (a drag), as the
        regression says.
        """
        n = np.asarray(n, dtype=float)
        J = self.advance_ratio(n, u)
        T = ((1.0 - np.asarray(self.t_P, dtype=float)) * np.asarray(self.rho, dtype=float)
             * n * np.abs(n) * np.asarray(self.D, dtype=float) ** 4 * self.kt(J))
        return np.asarray(T)[()]


# ---------------------------------------------------------------------------------------------
# Thrust deduction (Holtrop & Mennen, Mu et al. 2018 eq. 3-5) and wake fraction (Papmel, eq. 7-8)
# ---------------------------------------------------------------------------------------------

def holtrop_c10(L: ArrayLike, B: ArrayLike) -> np.ndarray:
    """C_10 of Mu et al. 2018 eq. 4 (Holtrop & Mennen 1982) [-].

    ``C_10 = B/L`` for L/B > 5.2, else ``0.25 - 0.003328402 / (B/L - 0.134615385)``.
    L, B [m]. (Same piecewise form in Holtrop & Mennen 1982, Int. Shipbuilding Progress 29.)
    """
    L = np.asarray(L, dtype=float)
    B = np.asarray(B, dtype=float)
    bl = B / L
    return np.asarray(np.where(L / B > 5.2, bl, 0.25 - 0.003328402 / (bl - 0.134615385)))[()]


C_STERN = {"V": -10.0, "conventional": 0.0, "U": 10.0}
"""Stern-shape coefficient of Mu et al. 2018 eq. 5: V sections -10, conventional 0, U
sections +10."""


def hollo_thrust_deduction(L: ArrayLike, B: ArrayLike, T: ArrayLike, D_P: ArrayLike,
                           C_P: ArrayLike, lcb: ArrayLike = 0.0,
                           C_stern: ArrayLike = 0.0) -> np.ndarray:
    """Thrust deduction factor t_P [-] by "Hollo's formula" for a single screw (Mu et al. 2018
    eq. 3-5).

    "Hollo" is Holtrop & Mennen (1982, "An approximate power prediction method", Int.
    Shipbuilding Progress 29, 166-170), single-screw conventional stern, which the extracted text
    garbles. Read as::

        t_P = 0.001979 L / (B - B C_P1) + 1.0585 C_10 - 0.00524 - 0.1418 D_P^2 / (B T)
              + 0.0015 C_stern
        C_P1 = 1.45 C_P - 0.315 - 0.0225 lcb

    The seed prints "0.000524" and "0.225 L_cb"; Holtrop & Mennen's constants 0.00524 and
    0.0225 (lcb in percent of L forward of 0.5 L) are used here. C_10 from :func:`holtrop_c10`.

    L [m] length, B [m] breadth, T [m] mean draught (the seed's d), D_P [m] propeller diameter,
    C_P [-] prismatic coefficient, lcb [% of L, + forward of midship], C_stern [-] (-10 V, 0
    conventional, +10 U; :data:`C_STERN`). C_P and lcb are not in Mu et al. 2018 Table 1: they are
    parameters. For the Lanxin (L 7.02, B 2.6, T 0.32, D_P 0.46) this gives about 0.22 for
    C_P = 0.71, lcb = 0, while the paper states t_P ~ 0.05 (not reproducible from its formula).
    """
    L = np.asarray(L, dtype=float)
    B = np.asarray(B, dtype=float)
    C_P1 = 1.45 * np.asarray(C_P, dtype=float) - 0.315 - 0.0225 * np.asarray(lcb, dtype=float)
    t = (0.001979 * L / (B - B * C_P1) + 1.0585 * holtrop_c10(L, B) - 0.00524
         - 0.1418 * np.asarray(D_P, dtype=float) ** 2 / (B * np.asarray(T, dtype=float))
         + 0.0015 * np.asarray(C_stern, dtype=float))
    return np.asarray(t)[()]


def froude_number(V: ArrayLike, L: ArrayLike, g: float = G) -> np.ndarray:
    """Length Froude number ``Fn = V / sqrt(g L)`` [-]; V [m/s], L [m], g [m/s^2]."""
    return np.asarray(np.asarray(V, dtype=float) / np.sqrt(g * np.asarray(L, dtype=float)))[()]


def wake_fraction(C_b: ArrayLike, volume: ArrayLike, D_P: ArrayLike, Fn: ArrayLike,
                  x: ArrayLike = 1) -> np.ndarray:
    """Propeller wake fraction w_P [-] by the "Bamier" (Papmel) formula (Mu et al. 2018 eq. 7-8).

    Read as ``w_P = 0.165 C_b^x (volume^(1/3) / D_P) - Delta_w`` with
    ``Delta_w = 0.1 (Fn - 0.2)`` for Fn > 0.2 and 0 otherwise. C_b [-] block coefficient,
    volume [m^3] displaced volume, D_P [m] propeller diameter, Fn [-] Froude number
    (:func:`froude_number`), x = 1 for a centre-line propeller, 2 for wing (side) propellers.
    For the Lanxin (C_b 0.6976, 2.73 m^3, D_P 0.46 m, 10 kn: Fn 0.62) this gives about 0.31,
    while the paper states w_P ~ 0.04 (not reproducible from its formula and Table 1).
    """
    Fn = np.asarray(Fn, dtype=float)
    dw = np.where(Fn > 0.2, 0.1 * (Fn - 0.2), 0.0)
    w = (0.165 * np.asarray(C_b, dtype=float) ** np.asarray(x, dtype=float)
         * np.cbrt(np.asarray(volume, dtype=float)) / np.asarray(D_P, dtype=float) - dw)
    return np.asarray(w)[()]


# ---------------------------------------------------------------------------------------------
# POD thruster (Mu et al. 2016 eq. 3-4)
# ---------------------------------------------------------------------------------------------

@dataclass
class PodThrust:
    """POD propulsor thrust ``T = c V n + d |n| n`` (Mu et al. 2016 eq. 3).

    c [N s^2/m] (per m/s of ship speed and per rps), d [N s^2] (per rps^2). Mu et al. 2016 states
    c, d > 0; they are not constrained here (a conventional propeller has c < 0: thrust falls
    with speed), only required to be finite. The force components are Mu et al. 2016 eq. 4, applied
    by the dynamics with the usvid sign convention (ARCHITECTURE.md).
    """

    c: ArrayLike
    d: ArrayLike

    def __post_init__(self) -> None:
        check_params("pod", {"c": self.c, "d": self.d})

    def thrust(self, V: ArrayLike, n: ArrayLike) -> np.ndarray:
        """Thrust [N] at ship speed V [m/s] and propeller speed n [rps] (Mu et al. 2016 eq. 3)."""
        V = np.asarray(V, dtype=float)
        n = np.asarray(n, dtype=float)
        return np.asarray(self.c * V * n + self.d * np.abs(n) * n)[()]


# ---------------------------------------------------------------------------------------------
# Twin thrusters (the catamaran paper): control code -> voltage -> thrust, or PWM -> thrust
# ---------------------------------------------------------------------------------------------

@dataclass
class TwinThrust:
    """Thrust of one thruster of a twin-thruster catamaran as a function of its command
    (the catamaran paper).

    Two command kinds:

    * ``command="code"`` (the catamaran paper, section 2.2): control code n in [0, code_max] (120)
      maps linearly to the control voltage ``U = voltage_max n / code_max`` in [0, voltage_max] (5
      V) (the catamaran paper eq. 31), then ``T = sum_k coeffs[k] U^k`` (the catamaran paper eq. 32,
      "from the thruster data sheet"; the extracted text lost the formula and its numbers, so
      the polynomial coefficients are parameters, in N/V^k, lowest power first). The code is clipped
      to its range.
    * ``command="pwm"``: a hobby ESC pulse width [us] with neutral ``pwm_neutral`` (1500),
      level ``s = (pwm - pwm_neutral) / pwm_span`` clipped to [-1, 1] and 0 within
      ``pwm_deadband`` [us] of neutral; ``T = P_fwd(s)`` for s >= 0 and ``T = -P_rev(-s)`` for
      s < 0 with ``P_fwd = coeffs`` and ``P_rev = reverse_coeffs`` (default: ``coeffs``), both in
      N per unit level^k. This is the mapping for the real twin-thruster logs (PWM_L/PWM_R).

    The catamaran dynamics combine the two: tau_u = T_port + T_stbd, tau_r = (T_port - T_stbd)
    b/2 (the catamaran paper eq. 26-27; ARCHITECTURE.md sign convention). :meth:`quadratic` builds
    the common choice T proportional to the square of the level (thrust ~ rpm^2 ~ voltage^2).
    """

    coeffs: tuple[float, ...]
    command: Literal["code", "pwm"] = "code"
    code_max: float = 120.0
    voltage_max: float = 5.0
    pwm_neutral: float = 1500.0
    pwm_span: float = 500.0
    pwm_deadband: float = 0.0
    reverse_coeffs: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if self.command not in ("code", "pwm"):
            raise UsvidError(f"twin_thrust.command must be 'code' or 'pwm' (got {self.command!r})")
        fwd = np.atleast_1d(np.asarray(self.coeffs, dtype=float))
        if fwd.ndim != 1 or fwd.size == 0:
            raise UsvidError("twin_thrust.coeffs must be a non-empty sequence of numbers "
                             f"(got {self.coeffs!r})")
        rev = fwd if self.reverse_coeffs is None else np.atleast_1d(
            np.asarray(self.reverse_coeffs, dtype=float))
        if rev.ndim != 1 or rev.size == 0:
            raise UsvidError("twin_thrust.reverse_coeffs must be a non-empty sequence of numbers "
                             f"(got {self.reverse_coeffs!r})")
        check_params("twin_thrust",
                     {"coeffs": fwd, "reverse_coeffs": rev, "code_max": self.code_max,
                      "voltage_max": self.voltage_max, "pwm_neutral": self.pwm_neutral,
                      "pwm_span": self.pwm_span, "pwm_deadband": self.pwm_deadband},
                     positive=("code_max", "voltage_max", "pwm_span"),
                     nonnegative=("pwm_deadband",))

    @property
    def _fwd(self) -> np.ndarray:
        return np.atleast_1d(np.asarray(self.coeffs, dtype=float))

    @property
    def _rev(self) -> np.ndarray:
        return self._fwd if self.reverse_coeffs is None else np.atleast_1d(
            np.asarray(self.reverse_coeffs, dtype=float))

    @classmethod
    def quadratic(cls, T_max: float, command: Literal["code", "pwm"] = "code",
                  **kwargs: float) -> TwinThrust:
        """T = T_max (level / level_max)^2: T_max [N] at full command (5 V, or PWM +-span)."""
        vmax = float(kwargs.get("voltage_max", 5.0)) if command == "code" else 1.0
        return cls(coeffs=(0.0, 0.0, T_max / vmax ** 2), command=command, **kwargs)

    def level(self, cmd: ArrayLike) -> np.ndarray:
        """Control level: voltage [V] (code mode, the catamaran paper eq. 31) or s in [-1, 1] (PWM
        mode)."""
        cmd = np.asarray(cmd, dtype=float)
        if self.command == "code":
            out = self.voltage_max * np.clip(cmd, 0.0, self.code_max) / self.code_max
        else:
            dev = cmd - self.pwm_neutral
            s = np.clip(dev / self.pwm_span, -1.0, 1.0)
            out = np.where(np.abs(dev) <= self.pwm_deadband, 0.0, s)
        return np.asarray(out)[()]

    def thrust(self, cmd: ArrayLike) -> np.ndarray:
        """Thrust [N] of one thruster for command ``cmd`` (control code [-] or PWM [us])."""
        x = np.asarray(self.level(cmd), dtype=float)
        fwd = np.polynomial.polynomial.polyval(np.abs(x), self._fwd)
        rev = np.polynomial.polynomial.polyval(np.abs(x), self._rev)
        return np.asarray(np.where(x >= 0.0, fwd, -rev))[()]

    def combined(self, cmd_port: ArrayLike, cmd_stbd: ArrayLike,
                 b: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(tau_u [N], tau_r [N m]) = (T_p + T_s, (T_p - T_s) b / 2) (the catamaran paper
        eq. 26-27).

        b [m] is the distance between the two thrusters (b/2 from the centre line each).
        """
        Tp = self.thrust(cmd_port)
        Ts = self.thrust(cmd_stbd)
        return np.asarray(Tp + Ts)[()], np.asarray((Tp - Ts) * np.asarray(b) / 2.0)[()]

    def nb_args(self) -> tuple[np.ndarray, np.ndarray, float, float, float, float, float]:
        """The packed form read by :func:`thrust_nb` (:func:`thrust_row`):
        ``(fwd, rev, offset, scale, lo, hi, deadband)`` (floats and float64 arrays)."""
        if self.command == "code":
            return (self._fwd.copy(), self._rev.copy(), 0.0, self.voltage_max / self.code_max,
                    0.0, float(self.voltage_max), 0.0)
        return (self._fwd.copy(), self._rev.copy(), float(self.pwm_neutral),
                1.0 / self.pwm_span, -1.0, 1.0, float(self.pwm_deadband))


# ---------------------------------------------------------------------------------------------
# numba scalar twins (for sim kernels)
# ---------------------------------------------------------------------------------------------

@numba.njit(cache=True, inline="always")
def _kt_row_nb(k: int, J: float, P: float) -> float:
    a = _KT[k]
    J2 = J * J
    P2 = P * P
    return (a[0] + a[1] * J + a[2] * J2 + a[3] * P + a[4] * P2 + a[5] * P2 * P
            + a[6] * J * P + a[7] * J2 * P + a[8] * J * P2 + a[9] * J2 * P2)


@numba.njit(cache=True, inline="always")
def kt_nb(J: float, P_D: float, theta: float) -> float:
    """Scalar numba twin of :func:`kt` (Mu et al. 2018 eq. 9, 10, Table 2) [-]."""
    w0 = (theta - 0.8) * (theta - 1.1) / 0.18
    w1 = (theta - 0.5) * (theta - 1.1) / -0.09
    w2 = (theta - 0.5) * (theta - 0.8) / 0.18
    return (w0 * _kt_row_nb(0, J, P_D) + w1 * _kt_row_nb(1, J, P_D)
            + w2 * _kt_row_nb(2, J, P_D))


@numba.njit(cache=True, inline="always")
def kt_quadratic_nb(P_D: float, theta: float) -> tuple[float, float, float]:
    """The K_T regression of :func:`kt_nb` at one pitch ratio P/D and disk ratio theta as a
    quadratic in J: ``K_T = c0 + c1 J + c2 J^2`` (Mu et al. 2018 eq. 9, 10, Table 2: c0 =
    A00 + A10 P + A20 P^2 + A30 P^3, c1 = A01 + A11 P + A21 P^2, c2 = A02 + A12 P + A22 P^2,
    each weighted over the disk ratios)."""
    w = ((theta - 0.8) * (theta - 1.1) / 0.18, (theta - 0.5) * (theta - 1.1) / -0.09,
         (theta - 0.5) * (theta - 0.8) / 0.18)
    P = P_D
    P2 = P * P
    c0 = c1 = c2 = 0.0
    for k in range(3):
        a = _KT[k]
        c0 += w[k] * (a[0] + a[3] * P + a[4] * P2 + a[5] * P2 * P)
        c1 += w[k] * (a[1] + a[6] * P + a[8] * P2)
        c2 += w[k] * (a[2] + a[7] * P + a[9] * P2)
    return c0, c1, c2


@numba.njit(cache=True, inline="always")
def kt_thrust_nb(n: float, uP: float, rho_d4: float, rho_d3: float, rho_d2: float, k0: float,
                 k1: float, k2: float) -> float:
    """Open-water thrust ``T = rho n |n| D^4 K_T(J)`` [N] of a K_T law quadratic in the advance
    ratio, ``K_T = k0 + k1 J + k2 J^2``, ``J = u_P / (|n| D)``: the one definition of the K_T
    thrust law (the propeller of Mu et al. 2018 eq. 1 through :func:`kt_quadratic_nb`, the MMG
    propeller of Yasukawa & Yoshimura 2015). n [rps], u_P [m/s] the propeller's inflow speed
    ((1 - w_P) u), ``rho_dk`` = rho D^k. Division-free, ``rho D^4 k0 n|n| + rho D^3 k1 n u_P +
    rho D^2 k2 sgn(n) u_P^2``: T = 0 at n = 0 without forming J; a reversing shaft (n < 0) is
    the mirrored propeller (J from |n|, thrust with the sign of n)."""
    sn = (1.0 if n > 0.0 else 0.0) - (1.0 if n < 0.0 else 0.0)
    return rho_d4 * k0 * n * abs(n) + rho_d3 * k1 * n * uP + rho_d2 * k2 * sn * uP * uP


@numba.njit(cache=True, inline="always")
def propeller_thrust_nb(n: float, u: float, D: float, P_D: float, theta: float, t_P: float,
                        w_P: float, rho: float) -> float:
    """Scalar numba twin of :meth:`Propeller.thrust` [N]: n [rps], u [m/s], D [m], rho [kg/m^3].

    ``T = (1 - t_P) rho n |n| D^4 K_T((1 - w_P) u / (|n| D))`` (:func:`kt_thrust_nb` with the
    K_T regression :func:`kt_quadratic_nb`); 0 for n = 0.
    """
    c0, c1, c2 = kt_quadratic_nb(P_D, theta)
    D2 = D * D
    return (1.0 - t_P) * kt_thrust_nb(n, (1.0 - w_P) * u, rho * D2 * D2, rho * D2 * D,
                                      rho * D2, c0, c1, c2)


@numba.njit(cache=True, inline="always")
def pod_thrust_nb(V: float, n: float, c: float, d: float) -> float:
    """Scalar numba twin of :meth:`PodThrust.thrust` [N]: ``c V n + d |n| n`` (Mu et al. 2016
    eq. 3)."""
    return c * V * n + d * abs(n) * n


# ---------------------------------------------------------------------------------------------
# thrust laws as flat rows for the integration core
# ---------------------------------------------------------------------------------------------
#: Length of a thrust-law row (mode + up to 19 coefficients).
THRUST_ROW = 20
#: Nested thrust-law classes by their model-file ``kind`` name.
THRUST_LAWS: dict[str, type] = {}  # filled at the end of the module


def thrust_row(thrust: object, constant: ArrayLike | None = None) -> list[ArrayLike]:
    """The flat row of a thrust law read by :func:`thrust_nb` (values may be (B,) arrays).

    ``thrust``: a number T [N] (constant thrust), ``None`` (then ``constant`` [N] is used),
    :class:`Propeller` (mode 1), :class:`PodThrust` (mode 2), :class:`TwinThrust` (mode 4);
    ``("per_command", k)``: T = k c, k [N per command unit] (mode 3).
    """
    row: list[ArrayLike] = [0.0] * THRUST_ROW
    if thrust is None:
        if constant is None:
            raise UsvidError("parameters.thrust is not set (give a thrust [N] or a thrust law)")
        row[1] = constant
    elif isinstance(thrust, Propeller):
        row[0] = 1.0
        row[1:7] = [thrust.D, thrust.pitch_ratio, thrust.disk_ratio, thrust.t_P, thrust.w_P,
                    thrust.rho]
    elif isinstance(thrust, PodThrust):
        row[0] = 2.0
        row[1:3] = [thrust.c, thrust.d]
    elif isinstance(thrust, tuple) and thrust[0] == "per_command":
        row[0] = 3.0
        row[1] = thrust[1]
    elif isinstance(thrust, TwinThrust):
        fwd, rev, off, sc, lo, hi, db = thrust.nb_args()
        if fwd.size > 6 or rev.size > 6:
            raise UsvidError("twin_thrust polynomials above degree 5 are not supported")
        row[0] = 4.0
        row[1:8] = [float(fwd.size), float(rev.size), off, sc, lo, hi, db]  # 8.. zero-padded
        row[8:8 + fwd.size] = list(fwd)
        row[14:14 + rev.size] = list(rev)
    elif hasattr(thrust, "thrust"):
        raise UsvidError(f"thrust law {type(thrust).__name__} is not supported by the simulator "
                         "(use a number, propeller, pod_thrust or twin_thrust)")
    else:
        row[1] = thrust  # a constant thrust [N]
    return row


@numba.njit(cache=True, inline="always")
def thrust_nb(t: tuple, u: float, n: float) -> float:
    """Thrust [N] of a packed thrust law ``t`` (the THRUST_ROW values of :func:`thrust_row`,
    as a tuple) at surge speed u [m/s] and shaft speed / command n; the formulas of
    :meth:`Propeller.thrust`, :meth:`PodThrust.thrust` and :meth:`TwinThrust.thrust`."""
    mode = t[0]
    if mode == 0.0:
        return t[1]
    if mode == 1.0:
        return propeller_thrust_nb(n, u, t[1], t[2], t[3], t[4], t[5], t[6])
    if mode == 2.0:
        return pod_thrust_nb(u, n, t[1], t[2])
    if mode == 3.0:
        return t[1] * n
    dev = n - t[3]
    x = 0.0 if abs(dev) <= t[7] else min(max(dev * t[4], t[5]), t[6])
    ax = abs(x)
    if x >= 0.0:  # coefficients zero-padded to degree 5
        return t[8] + ax * (t[9] + ax * (t[10] + ax * (t[11] + ax * (t[12] + ax * t[13]))))
    return -(t[14] + ax * (t[15] + ax * (t[16] + ax * (t[17] + ax * (t[18] + ax * t[19])))))


__all__ = [
    "C_STERN", "KT_DISK_RATIOS", "KT_TERMS", "MU2018_TABLE2", "PodThrust", "Propeller",
    "TwinThrust", "advance_ratio", "froude_number", "hollo_thrust_deduction", "holtrop_c10",
    "kt", "kt_nb", "kt_quadratic_nb", "kt_regression", "kt_thrust_nb", "lagrange_weights",
    "pod_thrust_nb", "propeller_thrust_nb",
    "wake_fraction", "THRUST_ROW", "THRUST_LAWS", "thrust_row",
    "thrust_nb",
]

THRUST_LAWS.update(propeller=Propeller, pod_thrust=PodThrust, twin_thrust=TwinThrust)
