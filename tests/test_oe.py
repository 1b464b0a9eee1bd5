"""Output-error machinery: replays of measured windows on the integration core against
closed-form responses, windowing, the autocorrelation factor, the Schur-complement solver against
scipy's least_squares, and the interval coverage of the output-error fit."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal
from scipy.optimize import least_squares

from usvid.identify.ls import autocorrelation_factor
from usvid.identify.output_error import SETTLED_SE, OEProblem, refine_output_error
from usvid.models import Nomoto1, Nomoto2, Norrbin, ThreeDOF, VesselModel, get_kind
from usvid.sim.replay import Windows, make_windows, replay_windows
from usvid.trial import Vessel

NOMOTO1 = get_kind("nomoto1")


def _windows(h: float, inputs: dict, init: dict, outputs=("psi", "r")) -> Windows:
    """Windows with the given inputs (B, W) and initial values; outputs are placeholders."""
    shape = next(iter(inputs.values())).shape
    return Windows(h=h, inputs=inputs, outputs={c: np.zeros(shape) for c in outputs},
                   init={k: np.asarray(v, float) for k, v in init.items()})


def test_nomoto1_replay_step_response_closed_form():
    # T r' + r = K delta, step delta = d from rest: r = K d (1 - e^{-t/T}),
    # psi = K d (t - T (1 - e^{-t/T}))
    K, T, d, h = 0.4, 5.0, 0.1, 0.05
    t = np.arange(0, 30.0 + h / 2, h)
    win = _windows(h, {"delta": np.full((2, len(t)), d)}, {"r": np.zeros(2), "psi": np.zeros(2)})
    sim = replay_windows(VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=2.0)), win)
    assert sim["psi"].shape == sim["r"].shape == (2, len(t))
    r_ex = K * d * (1 - np.exp(-t / T))
    psi_ex = K * d * (t - T * (1 - np.exp(-t / T)))
    assert np.max(np.abs(sim["r"][0] - r_ex)) < 1e-9  # RK4 with h/T = 0.01: error ~ (h/T)^4
    # psi is integrated with the yaw rate by RK4 (was the trapezoid rule on r, error ~3e-6 rad)
    assert np.max(np.abs(sim["psi"][1] - psi_ex)) < 1e-9


def test_nomoto2_replay_matches_scipy_lsim():
    # Mu et al. 2018 eq. 29: K (1 + T3 s) / ((1 + T1 s)(1 + T2 s)); input a smooth rudder sweep
    K, T1, T2, T3, h = 0.5, 6.0, 1.2, 0.7, 0.02
    t = np.arange(0, 40.0, h)
    u = 0.2 * np.sin(0.3 * t) * (1 - np.exp(-t))
    sys = signal.lti([K * T3, K], [T1 * T2, T1 + T2, 1.0])
    _, y, _ = signal.lsim(sys, u, t)
    win = _windows(h, {"delta": u[None, :]}, {"r": [0.0], "psi": [0.0], "rdot": [0.0]})
    sim = replay_windows(VesselModel(Nomoto2(K=K, T1=T1, T2=T2, T3=T3),
                                     vessel=Vessel(speed=1.0)), win)
    # lsim assumes linear input between samples as the replay does: agreement to 1e-6 rad/s
    assert np.max(np.abs(sim["r"][0] - y)) < 1e-6


def test_norrbin_replay_steady_turn_is_eq36():
    # steady turn: n1 r + n3 r^3 = K (delta + delta0)  (Mu et al. 2018 eq. 36)
    K, T, n1, n3, d = 0.5, 2.0, 1.0, 3.0, 0.2
    win = _windows(0.05, {"delta": np.full((1, 2000), d)}, {"r": [0.0], "psi": [0.0]})
    sim = replay_windows(VesselModel(Norrbin(K=K, T=T, n1=n1, n3=n3), vessel=Vessel(speed=1.0)),
                         win)
    rs = sim["r"][0, -1]
    assert n1 * rs + n3 * rs ** 3 == pytest.approx(K * d, rel=1e-9)


def test_threedof_replay_surge_closed_form():
    # v = r = 0 under a straight constant thrust: m11 u' = -d11 u + T ->
    # u = u_inf + (u0 - u_inf) e^{-d11 t / m11}, u_inf = T / d11
    dyn = ThreeDOF(m11=100.0, m22=150.0, m33=40.0, d11=50.0, d22=60.0, d33=30.0, x_l=1.0,
                   thrust=100.0)
    h, n = 0.05, 400
    win = _windows(h, {"delta": np.zeros((1, n))},
                   {"u": [0.5], "v": [0.0], "r": [0.0], "psi": [0.0]},
                   outputs=("psi", "r", "u", "v"))
    sim = replay_windows(VesselModel(dyn), win)
    t = np.arange(n) * h
    assert np.max(np.abs(sim["u"][0] - (2.0 + (0.5 - 2.0) * np.exp(-0.5 * t)))) < 1e-8
    assert np.all(sim["v"] == 0) and np.all(sim["r"] == 0) and np.all(sim["psi"] == 0)


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
    """Noisy windows of a Nomoto 1 model p = (K, T, delta0) replayed on the core."""
    rng = np.random.default_rng(seed)
    t = np.arange(W) * h
    delta = 0.2 * np.sign(np.sin(2 * np.pi * (t[None, :] + rng.uniform(0, 10, (n_windows, 1)))
                                 / 12.0))
    r0 = rng.normal(0, 0.02, n_windows)
    psi0 = rng.normal(0, 0.1, n_windows)
    truth = _windows(h, {"delta": delta}, {"r": r0, "psi": psi0})
    K, T, d0 = p
    sim = replay_windows(VesselModel(Nomoto1(K=K, T=T, delta0=d0), vessel=Vessel(speed=1.0)),
                         truth)
    rm = sim["r"] + rng.normal(0, noise[1], delta.shape)
    pm = sim["psi"] + rng.normal(0, noise[0], delta.shape)
    return Windows(h=h, inputs={"delta": delta}, outputs={"psi": pm, "r": rm},
                   init={"r": rm[:, 0], "psi": pm[:, 0], "rdot": np.zeros(n_windows)})


def test_schur_solver_matches_scipy_least_squares():
    # 6 windows (< MIN_CLUSTERS): the Gauss-Newton covariance (J^T J)^-1 s^2 f_ac
    win = _windows_from_truth([0.3, 4.0, 0.01], n_windows=6)
    start = {"K": 0.25, "T": 3.0, "delta0": 0.0}
    a = refine_output_error(NOMOTO1, start, {}, win, reweight=False)
    # the same problem for scipy: parameters and every window's initial (r, psi), residuals
    # weighted by the first-pass noise proxy of refine_output_error
    prob = OEProblem(NOMOTO1, {}, win, ("psi", "r"))
    B = win.batch_size
    sig = {c: max(float(np.std(np.diff(win.outputs[c], axis=1))),
                  1e-3 * float(np.std(win.outputs[c])), 1e-9) for c in ("psi", "r")}

    def resid(x):
        sim = prob.simulate(x[:3], {"r": x[3:3 + B], "psi": x[3 + B:]})
        return np.concatenate([((sim[c] - win.outputs[c]) / sig[c])[:, 1:].ravel()
                               for c in ("psi", "r")])

    x0 = np.concatenate([[0.25, 3.0, 0.0], win.init["r"], win.init["psi"]])
    b = least_squares(resid, x0, method="lm", xtol=1e-14, ftol=1e-14)
    f = b.fun
    s2 = float(f @ f) / (f.size - b.x.size)
    fac = max(autocorrelation_factor(f.reshape(2, B, -1)[i]) for i in range(2))
    cov = np.linalg.inv(b.jac.T @ b.jac)[:3, :3] * s2 * fac
    # the same optimum to the solver's resolution: it stops once the Gauss-Newton step is below
    # SETTLED_SE of every standard error, within about 2.5 such steps of the optimum (linear
    # convergence); 3 SETTLED_SE bounds that (scipy runs to xtol 1e-14)
    np.testing.assert_array_less(np.abs(a.x - b.x[:3]), 3 * SETTLED_SE * np.sqrt(np.diag(cov)))
    np.testing.assert_allclose(np.sqrt(np.diag(a.cov)), np.sqrt(np.diag(cov)), rtol=1e-3)
    assert list(a.params.values()) == pytest.approx([0.3, 4.0, 0.01], rel=0.02, abs=1e-3)


def test_warm_start_reaches_the_same_optimum_in_fewer_simulations():
    # a fit started from an earlier fit's pass optima (the estimator's fit again with a held
    # parameter) converges to the same optimum, to the solver's resolution, in fewer iterations
    win = _windows_from_truth([0.3, 4.0, 0.01], n_windows=12, seed=3)
    start = {"K": 0.2, "T": 2.5, "delta0": 0.0}
    cold = refine_output_error(NOMOTO1, start, {}, win)
    assert len(cold.pass_points) == 2  # reweighted: two passes
    warm = refine_output_error(NOMOTO1, start, {}, win, warm=cold)
    se = np.sqrt(np.diag(cold.x_cov))
    # both stop within about 2.5 SETTLED_SE of the optimum (linear convergence)
    np.testing.assert_array_less(np.abs(warm.x - cold.x), 6 * SETTLED_SE * se)
    assert warm.nfev < cold.nfev / 2
    # a warm fit of another fit space (other names) is ignored: a cold start, the same fit
    other = replace(cold, x_names=("a", "b", "c"))
    again = refine_output_error(NOMOTO1, start, {}, win, warm=other)
    assert again.nfev == cold.nfev and np.array_equal(again.x, cold.x)


def test_oe_interval_coverage_on_20_repetitions():
    # white output noise, correct model: the 95 % interval of K must cover the truth in most of
    # 20 seeded repetitions (binomial: P(X <= 15 | n=20, p=0.95) < 0.3 %)
    hits = 0
    for seed in range(20):
        win = _windows_from_truth([0.3, 4.0, 0.01], seed=100 + seed)
        res = refine_output_error(NOMOTO1, {"K": 0.28, "T": 3.5, "delta0": 0.0}, {}, win)
        se = math.sqrt(res.cov[0, 0])
        hits += abs(res.params["K"] - 0.3) < 1.96 * se
    assert hits >= 16
    assert math.isfinite(res.ac_factor)


def _norrbin_windows(seed, n=16, W=301, h=0.1, rho=0.95, amp=(0.02, 0.004)):
    """Windows of a Norrbin model (K 0.3, T 4 s, n1 1, n3 20 s^2) under zig-zag rudder,
    measured with AR(1) noise (rho 0.95 per sample: correlated errors, large residuals)."""
    rng = np.random.default_rng(seed)
    t = np.arange(W) * h
    delta = 0.35 * np.sign(np.sin(2 * np.pi * (t[None, :] + rng.uniform(0, 20, (n, 1))) / 20.0))
    truth = _windows(h, {"delta": delta}, {"r": rng.normal(0, 0.05, n),
                                           "psi": rng.normal(0, 0.1, n)})
    sim = replay_windows(VesselModel(Norrbin(K=0.3, T=4.0, n1=1.0, n3=20.0),
                                     vessel=Vessel(speed=1.0)), truth)
    e = rng.normal(size=(2, n, W))
    c = np.zeros_like(e)
    for k in range(1, W):
        c[..., k] = rho * c[..., k - 1] + math.sqrt(1 - rho ** 2) * e[..., k]
    pm, rm = sim["psi"] + amp[0] * c[0], sim["r"] + amp[1] * c[1]
    return Windows(h=h, inputs={"delta": delta}, outputs={"psi": pm, "r": rm},
                   init={"r": rm[:, 0], "psi": pm[:, 0], "rdot": np.zeros(n)})


def test_secant_tail_and_structured_step_recover_the_gauss_newton_optimum(monkeypatch):
    # Norrbin from noisy zig-zag windows (correlated noise): the fit with the secant tail
    # (sparse Broyden steps) and the structured step (NL2SOL) stops where the plain
    # Levenberg-Marquardt fit does, to the solver's resolution, with the covariance of a
    # finite-difference Jacobian at its own optimum, and recovers the model
    import usvid.identify.output_error as oe

    kind = get_kind("norrbin")
    win = _norrbin_windows(2)
    start = {"K": 0.25, "T": 3.0, "n1": 1.0, "n3": 5.0, "delta0": 0.0}
    new = refine_output_error(kind, start, {}, win)
    monkeypatch.setattr(oe, "SECANT_SE", 0.0)
    monkeypatch.setattr(oe, "STRUCTURED", False)
    plain = refine_output_error(kind, start, {}, win)
    assert new.success and new.message.startswith("converged (the Gauss-Newton step")
    assert new.nfev != plain.nfev  # the new steps were taken (another path to the optimum)
    se = np.sqrt(np.diag(plain.x_cov))
    free = se > 0  # (n1 is held at 1: Norrbin's normalisation)
    # both stop within about 2.5 SETTLED_SE of the optimum (linear convergence): 6 bounds it
    np.testing.assert_array_less(np.abs(new.x - plain.x)[free], 6 * SETTLED_SE * se[free])
    # the covariance is a finite-difference Jacobian's at a point 0.06 SE from the other's:
    # the standard errors agree to well within 1 %
    np.testing.assert_allclose(np.sqrt(np.diag(new.x_cov))[free], se[free], rtol=1e-2)
    # recovered: every parameter within 3 of its standard errors of the truth
    truth = {"K": 0.3, "T": 4.0, "n3": 20.0, "delta0": 0.0}
    psd = dict(zip(new.names, np.sqrt(np.diag(new.cov)), strict=True))
    for n, v in truth.items():
        assert abs(new.params[n] - v) < 3 * psd[n], (n, new.params[n], psd[n])
