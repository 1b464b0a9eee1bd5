"""4-DOF surge-sway-roll-yaw model with one vector thruster (Fossen 2021, ch. 6-7; Blanke &
Christensen 1993).

Fossen's matrix form (Fossen 2021, eq. 6.3 / 7.1: ``M nu' + C(nu) nu + D nu + g(eta) = tau``)
in four degrees of freedom, nu = (u, v, p, r), eta = (x, y, phi, psi), the heave and pitch
constrained (w = q = 0, theta = 0), as the 4-DOF manoeuvring models of Blanke & Christensen
(1993, "Rudder-roll damping autopilot robustness to sway-yaw-roll couplings", 10th Ship
Control Systems Symposium, Ottawa) and Fossen 2021 ch. 7.3 (with the Son & Nomoto 1982
container ship)::

    M = [[m11, 0,   0,   0  ],     m11 = m - X_u',   m22 = m - Y_v',   m44 = I_x - K_p',
         [0,   m22, m24, m26],     m66 = I_z - N_r',  m24 = -m z_G - Y_p',
         [0,   m24, m44, 0  ],     m26 = m x_G - Y_r'  (' : added-mass derivatives)
         [0,   m26, 0,   m66]]

C(nu) nu from M by Fossen 2021 Theorem 3.2 (rigid body and added mass, with the rigid body's
surge-pitch coupling m z_G, ``mzg``), D nu linear damping (d11 = -X_u, d22 = -Y_v, d24 = -Y_p,
d26 = -Y_r, d42 = -K_v, d44 = -K_p, d46 = -K_r, d62 = -N_v, d64 = -N_p, d66 = -N_r) and the
hydrostatic roll restoring ``g = w_gm sin phi`` (w_gm = rho g nabla GM_T: Fossen 2021 ch. 4,
the restoring moment rho g nabla GM_T sin phi cos theta, theta = 0); the force balance, solved
for the accelerations::

    m11 u'                         = X + (m22 v + m24 p + m26 r) r - d11 u
    m22 v' + m24 p' + m26 r'       = Y - m11 u r - d22 v - d24 p - d26 r
    m24 v' + m44 p'                = K + mzg u r - d42 v - d44 p - d46 r - w_gm sin phi
    m26 v' + m66 r'                = N - (m22 v + m24 p + m26 r) u + m11 u v - mzg u p
                                       - d62 v - d64 p - d66 r
    phi' = p

Kinematics (Fossen 2021 ch. 2, the Euler-angle transformation with w = q = theta = 0, as in
the 4-DOF models of its ch. 7): ``x' = u cos psi - v cos phi sin psi``,
``y' = u sin psi + v cos phi cos psi``, ``psi' = r cos phi`` (the velocities the core
integrates are u, v cos phi, r cos phi).

Actuator: one vector thruster (or an equivalent rudder force) at x_l [m] behind the pivot and
z_l [m] below the roll axis, angle delta [rad] (positive delta makes r > 0): ``X = T cos delta``,
``Y = -T sin delta``, ``K = -z_l Y``, ``N = x_l T sin delta`` (Mu et al. 2018 eq. 14 with the
side force), plus the external force f = (X, Y, K, N). The thrust T [N] is the thrust law
``thrust`` (as the kind ``threedof``: a number, a propeller or a pod law at the shaft speed n
[rps]; null: the constant thrust holding the approach speed, T = d11 U).

Roll sign (usvid): phi > 0 is heel to starboard. In a steady turn to starboard (r > 0) a
vessel whose centre of gravity is above the roll axis (z_G < 0, ``mzg`` < 0) heels outward, to
port: at rest in the turn (p = v' = p' = r' = 0) the roll equation gives
``w_gm sin phi = -z_l T sin delta + mzg u r - d42 v - d46 r`` (:func:`steady_heel`).

Roll alone (no coupling, at rest) is the oscillator ``m44 phi'' + d44 phi' + w_gm sin phi = 0``:
natural frequency ``sqrt(w_gm/m44)``, damping ratio ``d44 / (2 sqrt(w_gm m44))``; with the sway
free (m24 != 0, no sway damping at rest) the roll inertia is ``m44 - m24^2/m22``. For Blanke &
Christensen's 51.5 m naval vessel (I_x = 2.3763e6 kg m^2, K_p' = -774000 kg m^2, nabla 357
m^3, rho 1014 kg/m^3, GM_T 1.1 m, K_p = -500000 kg m^2/s; their published coefficients as
tabulated in the MSS toolbox's ``navalvessel.m``) that is a natural roll period of 5.64 s
(5.06 s with the sway free) and a damping ratio of 0.071 (tests/test_fourdof.py).

Identification: the force balance above is linear in the nine fitted parameters (m11, m22,
m44, m66, d11, d22, d44, d66, w_gm) once the couplings (m24, m26, d24, d26, d42, d46, d62, d64,
mzg), the thruster position and the thrust law are held (format spec ``vessel.extra`` or
options: ``x_l``, ``z_l``, the thrust law as for ``threedof``; the couplings by their names,
default 0): one least-squares regression of the four equations, each scaled by its force
level, on the smoothed u, v, r, roll rate p (logged, or the roll angle's derivative) and roll
angle phi (the Trial's ``phi`` channel) and their derivatives. Output error refines the same
nine parameters on u, v, r, psi and phi.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError, UsvidError
from usvid.models.kind import Block, Dynamics, ModelKind, Regression, param, rows, submodel
from usvid.models.kinds import _fossen
from usvid.models.thrust import thrust_nb, thrust_row

#: Parameters identification estimates (the force balance is linear in them).
FITTED = ("m11", "m22", "m44", "m66", "d11", "d22", "d44", "d66", "w_gm")
#: The couplings identification holds (format spec ``vessel.extra`` by name; default 0).
COUPLINGS = ("m24", "m26", "d24", "d26", "d42", "d46", "d62", "d64", "mzg")


@dataclass
class FourDOF(Dynamics):
    """4-DOF surge-sway-roll-yaw Fossen model with one vector thruster (module docstring), SI."""

    m11: Any = param("kg", "surge mass m - X_u'", gt=0.0)
    m22: Any = param("kg", "sway mass m - Y_v'", gt=0.0)
    m44: Any = param("kg m^2", "roll inertia I_x - K_p'", gt=0.0)
    m66: Any = param("kg m^2", "yaw inertia I_z - N_r'", gt=0.0)
    d11: Any = param("kg/s", "surge damping -X_u")
    d22: Any = param("kg/s", "sway damping -Y_v")
    d44: Any = param("kg m^2/s", "roll damping -K_p")
    d66: Any = param("kg m^2/s", "yaw damping -N_r")
    w_gm: Any = param("N m/rad", "roll restoring rho g nabla GM_T (displacement times the "
                      "transverse metacentric height)", gt=0.0)
    x_l: Any = param("m", "thruster arm behind the pivot", fit=False)
    z_l: Any = param("m", "thruster (side force) depth below the roll axis", fit=False,
                     default=0.0)
    m24: Any = param("kg m", "sway-roll inertia coupling -m z_G - Y_p'", fit=False, default=0.0)
    m26: Any = param("kg m", "sway-yaw inertia coupling m x_G - Y_r'", fit=False, default=0.0)
    d24: Any = param("kg m/s", "sway damping by roll rate -Y_p", fit=False, default=0.0)
    d26: Any = param("kg m/s", "sway damping by yaw rate -Y_r", fit=False, default=0.0)
    d42: Any = param("kg m/s", "roll damping by sway -K_v", fit=False, default=0.0)
    d46: Any = param("kg m^2/s", "roll damping by yaw rate -K_r", fit=False, default=0.0)
    d62: Any = param("kg m/s", "yaw damping by sway -N_v", fit=False, default=0.0)
    d64: Any = param("kg m^2/s", "yaw damping by roll rate -N_p", fit=False, default=0.0)
    mzg: Any = param("kg m", "m z_G: mass times the centre of gravity's depth below the roll "
                     "axis (negative above it)", fit=False, default=0.0)
    thrust: Any = submodel("thrust", "thrust law: a number [N], propeller or pod_thrust; "
                           "null holds the approach speed")
    n: Any = param("rps", "nominal shaft speed", fit=False, default=None)
    kind: ClassVar[str] = "fourdof"

    def validate(self) -> None:
        m22, m44, m66 = (np.asarray(getattr(self, k), float) for k in ("m22", "m44", "m66"))
        m24, m26 = np.asarray(self.m24, float), np.asarray(self.m26, float)
        det = m22 * m44 * m66 - m24 * m24 * m66 - m26 * m26 * m44
        if not np.all(det > 0):
            raise UsvidError("parameters: the sway-roll-yaw mass matrix [[m22, m24, m26], "
                             "[m24, m44, 0], [m26, 0, m66]] must be positive definite "
                             f"(determinant {det!r})")


# P rows (names, in order); then the inverse of the sway-roll-yaw mass matrix, then the thrust law
_ROWS = ("m11", "m22", "d11", "d22", "d44", "d66", "w_gm", "x_l", "z_l", "m24", "m26", "d24",
         "d26", "d42", "d46", "d62", "d64", "mzg", "n")
(_M11, _M22, _D11, _D22, _D44, _D66, _WGM, _XL, _ZL, _M24, _M26, _D24, _D26, _D42, _D46, _D62,
 _D64, _MZG, _N) = range(len(_ROWS))
#: Then 1/m11 and the entries of the inverse of the sway-roll-yaw mass matrix, then the thrust law.
_I11, _I22, _I24, _I26, _I44, _I46, _I66 = range(len(_ROWS), len(_ROWS) + 7)
_T0 = _I66 + 1


@numba.njit(cache=True, forceinline=True)
def _thrust_law(p):
    """The packed thrust law (``thrust_row``) of a lane's parameter tuple."""
    return (p[26], p[27], p[28], p[29], p[30], p[31], p[32], p[33], p[34], p[35], p[36],
            p[37], p[38], p[39], p[40], p[41], p[42], p[43], p[44], p[45])


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """The force balance of the module docstring; returns (u, v cos phi, r cos phi,
    (u', v', r', p', phi'))."""
    u = s[0]
    v = s[1]
    r = s[2]
    q = s[3]  # roll rate p
    phi = s[4]
    n = a[3]
    T = thrust_nb(_thrust_law(p), u, p[_N] if np.isnan(n) else n)
    ts = T * a[2]
    c = p[_M22] * v + p[_M24] * q + p[_M26] * r
    X = T * a[1] + f[0] + c * r - p[_D11] * u
    Y = f[1] - ts - p[_M11] * u * r - p[_D22] * v - p[_D24] * q - p[_D26] * r
    K = (f[2] + p[_ZL] * ts + p[_MZG] * u * r - p[_D42] * v - p[_D44] * q - p[_D46] * r
         - p[_WGM] * math.sin(phi))
    N = (f[3] + p[_XL] * ts - c * u + p[_M11] * u * v - p[_MZG] * u * q - p[_D62] * v
         - p[_D64] * q - p[_D66] * r)
    dv = p[_I22] * Y + p[_I24] * K + p[_I26] * N
    dp = p[_I24] * Y + p[_I44] * K + p[_I46] * N
    dr = p[_I26] * Y + p[_I46] * K + p[_I66] * N
    cp = math.cos(phi)
    return u, v * cp, r * cp, (X * p[_I11], dv, dr, dp, q)


