"""3-DOF surge-sway-yaw model with one stern vector thruster (Mu et al. 2018, section 4.1).

Fossen form (Mu et al. 2018, eq. 13): ``M nu' + C(nu) nu + D nu = tau``, nu = (u, v, r)::

    M = [[m11, 0, 0], [0, m22, m23], [0, m32, m33]]
    C(nu) = [[0, 0, -(m22 v + m23 r)], [0, 0, m11 u], [m22 v + m23 r, -m11 u, 0]]
    D = [[d11, 0, 0], [0, d22, d23], [0, d32, d33]]

(m11 = m - X_u', m22 = m - Y_v', m23 = m x_g - Y_r', m32 = m x_g - N_v', m33 = I_z - N_r';
d11 = -X_u, d22 = -Y_v, d23 = -Y_r, d32 = -N_v, d33 = -N_r). Under Assumption 1 (m23 = m32 =
d23 = d32 = 0) this is eq. 17 (signs restored); eq. 37, the identified Lanxin model printed with
its signs lost, reads ``u' = 1.065245 v r - 0.3197455 u + 0.000377 tau_u``,
``v' = -0.938753 u r - 3.5 v``, ``r' = -0.041187 u v - 5.407752 r + 0.000238 tau_r``: with
m11 = 1/0.000377, m22 = 1.065245 m11, m11/m22 = 0.938753 and (m22 - m11)/m33 =
173.06 * 0.000238 = 0.04119 it is consistent with eq. 17 to four digits, which is how the signs
are read (tests/test_threedof.py).

Vector thruster at x_l [m] behind the pivot, angle delta [rad] (positive delta makes r > 0):
``tau = (T cos delta, -T sin delta, x_l T sin delta)`` (Mu et al. 2018 eq. 14 with the usvid sign
convention); tau_v is neglected as in eq. 17 unless ``sway_force``. The thrust T [N] is the
thrust law ``thrust`` (propeller of eq. 1: ``(1 - t_P) rho n |n| D^4 K_T(J)``; POD law of Mu et
al. 2016: ``c u n + d |n| n``; or a constant [N]) at the shaft speed n [rps] (input, or the
nominal ``n``). ``thrust = None`` is a constant thrust holding the approach speed (T = d11 U).

Particulars for identification (format spec ``vessel.extra`` or CLI options): ``x_l`` [m];
the thrust law from ``propeller_diameter`` [m], ``propeller_pitch_ratio``,
``propeller_disk_ratio``, ``thrust_deduction``, ``wake_fraction``, ``water_density`` [kg/m^3],
or ``pod_c``, ``pod_d``; the nominal shaft speed ``shaft_speed_rps`` (default: the median
measured n).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError
from usvid.models.kind import (
    Dynamics,
    ModelKind,
    Regression,
    in_newtons,
    param,
    rows,
    submodel,
)
from usvid.models.kinds import _fossen
from usvid.models.thrust import THRUST_ROW, thrust_nb, thrust_row

#: Mu et al. 2018 eq. 37 (Lanxin USV, 7.02 m), our sign reading; x_l is not printed.
MU2018_EQ37 = {
    "a_vr": 1.065245, "a_u": -0.3197455, "a_tau": 0.000377,
    "b_ur": -0.938753, "b_v": -3.5,
    "c_uv": -0.041187, "c_r": -5.407752, "c_tau": 0.000238,
}


@dataclass
class ThreeDOF(Dynamics):
    """3-DOF vector-thruster model (Mu et al. 2018, eq. 13-17), SI units."""

    m11: Any = param("kg", "surge mass m - X_u'", gt=0.0)
    m22: Any = param("kg", "sway mass m - Y_v'", gt=0.0)
    m33: Any = param("kg m^2", "yaw inertia I_z - N_r'", gt=0.0)
    d11: Any = param("kg/s", "surge damping -X_u")
    d22: Any = param("kg/s", "sway damping -Y_v")
    d33: Any = param("kg m^2/s", "yaw damping -N_r")
    x_l: Any = param("m", "thruster arm behind the pivot", fit=False)
    m23: Any = param("kg m", "sway-yaw inertia coupling m x_g - Y_r' (0: Assumption 1)",
                     fit=False, default=0.0)
    m32: Any = param("kg m", "yaw-sway inertia coupling m x_g - N_v' (0: Assumption 1)",
                     fit=False, default=0.0)
    d23: Any = param("kg m/s", "sway-yaw damping -Y_r (0: Assumption 1)", fit=False,
                     default=0.0)
    d32: Any = param("kg m/s", "yaw-sway damping -N_v (0: Assumption 1)", fit=False,
                     default=0.0)
    thrust: Any = submodel("thrust", "thrust law: a number [N], propeller or pod_thrust; "
                           "null holds the approach speed")
    n: Any = param("rps", "nominal shaft speed", fit=False, default=None)
    sway_force: bool = False
    kind: ClassVar[str] = "threedof"

    def validate(self) -> None:
        _fossen.positive_masses(self)

    @classmethod
    def from_regression(cls, a_vr: float, a_u: float, a_tau: float, b_ur: float, b_v: float,
                        c_uv: float, c_r: float, c_tau: float, x_l: float, *,
                        rtol: float = 0.01, strict: bool = True, **kw: Any) -> ThreeDOF:
        """From the eq. 37 coefficients; with ``strict`` the implied b_ur, c_uv must agree
        within ``rtol`` (the 8-coefficient form is otherwise not a Fossen model)."""
        model = cls(**_fossen.fossen_from_regression(a_vr, a_u, a_tau, b_v, c_r, c_tau),
                    x_l=x_l, **kw)
        if strict:
            implied = model.regression_coefficients()
            for name, given in (("b_ur", b_ur), ("c_uv", c_uv)):
                want = implied[name]
                if abs(given - want) > rtol * max(abs(want), 1e-12):
                    raise IdentificationError(
                        f"regression coefficient {name}={given!r} is inconsistent with the "
                        f"other coefficients (Fossen form implies {want:.6g}; rtol {rtol})")
        return model

    def regression_coefficients(self) -> dict[str, Any]:
        """The eq. 37 coefficients of this model (requires Assumption 1)."""
        if any(np.any(np.asarray(getattr(self, k)) != 0) for k in ("m23", "m32", "d23", "d32")):
            raise IdentificationError("regression form needs m23 = m32 = d23 = d32 = 0 "
                                      "(Assumption 1)")
        return _fossen.regression_coefficients(self.values())

    def thrust_at(self, u: Any, n: Any = None) -> np.ndarray:
        """Thrust T [N] at surge speed u [m/s] and shaft speed n [rps] (default ``self.n``)."""
        return _fossen.thrust_of(self.thrust, u, self.n if n is None else n)


# P rows: 0-5 m11 m22 m33 d11 d22 d33, 6-9 m23 m32 d23 d32, 10 x_l, 11 sway, 12 n,
# 13 1/m11, 14 1/det, 15-34 thrust law, 35 the switch row: the thrust law's mode when the model is
# uncoupled (Assumption 1: m23 = m32 = d23 = d32 = 0, and no sway force), else -1
_T0 = 15
_SW = _T0 + THRUST_ROW


@numba.njit(cache=True, forceinline=True)
def _thrust_law(p, mode):
    """The packed thrust law (``thrust_row``) of a lane's parameter tuple, its mode ``mode``."""
    return (mode, p[16], p[17], p[18], p[19], p[20], p[21], p[22], p[23], p[24],
            p[25], p[26], p[27], p[28], p[29], p[30], p[31], p[32], p[33], p[34])


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """Eq. 13 with the vector thruster (module docstring) and the external force f = (X, Y, K,
    N) [N, N, N m, N m] (K unused: no roll); returns (u, v, r, (u', v', r')).

    An uncoupled model (switch row ``_SW`` >= 0) takes the equations without the vanishing
    coupling terms; with the switch row a constant (the core's vector step of a switch value)
    only that branch and that thrust law are compiled."""
    u = s[0]
    v = s[1]
    r = s[2]
    n = a[3]
    nn = p[12] if np.isnan(n) else n
    sw = p[_SW]
    plain = sw >= 0.0
    T = thrust_nb(_thrust_law(p, sw if plain else p[_T0]), u, nn)
    tu = T * a[1]
    tr = p[10] * T * a[2]
    m11 = p[0]
    m22 = p[1]
    m33 = p[2]
    if plain:
        c = m22 * v
        f1 = tu + c * r - p[3] * u + f[0]
        f2 = -(m11 * u * r) - p[4] * v + f[1]
        f3 = tr - c * u + m11 * u * v - p[5] * r + f[3]
        return u, v, r, (f1 * p[13], m33 * f2 * p[14], m22 * f3 * p[14])
    tv = -T * a[2] * p[11]
    m23 = p[6]
    m32 = p[7]
    c = m22 * v + m23 * r
    f1 = tu + c * r - p[3] * u + f[0]
    f2 = tv - m11 * u * r - p[4] * v - p[8] * r + f[1]
    f3 = tr - c * u + m11 * u * v - p[9] * v - p[5] * r + f[3]
    return u, v, r, (f1 * p[13], (m33 * f2 - m23 * f3) * p[14], (m22 * f3 - m32 * f2) * p[14])


