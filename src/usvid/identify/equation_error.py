"""Equation-error identification of any kind from its regression form.

Every kind with a :class:`usvid.models.kind.Regression` is put in the form ``y = Phi theta + e``
per equation (Mu et al. 2018, eq. 37-40 identify it by recursive least squares; batch least
squares is the same estimate with forgetting factor 1). Each equation ("block") is solved by
:class:`usvid.identify.ls.LeastSquares` (or :class:`usvid.identify.rls.RecursiveLeastSquares`
with forgetting factor ``lam``), the coefficients are mapped to the kind's parameters
(``Regression.to_params``) and their covariance by the delta method (numerical Jacobian).

When the regression has more coefficients than the kind has parameters (the Fossen 3-DOF
models: eight coefficients of six masses and dampings), the parameters are then fitted to all
equations at once: ``min sum_blocks ||(y_b - Phi_b theta_b(p)) / s_b||^2`` over p from the
unconstrained start, with ``s_b`` the block's residual RMS, so that the identified parameters
satisfy every equation (the two implied coefficients are not dropped); the reported
``consistency`` compares the free coefficients with those the parameters imply.

Standard errors: equation errors of manoeuvring data are coloured (smoothing, disturbances);
the covariance is inflated by the residual autocorrelation factor ``1 + 2 sum rho_k``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.ls import (
    LeastSquares,
    autocorrelation_factor,
    check_collinearity,
    numerical_jacobian,
)
from usvid.identify.rls import RecursiveLeastSquares
from usvid.identify.series import IdentificationWarning, Series
from usvid.manoeuvres import find_execute, steady_turn
from usvid.models.kind import Block, ModelKind


@dataclass
class EquationErrorFit:
    """Parameters [SI] of a kind's fitted names, their covariance (in ``names`` order), the
    regression coefficients with standard errors, and diagnostics (per block R^2,
    autocorrelation factor, consistency of a constrained form)."""

    params: dict[str, float]
    cov: np.ndarray
    names: tuple[str, ...]
    coefficients: dict[str, float]
    coefficient_std_errors: dict[str, float]
    diagnostics: dict[str, Any] = field(default_factory=dict)


def _solve(block: Block, method: str, lam: float, cond_max: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if method == "rls":
        est = RecursiveLeastSquares(lam=lam, p0=1e6).fit(block.Phi, block.y, block.names,
                                                         y_name=f"d{block.name}/dt")
        theta = est.coef_
        cov = est.P_ * est.sigma2_
        res = block.y - block.Phi @ theta
        check_collinearity(block.Phi, list(block.names), cond_max)  # RLS does not test it
        return theta, cov, res
    est = LeastSquares(cond_max=cond_max).fit(block.Phi, block.y, block.names,
                                              y_name=f"d{block.name}/dt")
    return est.coef_, est.cov_, est.residuals_


def fit_equation_error(kind: ModelKind, series: Sequence[Series], fixed: Mapping[str, Any], *,
                       form: str, h: float, method: str = "ls", lam: float = 1.0,
                       cond_max: float = 1e8, max_lag: int = 200) -> EquationErrorFit:
    """Least squares (``method`` "ls") or recursive least squares ("rls", forgetting factor
    ``lam``) on the kind's regression form ``form`` over ``series`` at step ``h`` [s]."""
    reg = kind.regression
    if reg is None:
        raise IdentificationError(f"model '{kind.name}' has no regression form")
    if form not in reg.forms:
        raise IdentificationError(f"model '{kind.name}': form {form!r} is not available "
                                  f"(one of {', '.join(reg.forms)})")
    data = [s.data for s in series]
    blocks = reg.blocks(data, fixed, form, h)
    thetas, covs, res_all, diag = [], [], [], {}
    for blk in blocks:
        theta, cov, res = _solve(blk, method, lam, cond_max)
        fac = autocorrelation_factor(res, max_lag=min(max_lag, max(len(res) // 4, 1)))
        thetas.append(theta)
        covs.append(cov * fac)
        res_all.append(res)
        diag[f"ls_{blk.name}_ac_factor"] = fac
        ss = float(np.sum((blk.y - blk.y.mean()) ** 2))
        diag[f"ls_{blk.name}_r2"] = 1 - float(res @ res) / ss if ss > 0 else math.nan
    theta = np.concatenate(thetas)
    cnames = tuple(n for b in blocks for n in b.names)
    cov_t = np.zeros((len(theta), len(theta)))
    i = 0
    for c in covs:
        k = c.shape[0]
        cov_t[i:i + k, i:i + k] = c
        i += k
    coefs = dict(zip(cnames, theta.tolist(), strict=True))
    fnames = kind.dynamics.fit_names()

    def to_params(th: np.ndarray) -> dict[str, float]:
        return reg.to_params(dict(zip(cnames, th, strict=True)), fixed, form, h)

    params = to_params(theta)
    names = tuple(n for n in fnames if n in params)
    vec = lambda p: np.array([p[n] for n in names], dtype=float)  # noqa: E731
    if reg.constrained:
        params, cov_p = _constrained(kind, blocks, res_all, params, names, fixed, form, h)
        implied = reg.coefficients(params, fixed, form, h)
        diag["consistency"] = {n: {"free": coefs[n], "implied": float(implied[n])}
                               for n in cnames}
    else:
        try:
            G = numerical_jacobian(lambda th: vec(to_params(th)), theta)
            cov_p = G @ cov_t @ G.T
        except (IdentificationError, UsvidError, ZeroDivisionError, ValueError):
            cov_p = np.full((len(names), len(names)), np.nan)
    se_t = np.sqrt(np.clip(np.diag(cov_t), 0, None))
    diag["regression"] = {"form": form, "step_s": h, "coefficients": coefs,
                          "std_errors": dict(zip(cnames, se_t.tolist(), strict=True))}
    return EquationErrorFit(params={n: float(params[n]) for n in names}, cov=cov_p,
                            names=names, coefficients=coefs,
                            coefficient_std_errors=dict(zip(cnames, se_t.tolist(), strict=True)),
                            diagnostics=diag)


def _constrained(kind: ModelKind, blocks: list[Block], res0: list[np.ndarray],
                 start: Mapping[str, float], names: tuple[str, ...], fixed: Mapping[str, Any],
                 form: str, h: float) -> tuple[dict[str, float], np.ndarray]:
    """Parameters fitted to every block at once (module docstring); covariance
    ``(J^T J)^-1 s^2 f_ac`` of the weighted stacked equation errors."""
    reg = kind.regression
    assert reg is not None and reg.coefficients is not None
    sig = [max(float(np.sqrt(np.mean(r * r))), 1e-300) for r in res0]
    space = kind.fit_space
    lo = np.full(len(names) if space is None else len(space.names), -np.inf)
    clipped: list[str] = []
    if space is not None:
        x0 = np.array([space.to_fit(start)[n] for n in space.names])
        lo = np.array([space.lower.get(n, -np.inf) for n in space.names])
        for i, n in enumerate(space.names):
            if not x0[i] > lo[i]:  # the unconstrained estimate breaks a physical bound
                x0[i] = space.fallback.get(n, 1.0 if lo[i] < 1.0 else 2.0 * lo[i])
                clipped.append(n)

        def params_of(x: np.ndarray) -> dict[str, float]:
            return space.from_fit(dict(zip(space.names, x, strict=True)))
    else:
        x0 = np.array([start[n] for n in names])

        def params_of(x: np.ndarray) -> dict[str, float]:
            return dict(zip(names, x, strict=True))

    def resid(x: np.ndarray) -> np.ndarray:
        th = reg.coefficients(params_of(x), fixed, form, h)
        return np.concatenate([(b.y - b.Phi @ np.array([th[n] for n in b.names])) / s
                               for b, s in zip(blocks, sig, strict=True)])

    sol = None
    if not clipped:
        sol = least_squares(resid, x0, x_scale="jac", method="lm", xtol=1e-12, ftol=1e-12)
    if sol is None or not np.all(sol.x > lo):  # bounded (trust region reflective)
        inside = np.where(np.isfinite(lo), np.maximum(x0, 2.0 * np.abs(lo) + 1e-12), x0)
        sol = least_squares(resid, inside, x_scale="jac",
                            method="trf", bounds=(lo, np.inf), xtol=1e-12, ftol=1e-12)
        at = [n for n, x, b in zip(space.names if space is not None else names, sol.x, lo,
                                   strict=True) if np.isfinite(b) and x <= 1.01 * b]
        warnings.warn(
            f"{kind.name}: least squares gives a non-physical {', '.join(clipped) or 'value'} "
            "(a negative mass or inertia); fitted with the masses constrained positive"
            + (f", {', '.join(at)} at its bound: that equation is not determined by these data"
               if at else ""), IdentificationWarning, stacklevel=4)
    J = sol.jac
    r = sol.fun
    s2 = float(r @ r) / max(len(r) - len(x0), 1)
    fac = max(autocorrelation_factor(r[i:i + len(b.y)]) for i, b in zip(
        np.cumsum([0] + [len(b.y) for b in blocks[:-1]]), blocks, strict=True))
    try:
        cov_x = np.linalg.inv(J.T @ J) * s2 * fac
    except np.linalg.LinAlgError:
        cov_x = np.full((len(x0), len(x0)), np.nan)
    params = params_of(sol.x)
    G = numerical_jacobian(lambda x: np.array([params_of(x)[n] for n in names]), sol.x)
    return {n: float(params[n]) for n in names}, G @ cov_x @ G.T


def two_step_norrbin(kind_nomoto: ModelKind, zigzags: Sequence[Series],
                     turns: Sequence[Series], *, h: float, method: str, lam: float,
                     cond_max: float) -> tuple[dict[str, float], np.ndarray, dict[str, Any]]:
    """Mu et al. 2018's two steps (remark 5, eq. 36): Nomoto K, T from the zig-zags, then
    alpha (n3 with n1 = 1) from the mean steady yaw rate of turning trials:
    ``alpha = sum r_i^3 (K (delta_i + delta0) - r_i) / sum r_i^6``. Returns the Norrbin
    parameters (K, T, n1, n3, delta0), their covariance and diagnostics."""
    if not zigzags:
        raise IdentificationError("two-step Norrbin: no zig-zag (varying rudder) trial for the "
                                  "Nomoto step")
    if not turns:
        raise IdentificationError(
            "two-step Norrbin (Mu et al. 2018, eq. 36) needs turning trials (constant rudder "
            "over their second half): give them with --turning (CLI) or fit(..., turning=...)")
    ee = fit_equation_error(kind_nomoto, zigzags, {}, form="continuous", h=h, method=method,
                            lam=lam, cond_max=cond_max)
    K, T, d0 = ee.params["K"], ee.params["T"], ee.params["delta0"]
    rr, dd = [], []
    for s in turns:  # the steady part of each turn (usvid.manoeuvres.steady_turn)
        st = steady_turn(s["t"], s["psi"], find_execute(s["t"], s["delta"])[0], r=s["r"],
                         delta=s["delta"])
        rr.append(float(st.yaw_rate))
        dd.append(float(st.delta))
    r_ = np.array(rr)
    d_ = np.array(dd)
    y = K * (d_ + d0) - r_
    alpha = float(np.sum(r_ ** 3 * y) / np.sum(r_ ** 6))
    se_a = math.nan
    if len(turns) > 1:
        res = y - alpha * r_ ** 3
        se_a = math.sqrt(float(res @ res) / max(len(turns) - 1, 1) / float(np.sum(r_ ** 6)))
    cov = np.zeros((5, 5))
    idx = [0, 1, 4]
    cov[np.ix_(idx, idx)] = ee.cov
    cov[3, 3] = se_a ** 2
    diag = dict(ee.diagnostics)
    diag["two_step"] = {"turning_trials": [s.name for s in turns], "mean_r": rr,
                        "mean_delta": dd}
    return {"K": K, "T": T, "n1": 1.0, "n3": alpha, "delta0": d0}, cov, diag
