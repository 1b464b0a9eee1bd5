"""Twin-thruster catamaran, 3-DOF (the catamaran paper; standard published Fossen/MMG form).

That paper's equations are mostly lost in the extracted text; usvid uses the diagonal Fossen form
(the reduction of Mu et al. 2018, eq. 17) with a differential-thrust yaw moment::

    m11 u' = m22 v r - d11 u + tau_u
    m22 v' = -m11 u r - d22 v
    m33 r' = (m11 - m22) u v - d33 r + tau_r
    tau_u = T_port + T_stbd,   tau_r = (T_port - T_stbd) arm

``arm`` [m] is each thruster's distance from the centreline: the catamaran paper's symbol in
its yaw moment (eq. 27, "the distance from the two thrusters to the ship's central axis"), so
the paper's value is entered as ``arm``. ``b`` [m] is the distance between the two thrusters
(spacing; arm = b/2), the parameter usvid read before: model files with ``b`` keep loading
and mean the same moment; give one of the two (both: they must agree). ARCHITECTURE.md sign
convention: more port thrust turns the vessel to starboard, r > 0.

Each thruster's thrust comes from its command c (control code 0..120, PWM [us] or shaft
speed): ``thrust`` is a
:class:`usvid.models.thrust.TwinThrust` (code -> voltage -> thrust, or PWM -> thrust) or a
number k [N per command unit] (T = k c). Standard manoeuvres steer through a rudder-equivalent
angle delta [rad]: ``c_port = cmd + steer_gain delta``, ``c_stbd = cmd - steer_gain delta``
(positive delta -> more port thrust -> r > 0); measured commands ``n_port``/``n_stbd`` replace
them when replayed.

Particulars for identification (format spec ``vessel.extra`` or options): ``thruster_arm`` [m]
(each thruster's distance from the centreline) or ``thruster_spacing`` b [m] (one required);
``thrust_per_command`` k [N per command unit] (default 1: thrust, masses and dampings then in
command units, which is all the commands can determine); ``nominal_command``
(default: the median mean command of the training data); ``steer_gain`` [command per rad]
(default: half the largest differential command of the data per 35 deg).
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
from usvid.models.kind import Dynamics, ModelKind, Regression, param, rows, submodel
from usvid.models.kinds import _fossen
from usvid.models.thrust import TwinThrust, thrust_nb, thrust_row


@dataclass
class Catamaran(Dynamics):
    """Twin-thruster catamaran (SI): masses, dampings, thruster spacing b, thrust law,
    nominal command and steering gain."""

    m11: Any = param("kg", "surge mass", gt=0.0)
    m22: Any = param("kg", "sway mass", gt=0.0)
    m33: Any = param("kg m^2", "yaw inertia", gt=0.0)
    d11: Any = param("kg/s", "surge damping")
    d22: Any = param("kg/s", "sway damping")
    d33: Any = param("kg m^2/s", "yaw damping")
    b: Any = param("m", "distance between the two thrusters (spacing, = 2 arm; or give arm)",
                   fit=False, gt=0.0, default=None)
    thrust: Any = submodel("thrust", "thrust of one thruster: k [N per command unit] or "
                           "twin_thrust", default=1.0)
    cmd: Any = param("command", "nominal command of each thruster", fit=False, default=0.0)
    steer_gain: Any = param("command/rad", "differential command per radian of "
                            "rudder-equivalent steering", fit=False, default=0.0)
    arm: Any = param("m", "each thruster's distance from the centreline (the catamaran "
                     "paper's symbol, = b/2; or give b)", fit=False, gt=0.0, default=None)
    kind: ClassVar[str] = "catamaran"

    @classmethod
    def example(cls) -> Catamaran:
        """A valid parameter set (every required parameter 1.0, arm 0.5 m)."""
        return cls(m11=1.0, m22=1.0, m33=1.0, d11=1.0, d22=1.0, d33=1.0, arm=0.5)

    def validate(self) -> None:
        if self.arm is None and self.b is None:
            raise UsvidError("parameters.arm (each thruster's distance from the centreline "
                             "[m]) or parameters.b (the spacing between the thrusters [m]) is "
                             "required")
        if self.arm is not None and self.b is not None and not np.allclose(
                np.asarray(self.arm, float), 0.5 * np.asarray(self.b, float), rtol=1e-9):
            raise UsvidError(f"parameters.arm ({self.arm!r} m, from the centreline) and "
                             f"parameters.b ({self.b!r} m, the spacing) disagree: arm must be "
                             "b/2; give only one")

    @property
    def half_spacing(self) -> Any:
        """Each thruster's distance from the centreline [m]: ``arm``, else ``b / 2``."""
        return self.arm if self.arm is not None else 0.5 * np.asarray(self.b, float)

    def thruster_thrust(self, c: Any) -> np.ndarray:
        """Thrust [N] of one thruster at command c (TwinThrust, or k c)."""
        if hasattr(self.thrust, "thrust"):
            return np.asarray(self.thrust.thrust(c), dtype=float)
        return np.asarray(self.thrust, dtype=float) * np.asarray(c, dtype=float)

    def tau(self, c_port: Any, c_stbd: Any) -> tuple[np.ndarray, np.ndarray]:
        """(tau_u [N], tau_r [N m]) = (T_p + T_s, (T_p - T_s) arm), arm = b/2."""
        Tp, Ts = self.thruster_thrust(c_port), self.thruster_thrust(c_stbd)
        return Tp + Ts, (Tp - Ts) * np.asarray(self.half_spacing, float)

    def commands(self, delta: Any) -> tuple[np.ndarray, np.ndarray]:
        """(c_port, c_stbd) for a rudder-equivalent steering angle delta [rad]."""
        d = np.asarray(delta, dtype=float)
        g = np.asarray(self.steer_gain)
        return np.asarray(self.cmd) + g * d, np.asarray(self.cmd) - g * d


