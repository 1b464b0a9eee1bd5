"""Empirical relative turning diameter of Ma et al. (a 1.5 m planing USV model).

Eq. 1:  ``D/L = a1 (Fr + a2 Fr^2 + a3 Fr^3) / (delta^a4 + a5 delta)``,
Eq. 2:  ``F = sqrt( sum_i [D_Li - D/L(Fr_i, delta_i)]^2 / N )`` (RMS objective of the fit),
Eq. 3:  the published fit a = (297.4084, -3.7937, 2.1316, 0.9707, 5.1594).

Units: Fr = V / sqrt(g L) [-] (V [m/s], L [m], g = 9.81 m/s^2), delta = rudder angle in
**radians** (the paper says "the unit is rad", and Table 2 lists 0.349...0.611 rad for
20...35 deg); D/L [-]. The reading is confirmed numerically: eq. 3 on Table 2 gives
F = 0.46650 (paper: 0.4665); the same with delta in degrees would give nonsense (D/L < 0.4).

The package data ``usvid/data/ma_table1.csv`` (Table 1, the 36 turning tests) and
``ma_table2.csv`` (Table 2: Fr, delta [rad], measured and identified D/L) are read by
:func:`load_ma_table1` / :func:`load_ma_table2`.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from importlib import resources

import numpy as np

from usvid.errors import UsvidError
from usvid.models.thrust import G, froude_number

ArrayLike = float | np.ndarray

KNOT = 1852.0 / 3600.0  # [m/s]

#: Length of the Ma et al. model [m].
MA_LENGTH = 1.5


@dataclass(frozen=True)
class TurningDiameterCoeffs:
    """Coefficients a1..a5 of Ma et al. eq. 1 (all dimensionless)."""

    a1: float
    a2: float
    a3: float
    a4: float
    a5: float

    def as_array(self) -> np.ndarray:
        """(5,) float array [a1, a2, a3, a4, a5]."""
        return np.array([self.a1, self.a2, self.a3, self.a4, self.a5], dtype=float)

    @classmethod
    def from_array(cls, a: ArrayLike) -> TurningDiameterCoeffs:
        """From a length-5 sequence [a1..a5]."""
        arr = np.asarray(a, dtype=float).ravel()
        if arr.size != 5:
            raise UsvidError(f"turning-diameter coefficients: expected 5 values a1..a5 "
                             f"(got {arr.size})")
        return cls(*(float(x) for x in arr))


#: Ma et al. eq. 3, the published chaotic-GA fit.
MA_EQ3 = TurningDiameterCoeffs(a1=297.4084, a2=-3.7937, a3=2.1316, a4=0.9707, a5=5.1594)

#: Ma et al. search bounds of the GA, (low, high) per a1..a5.
MA_BOUNDS: tuple[tuple[float, float], ...] = (
    (-20.0, 700.0), (-5.0, 5.0), (0.0, 5.0), (-5.0, 5.0), (-5.0, 30.0))


def _coeff_columns(a: TurningDiameterCoeffs | ArrayLike) -> tuple[np.ndarray, ...]:
    arr = a.as_array() if isinstance(a, TurningDiameterCoeffs) else np.asarray(a, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 5:
        raise UsvidError(f"turning-diameter coefficients: last axis must hold a1..a5 "
                         f"(got shape {arr.shape})")
    return tuple(arr[..., k] for k in range(5))


def relative_turning_diameter(Fr: ArrayLike, delta: ArrayLike,
                              a: TurningDiameterCoeffs | ArrayLike = MA_EQ3) -> np.ndarray:
    """Relative steady turning diameter D/L [-] of Ma et al. eq. 1.

    ``D/L = a1 (Fr + a2 Fr^2 + a3 Fr^3) / (|delta|^a4 + a5 |delta|)``.

    Fr [-] Froude number, delta [rad] rudder angle (its magnitude is used: the model is
    symmetric port/starboard), ``a`` a :class:`TurningDiameterCoeffs` or an array whose last axis
    holds a1..a5. Batch: with ``a`` of shape (P, 5) and data of shape S the result has shape
    (P, *S) (coefficient sets first); with one coefficient set it has the data's shape.
    delta = 0 gives an infinite diameter (division by zero, no warning suppression).
    """
    a1, a2, a3, a4, a5 = _coeff_columns(a)
    Fr = np.asarray(Fr, dtype=float)
    d = np.abs(np.asarray(delta, dtype=float))
    data_nd = np.broadcast(Fr, d).nd
    expand = (...,) + (None,) * data_nd
    a1, a2, a3, a4, a5 = (c[expand] for c in (a1, a2, a3, a4, a5))
    with np.errstate(divide="ignore"):
        out = a1 * (Fr + a2 * Fr ** 2 + a3 * Fr ** 3) / (d ** a4 + a5 * d)
    return np.asarray(out)[()]


def rms_objective(a: TurningDiameterCoeffs | ArrayLike, Fr: ArrayLike, delta: ArrayLike,
                  DL: ArrayLike) -> np.ndarray:
    """RMS objective F of Ma et al. eq. 2 [-].

    ``F = sqrt(mean_i (DL_i - D/L(Fr_i, delta_i; a))^2)`` over the N data points (Fr [-],
    delta [rad], DL [-], 1-D of equal length). ``a`` as in :func:`relative_turning_diameter`;
    with a (P, 5) population the result is (P,) -- one objective per coefficient set, which is
    what a genetic algorithm evaluates per generation.
    """
    Fr = np.asarray(Fr, dtype=float)
    DL = np.asarray(DL, dtype=float)
    if Fr.ndim != 1 or np.shape(delta) != Fr.shape or DL.shape != Fr.shape:
        raise UsvidError("rms_objective: Fr, delta and DL must be 1-D arrays of equal length "
                         f"(got shapes {Fr.shape}, {np.shape(delta)}, {DL.shape})")
    pred = relative_turning_diameter(Fr, delta, a)
    return np.asarray(np.sqrt(np.mean((DL - pred) ** 2, axis=-1)))[()]


def turning_diameter(V: ArrayLike, delta: ArrayLike, L: ArrayLike,
                     a: TurningDiameterCoeffs | ArrayLike = MA_EQ3,
                     g: float = G) -> np.ndarray:
    """Steady turning diameter D [m] = L * D/L(V / sqrt(g L), delta) (Ma et al. eq. 1).

    V [m/s] approach speed, delta [rad], L [m] vessel length.
    """
    return np.asarray(np.asarray(L, dtype=float)
                      * relative_turning_diameter(froude_number(V, L, g), delta, a))[()]


# ---------------------------------------------------------------------------------------------
# Ma et al. tables (package data)
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class MaTable1:
    """Ma et al. Table 1, one entry per turning test (36): voltage_V [V], draft_m [m],
    displacement_kg [kg], speed_kn [kn], rudder_deg [deg], turning_diameter_m [m]."""

    voltage_V: np.ndarray
    draft_m: np.ndarray
    displacement_kg: np.ndarray
    speed_kn: np.ndarray
    rudder_deg: np.ndarray
    turning_diameter_m: np.ndarray

    def fit_inputs(self, L: float = MA_LENGTH,
                   g: float = 9.8) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Fr [-], delta [rad], D/L [-]) for eq. 1-2: Fr = speed / sqrt(g L), L = 1.5 m.

        g defaults to 9.8 m/s^2, the value the paper evidently used: with it (and 1 kn = 1852/3600
        m/s) the Froude numbers round to Table 2's printed ones for 8 of the 9 speeds (1.21 kn
        gives 0.162355, printed 0.1623, a rounding-boundary case); with 9.81 four speeds differ
        in the 4th decimal.
        """
        Fr = froude_number(self.speed_kn * KNOT, L, g)
        return Fr, np.deg2rad(self.rudder_deg), self.turning_diameter_m / L


