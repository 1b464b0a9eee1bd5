"""Batch linear least squares ``y = X theta + e`` with parameter uncertainty.

The estimator follows the usvid estimator contract (scikit-learn style): hyper-parameters in
``__init__``, :meth:`LeastSquares.fit` returns ``self``, learned attributes end in ``_`` and
reading them before fitting raises :class:`NotFittedError`.

Theory (ordinary least squares, e.g. Ljung, *System Identification*, 2nd ed., sec. 7.3;
Mu et al. 2018 sec. 5.1 uses its recursive form, see :mod:`usvid.identify.rls`):

.. math::

    \\hat\\theta = (X^T X)^{-1} X^T y, \\quad
    \\hat\\sigma^2 = \\frac{\\lVert y - X\\hat\\theta\\rVert^2}{N - p}, \\quad
    \\mathrm{cov}(\\hat\\theta) = \\hat\\sigma^2 (X^T X)^{-1}

The 95 % interval is ``theta +- q * se`` with ``q`` the 0.975 quantile of Student's t with
``N - p`` degrees of freedom (``ci="t"``) or of the normal law (``ci="normal"``). The standard
errors assume white, homoscedastic equation errors; with coloured noise (typical of manoeuvring
data) they are optimistic.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy import stats

from usvid.errors import IdentificationError


class NotFittedError(IdentificationError):
    """An estimator's learned attribute was read before :meth:`fit` was called."""


class FittedAttributes:
    """Mixin of the estimator contract: reading a learned attribute (public name ending in ``_``)
    before ``fit`` raises :class:`NotFittedError` naming the estimator and the call to make."""

    _fit_call = "fit(X, y)"

    def _estimator_label(self) -> str:
        return type(self).__name__

    def __getattr__(self, name: str) -> Any:
        if name.endswith("_") and not name.startswith("_"):
            raise NotFittedError(f"{self._estimator_label()} is not fitted yet: call "
                                 f"{self._fit_call} before reading {name}")
        raise AttributeError(name)


def standard_errors(cov: np.ndarray) -> np.ndarray:
    """Standard errors ``sqrt(diag(cov))`` (p,), negative round-off on the diagonal read as 0."""
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def quantile975(dof: float = math.inf) -> float:
    """0.975 quantile of Student's t with ``dof`` degrees of freedom (of the normal law when
    ``dof`` is infinite): the half-width factor of a two-sided 95 % interval."""
    if math.isinf(dof):
        return float(stats.norm.ppf(0.975))
    return float(stats.t.ppf(0.975, dof))


def interval95(theta: Any, se: Any, q: float) -> np.ndarray:
    """95 % intervals ``theta -+ q se`` as a (p, 2) array of [low, high]."""
    theta = np.asarray(theta, dtype=float)
    se = np.asarray(se, dtype=float)
    return np.column_stack([theta - q * se, theta + q * se])


def numerical_jacobian(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, *,
                       floor: float = 1e-8) -> np.ndarray:
    """Central-difference Jacobian (m, p) of ``f`` at ``x`` (p,), step ``1e-6 max(|x_j|, floor)``
    (for the delta method ``cov(f) = J cov(x) J^T``)."""
    f0 = f(x)
    J = np.empty((len(f0), len(x)))
    for j in range(len(x)):
        h = 1e-6 * max(abs(x[j]), floor)
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        J[:, j] = (f(xp) - f(xm)) / (2 * h)
    return J


def _names(p: int, names: Sequence[str] | None, X: Any) -> list[str]:
    if names is None and hasattr(X, "columns"):
        names = [str(c) for c in X.columns]
    if names is None:
        return [f"x{j}" for j in range(p)]
    names = [str(n) for n in names]
    if len(names) != p:
        raise IdentificationError(f"got {len(names)} regressor names for {p} columns")
    return names