def _inverse(d: FourDOF) -> list[np.ndarray]:
    """1/m11 and the entries (22, 24, 26, 44, 46, 66) of the inverse of the symmetric
    sway-roll-yaw mass matrix [[m22, m24, m26], [m24, m44, 0], [m26, 0, m66]] (cofactors)."""
    m22, m44, m66, m24, m26 = (np.asarray(getattr(d, k), float)
                               for k in ("m22", "m44", "m66", "m24", "m26"))
    det = m22 * m44 * m66 - m24 * m24 * m66 - m26 * m26 * m44
    return [1.0 / np.asarray(d.m11, float), m44 * m66 / det, -m24 * m66 / det,
            -m26 * m44 / det, (m22 * m66 - m26 * m26) / det, m24 * m26 / det,
            (m22 * m44 - m24 * m24) / det]


def pack(d: FourDOF, speed: Any) -> np.ndarray:
    T0 = None
    if d.thrust is None:
        if speed is None:
            raise IdentificationError("a fourdof model with thrust=null needs an approach "
                                      "speed (vessel.speed or --speed): T = d11 U")
        T0 = np.asarray(d.d11, float) * np.asarray(speed, float)
    values = {k: getattr(d, k) for k in _ROWS}
    values["n"] = 0.0 if d.n is None else d.n
    return rows([values[k] for k in _ROWS] + _inverse(d) + thrust_row(d.thrust, T0))


