"""usvid.prep.state_estimation: EKF + RTS smoother from noisy positions/heading/gyro to u, v, r and
their derivatives; recovery against simulated truth, consistency, bad input, real data."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from usvid.errors import UsvidError
from usvid.io import read_trial
from usvid.io.modelfile import load_model
from usvid.prep import prepare, resample, savgol_derivative
from usvid.prep.state_estimation import (
    StateEstimate,
    StateEstimationError,
    estimate_states,
    white_noise_std,
)
from usvid.sim import Turning, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial
from usvid.trial import Trial

MODEL = Path(__file__).resolve().parents[1] / "examples" / "lanxin_threedof.json"

#: A small USV's sensor suite: 10 Hz GNSS with 5 cm white noise, 50 Hz compass (0.3 deg) and
#: gyro (0.2 deg/s), 2 ms time-stamp jitter (the project's calm-sea campaign suite).
SENSORS = SensorModel(gps_rate_hz=10.0, gps_sigma_m=0.05, heading_rate_hz=50.0,
                      heading_sigma_deg=0.3, gyro_rate_hz=50.0, gyro_sigma_deg_s=0.2)
#: Slow GNSS position error besides the white noise: 1 m std, 60 s correlation time per axis.
WANDER_M, WANDER_TAU_S = 1.0, 60.0
STATES = ("u", "v", "r", "udot", "vdot", "rdot")


def wander(t: np.ndarray, sigma: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Second-order Gauss-Markov position error at times t [s]: a first-order Gauss-Markov
    process (std sigma sqrt 2, time constant tau) through a first-order lag tau, so the error is
    smooth from fix to fix like a real receiver's (stationary std sigma, velocity std sigma/tau)."""
    step = float(np.median(np.diff(t)))
    burn = t[0] - step * np.arange(int(5 * tau / step), 0, -1)
    tt = np.concatenate([burn, t])
    phi = np.exp(-np.diff(tt) / tau)
    w = rng.normal(0.0, 1.0, tt.size - 1) * sigma * math.sqrt(2.0) * np.sqrt(1.0 - phi ** 2)
    a = np.empty(tt.size)
    b = np.empty(tt.size)
    a[0], b[0] = rng.normal(0.0, sigma * math.sqrt(2.0)), 0.0
    for k in range(1, tt.size):
        a[k] = phi[k - 1] * a[k - 1] + w[k - 1]
        b[k] = phi[k - 1] * b[k - 1] + (1.0 - phi[k - 1]) * a[k]
    return b[burn.size:]


def sensed(res, seed: int, *, with_wander: bool) -> Trial:
    """Positions, heading and gyro of a simulated run (no logged u, v or speed over ground)."""
    tr = virtual_trial(res, SENSORS, seed=seed, name="virtual")
    d = tr.data.copy()
    if with_wander:
        rng = np.random.default_rng(seed + 1000)
        ok = np.isfinite(d["x"].to_numpy())
        for c in ("x", "y"):
            d.loc[ok, c] += wander(d["t"].to_numpy()[ok], WANDER_M, WANDER_TAU_S, rng)
    return tr.with_data(d.drop(columns=["u", "v", "U"]))


def truth_of(res) -> dict[str, np.ndarray]:
    """Noise-free u, v, r and their derivatives (central differences at the 0.02 s step: error
    O(dt^2) ~ 1e-5 of the signal)."""
    out = {n: res.channels[n][0] for n in ("x", "y", "psi", "u", "v", "r")}
    for n in ("u", "v", "r"):
        out[n + "dot"] = np.gradient(out[n], res.t)
    return out


@pytest.fixture(scope="module")
def runs():
    model = load_model(MODEL)
    # start in the straight-line steady state of the model's shaft speed
    u_ss = float(simulate(model, Turning(0.0), t_end=60.0).channels["u"][0, -1])
    zz = simulate(model, ZigZag(math.radians(20), math.radians(20), t_start=5.0), t_end=90.0,
                  u0=u_ss)
    turn = simulate(model, Turning(math.radians(35), t_start=5.0), t_end=60.0, u0=u_ss)
    return {"zigzag": zz, "turning": turn}


@pytest.fixture(scope="module")
def estimates(runs):
    out = {}
    for name, res in runs.items():
        for wand in (True, False):
            tr = sensed(res, seed=1, with_wander=wand)
            out[name, wand] = (tr, estimate_states(tr), truth_of(res), res.t)
    return out


