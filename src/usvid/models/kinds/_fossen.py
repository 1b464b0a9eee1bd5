"""Shared pieces of the Fossen-form kinds (``threedof``, ``catamaran`` and the kinds with roll).

The thrust law of a vessel with one propeller or vector thruster (from the format spec's
particulars, evaluated along a log, its straight-running speed) is :func:`thrust_law`,
:func:`thrust_of`, :func:`thrust_particulars` and :func:`straight_speed`.

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

from usvid.errors import IdentificationError, UsvidError
from usvid.models.kind import EXTERNAL, Block, FitSpace
from usvid.models.thrust import PodThrust, Propeller


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
    """The three eq. 37 regressions on smoothed u, v, r, their derivatives and tau_u, tau_r.

    Known external loads (:data:`EXTERNAL`, where some trial carries them; 0 in the others)
    enter as the thrust does: ``u' = a_vr v r + a_u u + a_tau (tau_u + X_e)``,
    ``v' = b_ur u r + b_v v + b_Y Y_e``, ``r' = c_uv u v + c_r r + c_tau (tau_r + N_e)`` with
    ``b_Y = 1/m22`` (eq. 17 with the external force on its right-hand side; Fossen 2021,
    eq. 10.1), the one more coefficient tied to the six parameters like b_ur and c_uv."""
    ext = any(all(k in s for k in EXTERNAL) for s in series)

    def load(s: Mapping[str, np.ndarray], k: str) -> np.ndarray:
        return (np.asarray(s[k], float) if all(e in s for e in EXTERNAL)
                else np.zeros(np.shape(s["u_s"])))

    def stack(name: str, cols: Any, y: str, names: tuple[str, ...]) -> Block:
        parts = [(np.column_stack(cols(s)), s[y]) for s in series]
        return Block(name, np.concatenate([p[0] for p in parts]),
                     np.concatenate([p[1] for p in parts]), names, [len(p[1]) for p in parts])

    if not ext:
        return [
            stack("u", lambda s: [s["v_s"] * s["r_s"], s["u_s"], s["tau_u"]], "udot_s",
                  ("a_vr", "a_u", "a_tau")),
            stack("v", lambda s: [s["u_s"] * s["r_s"], s["v_s"]], "vdot_s", ("b_ur", "b_v")),
            stack("r", lambda s: [s["u_s"] * s["v_s"], s["r_s"], s["tau_r"]], "rdot_s",
                  ("c_uv", "c_r", "c_tau")),
        ]
    return [
        stack("u", lambda s: [s["v_s"] * s["r_s"], s["u_s"], s["tau_u"] + load(s, "ext_X")],
              "udot_s", ("a_vr", "a_u", "a_tau")),
        stack("v", lambda s: [s["u_s"] * s["r_s"], s["v_s"], load(s, "ext_Y")], "vdot_s",
              ("b_ur", "b_v", "b_Y")),
        stack("r", lambda s: [s["u_s"] * s["v_s"], s["r_s"], s["tau_r"] + load(s, "ext_N")],
              "rdot_s", ("c_uv", "c_r", "c_tau")),
    ]


def to_params(th: Mapping[str, float], fixed: Mapping[str, Any], form: str,
              h: float) -> dict[str, float]:
    return fossen_from_regression(th["a_vr"], th["a_u"], th["a_tau"], th["b_v"], th["c_r"],
                                  th["c_tau"])


def coefficients(p: Mapping[str, float], fixed: Mapping[str, Any], form: str,
                 h: float) -> dict[str, float]:
    """The eq. 37 coefficients of ``p`` and ``b_Y = 1/m22`` [1/kg], the sway equation's
    coefficient of a known external force (:func:`blocks`)."""
    return {**regression_coefficients(p), "b_Y": 1.0 / float(p["m22"])}


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


def thrust_of(thrust: Any, u: Any, n: Any) -> np.ndarray:
    """Thrust T [N] of the thrust law ``thrust`` (a number [N], :class:`Propeller` or
    :class:`PodThrust`) at surge speed u [m/s] and shaft speed n [rps]."""
    if thrust is None:
        raise IdentificationError("parameters.thrust is not set")
    if not hasattr(thrust, "thrust"):
        return np.broadcast_to(np.asarray(thrust, float), np.shape(u)) + 0.0
    if n is None:
        raise IdentificationError("parameters.n (shaft speed [rps]) is needed by the thrust law")
    if isinstance(thrust, PodThrust):
        return np.asarray(thrust.thrust(u, n), float)
    return np.asarray(thrust.thrust(n, u), float)


def straight_speed(thrust: Any, n: Any, d11: Any) -> Any:
    """Straight-line speed [m/s] at the shaft speed n [rps]: the root of T(u) = d11 u
    (bisection; d11 [kg/s] the surge damping); None without a thrust law."""
    if thrust is None:
        return None
    if not hasattr(thrust, "thrust"):
        return np.asarray(thrust, float) / np.asarray(d11, float)
    lo = np.zeros(np.broadcast_shapes(np.shape(d11), np.shape(n)))
    hi = lo + 100.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        g = np.asarray(thrust_of(thrust, mid, n)) - np.asarray(d11) * mid
        lo = np.where(g > 0, mid, lo)
        hi = np.where(g > 0, hi, mid)
    return 0.5 * (lo + hi)


def thrust_particulars(kind: str, vessel: Any, data: Sequence[Mapping[str, np.ndarray]],
                       options: Mapping[str, Any]) -> dict[str, Any]:
    """The thrust law and the nominal shaft speed of a one-thruster vessel from its
    particulars (format spec ``vessel.extra`` or options): ``thrust`` (an option: a law or a
    number [N]), else a propeller from ``propeller_diameter``, ``propeller_pitch_ratio``,
    ``propeller_disk_ratio`` (``thrust_deduction``, ``wake_fraction``, ``water_density``), else
    the pod law ``pod_c``, ``pod_d``; ``n`` from ``shaft_speed_rps``, else the median measured
    n. Returns ``{"thrust", "n"}``; :class:`IdentificationError` naming what is missing (for
    model ``kind``)."""
    num = extra_number
    D = num(vessel, options, "propeller_diameter")
    if options.get("thrust") is not None:  # a thrust law object or a number [N] (Python API)
        thrust: Any = options["thrust"]
    elif D is not None:
        pr = num(vessel, options, "propeller_pitch_ratio")
        dr = num(vessel, options, "propeller_disk_ratio")
        if pr is None or dr is None:
            raise IdentificationError(
                f"model '{kind}': propeller_diameter is given but propeller_pitch_ratio and "
                "propeller_disk_ratio are needed too (vessel.extra in the format spec)")
        thrust = Propeller(D=D, pitch_ratio=pr, disk_ratio=dr,
                           t_P=num(vessel, options, "thrust_deduction") or 0.0,
                           w_P=num(vessel, options, "wake_fraction") or 0.0,
                           rho=num(vessel, options, "water_density") or 1025.0)
    elif num(vessel, options, "pod_c") is not None:
        thrust = PodThrust(c=num(vessel, options, "pod_c"), d=num(vessel, options, "pod_d") or 0.0)
    else:
        raise IdentificationError(
            f"model '{kind}' needs a thrust law to be simulated: give propeller_diameter, "
            "propeller_pitch_ratio, propeller_disk_ratio (and thrust_deduction, wake_fraction) "
            "or pod_c, pod_d in the format spec's vessel.extra")
    n = num(vessel, options, "shaft_speed_rps")
    if n is None:
        ns = [s["n"][np.isfinite(s["n"])] for s in data if "n" in s]
        ns = [a for a in ns if a.size]
        if not ns and not hasattr(thrust, "thrust"):  # a constant thrust [N]: no shaft speed
            return {"thrust": thrust, "n": None}
        if not ns:
            raise IdentificationError(
                f"model '{kind}' needs the shaft speed: a channel 'n' [rps] in the logs, or "
                "vessel.extra.shaft_speed_rps")
        n = float(np.nanmedian(np.concatenate(ns)))
    return {"thrust": thrust, "n": n}


def thrust_series(kind: str, s: Mapping[str, np.ndarray], fixed: Mapping[str, Any]
                  ) -> np.ndarray:
    """Thrust T [N] along a trial's series: a measured ``thrust`` channel, else the thrust law
    of ``fixed`` at the measured n [rps] and u [m/s]."""
    if "thrust" in s:
        return np.asarray(s["thrust"], float)
    if "n" not in s and hasattr(fixed.get("thrust"), "thrust"):
        raise IdentificationError(f"model '{kind}' needs channel 'n' [rps] (or a thrust "
                                  "channel)")
    return thrust_of(fixed["thrust"], s["u"], s.get("n"))