def pack(d: ThreeDOF, speed: Any) -> np.ndarray:
    m11, m22, m33 = (np.asarray(getattr(d, k), float) for k in ("m11", "m22", "m33"))
    m23, m32 = np.asarray(d.m23, float), np.asarray(d.m32, float)
    T0 = None
    if d.thrust is None:
        if speed is None:
            raise IdentificationError("a threedof model with thrust=null needs an approach "
                                      "speed (vessel.speed or --speed): T = d11 U")
        T0 = np.asarray(d.d11, float) * np.asarray(speed, float)
    n0 = 0.0 if d.n is None else d.n
    law = thrust_row(d.thrust, T0)
    plain = ((m23 == 0.0) & (m32 == 0.0) & (np.asarray(d.d23, float) == 0.0)
             & (np.asarray(d.d32, float) == 0.0) & (not d.sway_force))
    return rows([d.m11, d.m22, d.m33, d.d11, d.d22, d.d33, d.m23, d.m32, d.d23, d.d32, d.x_l,
                 1.0 if d.sway_force else 0.0, n0, 1.0 / m11, 1.0 / (m22 * m33 - m23 * m32),
                 *law, np.where(plain, law[0], -1.0)])


def straight_speed(d: ThreeDOF) -> Any:
    """Straight-line speed [m/s] at the nominal shaft speed: root of T(u) = d11 u."""
    return _fossen.straight_speed(d.thrust, d.n, d.d11)