def rms_error(t, value, t_truth, truth, sel=None) -> float:
    e = value - np.interp(t, t_truth, truth)
    if sel is None:
        sel = (t > 2.0) & (t < t[-1] - 2.0) & np.isfinite(e)  # the smoother's ends excluded
    return float(np.sqrt(np.mean(e[sel] ** 2)))


def savgol_errors(tr: Trial, truth, t_truth, window_s: float) -> dict[str, float]:
    """RMS errors of the Savitzky-Golay route on the same data: u, v and their derivatives by
    usvid.prep.prepare on a 10 Hz grid (the GNSS rate), r and r' by savgol on the 50 Hz gyro."""
    pr = prepare(tr, 10.0, window_s=window_s)
    g = resample(tr, 50.0)
    out = {n: rms_error(pr.t, pr[c], t_truth, truth[n])
           for n, c in (("u", "u"), ("v", "v"), ("udot", "u_dot"), ("vdot", "v_dot"))}
    out["r"] = rms_error(g.t, savgol_derivative(g["r"], 0.02, window_s, deriv=0), t_truth,
                         truth["r"])
    out["rdot"] = rms_error(g.t, savgol_derivative(g["r"], 0.02, window_s), t_truth,
                            truth["rdot"])
    return out


# --------------------------------------------------------------------------------------------
# noise levels
# --------------------------------------------------------------------------------------------


def test_white_noise_std_on_uneven_grid():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.05, 0.15, 5000))  # irregular 10 Hz
    smooth = 3.0 * np.sin(0.2 * t) + 0.01 * t ** 2
    # 5000 samples: the MAD-based std has a relative standard error of ~1.2 %; 5 % is 4 se
    assert white_noise_std(t, smooth + rng.normal(0, 0.1, t.size)) == pytest.approx(0.1, rel=0.05)
    # a noise-free smooth signal is not mistaken for noise (third differences ~ h^3 y''' ~ 1e-5)
    assert white_noise_std(t, smooth) < 1e-3
    assert math.isnan(white_noise_std(t[:3], smooth[:3]))


def test_noise_levels_from_data(estimates):
    _, est, _, _ = estimates["zigzag", False]
    # white noise of the sensors; the estimate from 900 fixes / 4500 samples is within ~5 %
    # (MAD standard error 2-4 %), 15 % fails for a unit error (deg vs rad) or a missing sqrt
    assert est.sigma["x"] == pytest.approx(0.05, rel=0.15)
    assert est.sigma["psi"] == pytest.approx(math.radians(0.3), rel=0.15)
    assert est.sigma["r"] == pytest.approx(math.radians(0.2), rel=0.15)
    assert est.info["sigma_source"]["x"] == "data"
    assert est.info["tuning"]["tuned"]


# --------------------------------------------------------------------------------------------
# recovery of the simulated truth
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("manoeuvre", ["zigzag", "turning"])
def test_recovers_velocities_and_accelerations(estimates, manoeuvre):
    tr, est, truth, tt = estimates[manoeuvre, True]
    # the turning circle's heading crosses +-pi (wrapped compass): innovations must be wrapped
    if manoeuvre == "turning":
        psi = tr["psi"][np.isfinite(tr["psi"])]
        assert np.max(np.abs(np.diff(psi))) > math.pi
    err = {n: rms_error(est.t, est[n], tt, truth[n]) for n in STATES}
    # u, v: the GNSS wander (1 m / 60 s) moves the positions at sigma/tau = 0.017 m/s per axis,
    # indistinguishable from motion; over a 60-90 s run (1-1.5 correlation times) its sample
    # RMS scatters up to ~1.6x: 0.035 m/s is twice the wander's velocity (measured 0.014-0.027
    # over seeds 1-5)
    assert err["u"] < 0.035
    assert err["v"] < 0.035
    # r: gyro noise 0.0035 rad/s at 50 Hz averaged over the ~1 s the smoother needs
    # (0.0035/sqrt(50) = 0.0005) plus the smoothing of the rudder steps: 0.0015 rad/s (3x that
    # noise floor, 0.5 % of the peak yaw rate) - measured 0.0006-0.0008
    assert err["r"] < 1.5e-3
    # r': the rudder steps make r' jump within ~0.5 s; measured 6-9 % of the RMS r' (seeds 1-5).
    # 15 %: a smoother lagging by 0.5 s, or differentiating the heading alone, gives > 30 %
    rdot_rms = float(np.sqrt(np.mean(truth["rdot"] ** 2)))
    assert err["rdot"] < 0.15 * rdot_rms
    # u': 5 cm position noise at 10 Hz resolves a second derivative only over ~2-4 s; measured
    # 0.010-0.023 m/s^2 (seeds 1-5, both manoeuvres; the zig-zag's u' peaks at 0.1 m/s^2)
    assert err["udot"] < 0.03
    assert err["vdot"] < 0.045


