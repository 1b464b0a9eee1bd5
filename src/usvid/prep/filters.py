"""Zero-phase smoothing, derivative estimation and angle unwrapping on uniform grids.

All functions take 1-D arrays on a uniform time grid of step ``dt`` [s]; windows are given in
seconds, never in samples. NaN samples split the signal into finite runs, each filtered on its own
(no smoothing across a gap); runs shorter than the filter window are differentiated by central
differences instead.

Savitzky-Golay (Savitzky & Golay 1964): a local least-squares polynomial of order ``order`` fitted
over ``2 m + 1`` samples, evaluated (or differentiated) at the centre. It is a symmetric FIR filter,
hence zero-phase: a derivative estimated this way has no lag, which matters for identification.
"""

from __future__ import annotations

import numpy as np

from usvid.errors import UsvidError


def window_samples(window_s: float, dt: float, order: int = 3) -> int:
    """The odd window length [samples] closest to ``window_s`` [s] at step ``dt`` [s].

    At least ``order + 2`` (so the fit is over-determined) and always odd.
    """
    if not (dt > 0 and np.isfinite(dt)):
        raise UsvidError(f"sample step must be > 0 s (got {dt})")
    if not (window_s > 0 and np.isfinite(window_s)):
        raise UsvidError(f"filter window must be > 0 s (got {window_s})")
    n = int(round(window_s / dt))
    n = max(n, order + 2)
    if n % 2 == 0:
        n += 1
    return n


def finite_runs(y: np.ndarray) -> np.ndarray:
    """``(start, stop)`` index pairs (stop exclusive) of the runs of finite samples of ``y``."""
    ok = np.isfinite(np.asarray(y, dtype=float))
    edges = np.diff(np.concatenate(([0], ok.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    return np.column_stack([starts, stops])


def nan_runs(y: np.ndarray) -> np.ndarray:
    """``(start, stop)`` index pairs (stop exclusive) of the runs of NaN/inf samples of ``y``."""
    bad = ~np.isfinite(np.asarray(y, dtype=float))
    edges = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
    return np.column_stack([np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)])


def savgol_derivative(
    y: np.ndarray, dt: float, window_s: float = 1.0, order: int = 3, deriv: int = 1
) -> np.ndarray:
    """Zero-phase Savitzky-Golay estimate of the ``deriv``-th time derivative of ``y``.

    Parameters
    ----------
    y : array (N,)
        Samples on a uniform grid (any unit ``[y]``); NaN splits the signal into runs.
    dt : float
        Sample step [s].
    window_s : float
        Window length [s] (rounded to an odd number of samples, see :func:`window_samples`).
    order : int
        Polynomial order (3 keeps the peaks of a manoeuvre; must exceed ``deriv``).
    deriv : int
        0 smooths, 1 gives ``dy/dt`` [[y]/s], 2 gives ``d2y/dt2`` [[y]/s^2].

    Returns
    -------
    array (N,) with NaN where ``y`` is NaN.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise UsvidError(f"savgol_derivative expects a 1-D array (got shape {y.shape})")
    if order <= deriv - 1:
        raise UsvidError(f"savgol order {order} must be >= deriv {deriv}")
    from scipy.signal import savgol_filter  # (on first use: ~0.6 s CPU that a simulation spares)

    n = window_samples(window_s, dt, order)
    out = np.full_like(y, np.nan)
    for a, b in finite_runs(y):
        seg = y[a:b]
        if len(seg) >= n:
            out[a:b] = savgol_filter(seg, n, order, deriv=deriv, delta=dt, mode="interp")
        elif len(seg) >= 3 and deriv <= 2:
            d = seg
            for _ in range(deriv):
                d = np.gradient(d, dt)
            out[a:b] = d
        elif deriv == 0:
            out[a:b] = seg
    return out


def savgol_smooth(y: np.ndarray, dt: float, window_s: float = 1.0, order: int = 3) -> np.ndarray:
    """Zero-phase Savitzky-Golay smoothing of ``y`` (same unit), window ``window_s`` [s]."""
    return savgol_derivative(y, dt, window_s, order, deriv=0)


def lowpass(y: np.ndarray, dt: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass (forward-backward, ``sosfiltfilt``) of ``y``.

    ``cutoff_hz`` [Hz] is the -3 dB frequency of the single pass; the forward-backward pass
    squares the magnitude response (-6 dB there) and cancels the phase. NaN runs are kept.
    """
    y = np.asarray(y, dtype=float)
    if not (dt > 0 and np.isfinite(dt)):
        raise UsvidError(f"sample step must be > 0 s (got {dt})")
    nyq = 0.5 / dt
    if not 0 < cutoff_hz < nyq:
        raise UsvidError(f"cutoff {cutoff_hz} Hz must lie in (0, {nyq:g}) Hz at step {dt} s")
    from scipy.signal import butter, sosfiltfilt  # (on first use, as in savgol_derivative)

    sos = butter(order, cutoff_hz / nyq, output="sos")
    out = np.full_like(y, np.nan)
    padmin = 3 * (2 * len(sos) + 1)
    for a, b in finite_runs(y):
        seg = y[a:b]
        out[a:b] = sosfiltfilt(sos, seg) if len(seg) > padmin else seg
    return out


def unwrap_angle(a: np.ndarray, period: float = 2 * np.pi) -> np.ndarray:
    """Unwrap an angle series [rad] over its finite samples (NaN kept, unwrapping bridges them).

    A jump of more than half a ``period`` between consecutive finite samples is taken as a wrap.
    """
    a = np.asarray(a, dtype=float)
    out = np.full_like(a, np.nan)
    ok = np.isfinite(a)
    if ok.any():
        out[ok] = np.unwrap(a[ok], period=period)
    return out


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap an angle [rad] into [-pi, pi)."""
    return (np.asarray(a, dtype=float) + np.pi) % (2 * np.pi) - np.pi
