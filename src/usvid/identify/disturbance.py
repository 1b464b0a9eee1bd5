r"""What nobody logged, estimated with the hull: a constant current and constant sway-force and
yaw-moment biases per trial, parameters of the output-error fit.

Current (Fossen 2021, ch. 10.3; :mod:`usvid.models.environment.current`): each trial ``k`` has
a constant, uniform current with the velocity over ground :math:`v_c^n = (c_{N,k}, c_{E,k})`
[m/s, north, east: the direction it flows TOWARDS]. The kind's states are the velocities
through the water; the integration core adds the current to the kinematics and to the recorded
velocities over ground, so that the simulated ``u``, ``v`` compared with the measured ones are

.. math:: u = u_r + c_N \cos\psi + c_E \sin\psi, \qquad v = v_r - c_N \sin\psi + c_E \cos\psi.

A current is seen by the output error only through the turn of this vector with the heading
(and through the hull's response to the water-relative velocity): the window's estimated
initial state absorbs a current that the heading does not turn. Straight runs therefore do not
separate it; the collinearity warning says so.

Bias: a constant external force on the hull in body axes per trial, sway force
:math:`Y_{b,k}` [N] and yaw moment :math:`N_{b,k}` [N m] (the unlogged wind's and waves'
mean loads, an asymmetric hull or thrust), added to the kind's right-hand side as the core's
external force (X, Y, K, N) = (0, Y_b, 0, N_b). In kinds whose thrust is in command units
(``thrust_per_command`` 1), the biases are in the same units as the thrust.

Both are constant within a trial: a disturbance that changes through a trial leaves residuals
the fit reports (and a trial cut into parts, ``LOG:T0:T1``, gets one value per part).

Units: SI, velocities [m/s], forces [N], moments [N m]; directions in the JSON in degrees, as
named.
"""

from __future__ import annotations

import hashlib
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.ls import autocorrelation_factor
from usvid.identify.series import IdentificationWarning, Series

#: The terms of ``--disturbance`` and the per-trial quantities each adds (fit names
#: ``QUANTITY[TRIAL INDEX]``).
TERMS = {"current": ("current_north", "current_east"), "bias": ("bias_Y", "bias_N")}
#: Units of the quantities.
UNITS = {"current_north": "m/s", "current_east": "m/s", "bias_Y": "N", "bias_N": "N m"}
#: The integration core's input series each quantity drives (:data:`usvid.sim.layout.SERIES`).
SERIES_OF = {"current_north": "current_x", "current_east": "current_y", "bias_Y": "force_Y",
             "bias_N": "force_N"}
#: A disturbance parameter whose estimate correlates with another parameter by more than this
#: (absolute correlation of the fit's covariance) is reported as not separable.
CORR_MAX = 0.95


def parse_disturbance(text: str | Sequence[str] | None) -> tuple[str, ...]:
    """The terms of ``--disturbance`` (``"current"``, ``"bias"``, ``"current,bias"``; empty or
    ``"none"``: none), in :data:`TERMS` order. Raises :class:`UsvidError` naming the option."""
    if text is None:
        return ()
    items = text.split(",") if isinstance(text, str) else list(text)
    items = [s.strip().lower() for s in items if s.strip()]
    if items in ([], ["none"]):
        return ()
    bad = [s for s in items if s not in TERMS]
    if bad:
        raise UsvidError(f"--disturbance {','.join(items)!r}: unknown term(s) "
                         f"{', '.join(map(repr, bad))} (choose from: {', '.join(TERMS)}, "
                         "comma-separated, or none)")
    return tuple(t for t in TERMS if t in items)