@pytest.mark.parametrize("manoeuvre", ["zigzag", "turning"])
def test_against_savitzky_golay(estimates, manoeuvre):
    tr, est, truth, tt = estimates[manoeuvre, True]
    err = {n: rms_error(est.t, est[n], tt, truth[n]) for n in STATES}
    # usvid.prep.prepare with its defaults (50 Hz grid, 1 s Savitzky-Golay window): the second
    # derivative of 5 cm position noise over 1 s is of order 1 m/s^2, the EKF is 3.5-55x better
    # on u, v, r, u', v' (seeds 1-3). Its r' (the 1 s derivative of the 50 Hz gyro) suits the
    # zig-zag's gyro noise: the likelihood's q_r follows the rudder reversals and lets a little
    # more gyro noise through (EKF 1.33-1.48x worse in the zig-zag, 1.4-1.5x better in the turn,
    # seeds 1-3; was 1.2-1.33x with the example model's old shaft speed, 47.97 rps, which did
    # not hold its 10 kn: the faster zig-zag has sharper r' at the reversals)
    pr = prepare(tr)
    default = {n: rms_error(pr.t, pr[c], tt, truth[n])
               for n, c in (("u", "u"), ("v", "v"), ("r", "r"), ("udot", "u_dot"),
                            ("vdot", "v_dot"), ("rdot", "r_dot"))}
    for n in ("u", "v", "r", "udot", "vdot"):
        assert err[n] < 0.5 * default[n], (n, err[n], default[n])
    assert err["rdot"] < 1.5 * default["rdot"]
    # the best window chosen in hindsight with the truth, per quantity (4 s for the positions,
    # 1 s for the gyro): the EKF's u, v are better (measured 1.03-1.8x over seeds 1-3); r, u',
    # v' are within 35 % of that oracle (measured 0.64-1.18x: the accelerations are at the
    # limit 5 cm of position noise allows, whatever the smoother); r' within 55 % (1.08-1.47x;
    # the zig-zag's r' as above, was within 35 % with the old shaft speed)
    sg = {w: savgol_errors(tr, truth, tt, w) for w in (0.5, 1.0, 2.0, 4.0, 8.0)}
    best = {n: min(sg[w][n] for w in sg) for n in STATES}
    for n in ("u", "v"):
        assert err[n] < best[n], (n, err[n], best[n])
    for n in ("r", "udot", "vdot"):
        assert err[n] < 1.35 * best[n], (n, err[n], best[n])
    assert err["rdot"] < 1.55 * best["rdot"], (err["rdot"], best["rdot"])


@pytest.mark.parametrize("manoeuvre", ["zigzag", "turning"])
def test_standard_deviations_are_consistent(estimates, manoeuvre):
    # without GNSS wander (which the white-noise model does not describe, so no std can cover it)
    _, est, truth, tt = estimates[manoeuvre, False]
    sel = (est.t > 2.0) & (est.t < est.t[-1] - 2.0)
    for n in ("x", "y", "psi", *STATES):
        z = (est[n] - np.interp(est.t, tt, truth[n]))[sel] / est.std[n][sel]
        inside = float(np.mean(np.abs(z) <= 3.0))
        # Gaussian: 99.7 % inside +-3 sigma and RMS(z) = 1. The white jerk is not the jerk of a
        # rudder step, so the errors bunch at the steps: measured 94-100 % inside and RMS(z)
        # 0.5-1.5 (seeds 1-3). >= 95 % and 0.4..1.6 fail for a std off by a factor of 2
        assert inside >= 0.95, (n, inside)
        assert 0.4 < float(np.sqrt(np.mean(z ** 2))) < 1.6, n


def test_innovation_statistics(estimates):
    _, est, _, _ = estimates["zigzag", False]
    stats = est.info["innovations"]
    assert set(stats) == {"x", "y", "psi", "r"}
    # x, y at 10 Hz (900 fixes), psi and r at 50 Hz (4500) in 90 s
    assert stats["x"]["updates"] == pytest.approx(901, abs=2)
    assert stats["r"]["updates"] == pytest.approx(4501, abs=2)
    for ch, s in stats.items():
        # consistent noise model: NIS near 1 (measured 0.88-1.02) and white innovations
        assert 0.7 < s["nis_mean"] < 1.3, ch
        assert abs(s["lag1_autocorr"]) < 0.2, ch
        assert est.nis[ch] == s["nis_mean"]


