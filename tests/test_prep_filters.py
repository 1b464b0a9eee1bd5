"""usvid.prep.filters: Savitzky-Golay derivatives, zero-phase low-pass, angle unwrapping."""

from __future__ import annotations

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.prep.filters import (
    finite_runs,
    lowpass,
    savgol_derivative,
    savgol_smooth,
    unwrap_angle,
    window_samples,
    wrap_angle,
)


def test_window_samples_in_seconds_is_odd():
    # 1 s at 20 Hz = 20 samples -> 21 (odd); 0.5 s at 10 Hz = 5; 0.1 s at 100 Hz -> 10 -> 11
    assert window_samples(1.0, 0.05) == 21
    assert window_samples(0.5, 0.1) == 5
    assert window_samples(0.1, 0.01) == 11
    # never shorter than order + 2 (over-determined fit): 0.01 s at 10 Hz -> 5 for order 3
    assert window_samples(0.01, 0.1, order=3) == 5
    with pytest.raises(UsvidError, match="step"):
        window_samples(1.0, 0.0)
    with pytest.raises(UsvidError, match="window"):
        window_samples(-1.0, 0.1)


def test_cubic_derivative_is_exact():
    # a cubic is reproduced exactly by an order-3 Savitzky-Golay fit, edges included
    t = np.arange(0, 10, 0.05)
    y = 2 * t**3 - t + 4
    d1 = savgol_derivative(y, 0.05, 1.0)
    d2 = savgol_derivative(y, 0.05, 1.0, deriv=2)
    np.testing.assert_allclose(d1, 6 * t**2 - 1, rtol=0, atol=1e-8)
    np.testing.assert_allclose(d2, 12 * t, rtol=0, atol=1e-7)


def test_noisy_sine_derivative_has_no_lag():
    rng = np.random.default_rng(1)
    dt = 0.05
    t = np.arange(0, 60, dt)
    w = 2 * np.pi / 20.0  # a 20-s yaw oscillation, like a zig-zag
    y = np.sin(w * t) + rng.normal(0, 0.002, t.size)  # 0.002 rad heading noise
    d = savgol_derivative(y, dt, 2.0)
    truth = w * np.cos(w * t)
    # noise of a cubic SG derivative over 41 samples is ~ 0.002 * 0.1 / dt ~ 0.004 rad/s, the
    # polynomial bias (w T)^4-order ~ 1e-4: 0.01 rad/s bounds both (peak 0.31 rad/s)
    assert np.max(np.abs(d - truth)[40:-40]) < 0.01
    # zero phase: the best-fitting delay is zero to within one sample
    lags = np.arange(-10, 11)
    err = [np.mean((np.roll(d, k) - truth)[50:-50] ** 2) for k in lags]
    assert lags[int(np.argmin(err))] == 0


def test_nan_splits_runs_and_stays_nan():
    t = np.arange(0, 20, 0.1)
    y = 3.0 * t
    y[50:60] = np.nan
    d = savgol_derivative(y, 0.1, 1.0)
    assert np.isnan(d[50:60]).all()
    # each side is a line: slope 3 everywhere, nothing smeared across the gap
    np.testing.assert_allclose(d[np.isfinite(d)], 3.0, atol=1e-9)
    np.testing.assert_array_equal(finite_runs(y), [[0, 50], [60, 200]])
    # a run shorter than the window falls back to central differences
    y2 = np.full(30, np.nan)
    y2[10:14] = [0.0, 1.0, 2.0, 3.0]
    np.testing.assert_allclose(savgol_derivative(y2, 1.0, 10.0)[10:14], 1.0)
    np.testing.assert_allclose(savgol_smooth(y2, 1.0, 10.0)[10:14], [0, 1, 2, 3])


def test_lowpass_zero_phase():
    dt = 0.02
    t = np.arange(0, 100, dt)
    slow = np.sin(2 * np.pi * 0.05 * t)
    fast = 0.5 * np.sin(2 * np.pi * 5.0 * t)
    out = lowpass(slow + fast, dt, cutoff_hz=0.5)
    # 4th-order Butterworth twice: at 0.05 Hz gain ~1 (|H|^2 = 1 - 1e-8), at 5 Hz ~1e-8
    assert np.max(np.abs(out - slow)[500:-500]) < 1e-3
    with pytest.raises(UsvidError, match="cutoff"):
        lowpass(slow, dt, cutoff_hz=30.0)


def test_unwrap_bridges_nan():
    a = np.array([3.0, np.nan, -3.0, -2.9])
    out = unwrap_angle(a)
    assert np.isnan(out[1])
    # -3.0 follows 3.0: a wrap, so it becomes -3.0 + 2 pi
    np.testing.assert_allclose(out[[0, 2, 3]], [3.0, -3.0 + 2 * np.pi, -2.9 + 2 * np.pi])
    np.testing.assert_allclose(wrap_angle([np.pi, 3 * np.pi / 2]), [-np.pi, -np.pi / 2])


def test_lowpass_zero_step_is_usvid_error() -> None:
    # dt = 0 raised a bare ZeroDivisionError before the fix
    for dt in (0.0, -0.1, float("nan")):
        with pytest.raises(UsvidError, match="sample step"):
            lowpass(np.ones(100), dt, 1.0)