def steady_heel(d: FourDOF, u: Any, v: Any, r: Any, delta: Any = 0.0, T: Any = None) -> Any:
    """Heel phi [rad] of a steady turn at u, v [m/s], r [rad/s] (p = 0, no accelerations) with
    the thruster at delta [rad] and thrust T [N] (default the thrust law at u): ``w_gm sin phi =
    z_l T sin delta + mzg u r - d42 v - d46 r`` (the roll row of the force balance)."""
    if T is None:
        T = _fossen.thrust_of(d.thrust, u, d.n) if d.thrust is not None else 0.0
    moment = (np.asarray(d.z_l) * T * np.sin(delta) + np.asarray(d.mzg) * u * r
              - np.asarray(d.d42) * v - np.asarray(d.d46) * r)
    return np.arcsin(moment / np.asarray(d.w_gm, float))


def straight_speed(d: FourDOF) -> Any:
    """Straight-line speed [m/s] at the nominal shaft speed: root of T(u) = d11 u."""
    return _fossen.straight_speed(d.thrust, d.n, d.d11)


def particulars(vessel: Any, data: Sequence[Mapping[str, np.ndarray]],
                options: Mapping[str, Any]) -> dict[str, Any]:
    """x_l, z_l, the held couplings (module docstring; default 0), the thrust law and the
    nominal shaft speed; IdentificationError naming what is missing."""
    num = _fossen.extra_number
    x_l = num(vessel, options, "x_l")
    if x_l is None:
        raise IdentificationError(
            "model 'fourdof' needs the thruster arm x_l [m] behind the pivot: give --x-l or "
            "vessel.extra.x_l in the format spec")
    out: dict[str, Any] = {"x_l": x_l, "z_l": num(vessel, options, "z_l") or 0.0}
    for k in COUPLINGS:
        out[k] = num(vessel, options, k) or 0.0
    return {**out, **_fossen.thrust_particulars("fourdof", vessel, data, options)}