def test_to_trial(estimates):
    tr, est, _, _ = estimates["zigzag", False]
    out = est.to_trial(with_std=True)
    for c in ("x", "y", "psi", "u", "v", "r", "udot", "vdot", "rdot", "u_std", "rdot_std"):
        assert c in out.channels
    assert "delta" in out.channels  # other channels kept for the regression
    assert len(out) == len(tr)
    np.testing.assert_array_equal(out.t, tr.t)
    assert np.isfinite(out["rdot"]).all()
    meta = out.meta["state_estimation"]
    assert set(meta["sigma"]) == {"x", "y", "psi", "r"}
    assert set(meta["q"]) == {"q_u", "q_v", "q_r"}
    assert "nis_mean" in meta["innovations"]["psi"]
    json.dumps(meta)  # plain numbers and lists: writable with a trial or a model file
    assert isinstance(est, StateEstimate)


def test_overrides_and_fixed_process_noise(runs):
    tr = sensed(runs["zigzag"], seed=2, with_wander=False).slice_time(0.0, 40.0)
    est = estimate_states(tr, sigma_pos=0.1, sigma_psi=0.01, sigma_r=0.005,
                          q_u=1e-3, q_v=1e-2, q_r=4e-3, tune=True)
    assert est.sigma == {"x": 0.1, "y": 0.1, "psi": 0.01, "r": 0.005}
    assert est.q == {"q_u": 1e-3, "q_v": 1e-2, "q_r": 4e-3}
    assert not est.info["tuning"]["tuned"]  # nothing left to search
    # larger assumed position noise -> larger position std
    est2 = estimate_states(tr, sigma_pos=0.5, q_u=1e-3, q_v=1e-2, q_r=4e-3)
    assert np.median(est2.std["x"]) > 2 * np.median(est.std["x"])


def test_speed_and_course_over_ground_are_used(runs):
    res = runs["turning"]
    tr = virtual_trial(res, SENSORS, seed=4, name="sog")
    # speed over ground from the receiver, course = psi + drift angle, at the fixes
    d = tr.data.drop(columns=["u", "v"]).copy()
    ok = np.isfinite(d["U"].to_numpy())
    ts = d["t"].to_numpy()[ok]
    course = np.interp(ts, res.t, np.unwrap(res.channels["psi"][0] + np.arctan2(
        res.channels["v"][0], res.channels["u"][0])))
    rng = np.random.default_rng(9)
    d["cog"] = np.nan
    d.loc[ok, "cog"] = np.angle(np.exp(1j * (course + rng.normal(0, math.radians(0.5),
                                                                   ts.size))))
    est = estimate_states(tr.with_data(d))
    stats = est.info["innovations"]
    assert stats["U"]["updates"] > 500 and stats["cog"]["updates"] > 500
    assert 0.7 < stats["cog"]["nis_mean"] < 1.3
    truth = truth_of(res)
    # speed (5 cm/s Doppler) and course make u and v better than from positions alone (0.007-
    # 0.012 m/s without wander): 0.01 m/s
    assert rms_error(est.t, est["u"], res.t, truth["u"]) < 0.01
    assert rms_error(est.t, est["v"], res.t, truth["v"]) < 0.01


def test_multi_rate_with_stale_fixes_equals_missing_fixes(runs):
    """A logger writing the 10 Hz GNSS on every 50 Hz row repeats each fix five times: the
    repeats are not measurements, so the estimate equals the one with the repeats blank."""
    base = sensed(runs["zigzag"], seed=3, with_wander=False).slice_time(0.0, 30.0)
    g = resample(base, 50.0)  # every channel on one 50 Hz grid
    d = g.data.copy()
    keep = np.zeros(len(d), bool)
    keep[::5] = True
    for c in ("x", "y"):
        d.loc[~keep, c] = np.nan
    missing = g.with_data(d.copy(), name="missing")
    d[["x", "y"]] = d[["x", "y"]].ffill()
    stale = g.with_data(d, name="stale")
    kw = {"q_u": 1e-3, "q_v": 1e-2, "q_r": 4e-3, "sigma_pos": 0.05}
    e_stale = estimate_states(stale, **kw)
    e_missing = estimate_states(missing, **kw)
    n_fix = int(np.isfinite(missing["x"]).sum())
    assert n_fix > 290  # 30 s at 10 Hz
    assert e_stale.info["stale_fixes"] == int(np.isfinite(stale["x"]).sum()) - n_fix
    assert e_stale.info["innovations"]["x"]["updates"] == n_fix
    np.testing.assert_allclose(e_stale["u"], e_missing["u"], atol=1e-12)


