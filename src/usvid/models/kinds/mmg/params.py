"""The parameters of the MMG model (Yasukawa & Yoshimura 2015): declared once, in :data:`FIELDS`.

Every parameter of the kind ``mmg`` is one :class:`FieldInfo` of :data:`FIELDS`: name, unit,
meaning, physical bounds, group, choices (the string fields) and default. From it come both
the scalar physics parameter set :class:`MMGParameters` (validated; what the force models of
:mod:`usvid.models.kinds.mmg.physics` take) and the kind's parameter set
:class:`usvid.models.kinds.mmg.MMG` (the model file's ``parameters`` block, batches of lanes,
what identification estimates).

Coordinates and signs (usvid, ARCHITECTURE.md, the same as Y&Y 2015's)
---------------------------------------------------------------------
Body frame with its origin at **midship** (o_0 in Y&Y 2015), x forward, y to starboard, z down;
the state is ``(u, v, r)`` with ``v`` the sway velocity *at midship* (the paper's v_m) [m/s] and
``r`` [rad/s] positive clockwise seen from above. ``x_G`` [m] is the centre of gravity forward of
midship. ``delta`` [rad] is positive when it turns the vessel to starboard (makes r > 0).
Y&Y 2015 define the rudder angle the same way (in its rudder force model a positive delta gives
F_N > 0, Y_R < 0 at the stern and N_R > 0), so **no conversion is needed at this model
boundary**; data with the opposite convention (HSVA's logs, positive delta to port) are converted
by the format spec's ``sign: -1``. The asymmetric coefficients keep the paper's meaning:
``C_2_plus`` applies for beta_P > 0, ``gamma_R_plus`` for beta_R > 0, where beta = asin(-v/U) is
positive in a turn to starboard.

Units and non-dimensionalisation (stick to this)
------------------------------------------------
Particulars are SI: L, B, d, D_p, A_R, H_R [m], m [kg], I_zG [kg m^2], x_G [m], rho [kg/m^3].
Every hydrodynamic and interaction coefficient is **non-dimensional as in Y&Y 2015** (primes
dropped): added masses ``m_x = (surge added mass [kg]) / (0.5 rho L^2 d)``, m_y likewise,
``J_z = (added yaw inertia [kg m^2]) / (0.5 rho L^4 d)``, forces by ``0.5 rho L d U^2``,
moments by ``0.5 rho L^2 d U^2``, ``v' = v/U``, ``r' = r L/U``, ``U = sqrt(u^2 + v^2)``, and
the longitudinal positions ``x_P, x_H, x_R, l_R`` and the thruster half-spacing ``y_P`` as
fractions of L.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, fields
from typing import Any, NamedTuple

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import check_params
from usvid.models.kind import REQUIRED

VARIANTS = ("rudder", "pod", "twin")
THRUST_LAWS = ("kt", "pod")
WAKE_MODELS = ("yasukawa2015", "gaussian")
_CHOICE_FIELDS = ("variant", "thrust_law", "wake_model")


class FieldInfo(NamedTuple):
    """Metadata of one :class:`MMGParameters` field.

    name; unit (SI, or ``-`` for non-dimensional, ``L`` for a fraction of L); meaning (one line);
    lo, hi: physical bounds (inclusive, None = unbounded); group (particulars, added_mass, hull,
    propeller, rudder, thruster, asymmetry, model); choices for the string fields; default
    (``REQUIRED`` when the field must be given).
    """

    name: str
    unit: str
    meaning: str
    lo: float | None
    hi: float | None
    group: str
    choices: tuple[str, ...] | None = None
    default: Any = REQUIRED


_NOLIM = None
FIELDS: tuple[FieldInfo, ...] = (
    FieldInfo("variant", "-", "actuator variant: rudder behind a propeller, pod/vector thruster, "
              "twin thrusters", None, None, "model", VARIANTS, default="rudder"),
    FieldInfo("thrust_law", "-", "thrust law: 'kt' propeller K_T(J) with wake and thrust "
              "deduction, 'pod' T = c u n + d |n| n (Mu et al. 2016)", None, None, "model",
              THRUST_LAWS, default="kt"),
    FieldInfo("wake_model", "-", "propeller wake vs beta_P: 'yasukawa2015' (Y&Y 2015, C_1, C_2) or "
              "'gaussian' w_P = w_P0 exp(-C_w beta_P^2) (the form shipmmg implements)", None,
              None, "model", WAKE_MODELS, default="yasukawa2015"),
    # particulars (SI)
    FieldInfo("L", "m", "length between perpendiculars", 0.0, _NOLIM, "particulars",
              default=REQUIRED),
    FieldInfo("B", "m", "breadth", 0.0, _NOLIM, "particulars", default=REQUIRED),
    FieldInfo("d", "m", "mean draught", 0.0, _NOLIM, "particulars", default=REQUIRED),
    FieldInfo("m", "kg", "mass (displacement)", 0.0, _NOLIM, "particulars", default=REQUIRED),
    FieldInfo("x_G", "m", "centre of gravity forward of midship", _NOLIM, _NOLIM, "particulars",
              default=0.0),
    FieldInfo("I_zG", "kg m^2", "yaw moment of inertia about the centre of gravity", 0.0, _NOLIM,
              "particulars", default=REQUIRED),
    FieldInfo("rho", "kg/m^3", "water density", 900.0, 1100.0, "particulars", default=1025.0),
    # added masses (Y&Y 2015 eq. 4, non-dimensional)
    FieldInfo("m_x", "-", "surge added mass / (0.5 rho L^2 d)", 0.0, _NOLIM, "added_mass",
              default=0.0),
    FieldInfo("m_y", "-", "sway added mass / (0.5 rho L^2 d)", 0.0, _NOLIM, "added_mass",
              default=0.0),
    FieldInfo("J_z", "-", "yaw added moment of inertia / (0.5 rho L^4 d)", 0.0, _NOLIM,
              "added_mass", default=0.0),
    # hull force model (Y&Y 2015)
    FieldInfo("R_0", "-", "straight-running resistance / (0.5 rho L d U^2)", 0.0, _NOLIM, "hull",
              default=0.0),
    FieldInfo("X_vv", "-", "surge force coefficient of v'^2", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("X_vr", "-", "surge force coefficient of v' r'", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("X_rr", "-", "surge force coefficient of r'^2", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("X_vvvv", "-", "surge force coefficient of v'^4", _NOLIM, _NOLIM, "hull",
              default=0.0),
    FieldInfo("Y_v", "-", "sway force coefficient of v' (sway damping, < 0)", _NOLIM, 0.0, "hull",
              default=0.0),
    FieldInfo("Y_r", "-", "sway force coefficient of r'", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("Y_vvv", "-", "sway force coefficient of v'^3", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("Y_vvr", "-", "sway force coefficient of v'^2 r'", _NOLIM, _NOLIM, "hull",
              default=0.0),
    FieldInfo("Y_vrr", "-", "sway force coefficient of v' r'^2", _NOLIM, _NOLIM, "hull",
              default=0.0),
    FieldInfo("Y_rrr", "-", "sway force coefficient of r'^3", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("N_v", "-", "yaw moment coefficient of v'", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("N_r", "-", "yaw moment coefficient of r' (yaw damping, < 0)", _NOLIM, 0.0, "hull",
              default=0.0),
    FieldInfo("N_vvv", "-", "yaw moment coefficient of v'^3", _NOLIM, _NOLIM, "hull", default=0.0),
    FieldInfo("N_vvr", "-", "yaw moment coefficient of v'^2 r'", _NOLIM, _NOLIM, "hull",
              default=0.0),
    FieldInfo("N_vrr", "-", "yaw moment coefficient of v' r'^2", _NOLIM, _NOLIM, "hull",
              default=0.0),
    FieldInfo("N_rrr", "-", "yaw moment coefficient of r'^3", _NOLIM, _NOLIM, "hull", default=0.0),
    # propeller / thrusters (Y&Y 2015 propeller force model)
    FieldInfo("D_p", "m", "propeller diameter (0: no propeller)", 0.0, _NOLIM, "propeller",
              default=0.0),
    FieldInfo("k_0", "-", "K_T(J) = k_0 + k_1 J + k_2 J^2: constant", _NOLIM, _NOLIM, "propeller",
              default=0.0),
    FieldInfo("k_1", "-", "K_T(J): coefficient of J", _NOLIM, _NOLIM, "propeller", default=0.0),
    FieldInfo("k_2", "-", "K_T(J): coefficient of J^2", _NOLIM, _NOLIM, "propeller", default=0.0),
    FieldInfo("t_P", "-", "thrust deduction factor", 0.0, 0.95, "propeller", default=0.0),
    FieldInfo("w_P0", "-", "propeller wake fraction in straight running", 0.0, 0.95,
              "propeller", default=0.0),
    FieldInfo("x_P", "L", "propeller (thruster) position forward of midship, in beta_P and "
              "the thruster moments", -1.0, 1.0, "propeller", default=-0.5),
    FieldInfo("C_1", "-", "wake change with beta_P: exponential rate", 0.0, _NOLIM, "propeller",
              default=2.0),
    FieldInfo("C_2_plus", "-", "wake change with beta_P: level for beta_P > 0", 0.0, _NOLIM,
              "propeller", default=1.0),
    FieldInfo("C_2_minus", "-", "wake change with beta_P: level for beta_P < 0", 0.0, _NOLIM,
              "propeller", default=1.0),
    FieldInfo("C_w", "-", "wake_model 'gaussian': w_P = w_P0 exp(-C_w beta_P^2)", 0.0, _NOLIM,
              "propeller", default=4.0),
    FieldInfo("pod_c", "N s^2/m", "pod law T = c u n + d |n| n: coefficient c", _NOLIM, _NOLIM,
              "thruster", default=0.0),
    FieldInfo("pod_d", "N s^2", "pod law T = c u n + d |n| n: coefficient d", _NOLIM, _NOLIM,
              "thruster", default=0.0),
    FieldInfo("y_P", "L", "twin thrusters: half spacing (each at -+y_P L)", 0.0, 1.0,
              "thruster", default=0.0),
    # rudder (Y&Y 2015 rudder force model)
    FieldInfo("A_R", "m^2", "rudder area (0: no rudder)", 0.0, _NOLIM, "rudder", default=0.0),
    FieldInfo("H_R", "m", "rudder span", 0.0, _NOLIM, "rudder", default=0.0),
    FieldInfo("f_alpha", "-", "rudder lift gradient (Fujii: 6.13 Lambda/(Lambda + 2.25))", 0.0,
              2.0 * math.pi, "rudder", default=0.0),
    FieldInfo("t_R", "-", "steering resistance deduction factor", 0.0, 1.0, "rudder", default=0.0),
    FieldInfo("a_H", "-", "rudder force increase factor (hull-rudder interaction)", 0.0, 2.0,
              "rudder", default=0.0),
    FieldInfo("x_H", "L", "position of the additional lateral force forward of midship",
              -1.0, 0.5, "rudder", default=-0.5),
    FieldInfo("x_R", "L", "rudder position forward of midship", -1.0, 0.0, "rudder", default=-0.5),
    FieldInfo("epsilon", "-", "ratio of wake fraction at rudder to that at propeller", 0.0, 3.0,
              "rudder", default=1.0),
    FieldInfo("kappa", "-", "propeller slipstream factor for u_R", 0.0, 2.0, "rudder", default=0.5),
    FieldInfo("l_R", "L", "effective rudder position for the flow-straightening angle beta_R",
              -2.0, 0.0, "rudder", default=-1.0),
    FieldInfo("gamma_R_plus", "-", "flow straightening coefficient for beta_R > 0", 0.0, 2.0,
              "rudder", default=0.5),
    FieldInfo("gamma_R_minus", "-", "flow straightening coefficient for beta_R < 0", 0.0, 2.0,
              "rudder", default=0.5),
    # port/starboard asymmetry of a single propeller (0: a symmetric vessel)
    FieldInfo("Y_P0", "-", "propeller-induced side force per unit gross thrust, Y_P = Y_P0 T "
              "(single-propeller asymmetry; + to starboard)", -0.5, 0.5, "asymmetry",
              default=0.0),
    FieldInfo("N_P0", "-", "propeller-induced yaw moment per unit L times gross thrust, "
              "N_P = N_P0 L T (single-propeller asymmetry; + turns to starboard)", -0.5, 0.5,
              "asymmetry", default=0.0),
)
FIELD_NAMES = tuple(f.name for f in FIELDS)
HULL_COEFFICIENTS = ("R_0", "X_vv", "X_vr", "X_rr", "X_vvvv", "Y_v", "Y_r", "Y_vvv", "Y_vvr",
                     "Y_vrr", "Y_rrr", "N_v", "N_r", "N_vvv", "N_vvr", "N_vrr", "N_rrr")
_REQUIRED = tuple(f.name for f in FIELDS if f.default is REQUIRED)
#: The port/starboard asymmetry of a single propeller (rudder and pod variants): the
#: propeller-induced side force and yaw moment per unit gross thrust (:mod:`.physics`).
ASYMMETRY = ("Y_P0", "N_P0")


class _Physics:
    """The methods of :class:`MMGParameters` (its fields come from :data:`FIELDS`)."""

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS:
            raise UsvidError(f"parameters.variant must be one of {VARIANTS} "
                             f"(got {self.variant!r})")
        if self.thrust_law not in THRUST_LAWS:
            raise UsvidError(f"parameters.thrust_law must be one of {THRUST_LAWS} "
                             f"(got {self.thrust_law!r})")
        if self.wake_model not in WAKE_MODELS:
            raise UsvidError(f"parameters.wake_model must be one of {WAKE_MODELS} "
                             f"(got {self.wake_model!r})")
        if self.variant == "rudder" and self.thrust_law != "kt":
            raise UsvidError("parameters.thrust_law must be 'kt' for variant 'rudder' (the "
                             "rudder inflow model uses the propeller's K_T)")
        num = {f.name: getattr(self, f.name) for f in FIELDS if f.choices is None}
        check_params("parameters", num, positive=_REQUIRED + ("rho",))
        for f in FIELDS:
            if f.choices is not None:
                continue
            val = float(getattr(self, f.name))
            if (f.lo is not None and val < f.lo) or (f.hi is not None and val > f.hi):
                lo = "-inf" if f.lo is None else repr(f.lo)
                hi = "inf" if f.hi is None else repr(f.hi)
                raise UsvidError(f"parameters.{f.name} must be in [{lo}, {hi}] {f.unit} "
                                 f"({f.meaning}; got {val!r})")
        det = (self.m + self.m_y * self.q_mass) * self.Iz_total - (self.x_G * self.m) ** 2
        if not det > 0.0:
            raise UsvidError("parameters: (m + m_y)(I_zG + x_G^2 m + J_z) - (x_G m)^2 must be "
                             f"> 0 (singular inertia; got {det!r})")

    # --- derived quantities -------------------------------------------------------------------
    @property
    def q_mass(self) -> float:
        """0.5 rho L^2 d [kg]: the mass scale of the prime system (m_x = m_x' q_mass)."""
        return 0.5 * self.rho * self.L ** 2 * self.d

    @property
    def Iz_total(self) -> float:
        """I_zG + x_G^2 m + J_z [kg m^2]: yaw inertia about midship with added inertia."""
        return self.I_zG + self.x_G ** 2 * self.m + self.J_z * self.q_mass * self.L ** 2

    @property
    def kzz(self) -> float:
        """Yaw radius of gyration about G as a fraction of L [-]: sqrt(I_zG/m)/L."""
        return math.sqrt(self.I_zG / self.m) / self.L

    @property
    def m_prime(self) -> float:
        """m' = m / (0.5 rho L^2 d) [-]."""
        return self.m / self.q_mass

    @property
    def eta(self) -> float:
        """eta = D_p / H_R [-] (Y&Y 2015, in u_R); 0 without a rudder span."""
        return self.D_p / self.H_R if self.H_R > 0.0 else 0.0

    def mass_matrix(self) -> np.ndarray:
        """Dimensional mass matrix of Y&Y 2015 eq. 4 about midship (3, 3) [kg, kg m, kg m^2]:
        ``[[m + m_x, 0, 0], [0, m + m_y, x_G m], [0, x_G m, I_zG + x_G^2 m + J_z]]``."""
        q = self.q_mass
        xgm = self.x_G * self.m
        return np.array([[self.m + self.m_x * q, 0.0, 0.0],
                         [0.0, self.m + self.m_y * q, xgm],
                         [0.0, xgm, self.Iz_total]])

    def to_dict(self) -> dict[str, Any]:
        """Field name -> value (the model file's ``parameters`` block)."""
        return asdict(self)  # type: ignore[call-overload]

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Any:
        """From a ``parameters`` block; an unknown key is an error naming the key."""
        unknown = sorted(set(d) - set(FIELD_NAMES))
        if unknown:
            raise UsvidError(f"parameters: unknown key {unknown[0]!r} for kind mmg "
                             f"(known: {', '.join(FIELD_NAMES)})")
        missing = [k for k in _REQUIRED if k not in d]
        if missing:
            raise UsvidError(f"parameters.{missing[0]} is required for kind mmg")
        kw = {k: (v if k in _CHOICE_FIELDS else float(v)) for k, v in d.items()}
        return cls(**kw)

    def replace(self, **changes: Any) -> Any:
        """A copy with some fields changed (validated again)."""
        cur = {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]
        cur.update(changes)
        return type(self)(**cur)


#: MMG model parameters (Y&Y 2015): the fields of :data:`FIELDS` (keyword-only; L, B, d, m,
#: I_zG required), scalars, frozen, validated on construction.
MMGParameters = dataclasses.make_dataclass(
    "MMGParameters",
    [(f.name, str if f.choices else float) if f.default is REQUIRED
     else (f.name, str if f.choices else float, dataclasses.field(default=f.default))
     for f in FIELDS],
    bases=(_Physics,), frozen=True, kw_only=True,
    namespace={"__doc__": "MMG model parameters (Y&Y 2015); units and meaning of every field in "
               ":data:`FIELDS`.\n\n    Particulars SI, coefficients non-dimensional as in Y&Y "
               "2015. Required: L, B, d, m, I_zG; every other field has a neutral default (no "
               "propeller, no rudder, zero hull coefficients, added masses 0), so build complete "
               "sets with :func:`kvlcc2` or :func:`priors`. Validated on construction: finite "
               "values, the bounds of :data:`FIELDS`, ``variant``/``thrust_law`` choices; "
               "``variant='rudder'`` needs ``thrust_law='kt'`` (the slipstream model uses K_T)."},
)
MMGParameters.__module__ = __name__

__all__ = ["ASYMMETRY", "FIELDS", "FIELD_NAMES", "HULL_COEFFICIENTS", "THRUST_LAWS", "VARIANTS",
           "WAKE_MODELS", "FieldInfo", "MMGParameters"]
