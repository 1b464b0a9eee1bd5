"""Goodness-of-fit metrics of a prediction against measurements.

All metrics are in the units of the measured signal (RMSE, max error) or dimensionless (NRMSE,
R^2). Inputs are 1-D arrays or arrays with a leading batch axis; metrics reduce over every axis.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from usvid.errors import IdentificationError


def _pair(y: np.ndarray, y_hat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    if y.shape != y_hat.shape:
        raise IdentificationError(
            f"fit metrics: measured and predicted shapes differ ({y.shape} vs {y_hat.shape})")
    if y.size == 0:
        raise IdentificationError("fit metrics: no samples")
    return y, y_hat


def rmse(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Root-mean-square error ``sqrt(mean((y - y_hat)^2))`` [units of y]."""
    y, y_hat = _pair(y, y_hat)
    return float(np.sqrt(np.mean((y - y_hat) ** 2)))


def nrmse(y: np.ndarray, y_hat: np.ndarray) -> float:
    """RMSE divided by the standard deviation of ``y`` [-] (0 = perfect, 1 = as good as the mean).

    Returns inf when ``y`` is constant (no variation to normalise by).
    """
    y, y_hat = _pair(y, y_hat)
    sd = float(np.std(y))
    return rmse(y, y_hat) / sd if sd > 0 else float("inf")


def r_squared(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Coefficient of determination ``R^2 = 1 - SS_res / SS_tot`` [-] (-inf when y is constant)."""
    y, y_hat = _pair(y, y_hat)
    ss_res = float(np.sum((y - y_hat) ** 2))
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    if ss_tot == 0:
        return 1.0 if ss_res == 0 else float("-inf")
    return 1.0 - ss_res / ss_tot


def max_error(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Largest absolute error ``max |y - y_hat|`` [units of y]."""
    y, y_hat = _pair(y, y_hat)
    return float(np.max(np.abs(y - y_hat)))


@dataclass(frozen=True)
class FitMetrics:
    """RMSE and max error [units of y], NRMSE and R^2 [-], number of samples."""

    rmse: float
    nrmse: float
    r2: float
    max_error: float
    n: int

    def to_dict(self) -> dict[str, float | int]:
        """Plain dict (JSON-ready)."""
        return asdict(self)


def fit_metrics(y: np.ndarray, y_hat: np.ndarray) -> FitMetrics:
    """All four metrics of ``y_hat`` against ``y`` at once."""
    y, y_hat = _pair(y, y_hat)
    return FitMetrics(rmse=rmse(y, y_hat), nrmse=nrmse(y, y_hat), r2=r_squared(y, y_hat),
                      max_error=max_error(y, y_hat), n=int(y.size))
