"""Regression form of the MMG kind: hull coefficients from estimated states, regularised.

Y&Y 2015 eq. 4 is linear in the 17 hull coefficients once the particulars, masses and the
propeller/rudder models are held (:func:`.physics.hull_regression`): per equation
``y = Phi theta`` on the smoothed (or state-estimated) u, v, r and their derivatives.

Free-running manoeuvres do not separate all of them (:data:`.physics.CONFOUNDED`: the
cubic terms move together along a zig-zag, Y_r is only determined as Y_r - m' - m_x', the
Y_r / Y_ur cancellation). The regression is therefore **regularised towards physical priors**
(Tikhonov / ridge, Hoerl & Kennard 1970): every coefficient gets one pseudo-observation
``sqrt(w_k) theta_k = sqrt(w_k) prior_k`` with ``w_k = ALPHA sum_i Phi_ik^2`` -- the prior is
worth the fraction ALPHA of the data's own information on that regressor, so a well-excited
coefficient moves freely while a direction the data cannot see stays at its prior.
Priors: Kijima et al. 1990 for Y_v, Y_r, N_v, N_r (:func:`.physics.priors`), R_0 the
ITTC 1957 friction line with form factor 1.3 (``R_0 = 1.3 C_F S / (L d)``, wetted surface by
Denny-Mumford ``S = 1.7 L d + V / d``); the nonlinear terms 0.

The propeller asymmetry Y_P0, N_P0 (rudder and pod variants, :mod:`.physics`) is one more
column of the Y and N regressions when the runs turn to both sides (prior 0); otherwise it is
held at 0 with the reason (:func:`asymmetry_held`, said by the kind's particulars).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.kind import EXTERNAL, Block, LeftOutWarning
from usvid.models.kinds.mmg import physics as _m

#: Prior weight as a fraction of each regressor's sum of squares (module docstring).
ALPHA = 1e-3
#: Variance inflation factor above which a coefficient is reported as poorly separable.
VIF_WARN = 30.0
#: Twin thrusters: hull coefficients held at their priors (prior weight ALPHA_HELD, the data's
#: information times 1e4). Such vessels carry no sway log; the sway velocity estimated from
#: GNSS positions (which update slower than the rows) is too poor for the sway equation
#: (least squares on the Dalian USV's sine run gives Y_v > 0), so the sway equation and the
#: v-terms of surge and yaw keep their priors (Kijima 1990 / 0) and the data determine the
#: resistance R_0, X_rr and the yaw damping N_r, N_rrr.
TWIN_HELD = ("X_vv", "X_vr", "X_vvvv", *_m.Y_REGRESSORS, "N_v", "N_vvv", "N_vvr", "N_vrr")
ALPHA_HELD = 1e4
#: Rudder variant: interaction coefficients that the regression holds at their prior (the
#: particulars, else Fujii's formula / Y&Y 2015's KVLCC2 values) and output error refines with
#: the hull coefficients. f_alpha, the rudder lift gradient (Y&Y 2015: ``F_N = 0.5 rho A_R
#: U_R^2 f_alpha sin alpha_R``), scales every rudder force; Fujii's formula on the aspect ratio
#: is only an estimate (3.04 for the KVLCC2 rudder against the published 2.747). Chosen by
#: leave-one-out within the HSVA KVLCC2 training zig-zags (README); from noisy virtual
#: KVLCC2 zig-zags it recovers the published value within 2 % (tests/test_model_core.py).
REFINED = ("f_alpha",)


def held_names(fixed: Mapping[str, Any]) -> tuple[str, ...]:
    """Fitted names output error keeps at their equation-error (prior) values for the held
    particulars ``fixed``: :data:`TWIN_HELD` and the propeller asymmetry for the twin variant,
    the thrust asymmetry otherwise, :data:`REFINED` where there is no rudder (pod, twin), and
    the propeller asymmetry Y_P0, N_P0 where ``fixed`` holds it (:func:`asymmetry_held`)."""
    held = tuple(k for k in _m.ASYMMETRY if k in fixed)
    if fixed.get("variant", "rudder") == "rudder":
        return ("thrust_asymmetry", *held)
    if fixed.get("variant") == "twin":
        return (*TWIN_HELD, *REFINED, *_m.ASYMMETRY)
    return ("thrust_asymmetry", *REFINED, *held)


#: Both-sides test of the propeller asymmetry (:func:`asymmetry_held`): a side counts when at
#: least SIDE_FRACTION of all samples turn to it faster than SIDE_LEVEL times the data's turning
#: rate (the 95th percentile of |r|). A turning test to one side and its approach give the
#: other side nothing (at most the small opposite yaw of the first seconds of the turn).
SIDE_LEVEL = 0.3
SIDE_FRACTION = 0.05


def asymmetry_held(data: Sequence[Mapping[str, np.ndarray]]) -> str | None:
    """Why the data cannot separate the propeller asymmetry Y_P0, N_P0 from the hull
    coefficients, or None when they can (the runs turn to both sides).

    The asymmetry is a constant side force and yaw moment per unit thrust (:mod:`.physics`);
    the hull forces are odd in (v', r'). Only turns to both sides tell a constant from the hull
    polynomial (in a turn to one side the constant and Y_v v', N_r r' ... move together). A
    side is present when at least :data:`SIDE_FRACTION` of the samples yaw towards it faster
    than :data:`SIDE_LEVEL` times the 95th percentile of |r| (the yaw rate ``r`` [rad/s], else
    the rudder angle ``delta`` [rad])."""
    for ch in ("r", "delta"):
        arrs = [np.asarray(s[ch], float) for s in data if ch in s]
        x = np.concatenate(arrs) if arrs else np.zeros(0)
        x = x[np.isfinite(x)]
        if x.size:
            break
    else:
        return "the logs carry neither the yaw rate r nor the rudder angle delta"
    ref = float(np.percentile(np.abs(x), 95.0))
    if not ref > 0.0:
        return f"the {ch} channel never leaves 0"
    stbd = float(np.mean(x > SIDE_LEVEL * ref))
    port = float(np.mean(x < -SIDE_LEVEL * ref))
    if min(stbd, port) < SIDE_FRACTION:
        side = "port" if port < stbd else "starboard"
        return (f"the runs turn to one side only: {100 * min(stbd, port):.1f} % of the samples "
                f"turn to {side} ({ch} beyond {SIDE_LEVEL:g} of its 95th percentile of "
                f"|{ch}|; {100 * SIDE_FRACTION:g} % needed), so a constant side force and yaw "
                "moment cannot be told from the hull's terms in v', r'; give runs to both sides "
                "(zig-zags, turns to port and starboard)")
    return None


#: Low-speed floor of the regression as a fraction of the trials' median speed: below it v' =
#: v/U and r' = r L/U (Y&Y 2015's non-dimensional hull model, made for manoeuvres at speed)
#: are dominated by the noise of U -> 0 in a start from rest, and the sample carries no hull
#: information; it is left out (:func:`low_speed_floor`, reported by the estimator).
LOW_SPEED_FRACTION = 0.3


def low_speed_floor(U: np.ndarray) -> float:
    """The speed [m/s] below which a regression sample is left out: LOW_SPEED_FRACTION of the
    median speed ``U`` [m/s] of the trial."""
    return LOW_SPEED_FRACTION * float(np.median(U))


#: Kinematic viscosity of water [m^2/s] for the R_0 prior (15 deg C fresh water).
NU_WATER = 1.14e-6


class CollinearityWarning(UserWarning):
    """The data cannot separate some MMG hull coefficients (they stay near their priors)."""


def physics_of(fixed: Mapping[str, Any]) -> _m.MMGParameters:
    """MMGParameters of the held parameters (hull coefficients 0)."""
    kw = {f.name: fixed[f.name] for f in _m.FIELDS if f.name in fixed}
    return _m.MMGParameters(**kw)


def prior_hull(p: _m.MMGParameters, U: float) -> dict[str, float]:
    """Prior hull coefficients (module docstring) at speed U [m/s]."""
    vol = p.m / p.rho
    Cb = min(max(vol / (p.L * p.B * p.d), 0.3), 0.95)
    pri = _m.priors(p.L, p.B, p.d, Cb, p.m, rho=p.rho)
    Re = max(U, 0.1) * p.L / NU_WATER
    CF = 0.075 / (math.log10(Re) - 2.0) ** 2          # ITTC 1957
    S = 1.7 * p.L * p.d + vol / p.d                    # Denny-Mumford
    out = {k: 0.0 for k in _m.HULL_COEFFICIENTS}
    out.update({k: pri[k] for k in ("Y_v", "Y_r", "N_v", "N_r")})
    out["R_0"] = 1.3 * CF * S / (p.L * p.d)
    return out


def priors_of(series: Sequence[Mapping[str, np.ndarray]],
              fixed: Mapping[str, Any]) -> dict[str, float]:
    """The regression's priors (:func:`prior_hull`) at the trials' median speed [m/s]: the
    hull coefficients of a physically valid model of the particulars ``fixed``."""
    U = np.concatenate([np.hypot(_series_arrays(s)["u"], _series_arrays(s)["v"])
                        for s in series])
    return prior_hull(physics_of(fixed), float(np.median(U)))


def pwm_to_law(c: Any, neutral: float, span: float) -> np.ndarray:
    """Twin thrusters commanded by PWM: pulse widths c [us] -> the pod thrust law's command
    ``sgn(s) sqrt(|s|)`` at the level ``s = clip((c - neutral)/span, -1, 1)`` (so that
    ``T = pod_d |n| n = pod_d s``, the declared linear map; the kernel's ``_pwm_n``)."""
    s = np.clip((np.asarray(c, float) - neutral) / span, -1.0, 1.0)
    return np.sign(s) * np.sqrt(np.abs(s))


def _series_arrays(s: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    def pick(*names: str) -> np.ndarray | None:
        for n in names:
            if n in s:
                return np.asarray(s[n], float)
        return None

    out = {"u": pick("u_s", "u"), "v": pick("v_s", "v"), "r": pick("r_s", "r"),
           "udot": pick("udot_s"), "vdot": pick("vdot_s"), "rdot": pick("rdot_s"),
           "delta": pick("delta_s", "delta"), "n": pick("n"), "n_port": pick("n_port"),
           "n_stbd": pick("n_stbd")}
    return out


def blocks(series: Sequence[Mapping[str, np.ndarray]], fixed: Mapping[str, Any], form: str,
           h: float) -> list[Block]:
    """The X, Y, N regressions over all trials with the prior rows appended (module docstring).

    Needs per trial u, v, r [m/s, rad/s] and udot, vdot, rdot (smoothed ``*_s`` or estimated),
    delta [rad] and n [rps] (twin: n_port, n_stbd); a sample with U below 0.3 of the median
    speed carries no hull information and is dropped.
    """
    p = physics_of(fixed)
    asym = tuple(k for k in _m.ASYMMETRY if k not in fixed) if p.variant != "twin" else ()
    parts: list[list[Any]] = [[], [], []]
    diff_thrust: list[np.ndarray] = []
    rows: list[int] = []
    for s in series:
        a = _series_arrays(s)
        for k in ("u", "v", "r", "udot", "vdot", "rdot"):
            if a[k] is None:
                raise UsvidError(f"model 'mmg' regression needs '{k}' (state estimation of "
                                    "u, v, r and their derivatives)")
        N = a["u"].size
        ext = (tuple(np.asarray(s[k], float) for k in EXTERNAL) if all(k in s for k in EXTERNAL)
               else None)
        delta = a["delta"] if a["delta"] is not None else np.zeros(N)
        n = a["n"] if a["n"] is not None else np.full(N, fixed.get("n") or 0.0)
        if p.variant == "twin":
            npo, nst = a["n_port"], a["n_stbd"]
            if npo is None or nst is None:
                raise UsvidError("model 'mmg' (twin variant) needs channels n_port, n_stbd")
            if fixed.get("pwm_neutral") is not None:
                npo, nst = (pwm_to_law(c, float(fixed["pwm_neutral"]),
                                       float(fixed.get("pwm_span") or 500.0))
                            for c in (npo, nst))
            bl = _m.hull_regression(p, a["u"], a["v"], a["r"], a["udot"], a["vdot"], a["rdot"],
                                    n_port=npo, n_stbd=nst, external=ext)
            if fixed.get("pwm_neutral") is not None:
                bl[2], dT = _asymmetry_column(p, bl[2], a, npo, nst)
                diff_thrust.append(_moving_mean(dT, max(int(round(DIFF_SMOOTH_S / h)), 1)))
        else:
            bl = _m.hull_regression(p, a["u"], a["v"], a["r"], a["udot"], a["vdot"], a["rdot"],
                                    delta, n, external=ext, asymmetry=asym)
        U = np.hypot(a["u"], a["v"])
        keep = (U > low_speed_floor(U)) & np.all(
            [np.isfinite(b.y) & np.all(np.isfinite(b.Phi), axis=1) for b in bl], axis=0)
        for i, b in enumerate(bl):
            parts[i].append((b.Phi[keep], b.y[keep]))
        rows.append(int(keep.sum()))
        _report_low_speed(s, U, h, len(rows), len(series))
    if diff_thrust:
        _diagnose_twin(np.concatenate(diff_thrust))
    names = (_m.X_REGRESSORS, _m.Y_REGRESSORS, _m.N_REGRESSORS)
    if p.variant == "twin" and fixed.get("pwm_neutral") is not None:
        names = (names[0], names[1], (*names[2], "thrust_asymmetry"))
    elif asym:
        names = (names[0], (*names[1], *(k for k in asym if k == "Y_P0")),
                 (*names[2], *(k for k in asym if k == "N_P0")))
    U0 = float(np.median(np.concatenate([np.hypot(_series_arrays(s)["u"],
                                                  _series_arrays(s)["v"]) for s in series])))
    prior = prior_hull(p, U0)
    out = []
    for eq, nm, pr in zip("XYN", names, parts, strict=True):
        Phi = np.concatenate([q[0] for q in pr])
        y = np.concatenate([q[1] for q in pr])
        _diagnose(eq, Phi, nm)
        alpha = np.array([ALPHA_HELD if p.variant == "twin" and k in TWIN_HELD else ALPHA
                          for k in nm])
        w = np.sqrt(alpha * np.maximum(np.sum(Phi * Phi, axis=0), 1e-300))
        Phi_r = np.diag(w)
        y_r = w * np.array([prior.get(k, 0.0) for k in nm])
        out.append(Block(eq, np.vstack([Phi, Phi_r]), np.concatenate([y, y_r]), nm,
                         rows + [len(nm)]))
    return out


def _asymmetry_column(p: _m.MMGParameters, blk: Any, a: Mapping[str, np.ndarray],
                      npo: np.ndarray, nst: np.ndarray) -> tuple[Any, np.ndarray]:
    """The N regression of PWM-commanded twin thrusters with the thrust asymmetry a: the
    moment ``a (T_port + T_stbd) y_P L`` of thrusters giving (1 +- a) of the declared thrust
    (non-dimensional by 0.5 rho L^2 d U^2, as the N block) as one more regressor; and the
    differential thrust T_port - T_stbd [N] (for :func:`_diagnose_twin`)."""
    f = _m.forces(p, a["u"], a["v"], a["r"], n_port=npo, n_stbd=nst)
    U2 = np.maximum(a["u"] ** 2 + a["v"] ** 2, (_m.U_MIN_FROUDE ** 2) * _m.G * p.L)
    col = (f["T"] + f["T_stbd"]) * p.y_P * p.L / (0.5 * p.rho * p.L ** 2 * p.d * U2)
    return (_m.RegressionBlock(blk.equation, np.column_stack([blk.Phi, col]), blk.y,
                               (*blk.names, "thrust_asymmetry")), f["T"] - f["T_stbd"])


#: Twin thrusters: moving-mean window [s] of the differential thrust in the separability check
#: (the controller's sample-to-sample command jitter is filtered by the yaw dynamics).
DIFF_SMOOTH_S = 5.0
#: Robust spread / |median| of the smoothed differential thrust below which it is "nearly
#: constant" (a steady turn) and the yaw parameters cannot be separated.
DIFF_CV_WARN = 1.0


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    c = np.concatenate([[0.0], np.cumsum(x)])
    k = np.arange(x.size)
    lo, hi = np.maximum(k - n // 2, 0), np.minimum(k + n - n // 2, x.size)
    return (c[hi] - c[lo]) / (hi - lo)


def _diagnose_twin(dT: np.ndarray) -> None:
    """Warn when the (smoothed) differential thrust T_port - T_stbd [N] is nearly constant:
    robust spread (1.4826 median absolute deviation) below DIFF_CV_WARN times |median|. Such a
    run (a steady turn) shows the yaw moment balance at one turning rate only: the yaw damping
    N_r, N_rrr, the thrust asymmetry and the assumed thrust map cannot be separated, and the
    response to other differential thrusts is extrapolated."""
    dT = dT[np.isfinite(dT)]
    if dT.size == 0:
        return
    med = float(np.median(dT))
    spread = 1.4826 * float(np.median(np.abs(dT - med)))
    if spread < DIFF_CV_WARN * abs(med):
        warnings.warn(
            f"mmg twin thrusters: the differential thrust is nearly constant (smoothed over "
            f"{DIFF_SMOOTH_S:g} s: median {med:.3g} N, spread {spread:.3g} N): the data cannot "
            "separate the yaw damping N_r, N_rrr from the thrust asymmetry and the thrust map "
            "(only the yaw moment balance at this turning rate is determined); the model's "
            "response to other differential thrusts is extrapolated", CollinearityWarning,
            stacklevel=4)



def _report_low_speed(s: Any, U: np.ndarray, h: float, i: int, n: int) -> None:
    """Say which part of a trial the regression left out below the low-speed floor
    (:func:`low_speed_floor`): its time stretches [s] (a start from rest, a stop)."""
    low = U <= low_speed_floor(U)
    if not low.any():
        return
    t = np.asarray(s["t"], float) if "t" in s else np.arange(U.size) * h
    edges = np.flatnonzero(np.diff(np.concatenate([[0], low.astype(int), [0]])))
    spans = [(t[a], t[b - 1]) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    text = ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in spans[:4]) + (", ..." if len(spans) > 4
                                                                   else "")
    warnings.warn(f"mmg regression: trial {i} of {n}: {int(low.sum())} of "
                  f"{U.size} samples ({text}) below {low_speed_floor(U):.3g} m/s "
                  f"({LOW_SPEED_FRACTION:g} of its median speed) left out: v' = v/U and "
                  "r' = r L/U of a vessel near rest say nothing about its hull forces (the "
                  "simulations and the output error keep them)", LeftOutWarning, stacklevel=4)


def _diagnose(eq: str, Phi: np.ndarray, names: Sequence[str]) -> None:
    """Warn naming the coefficients whose regressor is nearly a combination of the others
    (variance inflation factor > VIF_WARN), with the known confounding (Y&Y 2015 form)."""
    X = Phi - Phi.mean(axis=0) if eq != "X" else Phi
    sd = np.sqrt(np.sum(X * X, axis=0))
    ok = sd > 0
    if ok.sum() < 2:
        return
    Z = X[:, ok] / sd[ok]
    try:
        vif = np.diag(np.linalg.inv(Z.T @ Z))
    except np.linalg.LinAlgError:
        vif = np.full(ok.sum(), np.inf)
    bad = [f"{n} (VIF {v:.0f})" for n, v in zip(np.asarray(names)[ok], vif, strict=True)
           if v > VIF_WARN]
    if bad:
        notes = "; ".join(f"{k}: {t}" for k, t in _m.CONFOUNDED.items()
                          if any(k2 in k for k2 in [b.split()[0] for b in bad]) or k == "cubic")
        warnings.warn(f"mmg {eq} equation: the data cannot separate {', '.join(bad)}; they are "
                      f"held near their priors (ridge towards Kijima 1990 / 0). {notes}",
                      CollinearityWarning, stacklevel=4)


def held_when_insignificant(params: Mapping[str, float], ci95: Mapping[str, Sequence[float]],
                            fixed: Mapping[str, Any]) -> dict[str, tuple[float, str]]:
    """The propeller asymmetry parameters (Y_P0, N_P0) that were estimated but whose 95 %
    interval ``ci95`` contains 0: the data do not tell the vessel from a symmetric one there,
    so the estimator holds them at 0 and fits again (the symmetric Y&Y 2015 model is the
    default; an asymmetry is only added where the data show it). Name -> (0, the reason)."""
    out = {}
    for k in _m.ASYMMETRY:
        if k in fixed or k not in ci95 or k not in params:
            continue
        lo, hi = (float(x) for x in ci95[k])
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0.0 <= hi:
            out[k] = (0.0, f"{k} = {params[k]:.3g} is not distinguishable from 0 (95 % "
                           f"interval {lo:.3g} .. {hi:.3g}): held at 0, the model fitted again")
    return out


def to_params(theta: Mapping[str, float], fixed: Mapping[str, Any], form: str,
              h: float) -> dict[str, float]:
    """The hull coefficients are the regression coefficients (and the twin PWM map's thrust
    asymmetry where it was regressed; 0 otherwise, held by :func:`held_names`; the propeller
    asymmetry Y_P0, N_P0 where it was regressed, else its held value); the
    :data:`REFINED` interaction coefficients keep their held values (output error refines
    them)."""
    out = {k: float(theta[k]) for k in _m.HULL_COEFFICIENTS}
    out["thrust_asymmetry"] = float(theta.get("thrust_asymmetry", 0.0))
    for k in _m.ASYMMETRY:  # regressed, or held (the particulars' value, else 0)
        out[k] = float(theta.get(k, fixed.get(k, 0.0)))
    for k in REFINED:
        out[k] = float(fixed.get(k, getattr(_m.MMGParameters, k)))
    return out
