"""Recursive least squares with exponential forgetting and covariance resetting.

Mu et al. 2018 sec. 5.1 (and Mu et al. 2016 sec. 3.2) identify every model with "the recursive least
squares method"; the papers do not print the recursion, so the standard form is implemented
(Ljung, *System Identification*, 2nd ed., eq. 11.16; Astrom & Wittenmark, *Adaptive Control*,
sec. 2.2). For each sample k with regressor row ``x_k`` (p,) and output ``y_k``:

.. math::

    e_k = y_k - x_k^T \\theta_{k-1}, \\quad
    K_k = \\frac{P_{k-1} x_k}{\\lambda + x_k^T P_{k-1} x_k}, \\quad
    \\theta_k = \\theta_{k-1} + K_k e_k, \\quad
    P_k = \\frac{(I - K_k x_k^T) P_{k-1}}{\\lambda}

with forgetting factor ``0 < lambda <= 1`` (memory ~ 1 / (1 - lambda) samples) and
``P_0 = p0 I``. Covariance resetting (``P <- p0 I``) happens every ``reset_every`` samples
and/or whenever ``trace(P)`` falls below ``reset_below`` (adaptation has frozen) or exceeds
``reset_above`` (wind-up under forgetting with poor excitation). The recursion is a numba loop over
samples (``cache=True``); everything else is vectorised.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError
from usvid.identify.ls import FittedAttributes, check_regression_data


@njit(cache=True)
def _rls_kernel(X, y, theta0, p0, lam, reset_every, reset_below, reset_above):  # pragma: no cover
    n, p = X.shape
    theta = theta0.copy()
    P = np.eye(p) * p0
    hist = np.empty((n, p))
    err = np.empty(n)
    trace = np.empty(n)
    n_resets = 0
    px = np.empty(p)
    for k in range(n):
        # a priori error and gain
        e = y[k]
        for i in range(p):
            e -= X[k, i] * theta[i]
        denom = lam
        for i in range(p):
            s = 0.0
            for j in range(p):
                s += P[i, j] * X[k, j]
            px[i] = s
            denom += X[k, i] * s
        for i in range(p):
            theta[i] += px[i] / denom * e
        # P <- (P - px px^T / denom) / lam   (P symmetric so x^T P = px^T)
        tr = 0.0
        for i in range(p):
            for j in range(p):
                P[i, j] = (P[i, j] - px[i] * px[j] / denom) / lam
            tr += P[i, i]
        reset = False
        if reset_every > 0 and (k + 1) % reset_every == 0:
            reset = True
        if tr < reset_below or tr > reset_above:
            reset = True
        if reset:
            for i in range(p):
                for j in range(p):
                    P[i, j] = p0 if i == j else 0.0
            tr = p0 * p
            n_resets += 1
        hist[k] = theta
        err[k] = e
        trace[k] = tr
    return theta, P, hist, err, trace, n_resets


class RecursiveLeastSquares(FittedAttributes):
    """Recursive least squares estimator (see the module docstring for the recursion).

    Parameters
    ----------
    lam : float
        Forgetting factor, 0 < lam <= 1 (1 = ordinary least squares, no forgetting).
    p0 : float
        Initial (and reset) covariance scale: ``P_0 = p0 I``. Large = weak prior on ``theta0``.
    theta0 : array (p,) or None
        Initial estimate (zeros by default).
    reset_every : int or None
        Reset ``P`` to ``p0 I`` every this many samples.
    reset_below, reset_above : float or None
        Reset ``P`` whenever ``trace(P)`` leaves ``[reset_below, reset_above]``.

    Learned attributes
    ------------------
    coef_ (p,) final estimate; history_ (N, p) estimate after each sample; errors_ (N,) a priori
    prediction errors; P_ (p, p) final covariance matrix; trace_ (N,) trace(P) after each sample;
    n_resets_; sigma2_ residual variance of the final estimate over all samples; std_errors_ (p,)
    ``sqrt(diag(sigma2_ * P_))`` (exact OLS standard errors when ``lam == 1`` and ``p0`` is large
    and there was no reset; a rough guide otherwise); names_.
    """

    def __init__(self, lam: float = 1.0, *, p0: float = 1e4, theta0: Sequence[float] | None = None,
                 reset_every: int | None = None, reset_below: float | None = None,
                 reset_above: float | None = None) -> None:
        if not 0 < lam <= 1:
            raise IdentificationError(f"`lam` (forgetting factor) must be in (0, 1] (got {lam!r})")
        if not p0 > 0:
            raise IdentificationError(f"`p0` must be > 0 (got {p0!r})")
        if reset_every is not None and reset_every < 1:
            raise IdentificationError(f"`reset_every` must be >= 1 (got {reset_every!r})")
        self.lam = float(lam)
        self.p0 = float(p0)
        self.theta0 = None if theta0 is None else np.asarray(theta0, dtype=float)
        self.reset_every = reset_every
        self.reset_below = reset_below
        self.reset_above = reset_above

    def fit(self, X: Any, y: Any, names: Sequence[str] | None = None, *,
            y_name: str = "y") -> RecursiveLeastSquares:
        """Run the recursion over the rows of ``X`` (N, p) and ``y`` (N,); returns self.

        Raises :class:`IdentificationError` for bad shapes, NaN/inf (naming the column), fewer
        than p + 1 samples or an identically zero regressor.
        """
        Xa, ya, nm = check_regression_data(X, y, names, y_name=y_name)
        p = Xa.shape[1]
        theta0 = np.zeros(p) if self.theta0 is None else self.theta0
        if theta0.shape != (p,):
            raise IdentificationError(f"`theta0` has shape {theta0.shape}, expected ({p},)")
        theta, P, hist, err, trace, n_resets = _rls_kernel(
            np.ascontiguousarray(Xa), np.ascontiguousarray(ya), theta0.astype(float), self.p0,
            self.lam, int(self.reset_every or 0),
            -np.inf if self.reset_below is None else float(self.reset_below),
            np.inf if self.reset_above is None else float(self.reset_above))
        res = ya - Xa @ theta
        sigma2 = float(res @ res) / max(Xa.shape[0] - p, 1)
        self.coef_ = theta
        self.history_ = hist
        self.errors_ = err
        self.P_ = P
        self.trace_ = trace
        self.n_resets_ = int(n_resets)
        self.sigma2_ = sigma2
        self.std_errors_ = np.sqrt(np.clip(np.diag(P), 0.0, None) * sigma2)
        self.names_ = nm
        return self

    def predict(self, X: Any) -> np.ndarray:
        """One-step prediction with the final estimate, ``X @ coef_`` (N,)."""
        return np.asarray(X, dtype=float) @ self.coef_