def test_geodetic_positions_are_converted(runs):
    tr = sensed(runs["turning"], seed=5, with_wander=False).slice_time(0.0, 30.0)
    import pymap3d

    d = tr.data.copy()
    lat, lon, _ = pymap3d.ned2geodetic(d["x"].to_numpy(), d["y"].to_numpy(), 0.0, 38.0, 121.0,
                                       0.0)
    d = d.drop(columns=["x", "y"]).assign(lat=lat, lon=lon)
    est_geo = estimate_states(tr.with_data(d), q_u=1e-3, q_v=1e-2, q_r=4e-3, sigma_pos=0.05)
    est_ned = estimate_states(tr, q_u=1e-3, q_v=1e-2, q_r=4e-3, sigma_pos=0.05)
    # same velocities to the mm/s (the NED origin differs: first fix vs simulation origin)
    np.testing.assert_allclose(est_geo["u"], est_ned["u"], atol=1e-3)


def test_gnss_outage_and_outlier(runs):
    res = runs["zigzag"]
    tr = sensed(res, seed=6, with_wander=False)
    d = tr.data.copy()
    t = d["t"].to_numpy()
    gap = (t > 40.0) & (t < 55.0)  # 15 s without GNSS (bridge, multipath)
    d.loc[gap, ["x", "y"]] = np.nan
    fixes = np.flatnonzero(np.isfinite(d["x"].to_numpy()))
    d.loc[fixes[100], "x"] += 30.0  # one 30 m jump
    kw = {"q_u": 1.5e-3, "q_v": 1e-2, "q_r": 4e-3, "sigma_pos": 0.05}
    est = estimate_states(tr.with_data(d), gate=6.0, **kw)
    assert est.info["innovations"]["x"]["rejected"] == 1
    truth = truth_of(res)
    # without gating the jump spreads into u (u RMS error 0.13 m/s against 0.036 with the gate)
    raw = estimate_states(tr.with_data(d), **kw)
    assert rms_error(raw.t, raw["u"], res.t, truth["u"]) > \
        2 * rms_error(est.t, est["u"], res.t, truth["u"])
    # in the outage the heading and gyro carry the estimate: position error grows (dead
    # reckoning on u, v), and the standard deviation grows with it and still covers it
    ex = est["x"] - np.interp(est.t, res.t, truth["x"])
    mid = np.abs(est.t - 47.5) < 1.0
    assert np.median(est.std["x"][mid]) > 3 * np.median(est.std["x"][est.t < 35.0])
    for n, tru in (("x", truth["x"]), ("u", truth["u"]), ("v", truth["v"])):
        e = est[n] - np.interp(est.t, res.t, tru)
        assert np.mean(np.abs(e[gap]) <= 3 * est.std[n][gap]) > 0.95, n
    # dead reckoning over 15 s at 4.5 m/s: measured 0.46 m at most (std 0.41 m mid-gap)
    assert np.max(np.abs(ex[gap])) < 1.5


# --------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------


def _small_trial(n: int = 50, name: str = "bad") -> Trial:
    t = np.arange(n) * 0.1
    return Trial(pd.DataFrame({"t": t, "x": 2.0 * t, "y": 0.1 * t, "psi": 0.05 * np.ones(n),
                               "r": np.zeros(n)}), name=name)


def test_no_heading():
    tr = _small_trial()
    tr = tr.with_data(tr.data.drop(columns=["psi"]))
    with pytest.raises(StateEstimationError, match=r"trial bad: no heading channel 'psi'"):
        estimate_states(tr)


def test_too_few_fixes():
    tr = _small_trial()
    d = tr.data.copy()
    d.loc[5:, ["x", "y"]] = np.nan
    with pytest.raises(StateEstimationError, match=r"trial bad: channels 'x', 'y' have 5 "):
        estimate_states(tr.with_data(d))


def test_stale_fixes_do_not_count():
    tr = _small_trial()
    d = tr.data.copy()
    d.loc[8:, ["x", "y"]] = d.loc[7, ["x", "y"]].to_numpy()  # the receiver stopped at row 7
    with pytest.raises(StateEstimationError, match=r"have 8 position fixes that are not stale"):
        estimate_states(tr.with_data(d))


