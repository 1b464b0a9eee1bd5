"""How far the data pin down a prediction of Ma et al.'s turning-diameter model: the profile
likelihood interval of D/L at one (Fr, delta).

Ma et al. eq. 1 has five coefficients for 36 turning tests at Fr 0.098-0.188 and delta 20-35
deg; its least-squares optimum within the paper's search bounds lies on two of them (a1 = 700,
a3 = 5): the data leave a ridge of nearly equal fits that agree inside the tested range and
part outside it (at Fr 0.3 and 10 deg the bounded optimum predicts D/L 9.7, the published eq. 3
4.4).

The interval is the profile-likelihood (likelihood-ratio) interval of the prediction
``p(a) = D/L(Fr0, delta0; a)`` for Gaussian errors of unknown variance (Venzon & Moolgavkar
1988; Seber & Wild 2003, section 5.4): the set of values p(a) over the coefficients a within
the bounds whose residual sum of squares satisfies

    N ln(SSR(a) / SSR_min) <= chi2_1(level)

(SSR_min the smallest SSR within the bounds, N the number of tests). Eq. 1 is linear in a1, so
for given a2..a5 the admissible a1 form an interval in closed form and the prediction is extreme
at one of its ends (:class:`_Profile`); the ends of the interval are then searched over a2..a5
by differential evolution (``scipy.optimize.differential_evolution``, seeded, vectorised, 300
generations of 80), started from the best fit. With the optimum on the bounds the chi-square
calibration is approximate: read the interval as how far the equally good fits spread, not as
an exact coverage.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize, stats

from usvid.errors import IdentificationError
from usvid.models.turning_diameter import MA_BOUNDS, relative_turning_diameter


@dataclass
class PredictionInterval:
    """D/L [-] at ``Fr`` [-] and ``delta`` [rad]: ``low``/``high`` ends of the ``level``
    profile-likelihood interval, ``by_fit`` the point predictions of the given fits,
    ``ssr_min`` [-] (smallest residual sum of squares found within the bounds) and
    ``ssr_limit`` [-] (the largest SSR inside the interval's set), ``a_low``/``a_high`` the
    coefficients a1..a5 at the ends, ``a_opt`` those of the smallest SSR found (the bounded
    least-squares optimum; ``sqrt(ssr_min / N)`` is its objective F of Ma et al. eq. 2),
    ``inside_data`` whether (Fr, delta) lies within the ranges of the data."""

    Fr: float
    delta: float
    level: float
    low: float
    high: float
    ssr_min: float
    ssr_limit: float
    a_low: np.ndarray
    a_high: np.ndarray
    a_opt: np.ndarray
    inside_data: bool
    by_fit: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``Fr``, ``delta_deg``, ``level``, ``low``, ``high``, ``by_fit``,
        ``ssr_min``, ``ssr_limit``, ``inside_data``, ``a_low``, ``a_high``."""
        return {"Fr": self.Fr, "delta_deg": math.degrees(self.delta), "level": self.level,
                "low": self.low, "high": self.high, "by_fit": dict(self.by_fit),
                "ssr_min": self.ssr_min, "ssr_limit": self.ssr_limit,
                "inside_data": self.inside_data, "a_low": self.a_low.tolist(),
                "a_high": self.a_high.tolist(), "a_opt": self.a_opt.tolist()}


def _shape(Fr: np.ndarray, delta: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Eq. 1 divided by a1, ``(Fr + a2 Fr^2 + a3 Fr^3) / (|delta|^a4 + a5 |delta|)``, for
    coefficient rows ``A`` (M, 4) = a2..a5 and data (N,): (M, N)."""
    a2, a3, a4, a5 = (A[:, k:k + 1] for k in range(4))
    f, d = Fr[None, :], np.abs(delta)[None, :]
    with np.errstate(all="ignore"):
        return (f + a2 * f**2 + a3 * f**3) / (d**a4 + a5 * d)


class _Profile:
    """Eq. 1 is linear in a1: for given a2..a5 the residual sum of squares is the quadratic
    ``SSR(a1) = a1^2 Sgg - 2 a1 Sgd + Sdd`` (g the model divided by a1), so the a1 that keep
    SSR <= limit form an interval (intersected with a1's bounds) and the prediction a1 g0 is
    extreme at one of its ends: the search runs over a2..a5 only, a1 in closed form."""

    def __init__(self, Fr, delta, DL, Fr0, delta0, lo1, hi1):
        self.Fr, self.delta, self.DL = Fr, delta, DL
        self.Fr0, self.delta0 = np.array([Fr0]), np.array([delta0])
        self.lo1, self.hi1 = lo1, hi1
        self.Sdd = float(DL @ DL)

    def sums(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        g = _shape(self.Fr, self.delta, A)
        g0 = _shape(self.Fr0, self.delta0, A)[:, 0]
        return np.sum(g * g, axis=1), g @ self.DL, g0

    def ssr_min(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest SSR over a1 within its bounds, and that a1, per row of A (M, 4)."""
        Sgg, Sgd, _ = self.sums(A)
        with np.errstate(all="ignore"):
            a1 = np.clip(Sgd / Sgg, self.lo1, self.hi1)
        s = a1 * a1 * Sgg - 2.0 * a1 * Sgd + self.Sdd
        return np.where(np.isfinite(s), s, np.inf), a1

    def extreme(self, A: np.ndarray, limit: float, sign: float
                ) -> tuple[np.ndarray, np.ndarray]:
        """``-sign * prediction`` at the a1 end that makes ``sign * prediction`` largest within
        SSR <= limit (penalised by the excess SSR where no a1 qualifies), and that a1."""
        Sgg, Sgd, g0 = self.sums(A)
        with np.errstate(all="ignore"):
            disc = Sgd * Sgd - Sgg * (self.Sdd - limit)
            root = np.sqrt(np.maximum(disc, 0.0))
            lo = np.maximum((Sgd - root) / Sgg, self.lo1)
            hi = np.minimum((Sgd + root) / Sgg, self.hi1)
            a1 = np.where(sign * g0 > 0, hi, lo)
            val = -sign * a1 * g0
        ok = (disc >= 0) & (lo <= hi) & np.isfinite(val) & (Sgg > 0)
        smin, _ = self.ssr_min(A)
        pen = 1e6 + np.where(np.isfinite(smin), smin - limit, 1e6)
        return np.where(ok, val, pen), a1


def prediction_interval(Fr: Any, delta: Any, DL: Any, Fr0: float, delta0: float,
                        fits: dict[str, Any], *, level: float = 0.95,
                        bounds: Sequence[tuple[float, float]] = MA_BOUNDS
                        ) -> PredictionInterval:
    """Profile-likelihood interval (module docstring) of D/L at ``Fr0`` [-], ``delta0`` [rad]
    from the data Fr [-], delta [rad], DL [-] (1-D, equal length) and the fitted coefficient
    sets ``fits`` ({name: a1..a5}; their predictions are reported, the best of them starts the
    search). ``level`` in (0, 1); ``bounds`` the five (lo, hi) of the coefficients."""
    Fr, delta, DL = (np.asarray(v, dtype=float) for v in (Fr, delta, DL))
    if not 0.0 < level < 1.0:
        raise IdentificationError(f"prediction interval: level must be in (0, 1) (got {level!r})")
    if not (math.isfinite(Fr0) and math.isfinite(delta0) and delta0 != 0.0):
        raise IdentificationError(f"prediction interval: need a finite Fr and a non-zero rudder "
                                  f"angle (got Fr {Fr0!r}, delta {delta0!r} rad)")
    if not fits:
        raise IdentificationError("prediction interval: no fitted coefficients given")
    b = np.asarray(bounds, dtype=float)
    lo, hi = b[:, 0], b[:, 1]
    prof = _Profile(Fr, delta, DL, float(Fr0), float(delta0), lo[0], hi[0])
    arrays = {k: np.asarray(getattr(v, "as_array", lambda v=v: v)(), dtype=float)
              for k, v in fits.items()}
    rest = [(float(lo[k]), float(hi[k])) for k in range(1, 5)]

    def search(f: Any, x0s: list[np.ndarray]) -> np.ndarray:
        # global: differential evolution, seeded and vectorised, started from the best fit
        return optimize.differential_evolution(
            lambda X: f(X.T), rest, seed=0, vectorized=True, updating="deferred", popsize=20,
            maxiter=300, tol=1e-10, polish=False, init="sobol",
            x0=min(x0s, key=lambda x: f(x[None])[0])).x

    x0s = [a[1:] for a in arrays.values()]
    best = search(lambda A: prof.ssr_min(A)[0], x0s)
    cands = [best, *x0s]
    sm = [prof.ssr_min(x[None]) for x in cands]
    k = int(np.argmin([v[0][0] for v in sm]))
    ssr_min = float(sm[k][0][0])
    a_opt = np.concatenate([sm[k][1], cands[k]])
    limit = ssr_min * math.exp(stats.chi2.ppf(level, 1) / Fr.size)
    ends = {}
    for sign in (1.0, -1.0):
        x = search(lambda A, s=sign: prof.extreme(A, limit, s)[0], [best, *x0s])
        val, a1 = prof.extreme(x[None], limit, sign)
        if val[0] >= 1e6:
            raise IdentificationError("prediction interval: no coefficients found within the "
                                      "likelihood bound (search failed)")
        ends[sign] = np.concatenate([a1, x])

    def pred(a: np.ndarray) -> float:
        with np.errstate(all="ignore"):
            return float(relative_turning_diameter(Fr0, delta0, a))

    inside = bool(Fr.min() <= Fr0 <= Fr.max()
                  and np.abs(delta).min() <= abs(delta0) <= np.abs(delta).max())
    return PredictionInterval(
        Fr=float(Fr0), delta=float(delta0), level=float(level), low=pred(ends[-1.0]),
        high=pred(ends[1.0]), ssr_min=float(ssr_min), ssr_limit=float(limit),
        a_low=ends[-1.0], a_high=ends[1.0], a_opt=a_opt, inside_data=inside,
        by_fit={k: pred(a) for k, a in arrays.items()})