@dataclass(frozen=True)
class MaTable2:
    """Ma et al. Table 2 (36 rows): Fr [-], delta_rad [rad], DL_test [-] measured D/L,
    DL_identified [-] the paper's eq. 3 output, relative_error_pct [%] as printed."""

    Fr: np.ndarray
    delta_rad: np.ndarray
    DL_test: np.ndarray
    DL_identified: np.ndarray
    relative_error_pct: np.ndarray


def _read_csv(name: str) -> dict[str, np.ndarray]:
    text = resources.files("usvid").joinpath("data", name).read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    rows = list(csv.reader(io.StringIO("\n".join(lines))))
    header, body = rows[0], rows[1:]
    cols = {h: np.array([float(r[i]) for r in body]) for i, h in enumerate(header)}
    return cols


def load_ma_table1() -> MaTable1:
    """Ma et al. Table 1 from the package data ``usvid/data/ma_table1.csv``."""
    return MaTable1(**_read_csv("ma_table1.csv"))


def load_ma_table2() -> MaTable2:
    """Ma et al. Table 2 from the package data ``usvid/data/ma_table2.csv``."""
    return MaTable2(**_read_csv("ma_table2.csv"))


__all__ = [
    "MA_BOUNDS", "MA_EQ3", "MA_LENGTH", "MaTable1", "MaTable2",
    "TurningDiameterCoeffs", "froude_number", "load_ma_table1", "load_ma_table2",
    "relative_turning_diameter", "rms_objective", "turning_diameter",
]