@dataclass(frozen=True)
class Disturbance:
    """The disturbance parameters of an output-error fit: ``terms`` (keys of :data:`TERMS`)
    for each of the trials named ``trials`` (the windows' ``trial_index`` counts them)."""

    terms: tuple[str, ...]
    trials: tuple[str, ...]

    @property
    def quantities(self) -> tuple[str, ...]:
        return tuple(q for t in self.terms for q in TERMS[t])

    @property
    def names(self) -> tuple[str, ...]:
        """Fit names, trial by trial: ``current_north[0]``, ``current_east[0]``, ..."""
        return tuple(f"{q}[{k}]" for k in range(len(self.trials)) for q in self.quantities)

    def values(self, x: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """(n_trials, n_quantities) of the fit vector ``x`` (names ``names``)."""
        idx = [list(names).index(n) for n in self.names]
        return np.asarray(x, float)[idx].reshape(len(self.trials), len(self.quantities))

    def series(self, x: np.ndarray, names: Sequence[str], trial_index: np.ndarray,
               width: int) -> dict[str, np.ndarray]:
        """The core's input series (B, width) of the windows (trial of window b:
        ``trial_index[b]``): each quantity constant in time at its trial's value."""
        return window_series(self.quantities, self.values(x, names), trial_index, width)


def window_series(quantities: Sequence[str], values: np.ndarray, trial_index: np.ndarray,
                  width: int) -> dict[str, np.ndarray]:
    """The core's input series (B, width) of windows whose trials have the per-trial
    ``values`` (n_trials, len(quantities)) of ``quantities`` (keys of :data:`SERIES_OF`; the
    trial of window b: ``trial_index[b]``): each quantity constant in time at its trial's
    value (a current [m/s, north, east, towards], a force bias [N, N m])."""
    vals = np.asarray(values, float).reshape(-1, len(quantities))[np.asarray(trial_index, int)]
    return {SERIES_OF[q]: np.repeat(vals[:, j:j + 1], width, axis=1)
            for j, q in enumerate(quantities)}


def in_their_water(series: Sequence[Series], quantities: Sequence[str], values: np.ndarray
                   ) -> list[Series]:
    """The trials' ``series`` with their smoothed velocities through the water of each trial's
    estimated current (:func:`through_water`; ``values`` (n_trials, len(quantities)) of
    ``quantities``, keys of :data:`SERIES_OF`): the replay of a trial in its current starts
    each window from them (the kind's states are through the water; the core adds the current
    back to the recorded velocities over ground). Unchanged without a current among
    ``quantities``; the measured outputs are left as they are."""
    qs = list(quantities)
    if "current_north" not in qs:
        return list(series)
    vals = np.asarray(values, float).reshape(len(series), len(qs))
    i, j = qs.index("current_north"), qs.index("current_east")
    return [Series(s.name, s.h, through_water(s.data, float(v[i]), float(v[j])))
            for s, v in zip(series, vals, strict=True)]


@dataclass(frozen=True)
class TrialWater:
    """The water each of several trials is replayed in after a fit with a disturbance: the
    per-trial ``values`` (n_trials, len(quantities)) of ``quantities`` (keys of
    :data:`SERIES_OF`: a current [m/s, north, east, towards], force biases [N, N m]); a row of
    zeros is calm water. The one definition of a replay "as fitted" (identify's own checks,
    :meth:`usvid.identify.estimator.ModelEstimator.score` and ``simulate``, the validation of
    the training logs): each window starts from its trial's velocities through the water
    (:meth:`through`) and runs in its trial's current and biases (:meth:`environment`)."""

    quantities: tuple[str, ...]
    values: np.ndarray

    def through(self, series: Sequence[Series]) -> list[Series]:
        """``series`` with their smoothed velocities through each trial's water
        (:func:`in_their_water`)."""
        return in_their_water(series, self.quantities, self.values)

    def environment(self, win: Any) -> dict[str, np.ndarray]:
        """The core's series (B, W) of the windows ``win`` (:class:`usvid.sim.replay.Windows`:
        ``trial_index``, ``width``) in their trials' water (:func:`window_series`)."""
        return window_series(self.quantities, self.values, win.trial_index, win.width)

    def row(self, k: int) -> dict[str, float]:
        """Trial ``k``'s values by quantity and unit (``current_north_m_s``, ``bias_N_N_m``)."""
        return {f"{q}_{UNITS[q].replace(' ', '_').replace('/', '_')}": float(v)
                for q, v in zip(self.quantities, np.asarray(self.values, float)[k],
                                strict=True)}


def match_training(log: tuple[str, float, float, str],
                   training: Sequence[tuple[str, float, float, str]]) -> int | str:
    """The index in ``training`` (name, first and last time [s], digest of the measured record:
    :func:`log_key`, of the trials a fit estimated a disturbance for) of the log ``log`` (the
    same form): the trial with the same record (digest), else the one trial of the same name
    whose time span overlaps the log's (a training log replayed whole, of which the fit used a
    part); or the reason there is none (a held-out log, or several candidates: which one's
    water is ambiguous)."""
    name, t0, t1, digest = log
    same = [i for i, k in enumerate(training) if k[3] == digest]
    if len(same) == 1:
        return same[0]
    named = [i for i, k in enumerate(training) if k[0] == name and k[1] <= t1 and t0 <= k[2]]
    if len(named) == 1:
        return named[0]
    if not named:
        return f"{name} is not one of the training logs (a held-out log)"
    return (f"{name} matches {len(named)} training logs (or parts) by its name and time span "
            "and none by its record: whose water is ambiguous")


def log_key(name: str, t: np.ndarray, psi: np.ndarray) -> tuple[str, float, float, str]:
    """(name, first and last time [s], digest of the time stamps and measured heading) of a
    log: how a log replayed after a fit is matched with its training logs
    (:func:`match_training`)."""
    t = np.ascontiguousarray(t, dtype=float)
    digest = hashlib.sha256(t.tobytes() + b"|"
                            + np.ascontiguousarray(psi, dtype=float).tobytes()).hexdigest()
    return str(name), float(t[0]), float(t[-1]), digest


#: What a replay in calm water after a fit with a disturbance says of a log.
CALM = ("replayed in calm water: no current or biases are estimated for it (the fit estimated "
        "them per training log; a mean of those would assume the runs shared their water)")


def water_for(logs: Sequence[tuple[str, float, float, str]], fitted: TrialWater,
              training: Sequence[tuple[str, float, float, str]]
              ) -> tuple[TrialWater | None, list[dict[str, Any]]]:
    """The water of ``logs`` (:func:`log_key` of each log to replay) after a fit that
    estimated ``fitted`` for the trials ``training`` (same form): a training log
    (:func:`match_training`) in its estimated current and biases, any other in calm water.
    Returns the :class:`TrialWater` of ``logs`` (None when all are calm) and one JSON-ready row
    per log saying which: ``trial``, ``water`` ("estimated" or "calm"), with the values
    (:meth:`TrialWater.row`) or ``why``."""
    vals = np.zeros((len(logs), len(fitted.quantities)))
    rows: list[dict[str, Any]] = []
    for k, log in enumerate(logs):
        name = log[0]
        i = match_training(log, training)
        if isinstance(i, str):
            rows.append({"trial": name, "water": "calm", "why": f"{i}: {CALM}"})
            continue
        vals[k] = np.asarray(fitted.values, float)[i]
        rows.append({"trial": name, "water": "estimated",
                     "why": "the current and biases the fit estimated for this training log",
                     **fitted.row(i)})
    if all(r["water"] == "calm" for r in rows):
        return None, rows
    return TrialWater(tuple(fitted.quantities), vals), rows


def disturbance_for(kind: Any, terms: Sequence[str], trials: Sequence[str]) -> Disturbance | None:
    """The :class:`Disturbance` of ``terms`` for a fit of ``kind`` (None without terms);
    refuses kinds that cannot carry it (a constant-speed response model has no surge or sway
    state to carry a current, and its rudder offset ``delta0`` already is its yaw bias)."""
    terms = tuple(terms)
    if not terms:
        return None
    if kind.constant_speed:
        raise IdentificationError(
            f"--disturbance {','.join(terms)}: a {kind.name} model moves at a constant speed "
            "with no surge or sway state, so a current cannot enter it, and its rudder offset "
            "delta0 already is a constant yaw bias; use a kind with surge and sway (threedof, "
            "catamaran, mmg)")
    return Disturbance(terms, tuple(trials))


def report(dist: Disturbance, x: np.ndarray, names: Sequence[str], cov: np.ndarray,
           q: float, free: Sequence[str], kind: str) -> dict[str, Any]:
    """The JSON-ready per-trial values with their 95 % intervals (``q`` the interval's
    quantile, ``cov`` the fit-space covariance over ``names``) and the separability verdict.

    Keys: ``terms``; ``trials``: one object per trial, ``trial`` its name, per quantity
    ``{"value", "std_error", "ci95", "unit"}``, with a current also its ``current_speed_m_s``
    and ``current_towards_deg`` (direction it flows towards, from north, clockwise);
    ``not_separable``: the quantities whose estimate correlates with another parameter above
    :data:`CORR_MAX` (with that parameter and the correlation) or whose interval is not
    finite; ``warning``: the text warned (None: all separable). Warns
    (:class:`IdentificationWarning`) when something is not separable."""
    names = list(names)
    cov = np.asarray(cov, float)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    fidx = [names.index(n) for n in free]
    vals = dist.values(x, names)
    trials, bad = [], []
    for k, tname in enumerate(dist.trials):
        row: dict[str, Any] = {"trial": tname}
        for j, qn in enumerate(dist.quantities):
            i = names.index(f"{qn}[{k}]")
            v, se = float(vals[k, j]), float(sd[i])
            row[qn] = {"value": v, "std_error": se, "ci95": [v - q * se, v + q * se],
                       "unit": UNITS[qn]}
            others = [(abs(float(corr[i, m])), names[m]) for m in fidx if m != i
                      and math.isfinite(float(corr[i, m]))]
            worst = max(others, default=(0.0, ""))
            if not (math.isfinite(se) and se > 0.0):
                bad.append({"quantity": f"{qn}[{tname}]", "reason": "no finite interval"})
            elif worst[0] > CORR_MAX and not any(  # each pair once
                    b.get("with") == f"{qn}[{tname}]" and b["quantity"] == _plain(worst[1], dist)
                    for b in bad):
                bad.append({"quantity": f"{qn}[{tname}]", "with": _plain(worst[1], dist),
                            "correlation": round(worst[0], 4)})
        if "current" in dist.terms:
            _current_polar(row)
        trials.append(row)
    text = _not_separable(
        bad, f"{kind}: the disturbance is not separable from the hull in these data",
        "its values and the correlated parameters are not determined separately; runs with "
        "turns through a wide range of headings (a current) and turns to both sides (a bias) "
        "separate them")
    return {"terms": list(dist.terms), "trials": trials, "not_separable": bad,
            "warning": text}


def _plain(name: str, dist: Disturbance) -> str:
    """A fit name with its trial's name in place of the index (``bias_N[run.csv]``)."""
    if name.endswith("]") and "[" in name:
        q, _, k = name[:-1].partition("[")
        try:
            return f"{q}[{dist.trials[int(k)]}]"
        except (ValueError, IndexError):
            return name
    return name


# ------------------------------------------------------------------------------------------
# the current in the regression (least squares on the smoothed states)
# ------------------------------------------------------------------------------------------

#: Terms the regression (``--method ls`` / ``rls``) estimates: the current only (a force bias
#: enters each kind's regression in its own normalisation; the output error estimates it).
REGRESSION_TERMS = ("current",)


def through_water(data: Mapping[str, np.ndarray], cn: float, ce: float) -> dict[str, np.ndarray]:
    """The series ``data`` (smoothed ``u_s``, ``v_s``, ``psi_s`` and, where present, ``r_s``,
    ``udot_s``, ``vdot_s``, over ground) with the velocities through the water of a constant
    current ``(cn, ce)`` [m/s, north, east, towards] (Fossen 2021, ch. 10.3): with the current
    in body axes ``u_c = c_N cos psi + c_E sin psi``, ``v_c = -c_N sin psi + c_E cos psi``,

    .. math:: u_r = u - u_c, \\quad v_r = v - v_c, \\quad \\dot u_r = \\dot u - r v_c, \\quad
              \\dot v_r = \\dot v + r u_c

    (``d u_c/dt = r v_c``, ``d v_c/dt = -r u_c`` for a constant current). For an irrotational
    constant current the rigid-body terms satisfy ``M_RB nu' + C_RB(nu) nu = M_RB nu_r' +
    C_RB(nu_r) nu_r`` (Fossen 2021, Property 10.1), so a kind's calm-water regression holds in
    the relative velocities. The other entries are shared, not copied."""
    d = dict(data)
    psi = d["psi_s"]
    c, s = np.cos(psi), np.sin(psi)
    uc = cn * c + ce * s
    vc = -cn * s + ce * c
    d["u_s"] = d["u_s"] - uc
    d["v_s"] = d["v_s"] - vc
    if "udot_s" in d:  # (a replay's series: only the velocities)
        d["udot_s"] = d["udot_s"] - d["r_s"] * vc
    if "vdot_s" in d:
        d["vdot_s"] = d["vdot_s"] + d["r_s"] * uc
    return d


def regression_current(kind: Any, series: Sequence[Any], fixed: Mapping[str, Any], *,
                       form: str, h: float, cond_max: float = 1e8
                       ) -> tuple[list[Any], np.ndarray, np.ndarray, np.ndarray]:
    """A constant current per trial estimated with the hull by the kind's regression: the
    series through the water (:func:`through_water`) of the currents minimising the
    regression's residuals, the hull's coefficients eliminated by variable projection (Golub &
    Pereyra 1973: for given currents the coefficients are the linear least-squares solution,
    so only the currents are iterated; scipy's Levenberg-Marquardt, numerical Jacobian).

    Each equation's residuals are scaled by their RMS at zero current (the equations' units
    differ). The currents' covariance is ``s^2 (J'J)^-1 f`` of the projected residuals' Jacobian
    ``J`` (Kaufman 1975's approximation of the variable-projection Jacobian), ``s^2`` the scaled
    residual variance and ``f`` the largest equation's residual autocorrelation factor
    (:func:`usvid.identify.ls.autocorrelation_factor`, as the regression's own intervals).
    ``collinear``: per current, the multiple correlation ``R = sqrt(1 - 1/VIF)`` of its effect
    on the residuals with that of the hull coefficients and the other currents (``VIF`` the
    ratio of the marginal to the conditional variance: the latter with the coefficients held
    at their values): near 1, the data cannot tell the current from the hull.

    The currents are found by batch least squares also when the hull is then fitted by
    recursive least squares (``rls``) on the series through the water. A regression that
    leaves rows out by the speed (near rest) may leave out a different number at another
    current: the residual vector is then cut or zero-padded to its length at zero current.

    Returns ``(series through the water, x (T, 2) [m/s], cov (2T, 2T), R (2T,))``; ``series``
    are :class:`usvid.identify.series.Series` with the kind's regression arrays."""
    from scipy.optimize import least_squares

    reg = kind.regression
    T = len(series)
    base = [s.data for s in series]
    for s in series:
        missing = [k for k in ("u_s", "v_s", "r_s", "psi_s", "udot_s", "vdot_s") if k not in s]
        if missing:
            raise IdentificationError(
                f"--disturbance current: trial {s.name} has no {', '.join(missing)} (the "
                f"{kind.name} regression has no surge and sway velocities to carry a current)")

    def blocks(x: np.ndarray) -> list[Any]:
        data = [through_water(d, float(x[2 * k]), float(x[2 * k + 1]))
                for k, d in enumerate(base)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return reg.blocks(data, fixed, form, h)

    def solve(blk: Any) -> np.ndarray:
        return np.linalg.lstsq(blk.Phi, blk.y, rcond=None)[0]

    x0 = np.zeros(2 * T)
    b0 = blocks(x0)
    scale = []
    for blk in b0:
        res = blk.y - blk.Phi @ solve(blk)
        scale.append(max(float(np.sqrt(np.mean(res * res))), 1e-300))
    n_ref = [blk.y.size for blk in b0]

    def fixed_len(r: np.ndarray, n: int) -> np.ndarray:  # rows left out vary with the speed
        return r[:n] if r.size >= n else np.concatenate([r, np.zeros(n - r.size)])

    def resid(x: np.ndarray, theta: list[np.ndarray] | None = None) -> np.ndarray:
        out = []
        for i, blk in enumerate(blocks(x)):
            th = solve(blk) if theta is None else theta[i]
            out.append(fixed_len((blk.y - blk.Phi @ th) / scale[i], n_ref[i]))
        return np.concatenate(out)

    sol = least_squares(resid, x0, method="lm", diff_step=1e-6, xtol=1e-10, ftol=1e-10)
    x = sol.x
    J = sol.jac
    r = sol.fun
    dof = max(r.size - x.size - sum(blk.Phi.shape[1] for blk in b0), 1)
    s2 = float(r @ r) / dof
    fac = max(autocorrelation_factor(r[sum(n_ref[:i]):sum(n_ref[:i + 1])],
                                     max_lag=min(200, max(n_ref[i] // 4, 1)))
              for i in range(len(n_ref)))
    JtJ = J.T @ J
    try:
        cov = np.linalg.inv(JtJ) * s2 * fac
    except np.linalg.LinAlgError:
        cov = np.full((x.size, x.size), np.inf)
    # conditional variance: the coefficients held at their values at the solution
    theta = [solve(blk) for blk in blocks(x)]
    Jc = np.empty_like(J)
    for j in range(x.size):
        step = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += step
        xm[j] -= step
        Jc[:, j] = (resid(xp, theta) - resid(xm, theta)) / (2 * step)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond_var = s2 * fac / np.einsum("ij,ij->j", Jc, Jc)
        R = np.sqrt(np.clip(1.0 - cond_var / np.diag(cov), 0.0, 1.0))
    R[~np.isfinite(np.diag(cov))] = 1.0
    out = [Series(s.name, s.h, through_water(d, float(x[2 * k]), float(x[2 * k + 1])))
           for k, (s, d) in enumerate(zip(series, base, strict=True))]
    return out, x.reshape(T, 2), cov, R


def regression_report(trials: Sequence[str], x: np.ndarray, cov: np.ndarray, R: np.ndarray,
                      q: float, kind: str) -> dict[str, Any]:
    """The JSON-ready per-trial current of :func:`regression_current` in the keys of
    :func:`report` (``terms``, ``trials``, ``not_separable``, ``warning``) and
    ``estimated_by`` (how): a current whose multiple correlation with the hull and the other
    currents exceeds :data:`CORR_MAX` (or whose interval is not finite) is not separable;
    warned as :func:`report` does."""
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rows, bad = [], []
    for k, tname in enumerate(trials):
        row: dict[str, Any] = {"trial": tname}
        for j, qn in enumerate(TERMS["current"]):
            i = 2 * k + j
            v, se = float(x[k, j]), float(sd[i])
            row[qn] = {"value": v, "std_error": se, "ci95": [v - q * se, v + q * se],
                       "unit": UNITS[qn], "correlation_with_hull": float(R[i])}
            if not (math.isfinite(se) and se > 0.0):
                bad.append({"quantity": f"{qn}[{tname}]", "reason": "no finite interval"})
            elif R[i] > CORR_MAX:
                bad.append({"quantity": f"{qn}[{tname}]",
                            "with": "the hull coefficients and the other currents",
                            "correlation": round(float(R[i]), 4)})
        _current_polar(row)
        rows.append(row)
    text = _not_separable(
        bad, f"{kind}: the current is not separable from the hull in these data",
        "its values and the hull's coefficients are not determined separately; runs with turns "
        "through a wide range of headings separate them")
    return {"terms": ["current"], "trials": rows, "not_separable": bad, "warning": text,
            "estimated_by": "regression"}


__all__ = ["CALM", "CORR_MAX", "Disturbance", "REGRESSION_TERMS", "SERIES_OF", "TERMS",
           "TrialWater", "UNITS", "disturbance_for", "in_their_water", "log_key", "match_training",
           "parse_disturbance", "regression_current", "regression_report", "report",
           "through_water", "water_for", "window_series"]


def _current_polar(row: dict) -> None:
    """Add the current's speed [m/s] and the direction it flows towards [deg, from north,
    clockwise] to a trial's row from its north and east components."""
    cn, ce = row["current_north"]["value"], row["current_east"]["value"]
    row["current_speed_m_s"] = float(math.hypot(cn, ce))
    row["current_towards_deg"] = float(math.degrees(math.atan2(ce, cn)) % 360.0)


def _not_separable(bad: list[dict], what: str, advice: str) -> str | None:
    """The collinearity warning of the not separable quantities ``bad`` (issued, at the
    caller's caller, and returned), or None when there are none."""
    if not bad:
        return None
    parts = [f"{b['quantity']} with {b['with']} (correlation {b['correlation']:.3f})"
             if "with" in b else f"{b['quantity']} ({b['reason']})" for b in bad[:6]]
    more = f" and {len(bad) - 6} more" if len(bad) > 6 else ""
    text = f"{what} (collinear: {'; '.join(parts)}{more}): {advice}"
    warnings.warn(text, IdentificationWarning, stacklevel=4)
    return text
