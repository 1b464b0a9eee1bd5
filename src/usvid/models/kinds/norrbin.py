"""Norrbin nonlinear yaw response: ``T r' + n1 r + n3 r^3 = K (delta + delta0)``, constant U.

Norrbin 1963; Mu et al. 2018, eq. 34-35 is the case n1 = 1, n3 = alpha [s^2/rad^2]. A free
linear term n1 < 0 describes a course-unstable vessel whose turns are held by n3 > 0 (the KVLCC2).
The model file normalises |n1| = 1 (n1 = +1 or -1; T then carries the scale).

Regression (equation error): ``r' = a1 r + a3 r^3 + b delta + c`` on smoothed r, delta, r';
T = 1/|a1|, n1 = -sign(a1), K = b T, n3 = -a3 T, delta0 = c/b.

Output error fits in the T = 1 normalisation (``k = K/T, m1 = n1/T, m3 = n3/T, delta0``), in
which m1 passes continuously through 0 between course-stable and course-unstable; the model file
gets T = 1/|m1|, n1 = sign(m1), K = k T, n3 = m3 T (the same dynamics).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.models.kind import (
    Block,
    Dynamics,
    FitSpace,
    ModelKind,
    Regression,
    inverse,
    param,
    rows,
)


@dataclass
class Norrbin(Dynamics):
    """Norrbin ``T r' + n1 r + n3 r^3 = K (delta + delta0)``: K [1/s], T [s] > 0, n1 [-],
    n3 [s^2/rad^2], delta0 [rad]."""

    K: Any = param("1/s", "gain: yaw rate per radian of rudder (linear part)")
    T: Any = param("s", "yaw time constant", gt=0.0)
    n1: Any = param("-", "linear damping sign: +1 course-stable, -1 course-unstable",
                    default=1.0)
    n3: Any = param("s^2/rad^2", "cubic yaw damping (Mu et al. 2018: alpha)", default=0.0)
    delta0: Any = param("rad", "rudder offset", default=0.0)
    N_delta: Any = param("N m/rad", "yaw moment of one radian of rudder: an external yaw moment "
                         "N (wind, waves) acts as the rudder angle N / N_delta (null: none)",
                         fit=False, default=None, gt=0.0)
    kind: ClassVar[str] = "norrbin"

    def steady_yaw_rate(self, delta: float) -> float:
        """Steady yaw rate [rad/s]: the real root of ``n1 r + n3 r^3 = K (delta + delta0)``.

        Scalars only. With n1 < 0 and n3 > 0 there may be three roots (the loop of a
        course-unstable vessel); the one with the sign of ``K (delta + delta0)`` and the largest
        magnitude is returned (the stable turn). With n1 = n3 = 0 there is none: +-inf.
        """
        rhs_ = float(self.K) * (float(delta) + float(self.delta0))
        n1, n3 = float(self.n1), float(self.n3)
        if n3 == 0.0:
            if n1 == 0.0:
                return math.copysign(math.inf, rhs_) if rhs_ != 0.0 else 0.0
            return rhs_ / n1
        roots = np.roots([n3, 0.0, n1, -rhs_])
        real = roots[np.abs(roots.imag) < 1e-9 * max(1.0, np.max(np.abs(roots)))].real
        same = real[np.sign(real) == np.sign(rhs_)] if rhs_ != 0 else real
        pick = same if same.size else real
        return float(pick[np.argmax(np.abs(pick))])


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """r' = (K (delta + delta0) - n1 r - n3 r^3) / T; rows K, T, n1, n3, delta0, U, 1/T,
    1/N_delta (0: none); an external yaw moment f[3] adds f[3] / N_delta to delta."""
    r = s[0]
    d = a[0]
    if f[3] != 0.0:  # an external yaw moment as a rudder-equivalent angle (calm: compiled away)
        d = d + p[7] * f[3]
    dr = (p[0] * (d + p[4]) - p[2] * r - p[3] * r * r * r) * p[6]
    return p[5], 0.0, r, (dr,)


def pack(d: Norrbin, speed: Any) -> np.ndarray:
    return rows([d.K, d.T, d.n1, d.n3, d.delta0, speed, 1.0 / np.asarray(d.T, float),
                 inverse(d.N_delta)])


def _blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
            h: float) -> list[Block]:
    parts = [(np.column_stack([s["r_s"], s["r_s"] ** 3, s["delta_s"], np.ones(len(s["t"]))]),
              s["rdot_s"]) for s in series]
    return [Block("r", np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                  ("a1", "a3", "b", "c"), [len(p[1]) for p in parts])]


def _to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
               h: float) -> dict[str, float]:
    a1, a3, b, c = th["a1"], th["a3"], th["b"], th["c"]
    T = 1.0 / max(abs(a1), 1e-12)
    return {"K": b * T, "T": T, "n1": -math.copysign(1.0, a1), "n3": -a3 * T, "delta0": c / b}


def _to_fit(p: Mapping[str, float]) -> dict[str, float]:
    T = p["T"]
    return {"k": p["K"] / T, "m1": p["n1"] / T, "m3": p["n3"] / T, "delta0": p["delta0"]}


def _from_fit(q: Mapping[str, float]) -> dict[str, float]:
    T = 1.0 / max(abs(q["m1"]), 1e-12)
    return {"K": q["k"] * T, "T": T, "n1": math.copysign(1.0, q["m1"]), "n3": q["m3"] * T,
            "delta0": q["delta0"]}


def transfer(d: Norrbin) -> tuple[list[float], list[float]]:
    """Linearised about r = 0 (the cubic term has zero slope there): r/delta = K / (T s + n1)."""
    return [float(d.K)], [float(d.T), float(d.n1)]


KIND = ModelKind(
    name="norrbin",
    title="Norrbin nonlinear response",
    equation="T r' + n1 r + n3 r^3 = K (delta + delta0); n1 = -1: course-unstable",
    reference="Norrbin 1963; Mu et al. 2018, eq. 34-35",
    dynamics=Norrbin,
    states=("r",),
    body=(-1, -1, 0),
    speed_row=5,
    inputs=("delta",),
    rhs=rhs,
    transfer=transfer,
    pack=pack,
    outputs=("psi", "r"),
    regression=Regression(_blocks, _to_params, needs=("delta",)),
    fit_space=FitSpace(("k", "m1", "m3", "delta0"), _to_fit, _from_fit),
)
