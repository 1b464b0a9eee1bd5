"""Shared pieces of the diagonal Fossen 3-DOF kinds (``threedof``, ``catamaran``).

Both kinds use the surge-sway-yaw model of Mu et al. 2018, eq. 13-17 (Fossen 2011 form
``M nu' + C(nu) nu + D nu = tau`` reduced under Assumption 1, m23 = m32 = d23 = d32 = 0)::

    u' = (m22/m11) v r - (d11/m11) u + tau_u/m11
    v' = -(m11/m22) u r - (d22/m22) v
    r' = ((m11 - m22)/m33) u v - (d33/m33) r + tau_r/m33

whose regression form (Mu et al. 2018, eq. 37) is
``u' = a_vr v r + a_u u + a_tau tau_u``, ``v' = b_ur u r + b_v v``,
``r' = c_uv u v + c_r r + c_tau tau_r``. The eight coefficients are functions of six
parameters (m11 = 1/a_tau, m22 = a_vr m11, m33 = 1/c_tau, d11 = -a_u m11, d22 = -b_v m22,
d33 = -c_r m33, and then b_ur = -m11/m22, c_uv = (m11 - m22)/m33): the estimator fits the six
parameters to all three equations (no coefficient is dropped).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.kind import Block, FitSpace


def fossen_from_regression(a_vr: float, a_u: float, a_tau: float, b_v: float, c_r: float,
                           c_tau: float) -> dict[str, float]:
    """m11 = 1/a_tau, m22 = a_vr m11, m33 = 1/c_tau [kg, kg, kg m^2]; d11 = -a_u m11,
    d22 = -b_v m22 [kg/s], d33 = -c_r m33 [kg m^2/s] (Mu et al. 2018, eq. 37 read with eq. 17)."""
    m11 = 1.0 / a_tau
    m22 = a_vr * m11
    m33 = 1.0 / c_tau
    return {"m11": m11, "m22": m22, "m33": m33, "d11": -a_u * m11, "d22": -b_v * m22,
            "d33": -c_r * m33}


def regression_coefficients(p: Mapping[str, Any]) -> dict[str, Any]:
    """The eight eq. 37 coefficients of diagonal Fossen parameters (numbers or arrays)."""
    m11, m22, m33 = (np.asarray(p[k], float) for k in ("m11", "m22", "m33"))
    d11, d22, d33 = (np.asarray(p[k], float) for k in ("d11", "d22", "d33"))
    out = {"a_vr": m22 / m11, "a_u": -d11 / m11, "a_tau": 1.0 / m11, "b_ur": -m11 / m22,
           "b_v": -d22 / m22, "c_uv": (m11 - m22) / m33, "c_r": -d33 / m33, "c_tau": 1.0 / m33}
    return {k: (float(v) if np.ndim(v) == 0 else v) for k, v in out.items()}


def blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
           h: float) -> list[Block]:
    """The three eq. 37 regressions on smoothed u, v, r, their derivatives and tau_u, tau_r."""
    def stack(name: str, cols: Any, y: str, names: tuple[str, ...]) -> Block:
        parts = [(np.column_stack(cols(s)), s[y]) for s in series]
        return Block(name, np.concatenate([p[0] for p in parts]),
                     np.concatenate([p[1] for p in parts]), names, [len(p[1]) for p in parts])

    return [
        stack("u", lambda s: [s["v_s"] * s["r_s"], s["u_s"], s["tau_u"]], "udot_s",
              ("a_vr", "a_u", "a_tau")),
        stack("v", lambda s: [s["u_s"] * s["r_s"], s["v_s"]], "vdot_s", ("b_ur", "b_v")),
        stack("r", lambda s: [s["u_s"] * s["v_s"], s["r_s"], s["tau_r"]], "rdot_s",
              ("c_uv", "c_r", "c_tau")),
    ]


def to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
              h: float) -> dict[str, float]:
    return fossen_from_regression(th["a_vr"], th["a_u"], th["a_tau"], th["b_v"], th["c_r"],
                                  th["c_tau"])


def coefficients(p: Mapping[str, float], fixed: Mapping[str, Any], form: str,
                 h: float) -> dict[str, float]:
    return regression_coefficients(p)


def _to_fit(p: Mapping[str, float]) -> dict[str, float]:
    c = regression_coefficients(p)
    return {k: c[k] for k in ("a_vr", "a_u", "a_tau", "b_v", "c_r", "c_tau")}


def _from_fit(q: Mapping[str, float]) -> dict[str, float]:
    return fossen_from_regression(q["a_vr"], q["a_u"], q["a_tau"], q["b_v"], q["c_r"],
                                  q["c_tau"])


#: Output error in the (better conditioned) inverse-mass coefficients of eq. 37.
FIT_SPACE = FitSpace(("a_vr", "a_u", "a_tau", "b_v", "c_r", "c_tau"), _to_fit, _from_fit,
                     lower={"a_vr": 1e-3, "a_tau": 1e-12, "c_tau": 1e-12},
                     fallback={"a_vr": 1.0})
"""Positive masses: m22/m11 = a_vr > 0, 1/m11 = a_tau > 0, 1/m33 = c_tau > 0; where least
squares gives a negative sway mass the constrained fit starts from m22 = m11."""


def positive_masses(d: Any) -> None:
    """Physical checks shared by the Fossen kinds: masses and inertia > 0 (by the bounds)."""
    det = np.asarray(getattr(d, "m22", 1.0)) * np.asarray(getattr(d, "m33", 1.0)) - np.asarray(
        getattr(d, "m23", 0.0)) * np.asarray(getattr(d, "m32", 0.0))
    if not np.all(det > 0):
        raise UsvidError("parameters: m22 m33 - m23 m32 must be > 0 (singular inertia)")


def extra_number(vessel: Any, options: Mapping[str, Any], *names: str) -> float | None:
    """The first of ``names`` given in ``options`` or in ``vessel.extra`` (a number), or None."""
    extra = getattr(vessel, "extra", None) or {}
    for n in names:
        for src in (options, extra):
            v = src.get(n)
            if v is not None:
                return float(v)
    return None
