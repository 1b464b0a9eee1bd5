"""Hull regressions: added mass and linear manoeuvring derivatives from main particulars.

the catamaran paper (section 2.1, eq. 17) names two regressions for the added masses and added
moment of inertia: Zhou et al.'s multiple regression of Motora's charts and Clarke et al. (1983).
The extracted seed lost the formulas; the published forms are implemented here, every coefficient
with its source:

* Clarke, D., Gedling, P. and Hine, G. (1983). "The application of manoeuvring criteria in hull
  design using linear theory", Trans. RINA 125, 45-68 -- sway/yaw acceleration derivatives and
  linear damping derivatives, as reproduced in Fossen, T. I. (2011/2021), Handbook of Marine
  Craft Hydrodynamics and Motion Control, and in the MSS toolbox function ``clarke83``.
* Soding, H. (1982), "Prediction of ship steering capabilities", Schiffstechnik 29, 3-29: surge
  added mass ``A11 = 2.7 rho V^(5/3) / L^2`` (MSS ``addedMassSurge``).
* Zhou Zhaoming et al. (1983), regression of Motora's charts (as used in the MMG literature,
  e.g. Jia & Yang, "Mathematical model of ship motion", Dalian Maritime Univ. Press 1999).
* Kijima, K., Katsuno, T., Nakiri, Y. and Furukawa, Y. (1990), "On the manoeuvring performance
  of a ship with the parameter of loading condition", J. Soc. Naval Arch. Japan 168, 141-148:
  linear MMG hull derivatives (non-dimensional, prime system of the MMG model).

Signs: Fossen's notation, ``X_udot, Y_vdot, ... <= 0`` are hydrodynamic derivatives and the added
mass matrix is ``M_A = -[[X_udot, 0, 0], [0, Y_vdot, Y_rdot], [0, N_vdot, N_rdot]]``; Zhou's
m_x, m_y, J_zz are positive added masses (m_x = -X_udot, m_y = -Y_vdot, J_zz = -N_rdot).
Units: lengths [m], masses [kg], moments of inertia [kg m^2], speeds [m/s], rho [kg/m^3].
All functions broadcast over array arguments.

Both regressions were fitted to conventional displacement ships (L/B roughly 4-8); applied to a
small USV (Lanxin L/B = 2.7) they are extrapolations, e.g. Zhou's m_x turns negative for short
beamy hulls: usvid returns the regression's value, it does not clip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import check_params, checked

ArrayLike = float | np.ndarray


@dataclass(frozen=True)
class HullParticulars:
    """Main particulars of a hull [m, -, m^3].

    L length between perpendiculars, B breadth, T (mean) draught, Cb block coefficient,
    volume displaced volume (None: Cb L B T).
    """

    L: float
    B: float
    T: float
    Cb: float
    volume: float | None = None

    def __post_init__(self) -> None:
        vals = {"L": self.L, "B": self.B, "T": self.T, "Cb": self.Cb}
        if self.volume is not None:
            vals["volume"] = self.volume
        check_params("hull", vals, positive=tuple(vals))

    @property
    def displaced_volume(self) -> float:
        """Displaced volume [m^3]: the given one, or Cb L B T."""
        return float(self.volume if self.volume is not None
                     else self.Cb * self.L * self.B * self.T)


#: Lanxin USV, Mu et al. 2018 Table 1 (draft full load 0.32 m, Cb 0.6976, displacement 2.73 m^3).
# Note
#: the table is not self-consistent: Cb L B T = 4.07 m^3, not 2.73 m^3.
LANXIN = HullParticulars(L=7.02, B=2.60, T=0.32, Cb=0.6976, volume=2.73)


@dataclass(frozen=True)
class AddedMass:
    """Added-mass derivatives in Fossen's notation (all usually <= 0).

    X_udot [kg], Y_vdot [kg], Y_rdot [kg m], N_vdot [kg m], N_rdot [kg m^2].
    """

    X_udot: ArrayLike
    Y_vdot: ArrayLike
    Y_rdot: ArrayLike
    N_vdot: ArrayLike
    N_rdot: ArrayLike

    def matrix(self) -> np.ndarray:
        """Added-mass matrix ``M_A`` (3, 3) in surge, sway, yaw (scalar derivatives only)."""
        return -np.array([[self.X_udot, 0.0, 0.0],
                          [0.0, self.Y_vdot, self.Y_rdot],
                          [0.0, self.N_vdot, self.N_rdot]], dtype=float)

    def inertia_terms(self, m: ArrayLike, Iz: ArrayLike, x_g: ArrayLike = 0.0) -> dict:
        """Mu et al. 2018 eq. 15 inertia terms: m11 = m - X_udot, m22 = m - Y_vdot,
        m23 = m x_g - Y_rdot, m32 = m x_g - N_vdot, m33 = Iz - N_rdot.

        m [kg], Iz [kg m^2] about the body origin, x_g [m]; returns a dict of the five terms
        (the keyword names of ``usvid.models.threedof.ThreeDOF``).
        """
        mxg = np.asarray(m) * np.asarray(x_g)
        return {"m11": m - self.X_udot, "m22": m - self.Y_vdot, "m23": mxg - self.Y_rdot,
                "m32": mxg - self.N_vdot, "m33": Iz - self.N_rdot}


@dataclass(frozen=True)
class LinearDamping:
    """Linear sway/yaw damping derivatives (Fossen notation, usually Y_v, N_r < 0).

    Y_v [kg/s], Y_r [kg m/s], N_v [kg m/s], N_r [kg m^2/s].
    """

    Y_v: ArrayLike
    Y_r: ArrayLike
    N_v: ArrayLike
    N_r: ArrayLike


def soding_surge_added_mass(volume: ArrayLike, L: ArrayLike, rho: ArrayLike = 1025.0) -> ArrayLike:
    """Surge added mass ``A11 = -X_udot = 2.7 rho volume^(5/3) / L^2`` [kg] (Soding 1982).

    volume [m^3] displaced volume, L [m], rho [kg/m^3]. Typically A11/m < 0.2.
    """
    vol = np.asarray(volume, dtype=float)
    return np.asarray(2.7 * rho * vol ** (5.0 / 3.0) / np.asarray(L, dtype=float) ** 2)[()]


def clarke83_added_mass(L: ArrayLike, B: ArrayLike, T: ArrayLike, Cb: ArrayLike, *,
                        rho: ArrayLike = 1025.0, volume: ArrayLike | None = None,
                        surge: str = "soding") -> AddedMass:
    """Added-mass derivatives from main particulars (Clarke, Gedling & Hine 1983).

    Non-dimensional (prime system, forces by 1/2 rho L^2 U^2) with ``S = pi (T/L)^2``::

        -Y_vdot' / S = 1 + 0.16 Cb B/T - 5.1 (B/L)^2
        -Y_rdot' / S = 0.67 B/L - 0.0033 (B/T)^2
        -N_vdot' / S = 1.1 B/L - 0.041 B/T
        -N_rdot' / S = 1/12 + 0.017 Cb B/T - 0.33 B/L

    (Clarke et al. 1983, PMM regression; coefficients as in Fossen's MSS ``clarke83``),
    dimensional: ``Y_vdot = Y_vdot' rho L^3/2``, ``Y_rdot = Y_rdot' rho L^4/2``,
    ``N_vdot = N_vdot' rho L^4/2``, ``N_rdot = N_rdot' rho L^5/2``.
    Surge: ``surge="soding"`` -> ``X_udot = -2.7 rho V^(5/3) / L^2`` (Soding 1982), or
    ``surge="ten_percent"`` -> ``X_udot = -0.1 m`` (the older MSS rule), with m = rho V.

    L, B, T [m] (T = draught), Cb [-], rho [kg/m^3], volume [m^3] (default Cb L B T).
    """
    L, B, T, Cb, rho = checked("clarke83", L=L, B=B, T=T, Cb=Cb, rho=rho,
                               positive=("L", "B", "T", "Cb", "rho"))
    vol = Cb * L * B * T if volume is None else np.asarray(volume, dtype=float)
    S = np.pi * (T / L) ** 2
    Yvd = -S * (1.0 + 0.16 * Cb * B / T - 5.1 * (B / L) ** 2)
    Yrd = -S * (0.67 * B / L - 0.0033 * (B / T) ** 2)
    Nvd = -S * (1.1 * B / L - 0.041 * B / T)
    Nrd = -S * (1.0 / 12.0 + 0.017 * Cb * B / T - 0.33 * B / L)
    half = 0.5 * rho
    if surge == "soding":
        Xud = -soding_surge_added_mass(vol, L, rho)
    elif surge == "ten_percent":
        Xud = -0.1 * rho * vol
    else:
        raise UsvidError(f"clarke83_added_mass: surge must be 'soding' or 'ten_percent' "
                         f"(got {surge!r})")
    return AddedMass(X_udot=np.asarray(Xud)[()], Y_vdot=(Yvd * half * L ** 3)[()],
                     Y_rdot=(Yrd * half * L ** 4)[()], N_vdot=(Nvd * half * L ** 4)[()],
                     N_rdot=(Nrd * half * L ** 5)[()])


def clarke83_damping(U: ArrayLike, L: ArrayLike, B: ArrayLike, T: ArrayLike, Cb: ArrayLike, *,
                     rho: ArrayLike = 1025.0) -> LinearDamping:
    """Linear sway/yaw derivatives from main particulars (Clarke, Gedling & Hine 1983).

    With ``S = pi (T/L)^2`` (rotating-arm / PMM regression, coefficients as in MSS
    ``clarke83``)::

        -Y_v' / S = 1 + 0.4 Cb B/T          -Y_r' / S = -1/2 + 2.2 B/L - 0.08 B/T
        -N_v' / S = 1/2 + 2.4 T/L           -N_r' / S = 1/4 + 0.039 B/T - 0.56 B/L

    dimensional: ``Y_v = Y_v' rho L^2 U/2``, ``Y_r = Y_r' rho L^3 U/2``,
    ``N_v = N_v' rho L^3 U/2``, ``N_r = N_r' rho L^4 U/2``. These include the linearised
    Coriolis terms (Fossen: N(U) = C(U) + D). U [m/s] > 0, L, B, T [m], Cb [-], rho [kg/m^3].
    """
    U, L, B, T, Cb, rho = checked("clarke83", U=U, L=L, B=B, T=T, Cb=Cb, rho=rho,
                                  positive=("U", "L", "B", "T", "Cb", "rho"))
    S = np.pi * (T / L) ** 2
    Yv = -S * (1.0 + 0.4 * Cb * B / T)
    Yr = -S * (-0.5 + 2.2 * B / L - 0.08 * B / T)
    Nv = -S * (0.5 + 2.4 * T / L)
    Nr = -S * (0.25 + 0.039 * B / T - 0.56 * B / L)
    q = 0.5 * rho * U
    return LinearDamping(Y_v=(Yv * q * L ** 2)[()], Y_r=(Yr * q * L ** 3)[()],
                         N_v=(Nv * q * L ** 3)[()], N_r=(Nr * q * L ** 4)[()])


@dataclass(frozen=True)
class ZhouAddedMass:
    """Zhou et al. (1983) added masses (positive): m_x, m_y [kg], J_zz [kg m^2]."""

    m_x: ArrayLike
    m_y: ArrayLike
    J_zz: ArrayLike

    def as_added_mass(self) -> AddedMass:
        """The same numbers as Fossen-notation derivatives (cross terms 0)."""
        return AddedMass(X_udot=-np.asarray(self.m_x)[()], Y_vdot=-np.asarray(self.m_y)[()],
                         Y_rdot=0.0, N_vdot=0.0, N_rdot=-np.asarray(self.J_zz)[()])


def zhou_added_mass(L: ArrayLike, B: ArrayLike, d: ArrayLike, Cb: ArrayLike,
                    m: ArrayLike) -> ZhouAddedMass:
    """Added masses by Zhou et al.'s regression of Motora's charts (the catamaran paper eq. 17)::

        m_x / m = [0.398 + 11.97 Cb (1 + 3.73 d/B) - 2.89 Cb L/B (1 + 1.13 d/B)
                   + 0.175 Cb (L/B)^2 (1 + 0.541 d/B) - 1.107 (L/B)(d/B)] / 100
        m_y / m = 0.882 - 0.54 Cb (1 - 1.6 d/B) - 0.156 (1 - 0.673 Cb) L/B
                  + 0.826 (d/B)(L/B)(1 - 0.678 d/B) - 0.638 Cb (d/B)(L/B)(1 - 0.669 d/B)
        J_zz / m = [L/100 (33 - 76.85 Cb (1 - 0.784 Cb) + 3.43 L/B (1 - 0.63 Cb))]^2

    Source: Zhou Zhaoming, Sheng Ziyin, Feng Mingqing (1983), "Prediction of the manoeuvrability
    of multi-purpose cargo ships" (Chinese), regression of Motora's added-mass charts; the
    coefficients as reproduced in the MMG literature (Jia & Yang 1999, and the open MMG codes
    that cite "Zhou et al., 1983"). L [m], B [m], d [m] draught, Cb [-], m [kg] ship mass.
    """
    L, B, d, Cb, m = checked("zhou", L=L, B=B, d=d, Cb=Cb, m=m,
                             positive=("L", "B", "d", "Cb", "m"))
    lb = L / B
    db = d / B
    mx = m * (0.398 + 11.97 * Cb * (1.0 + 3.73 * db) - 2.89 * Cb * lb * (1.0 + 1.13 * db)
              + 0.175 * Cb * lb ** 2 * (1.0 + 0.541 * db) - 1.107 * lb * db) / 100.0
    my = m * (0.882 - 0.54 * Cb * (1.0 - 1.6 * db) - 0.156 * (1.0 - 0.673 * Cb) * lb
              + 0.826 * db * lb * (1.0 - 0.678 * db) - 0.638 * Cb * db * lb * (1.0 - 0.669 * db))
    k_zz = L / 100.0 * (33.0 - 76.85 * Cb * (1.0 - 0.784 * Cb) + 3.43 * lb * (1.0 - 0.63 * Cb))
    jz = m * k_zz ** 2
    return ZhouAddedMass(m_x=mx[()], m_y=my[()], J_zz=jz[()])


@dataclass(frozen=True)
class MMGLinearDerivatives:
    """Linear hull derivatives of the MMG model, non-dimensional (prime system of Yasukawa &
    Yoshimura 2015: forces by 0.5 rho L d U^2, moments by 0.5 rho L^2 d U^2, v' = v/U,
    r' = r L/U): Y_v, Y_r, N_v, N_r [-]."""

    Y_v: ArrayLike
    Y_r: ArrayLike
    N_v: ArrayLike
    N_r: ArrayLike


def kijima1990_linear_derivatives(L: ArrayLike, B: ArrayLike, d: ArrayLike, Cb: ArrayLike, *,
                                  m_prime: ArrayLike, m_x_prime: ArrayLike = 0.0
                                  ) -> MMGLinearDerivatives:
    """Linear MMG hull derivatives from main particulars (Kijima et al. 1990), even keel.

    With ``k = 2 d / L`` (Kijima et al. write the drift angle beta = -v' for small angles, so
    Y_v' = -Y_beta', N_v' = -N_beta')::

        Y_v' = -(pi/2 k + 1.4 Cb B/L)
        Y_r' = m' + m_x' - 1.5 Cb B/L
        N_v' = -k
        N_r' = -0.54 k + k^2

    L, B [m], d [m] draught, Cb [-] block coefficient, m_prime = m / (0.5 rho L^2 d) [-],
    m_x_prime the surge added mass on the same basis [-]. The trim terms of the original are
    omitted (even keel). For KVLCC2 (L 7.00, B 1.27, d 0.46, Cb 0.810, m' 0.290, m_x' 0.022)
    this gives Y_v' -0.412, Y_r' 0.092, N_v' -0.131, N_r' -0.054 against the captive-test values
    -0.315, 0.083, -0.137, -0.049 of Yasukawa & Yoshimura (2015).
    """
    L, B, d, Cb, m_prime, m_x_prime = checked(
        "kijima1990", L=L, B=B, d=d, Cb=Cb, m_prime=m_prime, m_x_prime=m_x_prime,
        positive=("L", "B", "d", "Cb", "m_prime"), nonnegative=("m_x_prime",))
    cbl = Cb * B / L
    k = 2.0 * d / L
    Yv = -(0.5 * np.pi * k + 1.4 * cbl)
    Yr = m_prime + m_x_prime - 1.5 * cbl
    return MMGLinearDerivatives(Y_v=np.asarray(Yv)[()], Y_r=np.asarray(Yr)[()],
                                N_v=np.asarray(-k)[()], N_r=np.asarray(-0.54 * k + k ** 2)[()])


__all__ = [
    "LANXIN", "AddedMass", "HullParticulars", "LinearDamping", "MMGLinearDerivatives",
    "ZhouAddedMass", "clarke83_added_mass", "clarke83_damping", "kijima1990_linear_derivatives",
    "soding_surge_added_mass", "zhou_added_mass",
]
