"""Batch least squares: recovery, uncertainty against textbook formulas, bad-input errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from usvid.errors import IdentificationError
from usvid.identify.ls import LeastSquares, NotFittedError
from usvid.identify.metrics import fit_metrics, max_error, nrmse, r_squared, rmse


def _data(n=400, sigma=0.05, seed=0):
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.normal(size=n), rng.uniform(-1, 1, n), np.ones(n)])
    theta = np.array([1.5, -0.7, 0.3])
    return X, X @ theta + sigma * rng.normal(size=n), theta


def test_hand_computed_line():
    # y = 2 x + 1 through (0,1), (1,3), (2,5.5): normal equations by hand:
    # X^T X = [[5, 3], [3, 3]], X^T y = [14, 9.5] -> theta = [2.25, 0.9167]
    X = np.array([[0.0, 1], [1, 1], [2, 1]])
    y = np.array([1.0, 3.0, 5.5])
    ls = LeastSquares().fit(X, y, names=["slope", "icpt"])
    np.testing.assert_allclose(ls.coef_, [2.25, 11 / 12], rtol=1e-12)
    # residuals [1/12, -1/6, 1/12] -> sigma2 = (1/144 + 1/36 + 1/144) / 1 = 1/24
    assert ls.sigma2_ == pytest.approx(1 / 24, rel=1e-12)
    # cov = sigma2 (X^T X)^-1, (X^T X)^-1 = [[3, -3], [-3, 5]] / 6
    np.testing.assert_allclose(ls.cov_, (1 / 24) * np.array([[3, -3], [-3, 5]]) / 6, rtol=1e-10)
    q = stats.t.ppf(0.975, 1)  # 12.706 for 1 dof
    np.testing.assert_allclose(ls.ci95_[0], [2.25 - q * ls.std_errors_[0],
                                             2.25 + q * ls.std_errors_[0]], rtol=1e-12)
    assert ls.dof_ == 1 and ls.n_samples_ == 3
    assert ls.to_dict()["params"]["slope"] == pytest.approx(2.25)


def test_recovery_and_coverage():
    X, y, theta = _data()
    ls = LeastSquares().fit(X, y)
    # noise 0.05 over 400 samples: se ~ 0.05/sqrt(400) = 0.0025; 5 se is a loose bound
    assert np.all(np.abs(ls.coef_ - theta) < 5 * ls.std_errors_)
    assert np.all(ls.std_errors_ < 0.005)
    assert ls.sigma2_ == pytest.approx(0.05**2, rel=0.2)  # chi2 with 397 dof: +-15 % at 3 sd
    # interval coverage over 200 replications ~ 95 % (binomial sd 1.5 %, accept 90-99 %)
    hits = 0
    for s in range(200):
        Xs, ys, _ = _data(n=50, seed=100 + s)
        m = LeastSquares().fit(Xs, ys)
        hits += int(m.ci95_[0, 0] <= theta[0] <= m.ci95_[0, 1])
    assert 0.90 <= hits / 200 <= 0.99


def test_normal_interval_and_dataframe_names():
    X, y, _ = _data()
    df = pd.DataFrame(X, columns=["a", "b", "c"])
    m = LeastSquares(ci="normal").fit(df, y)
    assert m.names_ == ["a", "b", "c"]
    half = (m.ci95_[:, 1] - m.ci95_[:, 0]) / 2
    np.testing.assert_allclose(half, 1.959964 * m.std_errors_, rtol=1e-6)
    np.testing.assert_allclose(m.predict(X), X @ m.coef_)


def test_not_fitted():
    with pytest.raises(NotFittedError, match="not fitted"):
        LeastSquares().coef_  # noqa: B018


@pytest.mark.parametrize("bad, msg", [
    ("nan_col", "regressor 'b' has a non-finite value"),
    ("inf_y", "output 'r' has a non-finite value"),
    ("few", "too few samples"),
    ("zero", "no excitation: regressor\\(s\\) 'c'"),
    ("collinear", "collinear regressors 'a', 'b'"),
    ("shape", "50 rows but output .r. has 4"),
])
def test_bad_input(bad, msg):
    X, y, _ = _data(n=50)
    if bad == "nan_col":
        X[7, 1] = np.nan
    elif bad == "inf_y":
        y[3] = np.inf
    elif bad == "few":
        X, y = X[:3], y[:3]
    elif bad == "zero":
        X[:, 2] = 0.0
    elif bad == "collinear":
        X[:, 1] = 2 * X[:, 0] + 1e-12 * np.arange(50)
    elif bad == "shape":
        y = y[:4]
    with pytest.raises(IdentificationError, match=msg):
        LeastSquares().fit(X, y, names=["a", "b", "c"], y_name="r")


def test_bad_hyperparameters():
    with pytest.raises(IdentificationError, match="`ci`"):
        LeastSquares(ci="bootstrap")


def test_metrics_by_hand():
    y = np.array([1.0, 2.0, 3.0, 4.0])
    yh = np.array([1.0, 2.0, 3.0, 6.0])
    assert rmse(y, yh) == pytest.approx(1.0)  # sqrt(4 / 4)
    assert max_error(y, yh) == 2.0
    # SS_tot = 5, SS_res = 4 -> R^2 = 0.2; std(y) = sqrt(1.25)
    assert r_squared(y, yh) == pytest.approx(0.2)
    assert nrmse(y, yh) == pytest.approx(1 / np.sqrt(1.25))
    fm = fit_metrics(y, yh)
    assert fm.to_dict()["n"] == 4
    with pytest.raises(IdentificationError, match="shapes differ"):
        rmse(y, yh[:3])
