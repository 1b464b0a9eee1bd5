"""Nomoto 2nd-order yaw response at constant speed U (Nomoto et al. 1957; Mu et al. 2018,
eq. 29-30; Mu et al. 2016, eq. 18):

``T1 T2 r'' + (T1 + T2) r' + r = K (delta + delta0 + T3 delta')``, i.e.
``r / delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))``.

Realised without delta' in observable canonical form (the only copy of the equations):
``x1' = -a1 x1 + x2 + b1 (delta + delta0)``, ``x2' = -a0 x1 + b0 (delta + delta0)``, r = x1,
with ``a1 = (T1 + T2)/(T1 T2)``, ``a0 = 1/(T1 T2)``, ``b1 = K T3/(T1 T2)``, ``b0 = K/(T1 T2)``.
A measured yaw rate r0 and yaw acceleration rdot0 give ``x1 = r0``,
``x2 = rdot0 + a1 r0 - b1 (delta + delta0)``.

Regression: ARX(2,2) ``r[k] = a1 r[k-1] + a2 r[k-2] + b1 delta[k-1] + b2 delta[k-2] + c`` at the
decimated step h, converted to continuous time by zero-order hold (:func:`usvid.models.d2c.d2c`,
Mu et al. 2016 eq. 23-24): ``(n1 s + n0)/(s^2 + d1 s + d0)`` gives K = n0/d0, T1 T2 = 1/d0,
T1 + T2 = d1/d0, K T3 = n1/d0 (Mu et al. 2018 eq. 29), T1 >= T2.
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
from usvid.models.d2c import d2c
from usvid.models.kind import Block, Dynamics, ModelKind, Regression, inverse, param, rows


@dataclass
class Nomoto2(Dynamics):
    """Nomoto 2nd order: K [1/s], T1, T2 [s] > 0, T3 [s], delta0 [rad]."""

    K: Any = param("1/s", "gain: steady yaw rate per radian of rudder")
    T1: Any = param("s", "first time constant", gt=0.0)
    T2: Any = param("s", "second time constant", gt=0.0)
    T3: Any = param("s", "zero (lead) time constant", default=0.0)
    delta0: Any = param("rad", "rudder offset", default=0.0)
    N_delta: Any = param("N m/rad", "yaw moment of one radian of rudder: an external yaw moment "
                         "N (wind, waves) acts as the rudder angle N / N_delta (null: none)",
                         fit=False, default=None, gt=0.0)
    kind: ClassVar[str] = "nomoto2"


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """Observable canonical form; rows K, T1, T2, T3, delta0, U, a1, a0, b1, b0, 1/N_delta (0:
    none); an external yaw moment f[3] adds f[3] / N_delta to delta."""
    x1 = s[0]
    d = a[0]
    if f[3] != 0.0:  # an external yaw moment as a rudder-equivalent angle (calm: compiled away)
        d = d + p[10] * f[3]
    ue = d + p[4]
    return p[5], 0.0, x1, (-p[6] * x1 + s[1] + p[8] * ue, -p[7] * x1 + p[9] * ue)


def _coefficients(d: Nomoto2) -> tuple[np.ndarray, ...]:
    T1, T2 = np.asarray(d.T1, float), np.asarray(d.T2, float)
    K, T3 = np.asarray(d.K, float), np.asarray(d.T3, float)
    t12 = T1 * T2
    return (T1 + T2) / t12, 1.0 / t12, K * T3 / t12, K / t12


def pack(d: Nomoto2, speed: Any) -> np.ndarray:
    a1, a0, b1, b0 = _coefficients(d)
    return rows([d.K, d.T1, d.T2, d.T3, d.delta0, speed, a1, a0, b1, b0, inverse(d.N_delta)])


def initial(d: Nomoto2, values: Mapping[str, Any]) -> np.ndarray:
    a1, _, b1, _ = _coefficients(d)
    r0 = np.asarray(values.get("r", 0.0), float)
    rdot0 = np.asarray(values.get("rdot", 0.0), float)
    ue = np.asarray(values.get("delta", 0.0), float) + np.asarray(d.delta0, float)
    return rows([r0, rdot0 + a1 * r0 - b1 * ue])


def _blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
            h: float) -> list[Block]:
    parts = []
    for s in series:
        r, dl = s["r_s"], s["delta_s"]
        parts.append((np.column_stack([r[1:-1], r[:-2], dl[1:-1], dl[:-2], np.ones(len(r) - 2)]),
                      r[2:]))
    return [Block("r", np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                  ("a1", "a2", "b1", "b2", "c"), [len(p[1]) for p in parts])]


def _to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
               h: float) -> dict[str, float]:
    """ARX(2,2) -> K, T1, T2, T3 by ZOH d2c; non-real or unstable poles raise."""
    a1, a2, b1, b2 = th["a1"], th["a2"], th["b1"], th["b2"]
    try:
        tf = d2c([b1, b2], [1.0, -a1, -a2], h)
    except IdentificationError as exc:
        raise IdentificationError(f"nomoto2: {exc}") from exc
    den = np.zeros(3)
    den[3 - len(tf.den):] = tf.den
    num = np.zeros(2)
    num[2 - len(tf.num):] = tf.num[-2:]
    _, d1, d0 = den
    n1, n0 = num
    disc = d1 * d1 - 4.0 * d0
    if tf.delay_samples or d0 <= 0 or d1 <= 0 or disc < 0:
        raise IdentificationError(
            f"nomoto2: continuous poles not real and stable (s^2 + {d1:.4g} s + {d0:.4g}); "
            "the data do not support a 2nd-order Nomoto model")
    s1 = (-d1 + math.sqrt(disc)) / 2.0
    s2 = (-d1 - math.sqrt(disc)) / 2.0
    K = n0 / d0
    T3 = (n1 / d0) / K if K != 0 else 0.0
    return {"K": K, "T1": -1.0 / s1, "T2": -1.0 / s2, "T3": T3, "delta0": th["c"] / (b1 + b2)}


def transfer(d: Nomoto2) -> tuple[list[float], list[float]]:
    """r/delta = K (T3 s + 1) / (T1 T2 s^2 + (T1 + T2) s + 1)."""
    K, T1, T2, T3 = float(d.K), float(d.T1), float(d.T2), float(d.T3)
    return ([K * T3, K] if T3 != 0 else [K]), [T1 * T2, T1 + T2, 1.0]


KIND = ModelKind(
    name="nomoto2",
    title="Nomoto 2nd order",
    equation="T1 T2 r'' + (T1 + T2) r' + r = K (delta + delta0 + T3 delta')",
    reference="Nomoto et al. 1957; Mu et al. 2018, eq. 29-30",
    dynamics=Nomoto2,
    states=("r", "x2"),
    body=(-1, -1, 0),
    speed_row=5,
    inputs=("delta",),
    rhs=rhs,
    transfer=transfer,
    pack=pack,
    initial=initial,
    outputs=("psi", "r"),
    regression=Regression(_blocks, _to_params, forms=("arx",), needs=("delta",)),
)