# P rows: 0-5 m11 m22 m33 d11 d22 d33, 6 arm (= b/2), 7 cmd, 8 steer_gain, 9-11 1/m11 1/m22 1/m33,
# 12.. thrust law
_T0 = 12


@numba.njit(cache=True, forceinline=True)
def _thrust_law(p):
    """The packed thrust law (``thrust_row``) of a lane's parameter tuple."""
    return (p[12], p[13], p[14], p[15], p[16], p[17], p[18], p[19], p[20], p[21],
            p[22], p[23], p[24], p[25], p[26], p[27], p[28], p[29], p[30], p[31])


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """Module docstring equations with the external force f = (X, Y, K, N) [N, N, N m, N m]
    (K unused: no roll); returns (u, v, r, (u', v', r'))."""
    u = s[0]
    v = s[1]
    r = s[2]
    delta = a[0]
    cp = p[7] + p[8] * delta if np.isnan(a[4]) else a[4]
    cs = p[7] - p[8] * delta if np.isnan(a[5]) else a[5]
    law = _thrust_law(p)
    Tp = thrust_nb(law, u, cp)
    Ts = thrust_nb(law, u, cs)
    m11 = p[0]
    m22 = p[1]
    return u, v, r, ((m22 * v * r - p[3] * u + Tp + Ts + f[0]) * p[9],
                     (-m11 * u * r - p[4] * v + f[1]) * p[10],
                     ((m11 - m22) * u * v - p[5] * r + (Tp - Ts) * p[6] + f[3]) * p[11])


def _law(thrust: Any) -> Any:
    return thrust if isinstance(thrust, TwinThrust) else ("per_command", thrust)


def pack(d: Catamaran, speed: Any) -> np.ndarray:
    m11, m22, m33 = (np.asarray(getattr(d, k), float) for k in ("m11", "m22", "m33"))
    return rows([d.m11, d.m22, d.m33, d.d11, d.d22, d.d33, np.asarray(d.half_spacing, float),
                 d.cmd,
                 d.steer_gain, 1.0 / m11, 1.0 / m22, 1.0 / m33, *thrust_row(_law(d.thrust))])


def straight_speed(d: Catamaran) -> Any:
    """Straight-line speed [m/s] at the nominal command: 2 T(cmd) / d11 (thrust independent of
    the speed)."""
    return 2.0 * np.asarray(d.thruster_thrust(d.cmd), float) / np.asarray(d.d11, float)


def particulars(vessel: Any, data: Sequence[Mapping[str, np.ndarray]],
                options: Mapping[str, Any]) -> dict[str, Any]:
    """b, the thrust law, the nominal command and the steering gain (module docstring)."""
    num = _fossen.extra_number
    b = num(vessel, options, "thruster_spacing", "b")
    arm = num(vessel, options, "thruster_arm", "arm")
    if b is None and arm is None:
        raise IdentificationError(
            "model 'catamaran' needs each thruster's distance arm [m] from the centreline "
            "(vessel.extra.thruster_arm, or --vessel thruster_arm=ARM) or the spacing b [m] "
            "between the two thrusters (vessel.extra.thruster_spacing, or --vessel "
            "thruster_spacing=B) in the format spec")
    if b is not None and arm is not None and abs(arm - 0.5 * b) > 1e-9 * b:
        raise IdentificationError(
            f"vessel.extra.thruster_arm ({arm:g} m, from the centreline) and "
            f"thruster_spacing ({b:g} m) disagree: the arm is half the spacing; give one")
    k = num(vessel, options, "thrust_per_command")
    pwm = any("pwm_port" in s and "n_port" in s and np.array_equal(
        s["pwm_port"], s["n_port"], equal_nan=True) for s in data)
    cp = [s["n_port"] for s in data if "n_port" in s and "n_stbd" in s]
    cs = [s["n_stbd"] for s in data if "n_port" in s and "n_stbd" in s]
    if not cp:
        raise IdentificationError("model 'catamaran' needs the thruster commands n_port and "
                                  "n_stbd in the logs")
    cp_all, cs_all = np.concatenate(cp), np.concatenate(cs)
    cmd = num(vessel, options, "nominal_command")
    if cmd is None:
        cmd = float(np.nanmedian(0.5 * (cp_all + cs_all)))
    g = num(vessel, options, "steer_gain")
    if g is None:
        g = float(np.nanmax(np.abs(cp_all - cs_all))) / 2.0 / math.radians(35.0)
    thrust: Any = 1.0 if k is None else k
    if pwm or num(vessel, options, "pwm_neutral") is not None:
        thrust = pwm_thrust_map(vessel, options)
    out = {"b": b} if arm is None else {"arm": arm}
    return {**out, "thrust": thrust, "cmd": cmd, "steer_gain": g}