def check_regression_data(X: Any, y: Any, names: Sequence[str] | None = None, *,
                          y_name: str = "y", min_samples: int | None = None,
                          ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Validate a regression problem and return ``(X, y, names)`` as float arrays.

    ``X`` is (N, p) (a DataFrame gives the names), ``y`` is (N,). Raises
    :class:`IdentificationError` naming the culprit for: wrong shapes, NaN/inf (column and first
    bad row), fewer than ``min_samples`` rows (default ``p + 1``), a regressor that is identically
    zero (no excitation) and a constant output together with a zero regressor set.
    """
    Xa = np.asarray(X, dtype=float)
    ya = np.asarray(y, dtype=float)
    if Xa.ndim == 1:
        Xa = Xa[:, None]
    if Xa.ndim != 2:
        raise IdentificationError(f"regressor matrix must be 2-D (N, p); got shape {Xa.shape}")
    if ya.ndim == 2 and ya.shape[1] == 1:
        ya = ya[:, 0]
    if ya.ndim != 1:
        raise IdentificationError(f"output {y_name!r} must be 1-D (N,); got shape {ya.shape}")
    n, p = Xa.shape
    nm = _names(p, names, X)
    if ya.shape[0] != n:
        raise IdentificationError(
            f"regressors have {n} rows but output {y_name!r} has {ya.shape[0]}")
    if p == 0:
        raise IdentificationError("no regressors (p = 0)")
    need = p + 1 if min_samples is None else min_samples
    if n < need:
        raise IdentificationError(
            f"too few samples: {n} for {p} parameters (need at least {need})")
    bad = ~np.isfinite(Xa)
    if bad.any():
        j = int(np.argmax(bad.any(axis=0)))
        i = int(np.argmax(bad[:, j]))
        raise IdentificationError(
            f"regressor {nm[j]!r} has a non-finite value ({Xa[i, j]}) at row {i}")
    if not np.all(np.isfinite(ya)):
        i = int(np.argmax(~np.isfinite(ya)))
        raise IdentificationError(f"output {y_name!r} has a non-finite value ({ya[i]}) at row {i}")
    dead = np.all(Xa == 0.0, axis=0)
    if dead.any():
        cols = ", ".join(repr(nm[j]) for j in np.flatnonzero(dead))
        raise IdentificationError(f"no excitation: regressor(s) {cols} are identically zero")
    return Xa, ya, nm


def collinearity(X: np.ndarray, names: Sequence[str], cond_max: float
                 ) -> tuple[float, list[str]]:
    """Condition number of the column-equilibrated ``X`` and the columns in its weakest direction.

    Columns are scaled to unit Euclidean norm first, so the number measures collinearity rather
    than units. Returns ``(cond, culprits)``; ``culprits`` is empty when ``cond <= cond_max``,
    otherwise lists the columns whose weight in the smallest right singular vector is >= 10 % of
    its largest weight.
    """
    norms = np.linalg.norm(X, axis=0)
    Xs = X / np.where(norms > 0, norms, 1.0)
    _, s, vt = np.linalg.svd(Xs, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    if cond <= cond_max:
        return cond, []
    v = np.abs(vt[-1])
    return cond, [names[j] for j in np.flatnonzero(v >= 0.1 * v.max())]


def check_collinearity(X: np.ndarray, names: Sequence[str], cond_max: float) -> float:
    """:func:`collinearity`, raising :class:`IdentificationError` naming the collinear columns
    when the condition number exceeds ``cond_max``; returns the condition number."""
    cond, culprits = collinearity(X, names, cond_max)
    if culprits:
        raise IdentificationError(
            f"collinear regressors {', '.join(map(repr, culprits))} (condition number "
            f"{cond:.3g} > {cond_max:.3g}): the data cannot separate their effects")
    return cond


def arx_regressors(u: Any, y: Any, na: int, nb: int, nk: int = 1, *, start: int | None = None
                   ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Regressors of the ARX model (Mu et al. 2016 eq. 23 and 26 are ARX models identified by RLS).

    ``y_k = -a_1 y_{k-1} - ... - a_na y_{k-na} + b_1 u_{k-nk} + ... + b_nb u_{k-nk-nb+1} + e_k``,
    i.e. the discrete transfer function ``z^-nk (b_1 + b_2 z^-1 + ...) / (1 + a_1 z^-1 + ...)``.
    ``u``, ``y`` (N,) on a uniform grid; rows k = start .. N-1 (default the first k with every lag
    available, ``max(na, nk + nb - 1)``). Returns ``(X, target, names)`` with X columns
    ``-y_{k-i}`` (named ``a{i}``) then ``u_{k-nk-j+1}`` (named ``b{j}``); feed them to
    :class:`LeastSquares` or :class:`~usvid.identify.rls.RecursiveLeastSquares`, then
    :func:`arx_transfer_function` and :func:`usvid.identify.d2c.d2c` for continuous time.
    """
    ua = np.asarray(u, dtype=float)
    ya = np.asarray(y, dtype=float)
    if ua.ndim != 1 or ya.shape != ua.shape:
        raise IdentificationError(f"ARX: u and y must be 1-D of equal length (got {ua.shape} and "
                                  f"{ya.shape})")
    if na < 0 or nb < 1 or nk < 0:
        raise IdentificationError(f"ARX: need na >= 0, nb >= 1, nk >= 0 (got {na}, {nb}, {nk})")
    k0 = max(na, nk + nb - 1) if start is None else int(start)
    if k0 < max(na, nk + nb - 1):
        raise IdentificationError(f"ARX: start {k0} is before the longest lag")
    if ya.size - k0 < na + nb + 1:
        raise IdentificationError(
            f"ARX: too few samples ({ya.size}) for na={na}, nb={nb}, nk={nk}")
    k = np.arange(k0, ya.size)
    cols = [-ya[k - i] for i in range(1, na + 1)] + [ua[k - nk - j] for j in range(nb)]
    names = [f"a{i}" for i in range(1, na + 1)] + [f"b{j}" for j in range(1, nb + 1)]
    return np.column_stack(cols), ya[k], names


def arx_transfer_function(theta: Any, na: int, nb: int, nk: int = 1
                          ) -> tuple[np.ndarray, np.ndarray]:
    """(num, den) in ascending powers of z^-1 of ARX parameters ``[a_1..a_na, b_1..b_nb]``.

    ``num = [0]*nk + [b_1..b_nb]``, ``den = [1, a_1..a_na]``; pass them to
    ``d2c(num, den, dt, variable="z^-1")`` (the leading zeros become the dead time).
    """
    th = np.asarray(theta, dtype=float).ravel()
    if th.size != na + nb:
        raise IdentificationError(f"ARX: {th.size} parameters for na={na}, nb={nb}")
    return np.concatenate([np.zeros(nk), th[na:]]), np.concatenate([[1.0], th[:na]])


class LeastSquares(FittedAttributes):
    """Ordinary batch least squares with standard errors, covariance and 95 % intervals.

    Parameters
    ----------
    cond_max : float
        Largest accepted condition number of the column-equilibrated regressor matrix; above it the
        regressors are declared collinear and :class:`IdentificationError` names the columns.
    ci : {"t", "normal"}
        Quantile used for the 95 % intervals (Student's t with N - p dof, or normal).

    Learned attributes
    ------------------
    coef_ (p,), std_errors_ (p,), cov_ (p, p), ci95_ (p, 2), sigma2_ (residual variance, units of
    y squared), residuals_ (N,), cond_ (condition number, see :func:`collinearity`), dof_ (N - p),
    n_samples_, names_, rank_.
    """

    def __init__(self, *, cond_max: float = 1e8, ci: str = "t") -> None:
        if ci not in ("t", "normal"):
            raise IdentificationError(f"`ci` must be 't' or 'normal' (got {ci!r})")
        if not cond_max > 1:
            raise IdentificationError(f"`cond_max` must be > 1 (got {cond_max!r})")
        self.cond_max = float(cond_max)
        self.ci = ci

    def fit(self, X: Any, y: Any, names: Sequence[str] | None = None, *,
            y_name: str = "y") -> LeastSquares:
        """Estimate ``theta`` from regressors ``X`` (N, p) and output ``y`` (N,); returns self."""
        Xa, ya, nm = check_regression_data(X, y, names, y_name=y_name)
        n, p = Xa.shape
        cond = check_collinearity(Xa, nm, self.cond_max)
        # SVD solve on the equilibrated matrix (numerically safer than normal equations).
        norms = np.linalg.norm(Xa, axis=0)
        u, s, vt = np.linalg.svd(Xa / norms, full_matrices=False)
        theta_s = vt.T @ ((u.T @ ya) / s)
        theta = theta_s / norms
        res = ya - Xa @ theta
        dof = n - p
        sigma2 = float(res @ res) / dof
        inv_s = (vt.T / s) @ (vt / s[:, None])  # (Xs^T Xs)^-1
        cov = sigma2 * inv_s / np.outer(norms, norms)
        se = standard_errors(cov)
        q = quantile975(dof if self.ci == "t" else math.inf)
        self.coef_ = theta
        self.cov_ = cov
        self.std_errors_ = se
        self.ci95_ = interval95(theta, se, q)
        self.sigma2_ = sigma2
        self.residuals_ = res
        self.cond_ = cond
        self.dof_ = dof
        self.n_samples_ = n
        self.names_ = nm
        self.rank_ = p
        return self

    def predict(self, X: Any) -> np.ndarray:
        """One-step prediction ``X @ coef_`` (N,)."""
        Xa = np.asarray(X, dtype=float)
        if Xa.ndim == 1:
            Xa = Xa[:, None]
        if Xa.shape[-1] != self.coef_.shape[0]:
            raise IdentificationError(
                f"X has {Xa.shape[-1]} columns, the model was fitted with {self.coef_.shape[0]}")
        return Xa @ self.coef_

    def to_dict(self) -> dict[str, Any]:
        """Parameters, standard errors and intervals keyed by regressor name (JSON-ready)."""
        return {
            "params": dict(zip(self.names_, self.coef_.tolist(), strict=True)),
            "std_errors": dict(zip(self.names_, self.std_errors_.tolist(), strict=True)),
            "ci95": {k: v.tolist() for k, v in zip(self.names_, self.ci95_, strict=True)},
            "sigma2": self.sigma2_, "cond": self.cond_, "n": self.n_samples_, "dof": self.dof_,
        }


def autocorrelation_factor(res: np.ndarray, max_lag: int | None = None) -> float:
    """Variance inflation ``1 + 2 sum_k (1 - k/L) rho_k`` of a (B, W) residual batch.

    rho_k is the lag-k autocorrelation pooled over windows (lags within a window only), summed with
    Bartlett weights up to ``L`` = ``max_lag`` (default W/4) or the first non-positive lag. This is
    the ratio of the true variance of a mean of correlated residuals to the white-noise variance;
    it is >= 1 by construction (clipped).
    """
    res = np.asarray(res, dtype=float)
    if res.ndim == 1:
        res = res[None, :]
    res = res - res.mean()
    W = res.shape[1]
    L = max_lag or max(W // 4, 1)
    var = float(np.mean(res * res))
    if var <= 0:
        return 1.0
    f = 1.0
    for k in range(1, min(L, W - 1) + 1):
        rho = float(np.mean(res[:, k:] * res[:, :-k])) / var
        if rho <= 0:
            break
        f += 2.0 * (1.0 - k / (L + 1)) * rho
    return max(f, 1.0)
