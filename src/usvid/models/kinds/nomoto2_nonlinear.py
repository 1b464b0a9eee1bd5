"""Second-order nonlinear yaw response at constant speed U (Mu et al. 2018, eq. 34):

``T1 T2 r'' + (T1 + T2) r' + r + alpha r^3 = K (delta + delta0) + K T3 delta'``

(Nomoto's second-order model with Nomoto's nonlinear stability index C = C0 + w r^2, eq. 31-33,
which divided by C0 gives the cubic term alpha = w / C0). With alpha = 0 it is the kind
``nomoto2``; reduced to first order (eq. 35) it is Norrbin's ``T r' + r + alpha r^3 = K delta``.

Realised without delta' in the observable canonical form of ``nomoto2`` (the only copy of the
equations): ``x1' = -a1 x1 + x2 + b1 (delta + delta0)``, ``x2' = -a0 (x1 + alpha x1^3) + b0
(delta + delta0)``, r = x1, with ``a1 = (T1 + T2)/(T1 T2)``, ``a0 = 1/(T1 T2)``, ``b1 = K T3/(T1
T2)``, ``b0 = K/(T1 T2)``. Substituting x2 = r' + a1 r - b1 (delta + delta0) gives eq. 34 back:
the r' and delta' terms cancel and ``r'' = b0 (delta + delta0) + b1 delta' - a1 r' - a0 (r + alpha
r^3)``. A measured yaw rate r0 and yaw acceleration rdot0 give ``x1 = r0``, ``x2 = rdot0 + a1 r0
- b1 (delta + delta0)``. In a steady turn ``r + alpha r^3 = K (delta + delta0)`` (eq. 36).

Regression: ARX(2,2) with a cubic term at the decimated step h,
``r[k] = a1 r[k-1] + a2 r[k-2] + g r[k-1]^3 + b1 delta[k-1] + b2 delta[k-2] + c``. Its linear part
gives K, T1, T2, T3 by zero-order-hold conversion exactly as ``nomoto2`` (Mu et al. 2016, eq.
23-24); alpha comes from its steady state, ``r (1 - a1 - a2) - g r^3 = (b1 + b2)(delta +
delta0)``, that is ``alpha = -g / (1 - a1 - a2)`` (exact in steady turns, the relation Mu et al.
2018 fit alpha to; the transient discretisation of the cubic is left to output error, which
refines all parameters on the simulated responses).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError
from usvid.models.kind import Block, Dynamics, ModelKind, Regression, inverse, param, rows
from usvid.models.kinds.nomoto2 import _coefficients
from usvid.models.kinds.nomoto2 import _to_params as _linear_params
from usvid.models.kinds.nomoto2 import initial as _nomoto2_initial
from usvid.models.kinds.nomoto2 import transfer as _nomoto2_transfer


@dataclass
class Nomoto2Nonlinear(Dynamics):
    """Mu et al. 2018 eq. 34: K [1/s], T1, T2 [s] > 0, T3 [s], alpha [s^2/rad^2], delta0
    [rad]."""

    K: Any = param("1/s", "gain: steady yaw rate per radian of rudder (linear part)")
    T1: Any = param("s", "first time constant", gt=0.0)
    T2: Any = param("s", "second time constant", gt=0.0)
    T3: Any = param("s", "zero (lead) time constant", default=0.0)
    alpha: Any = param("s^2/rad^2", "cubic yaw damping (Mu et al. 2018 eq. 34: alpha)",
                       default=0.0)
    delta0: Any = param("rad", "rudder offset", default=0.0)
    N_delta: Any = param("N m/rad", "yaw moment of one radian of rudder: an external yaw moment "
                         "N (wind, waves) acts as the rudder angle N / N_delta (null: none)",
                         fit=False, default=None, gt=0.0)
    kind: ClassVar[str] = "nomoto2_nonlinear"


@numba.njit(cache=True, forceinline=True)
def rhs(p, s, a, f):
    """Observable canonical form with the cubic term; rows K, T1, T2, T3, alpha, delta0, U,
    a1, a0, b1, b0, 1/N_delta (0: none); an external yaw moment f[3] adds f[3] / N_delta to
    delta (as in ``nomoto2``)."""
    x1 = s[0]
    d = a[0]
    if f[3] != 0.0:  # an external yaw moment as a rudder-equivalent angle (calm: compiled away)
        d = d + p[11] * f[3]
    ue = d + p[5]
    return p[6], 0.0, x1, (-p[7] * x1 + s[1] + p[9] * ue,
                           -p[8] * (x1 + p[4] * x1 * x1 * x1) + p[10] * ue)


def pack(d: Nomoto2Nonlinear, speed: Any) -> np.ndarray:
    a1, a0, b1, b0 = _coefficients(d)
    return rows([d.K, d.T1, d.T2, d.T3, d.alpha, d.delta0, speed, a1, a0, b1, b0,
                 inverse(d.N_delta)])


def initial(d: Nomoto2Nonlinear, values: Mapping[str, Any]) -> np.ndarray:
    """x1 = r0, x2 = rdot0 + a1 r0 - b1 (delta + delta0): the same states as ``nomoto2`` (the
    cubic term enters x2' only)."""
    return _nomoto2_initial(d, values)


def _blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
            h: float) -> list[Block]:
    parts = []
    for s in series:
        r, dl = s["r_s"], s["delta_s"]
        parts.append((np.column_stack([r[1:-1], r[:-2], r[1:-1] ** 3, dl[1:-1], dl[:-2],
                                       np.ones(len(r) - 2)]), r[2:]))
    return [Block("r", np.concatenate([p[0] for p in parts]),
                  np.concatenate([p[1] for p in parts]), ("a1", "a2", "g", "b1", "b2", "c"),
                  [len(p[1]) for p in parts])]


def _to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
               h: float) -> dict[str, float]:
    """The linear part as ``nomoto2`` (ARX(2,2) -> ZOH d2c), alpha from the steady state."""
    try:
        out = _linear_params(th, fixed, form, h)
    except IdentificationError as exc:
        raise IdentificationError(str(exc).replace("nomoto2:", "nomoto2_nonlinear:")) from exc
    out["alpha"] = -th["g"] / (1.0 - th["a1"] - th["a2"])
    return out


def transfer(d: Nomoto2Nonlinear) -> tuple[list[float], list[float]]:
    """Linearised about r = 0 (the cubic term has zero slope there): the ``nomoto2`` transfer
    function K (T3 s + 1) / (T1 T2 s^2 + (T1 + T2) s + 1)."""
    return _nomoto2_transfer(d)


KIND = ModelKind(
    name="nomoto2_nonlinear",
    title="Nomoto 2nd order, nonlinear (Mu et al. 2018 eq. 34)",
    equation="T1 T2 r'' + (T1 + T2) r' + r + alpha r^3 = K (delta + delta0 + T3 delta')",
    reference="Mu et al. 2018, eq. 31-34",
    dynamics=Nomoto2Nonlinear,
    states=("r", "x2"),
    body=(-1, -1, 0),
    speed_row=6,
    inputs=("delta",),
    rhs=rhs,
    transfer=transfer,
    pack=pack,
    initial=initial,
    outputs=("psi", "r"),
    regression=Regression(_blocks, _to_params, forms=("arx",), needs=("delta",)),
)
