"""Nomoto 1st-order yaw response: ``T r' + r = K (delta + delta0)`` at constant speed U.

Nomoto, Taguchi, Honda & Hirano 1957; Mu et al. 2018, eq. 35 with alpha = 0. Mu et al. 2018
print "K = 0.332 and T = 0.707" for ``0.332 r' + r = 0.707 delta``: read as an equation, the
coefficient of r' is the time constant and the right-hand gain is K, so the consistent reading
(also the order of magnitude of Mu et al. 2016) is T = 0.332 s, K = 0.707 1/s.

Kinematics at constant speed (no drift angle): ``x' = U cos psi``, ``y' = U sin psi``,
``psi' = r``; U [m/s] is the approach speed (``vessel.speed``, or ``--speed``).

Regression forms (equation error):

* ``continuous``: ``r' = a r + b delta + c`` on Savitzky-Golay smoothed r, delta and r'
  (K = -b/a, T = -1/a, delta0 = c/b);
* ``arx``: ``r[k+1] = alpha r[k] + beta delta[k] + gamma`` at step h (zero-order hold; Mu et al.
  2016 eq. 23-24): T = -h / ln(alpha), K = beta / (1 - alpha), delta0 = gamma / beta.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError
from usvid.models.kind import Block, Dynamics, ModelKind, Regression, inverse, param, rows


@dataclass
class Nomoto1(Dynamics):
    """Nomoto 1st order ``T r' + r = K (delta + delta0)``: K [1/s], T [s] > 0, delta0 [rad]."""

    K: Any = param("1/s", "gain: steady yaw rate per radian of rudder")
    T: Any = param("s", "yaw time constant", gt=0.0)
    delta0: Any = param("rad", "rudder offset (straight running at delta = -delta0)",
                        default=0.0)
    N_delta: Any = param("N m/rad", "yaw moment of one radian of rudder: an external yaw moment "
                         "N (wind, waves) acts as the rudder angle N / N_delta (null: none)",
                         fit=False, default=None, gt=0.0)
    kind: ClassVar[str] = "nomoto1"


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """r' = (K (delta + delta0) - r) / T; returns (U, 0, r, (r',)). Rows: K, T, delta0, U,
    1/T, 1/N_delta (0: none); an external yaw moment f[3] adds f[3] / N_delta to delta."""
    r = s[0]
    d = a[0]
    if f[3] != 0.0:  # an external yaw moment as a rudder-equivalent angle (calm: compiled away)
        d = d + p[5] * f[3]
    return p[3], 0.0, r, ((p[0] * (d + p[2]) - r) * p[4],)


def pack(d: Nomoto1, speed: Any) -> np.ndarray:
    return rows([d.K, d.T, d.delta0, speed, 1.0 / np.asarray(d.T, float), inverse(d.N_delta)])


def _blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
            h: float) -> list[Block]:
    if form == "arx":
        parts = [(np.column_stack([s["r_s"][:-1], s["delta_s"][:-1], np.ones(len(s["t"]) - 1)]),
                  s["r_s"][1:]) for s in series]
        names = ("alpha", "beta", "gamma")
    else:
        parts = [(np.column_stack([s["r_s"], s["delta_s"], np.ones(len(s["t"]))]), s["rdot_s"])
                 for s in series]
        names = ("a", "b", "c")
    return [Block("r", np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                  names, [len(p[1]) for p in parts])]


def _to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
               h: float) -> dict[str, float]:
    if form == "arx":
        al, be, ga = th["alpha"], th["beta"], th["gamma"]
        if not 0.0 < al < 1.0:
            raise IdentificationError(f"nomoto1 (ARX): pole alpha = {al:.6g} is not in (0, 1); "
                                      "the data do not show a stable first-order response")
        return {"K": be / (1.0 - al), "T": -h / math.log(al), "delta0": ga / be}
    a, b, c = th["a"], th["b"], th["c"]
    if a >= 0.0:
        raise IdentificationError(
            f"nomoto1: the yaw-rate coefficient a = {a:.4g} >= 0 gives T <= 0 (a course-unstable "
            "vessel): use --model norrbin")
    return {"K": -b / a, "T": -1.0 / a, "delta0": c / b}


def transfer(d: Nomoto1) -> tuple[list[float], list[float]]:
    """r/delta = K / (T s + 1)."""
    return [float(d.K)], [float(d.T), 1.0]


KIND = ModelKind(
    name="nomoto1",
    title="Nomoto 1st order",
    equation="T r' + r = K (delta + delta0)",
    reference="Nomoto et al. 1957; Mu et al. 2018, eq. 35",
    dynamics=Nomoto1,
    states=("r",),
    body=(-1, -1, 0),
    speed_row=3,
    inputs=("delta",),
    rhs=rhs,
    transfer=transfer,
    pack=pack,
    outputs=("psi", "r"),
    regression=Regression(_blocks, _to_params, forms=("continuous", "arx"),
                          needs=("delta",)),
)