def force_units(vessel: Any, options: Mapping[str, Any]) -> str | None:
    """Why the forces of a catamaran with these particulars are not in newtons (the kind's
    ``Regression.external``), None when they are: a thrust law in newtons is a
    ``thrust_per_command`` k [N per command unit], a PWM map's ``thrust_full`` [N] or a thrust
    law object given as an option; without one the thrust is in command units (k = 1, or the
    full thrust 1), and so are the masses and dampings the commands determine (module
    docstring), to which no load in newtons can be added."""
    num = _fossen.extra_number
    if (options.get("thrust") is not None or num(vessel, options, "thrust_per_command")
            is not None or num(vessel, options, "thrust_full") is not None):
        return None
    return ("its thrust is in command units (no thrust_per_command [N per command unit] or "
            "thrust_full [N] among the particulars), and so are its masses and dampings: no "
            "load in newtons can be added to them")


def pwm_thrust_map(vessel: Any, options: Mapping[str, Any]) -> TwinThrust:
    """The declared thrust map of PWM-commanded thrusters (format spec ``vessel.extra``):
    ``T = thrust_full s^thrust_exponent`` with the level ``s = (pwm - pwm_neutral)/pwm_span``
    (:class:`usvid.models.thrust.TwinThrust`, ``command="pwm"``); defaults pwm_neutral 1500 us,
    pwm_span 500 us, thrust_full 1 (thrust, masses and dampings then in units of the full
    thrust, all that commands alone can determine), thrust_exponent 1."""
    num = _fossen.extra_number
    full = num(vessel, options, "thrust_full") or 1.0
    expo = int(num(vessel, options, "thrust_exponent") or 1)
    if expo not in (1, 2):
        raise IdentificationError(f"vessel.extra.thrust_exponent must be 1 or 2 (got {expo})")
    coeffs = (0.0, full) if expo == 1 else (0.0, 0.0, full)
    return TwinThrust(coeffs=coeffs, command="pwm",
                      pwm_neutral=num(vessel, options, "pwm_neutral") or 1500.0,
                      pwm_span=num(vessel, options, "pwm_span") or 500.0)


def series(s: dict[str, np.ndarray], fixed: Mapping[str, Any]) -> None:
    """tau_u = T_p + T_s, tau_r = (T_p - T_s) arm from the thrust law at the commands."""
    if "tau_u" in s and "tau_r" in s:
        return
    model = Catamaran(1.0, 1.0, 1.0, 0.0, 0.0, 0.0, b=fixed.get("b"), arm=fixed.get("arm"),
                      thrust=fixed["thrust"])
    if "T_port" in s and "T_stbd" in s:
        tp, ts = s["T_port"], s["T_stbd"]
    else:
        if "n_port" not in s or "n_stbd" not in s:
            raise IdentificationError("model 'catamaran' needs channels n_port and n_stbd")
        tp, ts = model.thruster_thrust(s["n_port"]), model.thruster_thrust(s["n_stbd"])
    s["tau_u"], s["tau_r"] = tp + ts, (tp - ts) * float(model.half_spacing)


def channels(d: Catamaran, rec: dict[str, np.ndarray]) -> None:
    """Recorded thruster commands from the steering angle where they were not commanded."""
    if "delta" not in rec:
        return
    cp, cs = d.commands(rec["delta"])
    for name, c in (("n_port", cp), ("n_stbd", cs)):
        if name in rec:
            rec[name] = np.where(np.isnan(rec[name]), c, rec[name])


KIND = ModelKind(
    name="catamaran",
    title="Twin-thruster catamaran",
    equation="M nu' + C(nu) nu + D nu = tau; tau = (T_p + T_s, 0, (T_p - T_s) arm), arm = b/2",
    reference="Mu et al. 2018 eq. 17 with twin thrusters (catamaran paper)",
    dynamics=Catamaran,
    states=("u", "v", "r"),
    body=(0, 1, 2),
    inputs=("delta", "n_port", "n_stbd"),
    rhs=rhs,
    pack=pack,
    speed=straight_speed,
    outputs=("u", "v", "r", "psi"),
    regression=Regression(_fossen.blocks, _fossen.to_params, _fossen.coefficients,
                          needs=("u", "v"), external=force_units),
    fit_space=_fossen.FIT_SPACE,
    particulars=particulars,
    series=series,
    channels=channels,
)