def series(s: dict[str, np.ndarray], fixed: Mapping[str, Any]) -> None:
    """The thrust T [N] along the trial (``thrust_s``: a thrust channel, else the thrust law at
    the measured n and u)."""
    if "delta" not in s:
        raise IdentificationError("model 'fourdof' needs channel 'delta' (thruster angle)")
    s["thrust_s"] = _fossen.thrust_series("fourdof", s, fixed)


def _blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
            h: float) -> list[Block]:
    """The four rows of the force balance, linear in :data:`FITTED` with the couplings held
    (module docstring), stacked and each equation scaled by its force level (the RMS of its
    known side)."""
    c = {k: float(fixed.get(k, 0.0)) for k in COUPLINGS}
    eqs: list[list[tuple[np.ndarray, np.ndarray]]] = [[], [], [], []]
    for s in series:
        u, v, r, p, phi = (s[k + "_s"] for k in ("u", "v", "r", "p", "phi"))
        ud, vd, rd, pd = (s[k + "dot_s"] for k in ("u", "v", "r", "p"))
        T = s["thrust_s"]
        ts = T * np.sin(s["delta"])
        z = np.zeros_like(u)
        # columns: m11 m22 m44 m66 d11 d22 d44 d66 w_gm
        eqs[0].append((np.column_stack([ud, -v * r, z, z, u, z, z, z, z]),
                       T * np.cos(s["delta"]) + (c["m24"] * p + c["m26"] * r) * r))
        eqs[1].append((np.column_stack([u * r, vd, z, z, z, v, z, z, z]),
                       -ts - c["m24"] * pd - c["m26"] * rd - c["d24"] * p - c["d26"] * r))
        eqs[2].append((np.column_stack([z, z, pd, z, z, z, p, z, np.sin(phi)]),
                       float(fixed.get("z_l", 0.0)) * ts - c["m24"] * vd + c["mzg"] * u * r
                       - c["d42"] * v - c["d46"] * r))
        eqs[3].append((np.column_stack([-u * v, u * v, z, rd, z, z, z, r, z]),
                       float(fixed["x_l"]) * ts - c["m26"] * vd - (c["m24"] * p + c["m26"] * r)
                       * u - c["mzg"] * u * p - c["d62"] * v - c["d64"] * p))
    Phi, y, trial_rows = [], [], []
    for parts in eqs:
        yy = np.concatenate([q[1] for q in parts])
        scale = 1.0 / max(float(np.sqrt(np.mean(yy * yy))), 1e-12)
        Phi.append(np.concatenate([q[0] for q in parts]) * scale)
        y.append(yy * scale)
        trial_rows += [len(q[1]) for q in parts]
    return [Block("force balance", np.concatenate(Phi), np.concatenate(y), FITTED, trial_rows)]


def _to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
               h: float) -> dict[str, float]:
    bad = [k for k in ("m11", "m22", "m44", "m66", "w_gm") if not th[k] > 0.0]
    if bad:
        raise IdentificationError(
            f"fourdof: least squares gives {', '.join(f'{k} = {th[k]:.4g}' for k in bad)} "
            "(must be > 0): the data do not excite that motion (roll needs the roll angle "
            "phi in the logs and turns or zig-zags that heel the vessel)")
    return {k: float(th[k]) for k in FITTED}


KIND = ModelKind(
    name="fourdof",
    title="4-DOF Fossen model (surge, sway, roll, yaw), vector thruster",
    equation="M nu' + C(nu) nu + D nu + g(phi) = tau, nu = (u, v, p, r); "
             "tau = (T cos delta, -T sin delta, z_l T sin delta, x_l T sin delta)",
    reference="Fossen 2021, eq. 6.3 and ch. 7; Blanke & Christensen 1993",
    dynamics=FourDOF,
    states=("u", "v", "r", "p", "phi"),
    body=(0, 1, 2),
    inputs=("delta", "n"),
    rhs=rhs,
    pack=pack,
    speed=straight_speed,
    outputs=("u", "v", "r", "psi", "phi"),
    regression=Regression(_blocks, _to_params, needs=("delta", "u", "v", "phi")),
    particulars=particulars,
    series=series,
    uses_trig=True,
)

__all__ = ["COUPLINGS", "FITTED", "KIND", "FourDOF", "steady_heel"]