def test_non_increasing_time():
    tr = _small_trial()
    d = tr.data.copy()
    d.loc[10, "t"] = d.loc[9, "t"]
    with pytest.raises(StateEstimationError, match=r"channel 't' is not strictly increasing "
                                                   r"at row 10"):
        estimate_states(tr.with_data(d))
    d.loc[10, "t"] = np.nan
    with pytest.raises(StateEstimationError, match=r"non-finite time at row 10"):
        estimate_states(tr.with_data(d))


def test_no_positions_and_bad_settings():
    tr = _small_trial()
    with pytest.raises(StateEstimationError, match=r"no position channels"):
        estimate_states(tr.with_data(tr.data.drop(columns=["x", "y"])))
    with pytest.raises(StateEstimationError, match=r"cannot exclude channel 'w'"):
        estimate_states(tr, exclude=("w",))
    with pytest.raises(StateEstimationError, match=r"sigma_pos must be a finite number > 0"):
        estimate_states(tr, sigma_pos=-1.0)
    with pytest.raises(StateEstimationError, match=r"q_r must be a finite number > 0"):
        estimate_states(tr, q_r=float("nan"))
    assert issubclass(StateEstimationError, UsvidError)


# --------------------------------------------------------------------------------------------
# real data
# --------------------------------------------------------------------------------------------

HSVA_RUNS = ("HSVA_CPMC_KVLCC2_Z_10_10_S.dat", "HSVA_CPMC_KVLCC2_Z_20_10_P.dat",
             "HSVA_CPMC_KVLCC2_Z_35_05.dat")


@pytest.mark.parametrize("run", HSVA_RUNS)
def test_hsva_u_against_logged_u(hsva_dir, run):
    """KVLCC2 model zig-zags (20 Hz): u held out of the filter, compared with the logged u."""
    tr = read_trial(hsva_dir / run, "hsva_kvlcc2")
    est = estimate_states(tr, exclude=("u",))
    assert "u" not in est.info["channels_used"]
    u_log = tr["u"]
    err = est["u"] - u_log
    # straight approach, before the rudder moves (first 0.5-2 s): the logged u and the
    # kinematic u agree to 1 mm/s (measured 0.5-1.1 mm/s over the 13 runs)
    t = tr.t
    approach = t < t[np.argmax(np.abs(tr["delta"] - tr["delta"][0]) > math.radians(1.0))]
    assert np.sqrt(np.mean(err[approach] ** 2)) < 0.003
    # in the manoeuvre the logged u falls below the speed the positions show (up to 0.14 m/s
    # at the end of the 10/10): Savitzky-Golay differentiation of the same positions shows the
    # same difference to 0.5 mm/s RMS, so it is in the data, not in the estimator
    pr = prepare(tr.with_data(tr.data.drop(columns=["u"])))
    u_sg = np.interp(t, pr.t, pr["u"])
    assert np.sqrt(np.nanmean((est["u"] - u_sg) ** 2)) < 0.002
    assert np.sqrt(np.mean(err ** 2)) < 0.07  # measured 0.021-0.056 m/s for these runs


def test_twin_thruster_stale_positions(twin_dir):
    """Twin-thruster USV: 10 Hz rows, GNSS (position, heading, speed, course) repeated between
    fixes; speed over ground held out and compared with the estimate."""
    tr = read_trial(twin_dir / "boat1_2_sin.xlsx", "twin_thruster_xlsx")
    est = estimate_states(tr, exclude=("U",))
    stats = est.info["innovations"]
    n_fixes = stats["x"]["updates"]
    assert est.info["stale_fixes"] > 0.3 * len(tr)  # 695 of 1536 rows repeat the fix
    assert n_fixes == len(tr) - est.info["stale_fixes"]
    for ch in ("x", "y", "psi", "cog"):
        # measured 0.6-1.8: no gross inconsistency (a wrong unit or frame gives >> 10)
        assert 0.3 < stats[ch]["nis_mean"] < 3.0, ch
    sog = np.hypot(est["u"], est["v"])
    U = tr["U"]
    ok = np.isfinite(U)
    # the receiver's speed (held out) agrees within a few cm/s (measured 0.039 m/s RMS at
    # speeds of 0.2-1.1 m/s)
    assert np.sqrt(np.mean((sog[ok] - U[ok]) ** 2)) < 0.06