def particulars(vessel: Any, data: Sequence[Mapping[str, np.ndarray]],
                options: Mapping[str, Any]) -> dict[str, Any]:
    """x_l, the thrust law and the nominal shaft speed (module docstring); IdentificationError
    naming what is missing."""
    x_l = _fossen.extra_number(vessel, options, "x_l")
    if x_l is None:
        raise IdentificationError(
            "model 'threedof' needs the thruster arm x_l [m] behind the pivot: give --x-l or "
            "vessel.extra.x_l in the format spec")
    return {"x_l": x_l, **_fossen.thrust_particulars("threedof", vessel, data, options)}


def series(s: dict[str, np.ndarray], fixed: Mapping[str, Any]) -> None:
    """tau_u = T cos delta, tau_r = x_l T sin delta [N, N m] from the thrust law at the measured
    n and u (or a measured thrust channel)."""
    if "tau_u" in s and "tau_r" in s:
        return
    if "delta" not in s:
        raise IdentificationError("model 'threedof' needs channel 'delta' (thruster angle)")
    if "thrust" not in s and "n" not in s:
        raise IdentificationError("model 'threedof' needs channel 'n' [rps] (or tau_u/tau_r, "
                                  "or a thrust channel)")
    T = _fossen.thrust_series("threedof", s, fixed)
    s["tau_u"] = T * np.cos(s["delta"])
    s["tau_r"] = fixed["x_l"] * T * np.sin(s["delta"])


KIND = ModelKind(
    name="threedof",
    title="3-DOF Fossen model, vector thruster",
    equation="M nu' + C(nu) nu + D nu = tau; tau = (T cos delta, 0, x_l T sin delta)",
    reference="Mu et al. 2018, eq. 13-17 and 37",
    dynamics=ThreeDOF,
    states=("u", "v", "r"),
    body=(0, 1, 2),
    inputs=("delta", "n"),
    rhs=rhs,
    pack=pack,
    speed=straight_speed,
    outputs=("u", "v", "r", "psi"),
    regression=Regression(_fossen.blocks, _fossen.to_params, _fossen.coefficients,
                          needs=("delta", "u", "v"), external=in_newtons),
    fit_space=_fossen.FIT_SPACE,
    particulars=particulars,
    series=series,
    uses_trig=True,
    # an uncoupled model's thrust law (a constant thrust: null or a number, a propeller, a pod
    # law) has vector steps of its own (the coupled models and other laws: the generic one)
    switch_row=_SW,
    switch_values=(0.0, 1.0, 2.0),
)

__all__ = ["KIND", "MU2018_EQ37", "THRUST_ROW", "ThreeDOF"]
