"""Output-error machinery: the batch RK4 kernels against closed-form responses, windowing, the
autocorrelation factor, the Schur-complement solver against scipy's least_squares, and the
interval coverage of the output-error fit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from usvid.identify.output_error import (
    Windows,
    autocorrelation_factor,
    make_windows,
    refine_output_error,
    simulate_response_batch,
    simulate_threedof_batch,
    simulate_windows,
)


def test_nomoto1_kernel_step_response_closed_form():
    # T r' + r = K delta, step delta = d from rest: r = K d (1 - e^{-t/T}),
    # psi = K d (t - T (1 - e^{-t/T}))
    K, T, d, h = 0.4, 5.0, 0.1, 0.05
    t = np.arange(0, 30.0 + h / 2, h)
    delta = np.full((2, len(t)), d)
    r, psi = simulate_response_batch(0, np.array([K, T, 0.0]), delta, h, np.zeros(2),
                                     np.zeros(2), np.zeros(2))
    r_ex = K * d * (1 - np.exp(-t / T))
    psi_ex = K * d * (t - T * (1 - np.exp(-t / T)))
    assert np.max(np.abs(r[0] - r_ex)) < 1e-9  # RK4 with h/T = 0.01: error ~ (h/T)^4
    # psi by the trapezoid rule on r: error ~ h^2/12 * max|r''| * t = ~3e-6 rad here
    assert np.max(np.abs(psi[1] - psi_ex)) < 1e-5


def test_nomoto2_kernel_matches_scipy_lsim():
    # seed 000 eq. 29: K (1 + T3 s) / ((1 + T1 s)(1 + T2 s)); input a smooth rudder sweep
    K, T1, T2, T3, h = 0.5, 6.0, 1.2, 0.7, 0.02
    t = np.arange(0, 40.0, h)
    u = 0.2 * np.sin(0.3 * t) * (1 - np.exp(-t))
    sys = signal.lti([K * T3, K], [T1 * T2, T1 + T2, 1.0])
    _, y, _ = signal.lsim(sys, u, t)
    r, _ = simulate_response_batch(1, np.array([K, T1, T2, T3, 0.0]), u[None, :], h,
                                   np.zeros(1), np.zeros(1), np.zeros(1))
    # lsim assumes linear input between samples as the kernel does: agreement to 1e-6 rad/s
    assert np.max(np.abs(r[0] - y)) < 1e-6


def test_norrbin_kernel_steady_turn_is_eq36():
    # steady turn: n1 r + n3 r^3 = K (delta + delta0)  (seed 000 eq. 36)
    K, T, n1, n3, d = 0.5, 2.0, 1.0, 3.0, 0.2
    h = 0.05
    delta = np.full((1, 2000), d)
    r, _ = simulate_response_batch(2, np.array([K, T, n1, n3, 0.0]), delta, h, np.zeros(1),
                                   np.zeros(1), np.zeros(1))
    rs = r[0, -1]
    assert n1 * rs + n3 * rs ** 3 == pytest.approx(K * d, rel=1e-9)


def test_threedof_kernel_surge_closed_form():
    # v = r = 0: u' = a_u u + a_tau tau_u  ->  u = u_inf + (u0 - u_inf) e^{a_u t}
    p = np.array([1.0, -0.5, 0.01, -1.0, -2.0, 0.1, -1.0, 0.02])
    h, n = 0.05, 400
    tau_u = np.full((1, n), 100.0)
    tau_r = np.zeros((1, n))
    U, V, R, P = simulate_threedof_batch(p, tau_u, tau_r, h, np.array([0.5]), np.zeros(1),
                                         np.zeros(1), np.zeros(1))
    t = np.arange(n) * h
    u_inf = -p[2] * 100.0 / p[1]
    assert np.max(np.abs(U[0] - (u_inf + (0.5 - u_inf) * np.exp(p[1] * t)))) < 1e-8
    assert np.all(V == 0) and np.all(R == 0) and np.all(P == 0)


def test_make_windows_covers_record_with_last_window_aligned_to_end():
    n = 105
    s = {"delta": np.arange(n, dtype=float), "psi": np.arange(n, dtype=float),
         "r": np.zeros(n), "r_s": np.zeros(n), "rdot_s": np.zeros(n), "psi_s": np.zeros(n)}
    w = make_windows([s], 1.0, 20.0)
    assert w.outputs["psi"].shape[1] == 21
    assert w.outputs["psi"][0, 0] == 0 and w.outputs["psi"][-1, -1] == n - 1
    # windows share their edge sample (start every W - 1 samples)
    assert w.outputs["psi"][1, 0] == 20
    w2 = make_windows([s], 1.0, 20.0, overlap=0.5)
    assert w2.outputs["psi"][1, 0] == 10
    assert w2.batch_size > w.batch_size


def test_autocorrelation_factor_white_and_ar1():
    rng = np.random.default_rng(0)
    white = rng.normal(size=(50, 400))
    # white noise: factor 1 (within sampling error of the pooled lag-1 correlation)
    assert autocorrelation_factor(white) == pytest.approx(1.0, abs=0.05)
    # AR(1) with rho = 0.8: long-run variance ratio (1 + rho)/(1 - rho) = 9; the Bartlett taper
    # removes a few %, the sampling error of the summed correlations (20 000 samples) is ~10 %
    e = rng.normal(size=(50, 400))
    x = np.zeros_like(e)
    for k in range(1, 400):
        x[:, k] = 0.8 * x[:, k - 1] + e[:, k]
    f = autocorrelation_factor(x)
    assert 7.0 < f < 11.0


def _windows_from_truth(p, n_windows=12, W=201, h=0.1, noise=(0.002, 0.001), seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(W) * h
    delta = 0.2 * np.sign(np.sin(2 * np.pi * (t[None, :] + rng.uniform(0, 10, (n_windows, 1)))
                                 / 12.0))
    r0 = rng.normal(0, 0.02, n_windows)
    psi0 = rng.normal(0, 0.1, n_windows)
    r, psi = simulate_response_batch(0, np.asarray(p, float), delta, h, r0, np.zeros(n_windows),
                                     psi0)
    rm = r + rng.normal(0, noise[1], r.shape)
    pm = psi + rng.normal(0, noise[0], psi.shape)
    return Windows(h=h, inputs={"delta": delta}, outputs={"psi": pm, "r": rm},
                   init={"r": rm[:, 0], "psi": pm[:, 0], "rdot": np.zeros(n_windows)})


def test_schur_solver_matches_scipy_least_squares():
    win = _windows_from_truth([0.3, 4.0, 0.01])
    p0 = np.array([0.25, 3.0, 0.0])
    a = refine_output_error("nomoto1", p0, win, solver="schur")
    b = refine_output_error("nomoto1", p0, win, solver="scipy")
    assert a.params == pytest.approx(b.params, rel=1e-5)
    assert a.std_errors == pytest.approx(b.std_errors, rel=1e-3)
    assert a.params == pytest.approx([0.3, 4.0, 0.01], rel=0.02, abs=1e-3)


def test_oe_fixed_parameter_and_simulate_windows():
    win = _windows_from_truth([0.3, 4.0, 0.01], seed=3)
    free = np.array([True, True, False])
    res = refine_output_error("nomoto1", np.array([0.25, 3.0, 0.01]), win, free=free)
    assert res.params[2] == 0.01 and res.std_errors[2] == 0.0
    sim = simulate_windows("nomoto1", res.params, win)
    assert sim["psi"].shape == win.outputs["psi"].shape


def test_oe_interval_coverage_on_20_repetitions():
    # white output noise, correct model: the 95 % interval of K must cover the truth in most of
    # 20 seeded repetitions (binomial: P(X <= 15 | n=20, p=0.95) < 0.3 %)
    hits = 0
    for seed in range(20):
        win = _windows_from_truth([0.3, 4.0, 0.01], seed=100 + seed)
        res = refine_output_error("nomoto1", np.array([0.28, 3.5, 0.0]), win)
        hits += abs(res.params[0] - 0.3) < 1.96 * res.std_errors[0]
    assert hits >= 16
    assert math.isfinite(res.ac_factor)
