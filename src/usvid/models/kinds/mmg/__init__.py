"""MMG standard model, 3 DOF with speed varying (Yasukawa & Yoshimura 2015): the kind ``mmg``.

One package: the parameters declared once (:mod:`.params`, :data:`FIELDS`), the physics
(:mod:`.physics`: hull, propeller, rudder, pod and twin-thruster force models, the equations of
motion Y&Y 2015 eq. 4 about midship, the published KVLCC2 coefficients and the priors from the
particulars; the K_T and pod thrust laws of :mod:`usvid.models.thrust`), the regression form of
identification (:mod:`.fit`) and, here, the kind: the parameter set :class:`MMG` (every field
of :data:`FIELDS` with its unit, bounds and meaning, plus the nominal shaft speed ``n`` [rps]
and, for twin thrusters, ``steer_gain`` [rps/rad] and the PWM map), the numba right-hand side
the integration core runs, ``pack``, the straight-line speed and the particulars from a format
spec's ``vessel`` block. The physics API is re-exported here (``from usvid.models.kinds.mmg
import kvlcc2``; :mod:`usvid.models.mmg` is the same API under its earlier name).

States u, v [m/s] (v at midship), r [rad/s]; inputs delta [rad] (positive turns to starboard),
n [rps] (NaN: the nominal ``n``), and for ``variant='twin'`` the thruster speeds n_port, n_stbd
[rps] (NaN: ``n +- steer_gain delta``, more port thrust for a positive delta, which turns to
starboard). Identification estimates the 17 hull coefficients (R_0, X_vv, ..., N_rrr), the
propeller asymmetry Y_P0, N_P0 (rudder and pod variants, when the runs turn to both sides;
held at 0 with the reason otherwise, or at the value given as a particular), and output error
also refines the rudder lift gradient f_alpha (rudder variant,
:data:`usvid.models.kinds.mmg.fit.REFINED`); the particulars, added masses and the other
propeller/rudder interaction coefficients are held.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.models import vmath as _vmath
from usvid.models.kind import (
    REQUIRED,
    Dynamics,
    ModelKind,
    Regression,
    in_newtons,
    param,
)
from usvid.models.kinds.mmg import fit as _mmg_fit
from usvid.models.kinds.mmg import physics as _m
from usvid.models.kinds.mmg.physics import (
    COMPONENTS,
    CONFOUNDED,
    FIELD_NAMES,
    FIELDS,
    HULL_COEFFICIENTS,
    KVLCC2_COEFFICIENTS,
    KVLCC2_HSVA_PARTICULARS,
    KVLCC2_PAPER_PARTICULARS,
    N_PACKED,
    PACKED_NAMES,
    PRIOR_SOURCES,
    THRUST_LAWS,
    VARIANTS,
    WAKE_MODELS,
    FieldInfo,
    MMGParameters,
    RegressionBlock,
    accelerations,
    forces,
    fujii_f_alpha,
    hull_regression,
    kvlcc2,
    mmg_accelerations,
    mmg_accelerations_any,
    mmg_accelerations_cs,
    mmg_hull_accelerations,
    mmg_pod_accelerations,
    mmg_twin_accelerations,
    pack_lanes,
    priors,
)

#: Packed row of the nominal shaft speed [rps] (after the physics rows of :func:`mmg.pack`).
IDX_N_NOM = _m.N_PACKED
#: Packed row of the twin thrusters' differential speed per radian of steering [rps/rad].
IDX_STEER = _m.N_PACKED + 1
#: Packed rows of the twin thrusters' PWM map: neutral pulse width [us] and 1/span [1/us] (0:
#: the commands are the thrust law's own unit, no map).
IDX_PWM0 = _m.N_PACKED + 2
IDX_PWM_K = _m.N_PACKED + 3
#: Packed row of the twin PWM map's thrust asymmetry a [-] (port (1 + a), starboard (1 - a)).
IDX_ASYM = _m.N_PACKED + 4
N_ROWS = _m.N_PACKED + 5

_POSITIVE = ("L", "B", "d", "m", "I_zG", "rho")


def _field(f: FieldInfo) -> tuple[str, Any, Any]:
    kw: dict[str, Any] = {"fit": f.name in HULL_COEFFICIENTS or f.name in _mmg_fit.REFINED
                               or f.name in _m.ASYMMETRY}
    if f.default is not REQUIRED:
        kw["default"] = f.default
    if f.lo is not None:
        kw["gt" if f.name in _POSITIVE else "ge"] = f.lo
    if f.hi is not None:
        kw["le"] = f.hi
    unit = "-" if f.unit == "L" else f.unit
    meaning = f.meaning + (" (fraction of L)" if f.unit == "L" else "")
    return f.name, Any, param(unit, meaning, **kw)


def _choice(f: FieldInfo) -> tuple[str, Any, Any]:
    return f.name, "str", dataclasses.field(default=f.default)


def _validate(self: Any) -> None:
    for lane in self.lanes():
        lane.physics()


def _lanes(self: Any) -> list[Any]:
    """Scalar parameter sets of a batch (one per lane; ``[self]`` for a scalar set)."""
    vals = {k: v for k, v in self.values().items() if v is not None}
    shapes = [np.shape(v) for v in vals.values()]
    B = int(np.broadcast_shapes(*shapes)[0]) if any(shapes) else 0
    if B == 0:
        return [self]
    out = []
    for b in range(B):
        kw = {k: float(np.broadcast_to(np.asarray(v, float), (B,))[b]) for k, v in vals.items()}
        out.append(dataclasses.replace(self, **kw))
    return out


def _physics(self: Any) -> Any:
    """The :class:`MMGParameters` of a scalar parameter set (validated: choices, bounds, a
    positive-definite mass matrix)."""
    kw = {f.name: getattr(self, f.name) for f in FIELDS}
    for f in FIELDS:
        if f.choices is None:
            kw[f.name] = float(kw[f.name])
    return MMGParameters(**kw)


#: The parameter set of kind ``mmg`` (keyword-only; L, B, d, m, I_zG required).
MMG = dataclasses.make_dataclass(
    "MMG",
    [_choice(f) if f.choices is not None else _field(f) for f in FIELDS]
    + [("n", Any, param("rps", "nominal shaft speed (standard manoeuvres; null: the speed "
                        "holding the approach speed)", fit=False, default=None, ge=0.0)),
       ("steer_gain", Any, param("rps/rad", "twin thrusters: differential shaft speed per "
                                 "radian of rudder-equivalent steering", fit=False,
                                 default=0.0)),
       ("pwm_neutral", Any, param("us", "twin thrusters commanded by PWM pulse widths: the "
                                  "neutral pulse width (null: the commands n_port, n_stbd are "
                                  "the thrust law's own unit)", fit=False, default=None)),
       ("pwm_span", Any, param("us", "twin thrusters commanded by PWM: pulse-width deviation of "
                               "full thrust (level s = (pwm - pwm_neutral)/pwm_span in -1..1; "
                               "thrust pod_d s with thrust_law 'pod', pod_c 0)", fit=False,
                               default=500.0, gt=0.0)),
       ("thrust_asymmetry", Any, param("-", "twin thrusters commanded by PWM: thrust asymmetry "
                                       "a, port thrust (1 + a) pod_d s, starboard (1 - a) "
                                       "pod_d s (identified; held at 0 otherwise)", fit=True,
                                       default=0.0, ge=-0.5, le=0.5))],
    bases=(Dynamics,),
    namespace={"kind": "mmg", "validate": _validate, "lanes": _lanes, "physics": _physics,
               "held_names": staticmethod(_mmg_fit.held_names),
               "held_when_insignificant": staticmethod(_mmg_fit.held_when_insignificant),
               "__doc__": "MMG model parameters (Yasukawa & Yoshimura 2015): particulars SI, "
                          "coefficients non-dimensional as in the paper "
                          "(:mod:`usvid.models.kinds.mmg.params`)."},
    kw_only=True,
)
MMG.__module__ = __name__


def from_physics(p: Any, **extra: Any) -> Any:
    """The kind's parameter set of an :class:`MMGParameters` (``extra``:
    ``n`` [rps], ``steer_gain`` [rps/rad])."""
    return MMG(**p.to_dict(), **extra)


@numba.njit(cache=True, inline="always")
def _pwm_n(c, c0, k, g):
    """Thrust-law command of a PWM pulse width c [us] (neutral c0 [us], k = 1/span [1/us],
    thruster gain g = 1 +- thrust_asymmetry): ``sgn(s) sqrt(g |s|)`` with the level
    ``s = clip((c - c0) k, -1, 1)``, so that the pod law ``T = d |n| n`` (c = 0) gives the
    declared linear map ``T = g d s``."""
    s = min(max((c - c0) * k, -1.0), 1.0)
    return math.copysign(_vmath.sqrt(g * abs(s)), s)


pwm_to_law = _mmg_fit.pwm_to_law


def law_to_pwm(n: Any, neutral: float, span: float) -> Any:
    """Inverse of :func:`pwm_to_law` (within the full-thrust range)."""
    return neutral + span * np.sign(n) * np.asarray(n, float) ** 2


@numba.njit(cache=True, inline="always")
def rhs(p, s, a, f):
    """Y&Y 2015 eq. 4 with the variant's actuator forces and the external force f = (X, Y, K,
    N) [N, N, N m, N m] about midship (K unused: no roll); returns (u, v, r, (u', v', r')).

    Straight-line arithmetic within a variant (selects, square roots, the branch-free asin and
    exp of :mod:`usvid.models.vmath`; the steering angle's cos and sin from ``a``): the core's
    vector step inlines it and vectorises its lane loop, with the variant a constant
    (the kind's switch row)."""
    u = s[0]
    v = s[1]
    r = s[2]
    delta = a[0]
    n = a[3]
    nn = p[IDX_N_NOM] if np.isnan(n) else n
    var = p[_m.IDX_VARIANT]
    if var == 0.0:
        du, dv, dr = _m.mmg_accelerations_cs(p, u, v, r, a[1], a[2], nn)
    elif var == 1.0:
        du, dv, dr = _m.mmg_pod_accelerations_cs(p, u, v, r, a[1], a[2], nn)
    else:
        npo = nn + p[IDX_STEER] * delta if np.isnan(a[4]) else a[4]
        nst = nn - p[IDX_STEER] * delta if np.isnan(a[5]) else a[5]
        pwm = p[IDX_PWM_K] > 0.0
        npo = _pwm_n(npo, p[IDX_PWM0], p[IDX_PWM_K], 1.0 + p[IDX_ASYM]) if pwm else npo
        nst = _pwm_n(nst, p[IDX_PWM0], p[IDX_PWM_K], 1.0 - p[IDX_ASYM]) if pwm else nst
        du, dv, dr = _m.mmg_twin_accelerations(p, u, v, r, npo, nst)
    # the external force through the inverse mass matrix of eq. 4 (the accelerations are linear
    # in the forces)
    return u, v, r, (du + p[_m.IDX_INV11] * f[0],
                     dv + p[_m.IDX_INV22] * f[1] + p[_m.IDX_INV23] * f[3],
                     dr + p[_m.IDX_INV23] * f[1] + p[_m.IDX_INV33] * f[3])


def surge_acceleration(p: Any, u: Any, n: Any) -> np.ndarray:
    """du/dt [m/s^2] in straight running (v = r = delta = 0) at u [m/s], n [rps]."""
    if p.variant == "twin":
        return _m.accelerations(p, u, 0.0, 0.0, n_port=n, n_stbd=n)[0]
    return _m.accelerations(p, u, 0.0, 0.0, 0.0, n)[0]


def equilibrium_rps(p: Any, U: float) -> float:
    """Shaft speed n [rps] at which the straight-running surge force is zero at U [m/s]
    (bisection on ``du/dt(U, n) = 0``; the thrust grows with n)."""
    lo, hi = 0.0, 1.0
    while surge_acceleration(p, U, hi) < 0.0:
        hi *= 2.0
        if hi > 1e5:
            raise UsvidError(f"mmg: no shaft speed holds {U:g} m/s (thrust never exceeds the "
                             "resistance)")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if surge_acceleration(p, U, mid) < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def straight_speed_of(p: Any, n: float) -> float:
    """Straight-running speed u [m/s] at n [rps] (bisection on ``du/dt(u, n) = 0``)."""
    if not n > 0.0:
        return 0.0
    lo, hi = 0.0, 1.0
    while surge_acceleration(p, hi, n) > 0.0:
        hi *= 2.0
        if hi > 1e3:
            raise UsvidError("mmg: no straight-running speed (resistance never balances the "
                             "thrust); check R_0 and the thrust law")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if surge_acceleration(p, mid, n) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def pack(d: Any, speed: Any) -> np.ndarray:
    """Rows: :func:`.physics.pack` of each lane, then the nominal n [rps] (when not
    given: the shaft speed holding ``speed`` [m/s]) and the steering gain [rps/rad]."""
    lanes = d.lanes()
    # one column per lane, or per speed when one parameter set runs at several speeds
    B = max(len(lanes), int(np.size(speed)) if np.ndim(speed) else 1)
    sp = np.broadcast_to(np.asarray(1.0 if speed is None else speed, float),
                         (B,)) if np.ndim(speed) else None
    if len(lanes) not in (1, B):
        raise UsvidError(f"mmg: {len(lanes)} parameter sets for {B} speeds")
    out = np.empty((N_ROWS, B))
    for b in range(B):
        lane = lanes[b if len(lanes) > 1 else 0]
        ph = lane.physics()
        out[:_m.N_PACKED, b] = _m.pack(ph)
        U = float(sp[b]) if sp is not None else float(1.0 if speed is None else speed)
        pwm = ph.variant == "twin" and lane.pwm_neutral is not None
        if lane.n is not None:
            out[IDX_N_NOM, b] = lane.n
        elif pwm:
            out[IDX_N_NOM, b] = law_to_pwm(equilibrium_rps(ph, U), float(lane.pwm_neutral),
                                           float(lane.pwm_span))
        else:
            out[IDX_N_NOM, b] = equilibrium_rps(ph, U)
        out[IDX_STEER, b] = lane.steer_gain
        out[IDX_PWM0, b] = float(lane.pwm_neutral) if pwm else 0.0
        out[IDX_PWM_K, b] = 1.0 / float(lane.pwm_span) if pwm else 0.0
        out[IDX_ASYM, b] = float(lane.thrust_asymmetry) if pwm else 0.0
    return out


def packed_row(d: Any, name: str) -> tuple[int, float] | None:
    """The row of :func:`pack` holding the fitted parameter ``name`` alone, and its factor
    (row = factor * value), for a scalar parameter set ``d``; None where another row depends
    on it too (:attr:`usvid.models.kind.ModelKind.packed_row`).

    The hull coefficients are rows of their own; Y_P0 enters as itself, N_P0 as N_P0 L,
    f_alpha as 0.5 rho A_R f_alpha, the twin PWM map's thrust asymmetry as itself. The one
    derived row is the nominal shaft speed when ``n`` is not given: the shaft speed whose
    straight-running surge force is zero (:func:`equilibrium_rps`). Straight running (v = r =
    delta = 0, v' = r' = 0) leaves of the hull only -R_0 (every other X term carries v' or
    r'; Y and N do not enter the surge equation, Y&Y 2015 eq. 4), of the rudder nothing (its
    normal force is proportional to sin(alpha_R) = 0, so f_alpha drops out) and of the
    asymmetry nothing (a side force and a yaw moment): only R_0 moves it. Validity: the
    other checks of the set (the mass matrix, the variant's choices) do not involve these
    parameters, so the parameter's own bounds are the only check."""
    if any(np.ndim(getattr(d, k, None)) != 0 for k in (name, "n", "L", "rho", "A_R")):
        return None  # (a batch of parameter sets)
    if name in HULL_COEFFICIENTS:
        if name == "R_0" and d.n is None:  # the nominal shaft speed is R_0's equilibrium
            return None
        return _m.IDX_R_0 + HULL_COEFFICIENTS.index(name), 1.0
    if name == "Y_P0":
        return _m.IDX_Y_P0, 1.0
    if name == "N_P0":
        return _m.IDX_N_P0_M, float(d.L)
    if name == "f_alpha":
        return _m.IDX_Q_R, 0.5 * float(d.rho) * float(d.A_R)
    if name == "thrust_asymmetry" and d.variant == "twin" and d.pwm_neutral is not None:
        return IDX_ASYM, 1.0
    return None


def initial(d: Any, values: Mapping[str, Any]) -> np.ndarray:
    B = max(len(d.lanes()), max((np.size(v) for v in values.values()), default=1))
    return np.vstack([np.broadcast_to(np.asarray(values.get(k, 0.0), float), (B,))
                      for k in ("u", "v", "r")])


def straight_speed(d: Any) -> Any:
    """Straight-running speed [m/s] at the nominal shaft speed (None when ``n`` is not set)."""
    lanes = d.lanes()
    if any(lane.n is None for lane in lanes):
        return None
    out = np.array([straight_speed_of(lane.physics(), float(
        pwm_to_law(lane.n, float(lane.pwm_neutral), float(lane.pwm_span))
        if lane.pwm_neutral is not None and lane.variant == "twin" else lane.n))
        for lane in lanes])
    return float(out[0]) if len(lanes) == 1 and np.ndim(d.n) == 0 else out


# ---------------------------------------------------------------------------------------------
# particulars from the format spec's vessel block
# ---------------------------------------------------------------------------------------------
#: vessel.extra keys (SI) -> MMG fields; positions are metres forward of midship.
EXTRA_KEYS: dict[str, str] = {
    "x_g": "x_G [m] centre of gravity forward of midship",
    "yaw_inertia": "I_zG [kg m^2] yaw moment of inertia about G",
    "propeller_diameter": "D_p [m]",
    "rudder_area": "A_R [m^2]",
    "rudder_span": "H_R [m]",
    "propeller_x": "x_P L [m] propeller position forward of midship",
    "rudder_x": "x_R L [m] rudder position forward of midship",
    "thrust_deduction": "t_P [-]",
    "wake_fraction": "w_P0 [-]",
    "water_density": "rho [kg/m^3]",
    "mmg_variant": "0 rudder, 1 pod, 2 twin",
    "thruster_spacing": "twin: distance between the thrusters [m] (y_P = spacing / (2 L))",
    "pwm_neutral": "twin commanded by PWM: neutral pulse width [us] (declares the PWM map)",
    "pwm_span": "twin PWM map: pulse-width deviation of full thrust [us] (default 500)",
    "thrust_full": "twin PWM map: each thruster's thrust at full PWM [N]",
    "nominal_command": "twin PWM map: nominal pulse width [us] (default: median of the data)",
    "steer_gain": "twin: differential command per radian of rudder-equivalent steering",
}

#: Interaction and open-water coefficients without a regression on the particulars: Y&Y
#: 2015's KVLCC2 values (their worked example), used when the vessel block does not give them;
#: the propeller-side asymmetric pairs (gamma_R_plus/minus, C_2_plus/minus) by their mean,
#: since the asymmetry belongs to one propeller's rotation (with the published pair the
#: KVLCC2 10/10 zig-zag overshoots 2.5 deg less to starboard than to port, where the HSVA
#: model's measured first overshoots agree within 0.02 deg).
GENERIC = ("k_0", "k_1", "k_2", "t_P", "w_P0", "x_P", "C_1", "C_2_plus", "C_2_minus", "t_R",
           "a_H", "x_H", "x_R", "epsilon", "kappa", "l_R", "gamma_R_plus", "gamma_R_minus")


class ParticularsWarning(UserWarning):
    """A particular of the MMG model was not given and comes from a regression or a default."""


def particulars(vessel: Any, data: Sequence[Mapping[str, np.ndarray]],
                options: Mapping[str, Any]) -> dict[str, Any]:
    """The held (non-fitted) MMG parameters from the trials' vessel particulars.

    ``vessel``: length, beam, draft [m], mass [kg] (or ``extra.volume`` [m^3] times the water
    density), block_coefficient; ``vessel.extra`` (or ``--vessel NAME=VALUE``): the keys of
    :data:`EXTRA_KEYS`, and any MMG field by its own name (e.g. ``a_H``). What is missing comes
    from published regressions (added masses Zhou et al. 1983; I_zG by k_zz = 0.25 L; rudder
    area by the DNV rule ``A_R = L d (1 + 25 (B/L)^2)/100``; span 0.75 d; propeller diameter
    0.65 d) or, for the interaction coefficients (:data:`GENERIC`), from Y&Y 2015's KVLCC2
    values (the asymmetric pairs by their mean), each with a :class:`ParticularsWarning` naming
    it. With a measured ``thrust``
    channel [N] the open-water K_T(J) law is scaled to it (least squares of one factor on the
    samples with n > 0). The propeller asymmetry Y_P0, N_P0 (rudder and pod variants) is held
    at its given value (``--vessel Y_P0=...``), at 0 when the runs do not turn to both sides
    (:func:`usvid.models.kinds.mmg.fit.asymmetry_held`; a ``CollinearityWarning`` says why), and
    left to identification otherwise.
    """
    extra = dict(getattr(vessel, "extra", None) or {})
    extra.update({k: v for k, v in options.items() if v is not None and not hasattr(v, "kind")})

    def get(name: str) -> float | None:
        v = extra.get(name)
        return None if v is None else float(v)

    missing: list[str] = []
    L = getattr(vessel, "length", None)
    B = getattr(vessel, "beam", None)
    d = getattr(vessel, "draft", None)
    for nm, v in (("length", L), ("beam", B), ("draft", d)):
        if v is None:
            raise UsvidError(f"model 'mmg' needs vessel.{nm} [m] in the format spec's vessel "
                             "block")
    rho = get("water_density") or 1025.0
    m = getattr(vessel, "mass", None)
    vol = get("volume")
    if m is None and getattr(vessel, "displacement", None) is not None:
        m = float(vessel.displacement)
    if m is None and vol is not None:
        m = rho * vol
    Cb = getattr(vessel, "block_coefficient", None)
    if m is None and Cb is not None:
        m = rho * Cb * L * B * d
    if m is None:
        raise UsvidError("model 'mmg' needs vessel.mass [kg] (or vessel.extra.volume [m^3], or "
                         "vessel.block_coefficient) in the format spec's vessel block")
    if Cb is None:
        Cb = m / (rho * L * B * d)
        missing.append(f"block_coefficient = {Cb:.3f} from the mass")
    pri = _m.priors(L, B, d, Cb, m, rho=rho)
    out: dict[str, Any] = {"L": L, "B": B, "d": d, "m": m, "rho": rho,
                           "m_x": pri["m_x"], "m_y": pri["m_y"], "J_z": pri["J_z"]}
    xg = get("x_g")
    if xg is None:
        xg = 0.0
        missing.append("x_g = 0 (centre of gravity at midship)")
    out["x_G"] = xg
    Iz = get("yaw_inertia")
    if Iz is None:
        Iz = pri["I_zG"]
        missing.append(f"yaw_inertia = {Iz:.4g} kg m^2 (k_zz = 0.25 L)")
    out["I_zG"] = Iz
    variant = {0: "rudder", 1: "pod", 2: "twin"}[int(get("mmg_variant") or 0)]
    out["variant"] = variant
    for k in GENERIC:
        out[k] = _m.KVLCC2_COEFFICIENTS[k]
    for a, b in (("gamma_R_plus", "gamma_R_minus"), ("C_2_plus", "C_2_minus")):
        out[a] = out[b] = 0.5 * (out[a] + out[b])  # symmetric (docstring)
    out["f_alpha"] = None
    Dp = get("propeller_diameter")
    if Dp is None:
        Dp = 0.65 * d
        if not (variant == "twin" and get("pwm_neutral") is not None):  # unused by the map
            missing.append(f"propeller_diameter = {Dp:.4g} m (0.65 d)")
    out["D_p"] = Dp
    if variant == "rudder":
        AR = get("rudder_area")
        if AR is None:
            AR = L * d * (1.0 + 25.0 * (B / L) ** 2) / 100.0
            missing.append(f"rudder_area = {AR:.4g} m^2 (DNV rule L d (1 + 25 (B/L)^2)/100)")
        HR = get("rudder_span")
        if HR is None:
            HR = 0.75 * d
            missing.append(f"rudder_span = {HR:.4g} m (0.75 d)")
        out["A_R"], out["H_R"] = AR, HR
        out["f_alpha"] = _m.fujii_f_alpha(HR ** 2 / AR)
    if get("propeller_x") is not None:
        out["x_P"] = get("propeller_x") / L
    if get("rudder_x") is not None:
        out["x_R"] = get("rudder_x") / L
    if get("thrust_deduction") is not None:
        out["t_P"] = get("thrust_deduction")
    if get("wake_fraction") is not None:
        out["w_P0"] = get("wake_fraction")
    if get("thruster_spacing") is not None:
        out["y_P"] = get("thruster_spacing") / (2.0 * L)
    given = {f.name for f in FIELDS} & set(extra)
    for k in given:
        out[k] = extra[k] if k in ("variant", "thrust_law", "wake_model") else float(extra[k])
    asym_why = None
    if given & set(_m.ASYMMETRY):  # given: held (both; the other at 0 if not given)
        out.update({k: float(extra.get(k, 0.0)) for k in _m.ASYMMETRY})
    elif variant != "twin":
        asym_why = _mmg_fit.asymmetry_held(data)
        if asym_why is not None:
            out.update(dict.fromkeys(_m.ASYMMETRY, 0.0))
    generic = [k for k in GENERIC if k not in given and not (
        (k == "t_P" and get("thrust_deduction") is not None)
        or (k == "w_P0" and get("wake_fraction") is not None)
        or (k == "x_P" and get("propeller_x") is not None)
        or (k == "x_R" and get("rudder_x") is not None))]
    if variant != "rudder":
        generic = [k for k in generic if k in ("k_0", "k_1", "k_2", "t_P", "w_P0", "x_P",
                                               "C_1", "C_2_plus", "C_2_minus")]
        out["f_alpha"] = 0.0
    pwm = variant == "twin" and get("pwm_neutral") is not None
    if pwm:
        _twin_pwm(out, extra, data)
        generic = []
    if out["f_alpha"] is None:
        out["f_alpha"] = 0.0
    scale = _kt_scale(out, data)
    if scale is not None:
        for k in ("k_0", "k_1", "k_2"):
            out[k] *= scale
        out["kt_scale_from_thrust"] = scale
    if generic:
        missing.append("interaction coefficients " + ", ".join(generic)
                       + " from Yasukawa & Yoshimura 2015's KVLCC2 values"
                       + (f" (K_T scaled by {scale:.3f} to the logged thrust)"
                          if scale is not None else ""))
    if missing:
        warnings.warn("mmg particulars not given (format spec vessel block): "
                      + "; ".join(missing), ParticularsWarning, stacklevel=3)
    if asym_why is not None:
        warnings.warn(f"mmg: the propeller asymmetry Y_P0, N_P0 held at 0: {asym_why}",
                      _mmg_fit.CollinearityWarning, stacklevel=3)
    out.pop("kt_scale_from_thrust", None)
    if pwm:
        return out
    n = get("shaft_speed_rps")
    if n is None:
        ns = [np.asarray(s["n"], float) for s in data if "n" in s]
        ns = [a[np.isfinite(a)] for a in ns]
        ns = [a for a in ns if a.size]
        n = float(np.median(np.concatenate(ns))) if ns else None
    out["n"] = n
    return out


def _twin_pwm(out: dict[str, Any], extra: Mapping[str, Any],
              data: Sequence[Mapping[str, np.ndarray]]) -> None:
    """The declared thrust map of PWM-commanded twin thrusters (format spec ``vessel.extra``):
    each thruster's thrust ``T = thrust_full s`` [N] at the level ``s = (pwm - pwm_neutral) /
    pwm_span`` (clipped to -1..1), as the pod law ``T = pod_d |n| n`` with ``pod_c = 0`` on
    ``n = sgn(s) sqrt(|s|)`` (:func:`pwm_to_law`); gross thrust, no wake or thrust deduction
    (the map is the thrust at the trials' speeds). ``thrust_full`` [N] is required (the MMG
    masses are in kg, so the thrust must be in newtons). Nominal command ``n``: the median
    mean pulse width of the data; ``steer_gain`` [us/rad]: half the largest differential
    pulse width of the data per 35 deg (as the catamaran kind)."""
    full = extra.get("thrust_full")
    if full is None:
        raise UsvidError("model 'mmg' (twin thrusters commanded by PWM) needs "
                         "vessel.extra.thrust_full [N] (each thruster's thrust at full PWM) in "
                         "the format spec, or --vessel thrust_full=N")
    out.update(thrust_law="pod", pod_c=0.0, pod_d=float(full),
               pwm_neutral=float(extra["pwm_neutral"]),
               pwm_span=float(extra.get("pwm_span") or 500.0))
    cp = [np.asarray(s["pwm_port" if "pwm_port" in s else "n_port"], float) for s in data
          if ("pwm_port" in s or "n_port" in s) and ("pwm_stbd" in s or "n_stbd" in s)]
    cs = [np.asarray(s["pwm_stbd" if "pwm_stbd" in s else "n_stbd"], float) for s in data
          if ("pwm_port" in s or "n_port" in s) and ("pwm_stbd" in s or "n_stbd" in s)]
    if not cp:
        raise UsvidError("model 'mmg' (twin variant) needs the thruster commands pwm_port, "
                         "pwm_stbd (or n_port, n_stbd) in the logs")
    a, b = np.concatenate(cp), np.concatenate(cs)
    n = extra.get("nominal_command")
    out["n"] = float(n) if n is not None else float(np.nanmedian(0.5 * (a + b)))
    g = extra.get("steer_gain")
    out["steer_gain"] = (float(g) if g is not None
                         else float(np.nanmax(np.abs(a - b))) / 2.0 / math.radians(35.0))
    if "thruster_spacing" not in extra and "y_P" not in extra:
        raise UsvidError("model 'mmg' (twin variant) needs vessel.extra.thruster_spacing [m] "
                         "(distance between the two thrusters) in the format spec")


def _kt_scale(fixed: Mapping[str, Any], data: Sequence[Mapping[str, np.ndarray]]
              ) -> float | None:
    """Least-squares factor c of ``T_meas = c rho n^2 D^4 K_T(J)`` (Y&Y 2015 propeller model
    with the held wake fraction w_P0, J = (1 - w_P0) u/(n D)) over the samples with a measured
    thrust [N], u [m/s] and n > 0 [rps]; None without such samples."""
    num = den = 0.0
    D, rho = fixed["D_p"], fixed["rho"]
    for s in data:
        if not all(k in s for k in ("thrust", "n", "u")):
            continue
        T, n, u = (np.asarray(s[k], float) for k in ("thrust", "n", "u"))
        ok = np.isfinite(T) & np.isfinite(n) & np.isfinite(u) & (n > 0.1)
        if ok.sum() < 10:
            continue
        J = (1.0 - fixed["w_P0"]) * u[ok] / (n[ok] * D)
        Tm = rho * n[ok] ** 2 * D ** 4 * (fixed["k_0"] + fixed["k_1"] * J + fixed["k_2"] * J * J)
        num += float(Tm @ T[ok])
        den += float(Tm @ Tm)
    return num / den if den > 0.0 else None


KIND = ModelKind(
    name="mmg",
    title="MMG standard model (3 DOF, speed varying)",
    equation="Y&Y 2015 eq. 4 about midship: (M + M_A) (u', v', r') + Coriolis = hull "
             "(polynomials in v', r') + rudder + propeller forces",
    reference="Yasukawa & Yoshimura 2015, eq. 4 and the hull, propeller and rudder force models",
    dynamics=MMG,
    states=("u", "v", "r"),
    body=(0, 1, 2),
    inputs=("delta", "n", "n_port", "n_stbd"),
    rhs=rhs,
    pack=pack,
    packed_row=packed_row,
    initial=initial,
    speed=straight_speed,
    outputs=("u", "v", "r", "psi"),
    regression=Regression(_mmg_fit.blocks, _mmg_fit.to_params, needs=("u",),
                          priors=_mmg_fit.priors_of, external=in_newtons),
    particulars=particulars,
    uses_trig=True,
    # the variant (rudder, pod, twin): one vector step per variant, only its forces compiled
    switch_row=_m.IDX_VARIANT,
    switch_values=(0.0, 1.0, 2.0),
    state_estimation=True,
    # the hull's, drift angle's and rudder inflow's square roots and divisions in series (20
    # and 8 per RK4 step): two lane vectors side by side
    vector_interleave=2,
)

__all__ = ["COMPONENTS", "CONFOUNDED", "EXTRA_KEYS", "FIELDS", "FIELD_NAMES", "GENERIC",
           "HULL_COEFFICIENTS", "KIND", "KVLCC2_COEFFICIENTS", "KVLCC2_HSVA_PARTICULARS",
           "KVLCC2_PAPER_PARTICULARS", "MMG", "N_PACKED", "PACKED_NAMES", "PRIOR_SOURCES",
           "THRUST_LAWS", "VARIANTS", "WAKE_MODELS", "FieldInfo", "MMGParameters",
           "ParticularsWarning", "RegressionBlock", "accelerations", "equilibrium_rps", "forces",
           "from_physics", "fujii_f_alpha", "hull_regression", "kvlcc2", "mmg_accelerations",
           "mmg_accelerations_any", "mmg_accelerations_cs", "mmg_hull_accelerations",
           "mmg_pod_accelerations", "mmg_twin_accelerations", "pack_lanes", "priors",
           "straight_speed_of"]
