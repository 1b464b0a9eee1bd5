"""Goodness-of-fit metrics of a prediction against measurements.

All metrics are in the units of the measured signal (RMSE, max error) or dimensionless (NRMSE,
R^2). Inputs are 1-D arrays or arrays with a leading batch axis; metrics reduce over every axis.
"""

from __future__ import annotations

from collections.abc import Mapping
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


def replay_metrics(sim: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray]
                   ) -> dict[str, dict[str, float | int]]:
    """Fit metrics per output channel of replays against measurements: the one definition used
    for the estimator's fit metrics (windowed and free run) and the validation's free-run
    replay.

    ``sim`` and ``outputs``: name -> (B, W) simulated and measured values of B windows (a free
    run is one window per record). Compared from each window's second sample on (the first is
    the measured initial state); samples where the measurement is missing (past the end of a
    shorter record) are left out. A simulated sample that is not finite where the measurement
    is (the replay diverged) is an infinite error: a replay that diverged has an infinite RMSE
    and max error (never the RMS of the samples before the divergence) and R^2 = -inf.
    """
    out: dict[str, dict[str, float | int]] = {}
    for ch, s in sim.items():
        y = np.asarray(outputs[ch], dtype=float)[:, 1:].ravel()
        yh = np.asarray(s, dtype=float)[:, 1:].ravel()
        keep = np.isfinite(y)
        yh = np.where(np.isfinite(yh), yh, np.inf)
        with np.errstate(invalid="ignore", over="ignore"):
            out[ch] = fit_metrics(y[keep], yh[keep]).to_dict()
    return out


def diverged_at(t: np.ndarray, sim: np.ndarray, measured: np.ndarray) -> float | None:
    """Time [s] of ``t`` (the replay's grid) of the first simulated sample of the one-window
    replay ``sim`` that is not finite where ``measured`` is: where the replay diverged; None
    when it did not."""
    bad = ~np.isfinite(np.asarray(sim, dtype=float)) & np.isfinite(np.asarray(measured, float))
    return float(t[int(np.argmax(bad))]) if bad.any() else None
