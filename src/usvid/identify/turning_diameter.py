"""Fitting Ma et al.'s relative turning-diameter model (eq. 1) by CGA and by least squares.

The model, the RMS objective F (eq. 2), the published coefficients (eq. 3), the GA bounds and
the Tables live in :mod:`usvid.models.turning_diameter` (package data
``usvid/data/ma_table*.csv``); this module only estimates. Methods (each returns a
:class:`TurningDiameterFit`):

* ``"cga"`` -- the chaotic genetic algorithm exactly as Ma et al. configures it
  (:func:`usvid.identify.cga.cga`, population 100, 1000 generations, ..., seeded), minimising F
  within :data:`~usvid.models.turning_diameter.MA_BOUNDS`.
* ``"least_squares"`` -- a deterministic global fit: ``scipy.optimize.differential_evolution``
  (seeded, vectorised over its population) within the same bounds, polished by
  ``scipy.optimize.least_squares`` (trust-region reflective, bounded). Minimising the sum of
  squares minimises F.
* ``"published_eq3"`` -- Ma et al. eq. 3 evaluated on the data (no fitting).

Leave-one-out error (``loo_rmse``): for each data point i the coefficients are re-fitted on the
other N - 1 points by bounded ``least_squares`` *started from the method's full-data optimum* (a
warm-started local refit: re-running a 1000-generation GA 36 times would add nothing but time), the
point i is predicted, and ``loo_rmse = sqrt(mean(e_i^2))`` [-]. The published coefficients are not
a fitting method, so their ``loo_rmse`` is None.

On Table 2 the unconstrained least-squares optimum runs along a ridge out of the box (a1 and a3
end on their upper bounds 700 and 5): eq. 1 is over-parameterised for 36 points. ``at_bounds``
names the parameters on a bound.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import optimize

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.cga import cga
from usvid.models.turning_diameter import (
    KNOT,
    MA_BOUNDS,
    MA_EQ3,
    MA_LENGTH,
    TurningDiameterCoeffs,
    froude_number,
    load_ma_table2,
    relative_turning_diameter,
    rms_objective,
)

METHODS = ("cga", "least_squares", "published_eq3")
PARAMS = ("a1", "a2", "a3", "a4", "a5")


@dataclass
class TurningDiameterFit:
    """One method's result: ``coeffs`` (a1..a5), ``F`` (Ma et al. eq. 2 on the data) [-],
    ``loo_rmse`` [-] (None when not applicable), ``max_rel_error`` max |pred/DL - 1| [-],
    ``at_bounds`` (names of coefficients on a bound), ``details`` (method specifics)."""

    method: str
    coeffs: TurningDiameterCoeffs
    F: float
    loo_rmse: float | None
    max_rel_error: float
    n: int
    at_bounds: list[str] = field(default_factory=list)
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """``{"a1": ..., ..., "a5": ..., "F": ..., "loo_rmse": ..., ...}`` (JSON-ready)."""
        out: dict[str, Any] = dict(zip(PARAMS, self.coeffs.as_array().tolist(), strict=True))
        out.update(F=self.F, loo_rmse=self.loo_rmse, max_rel_error=self.max_rel_error, n=self.n,
                   at_bounds=self.at_bounds, **self.details)
        return out


def _check_data(Fr: Any, delta: Any, DL: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrs = [np.asarray(v, dtype=float) for v in (Fr, delta, DL)]
    names = ("Fr", "delta", "DL")
    for nm, a in zip(names, arrs, strict=True):
        if a.ndim != 1:
            raise IdentificationError(f"turning-diameter fit: {nm} must be 1-D (got {a.shape})")
        if not np.all(np.isfinite(a)):
            i = int(np.argmax(~np.isfinite(a)))
            raise IdentificationError(f"turning-diameter fit: {nm} is not finite at row {i}")
    if not arrs[0].size == arrs[1].size == arrs[2].size:
        raise IdentificationError("turning-diameter fit: Fr, delta and DL differ in length")
    if arrs[0].size < 6:
        raise IdentificationError(
            f"turning-diameter fit: too few data points ({arrs[0].size}) for 5 coefficients "
            "(need at least 6)")
    if np.any(arrs[1] == 0):
        raise IdentificationError("turning-diameter fit: delta = 0 (straight running) has an "
                                  "infinite turning diameter; remove those rows")
    if np.ptp(arrs[1]) == 0 or np.ptp(arrs[0]) == 0:
        raise IdentificationError("turning-diameter fit: no excitation (Fr or delta constant)")
    return arrs[0], arrs[1], arrs[2]


def _objective(Fr: np.ndarray, delta: np.ndarray, DL: np.ndarray):
    def f(A: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            v = rms_objective(A, Fr, delta, DL)
        return np.where(np.isfinite(v), v, 1e12)
    return f


def _residuals(Fr: np.ndarray, delta: np.ndarray, DL: np.ndarray):
    def r(a: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            v = relative_turning_diameter(Fr, delta, a) - DL
        return np.where(np.isfinite(v), v, 1e6)
    return r


def _local_fit(Fr, delta, DL, x0, lo, hi) -> np.ndarray:
    x0 = np.clip(x0, lo, hi)
    # least_squares needs a strictly interior start
    span = hi - lo
    x0 = np.clip(x0, lo + 1e-9 * span, hi - 1e-9 * span)
    res = optimize.least_squares(_residuals(Fr, delta, DL), x0, bounds=(lo, hi), method="trf",
                                 x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return res.x


def leave_one_out_rmse(Fr: Any, delta: Any, DL: Any, a: Any,
                       bounds: Sequence[tuple[float, float]] = MA_BOUNDS) -> float:
    """Leave-one-out prediction RMS [-] by warm-started bounded least-squares refits from ``a``."""
    Fr, delta, DL = _check_data(Fr, delta, DL)
    b = np.asarray(bounds, dtype=float)
    a0 = np.asarray(a.as_array() if isinstance(a, TurningDiameterCoeffs) else a, dtype=float)
    err = np.empty(Fr.size)
    keep = np.ones(Fr.size, dtype=bool)
    for i in range(Fr.size):
        keep[:] = True
        keep[i] = False
        ai = _local_fit(Fr[keep], delta[keep], DL[keep], a0, b[:, 0], b[:, 1])
        err[i] = float(relative_turning_diameter(Fr[i], delta[i], ai)) - DL[i]
    return float(np.sqrt(np.mean(err**2)))


def _make(method, a, Fr, delta, DL, bounds, loo, details) -> TurningDiameterFit:
    a = np.asarray(a, dtype=float)
    pred = relative_turning_diameter(Fr, delta, a)
    b = np.asarray(bounds, dtype=float)
    tol = 1e-6 * (b[:, 1] - b[:, 0])
    at = [PARAMS[k] for k in range(5)
          if abs(a[k] - b[k, 0]) <= tol[k] or abs(a[k] - b[k, 1]) <= tol[k]]
    return TurningDiameterFit(
        method=method, coeffs=TurningDiameterCoeffs.from_array(a),
        F=float(rms_objective(a, Fr, delta, DL)),
        loo_rmse=leave_one_out_rmse(Fr, delta, DL, a, bounds) if loo else None,
        max_rel_error=float(np.max(np.abs(pred / DL - 1.0))), n=int(Fr.size), at_bounds=at,
        details=details)


def fit_turning_diameter(Fr: Any, delta: Any, DL: Any, *,
                         methods: Sequence[str] = METHODS, seed: int = 0,
                         bounds: Sequence[tuple[float, float]] = MA_BOUNDS,
                         loo: bool = True, cga_options: dict[str, Any] | None = None,
                         ) -> dict[str, TurningDiameterFit]:
    """Fit Ma et al. eq. 1 to data by each of ``methods`` (see the module docstring).

    Fr [-] Froude numbers, delta [rad] rudder angles, DL [-] measured relative turning diameters
    (1-D, equal length). ``seed`` seeds the CGA and differential evolution; ``cga_options``
    overrides :func:`~usvid.identify.cga.cga` settings (Ma et al.'s by default). Returns
    ``{method: TurningDiameterFit}`` in the order given.
    """
    Fr, delta, DL = _check_data(Fr, delta, DL)
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise IdentificationError(f"turning-diameter fit: unknown method(s) {unknown}; "
                                  f"choose from {list(METHODS)}")
    b = np.asarray(bounds, dtype=float)
    if b.shape != (5, 2) or np.any(b[:, 1] <= b[:, 0]):
        raise IdentificationError(
            "turning-diameter fit: `bounds` must be 5 (lo, hi) pairs with lo < hi")
    lo, hi = b[:, 0], b[:, 1]
    obj = _objective(Fr, delta, DL)
    out: dict[str, TurningDiameterFit] = {}
    for m in methods:
        if m == "cga":
            r = cga(obj, b, seed=seed, **(cga_options or {}))
            out[m] = _make(m, r.x, Fr, delta, DL, b, loo,
                           {"seed": seed, "n_evaluations": r.n_evaluations, **r.settings})
        elif m == "least_squares":
            de = optimize.differential_evolution(
                lambda A: obj(A.T), b, seed=seed, vectorized=True, updating="deferred",
                popsize=30, maxiter=2000, tol=1e-10, polish=False)
            x = _local_fit(Fr, delta, DL, de.x, lo, hi)
            if obj(x[None])[0] > de.fun:  # keep the better of DE and its polish
                x = de.x
            out[m] = _make(m, x, Fr, delta, DL, b, loo,
                           {"seed": seed, "global": "differential_evolution",
                            "local": "least_squares (trf, bounded)"})
        else:
            out[m] = _make(m, MA_EQ3.as_array(), Fr, delta, DL, b, False,
                           {"source": "Ma et al. eq. 3"})
    return out


def _parse_table(text: str, name: str, length: float) -> tuple[np.ndarray, ...]:
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise UsvidError(f"{name}: empty table")
    rows = list(csv.reader(io.StringIO("\n".join(ln for _, ln in lines))))
    header = [h.strip() for h in rows[0]]
    body = list(zip((i for i, _ in lines[1:]), rows[1:], strict=True))
    if not body:
        raise UsvidError(f"{name}: no data rows under the header")

    def col(options: Sequence[str]) -> np.ndarray | None:
        for opt in options:
            if opt in header:
                j = header.index(opt)
                vals = []
                for lineno, r in body:
                    try:
                        v = float(r[j])
                    except (IndexError, ValueError):
                        got = r[j] if j < len(r) else "nothing"
                        raise UsvidError(f"{name} line {lineno}: column {opt!r}: expected a "
                                         f"number (got {got!r})") from None
                    if not np.isfinite(v):
                        raise UsvidError(f"{name} line {lineno}: column {opt!r} is not finite")
                    vals.append(v)
                return np.array(vals)
        return None

    Fr, de, DL = col(["Fr"]), col(["delta_rad", "delta"]), col(["DL_test", "DL"])
    if Fr is not None and de is not None and DL is not None:
        return Fr, de, DL
    V, rud, D = col(["speed_kn"]), col(["rudder_deg"]), col(["turning_diameter_m"])
    if V is not None and rud is not None and D is not None:
        # Table 1 form; g = 9.8 m/s^2 as the paper evidently used (see MaTable1.fit_inputs)
        return froude_number(V * KNOT, length, 9.8), np.deg2rad(rud), D / length
    raise UsvidError(
        f"{name}: expected columns Fr, delta_rad (or delta), DL_test (or DL) -- or Table 1's "
        f"speed_kn, rudder_deg, turning_diameter_m; found {header}")


def load_turning_table(path: str | Path | None = None, *, length: float = MA_LENGTH
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Fr [-], delta [rad], DL [-]) from a CSV table, or Ma et al. Table 2 when ``path`` is None.

    Accepted columns: ``Fr, delta_rad|delta, DL_test|DL`` (Table 2 form) or ``speed_kn,
    rudder_deg, turning_diameter_m`` (Table 1 form, converted with ``length`` [m]). Lines starting
    with ``#`` are comments. Errors name the file, line and column.
    """
    if path is None:
        t = load_ma_table2()
        return t.Fr, t.delta_rad, t.DL_test
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UsvidError(f"{p}: cannot read table ({exc})") from None
    return _parse_table(text, str(p), length)
