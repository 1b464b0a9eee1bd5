"""Virtual trials: multi-rate layout, noise levels, seeding, and metrics that survive the noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.errors import SimulationError, UsvidError
from usvid.manoeuvres.metrics import turning_metrics, zigzag_metrics
from usvid.models import Nomoto1
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo
from usvid.sim import Turning, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial, virtual_trial_uniform
from usvid.trial import Vessel

MODEL = VesselModel(Nomoto1(K=0.5, T=2.0), servo=IdealServo(),
                    vessel=Vessel(length=5.0, speed=2.0))


@pytest.fixture(scope="module")
def turn():
    return simulate(MODEL, Turning(delta=math.radians(20)), t_end=60.0, dt=0.02)


@pytest.fixture(scope="module")
def zig():
    return simulate(MODEL, ZigZag(delta_amp=math.radians(10), psi_switch=math.radians(10)),
                    t_end=60.0, dt=0.02)


def test_multirate_layout(turn):
    s = SensorModel(jitter_s=0.0)
    tr = virtual_trial(turn, s, seed=1)
    d = tr.data
    t = tr.t
    assert np.all(np.diff(t) > 0)
    # 60 s at 5 / 10 / 50 Hz, both ends included
    assert np.isfinite(d["x"]).sum() == 301 and np.isfinite(d["y"]).sum() == 301
    assert np.isfinite(d["psi"]).sum() == 601
    assert np.isfinite(d["r"]).sum() == 3001 and np.isfinite(d["delta"]).sum() == 3001
    assert len(tr) == 3001  # the 50 Hz stamps contain the others (no jitter)
    assert np.all(np.isfinite(d.loc[np.isfinite(d["x"]), "y"]))  # x, y share their stamps
    assert tr.vessel.length == 5.0
    assert tr.meta["virtual"] and tr.meta["truth"].kind == "nomoto1"
    assert tr.meta["truth_file"]["parameters"]["K"] == 0.5
    # heading wrapped to (-pi, pi] like a compass
    assert np.nanmax(d["psi"]) <= math.pi and np.nanmin(d["psi"]) > -math.pi


def test_noise_levels_and_bias(turn):
    s = SensorModel(jitter_s=0.0, gyro_bias_deg_s=0.5, wrap_heading=False)
    tr = virtual_trial(turn, s, seed=2)
    truth = turn.to_trial()
    d = tr.data
    for ch, sigma in (("x", 0.5), ("psi", math.radians(0.5)), ("delta", math.radians(0.2))):
        sel = np.isfinite(d[ch].to_numpy())
        err = d[ch].to_numpy()[sel] - np.interp(tr.t[sel], truth.t, truth[ch])
        # n >= 301 samples: the sample std is within ~4 / sqrt(2 n) = 16 % of sigma at 4 sigma
        assert np.std(err) == pytest.approx(sigma, rel=0.16)
        assert abs(np.mean(err)) < 4 * sigma / math.sqrt(sel.sum())
    sel = np.isfinite(d["r"].to_numpy())
    err = d["r"].to_numpy()[sel] - np.interp(tr.t[sel], truth.t, truth["r"])
    # 3001 samples with 0.2 deg/s noise: mean within 4 * 0.2 / sqrt(3001) = 0.015 deg/s of bias
    assert math.degrees(np.mean(err)) == pytest.approx(0.5, abs=0.015)


def test_seeded_and_jittered(turn):
    a = virtual_trial(turn, seed=5)
    b = virtual_trial(turn, seed=5)
    c = virtual_trial(turn, seed=6)
    assert a.data.equals(b.data)
    assert not np.allclose(a.data["x"].dropna().to_numpy(), c.data["x"].dropna().to_numpy())
    # default 2 ms jitter: GNSS stamps scatter around the 0.2 s grid, never by more than 0.08 s
    tx = a.t[np.isfinite(a.data["x"].to_numpy())]
    dev = tx - 0.2 * np.round(tx / 0.2)
    assert 0 < np.std(dev) < 0.004 and np.max(np.abs(dev)) <= 0.08
    assert not a.is_uniform
    # adding a sensor group does not change another group's noise (independent streams)
    s2 = SensorModel(gps_sigma_m=0.0)
    d = virtual_trial(turn, s2, seed=5)
    np.testing.assert_array_equal(a.data["r"].dropna().to_numpy(),
                                  d.data["r"].dropna().to_numpy())


def test_uniform_convenience(turn):
    tr = virtual_trial_uniform(turn, seed=3, rate_hz=10.0)
    assert tr.is_uniform and tr.sample_rate == pytest.approx(10.0)
    assert not tr.data.isna().any().any()
    assert set(tr.channels) >= {"x", "y", "psi", "r", "delta", "delta_cmd", "U"}


def test_perfect_sensors_reproduce_truth(turn):
    tr = virtual_trial(turn, SensorModel.perfect(rate_hz=50.0))
    truth = turn.to_trial()
    np.testing.assert_allclose(tr["x"], truth["x"], atol=1e-9)
    np.testing.assert_allclose(tr["psi"], truth["psi"], atol=1e-12)


def test_turning_metrics_survive_sensor_noise(turn):
    true_m = turn.turning_metrics()[0]
    tr = virtual_trial(turn, SensorModel(), seed=11)
    d = tr.data
    g = np.isfinite(d["x"].to_numpy())
    h = np.isfinite(d["psi"].to_numpy())
    # positions at 5 Hz with 0.5 m noise; heading at 10 Hz interpolated to the GNSS stamps
    psi = np.interp(tr.t[g], tr.t[h], np.unwrap(d["psi"].to_numpy()[h]))
    m = turning_metrics(tr.t[g], d["x"].to_numpy()[g], d["y"].to_numpy()[g], psi,
                        t_execute=0.0)
    # a circle fit over ~100 noisy fixes (0.5 m): radius error ~0.5/sqrt(100) = 0.05 m; advance
    # and transfer are single interpolated fixes: +-0.5 m noise, 4 sigma = 2 m
    assert m.steady_diameter_m == pytest.approx(true_m.steady_diameter_m, abs=0.3)
    assert m.advance_m == pytest.approx(true_m.advance_m, abs=2.0)
    assert m.tactical_diameter_m == pytest.approx(true_m.tactical_diameter_m, abs=2.0)
    assert m.steady_yaw_rate_rad_s == pytest.approx(true_m.steady_yaw_rate_rad_s, rel=0.01)


def test_zigzag_metrics_survive_sensor_noise(zig):
    true_m = zig.zigzag_metrics()[0]
    tr = virtual_trial(zig, SensorModel(), seed=4)
    d = tr.data
    h = np.isfinite(d["psi"].to_numpy())
    m = zigzag_metrics(tr.t[h], np.unwrap(d["psi"].to_numpy()[h]),
                       np.interp(tr.t[h], tr.t[np.isfinite(d["delta"])],
                                 d["delta"].dropna().to_numpy()),
                       psi_switch=math.radians(10))
    # heading noise 0.5 deg: a peak read from the largest noisy sample is biased up by about
    # 1-2 sigma; 1.5 deg bounds it. Times: crossings shift by noise / r ~ 0.5 deg / 10 deg/s
    assert len(m.overshoot_deg) >= 3
    assert m.overshoot_deg[:3] == pytest.approx(true_m.overshoot_deg[:3], abs=1.5)
    assert m.initial_turning_time_s == pytest.approx(true_m.initial_turning_time_s, abs=0.3)
    assert m.period_s == pytest.approx(true_m.period_s, abs=0.5)


def test_bad_sensor_settings(turn):
    with pytest.raises(SimulationError, match="gps_rate_hz"):
        SensorModel(gps_rate_hz=0)
    with pytest.raises(SimulationError, match="heading_sigma_deg"):
        SensorModel(heading_sigma_deg=-1)
    with pytest.raises(SimulationError, match="dropout"):
        SensorModel(dropout=1.0)
    with pytest.raises(UsvidError, match="out of range"):
        virtual_trial(turn, i=3)


def test_dropout_and_batch():
    res = simulate(VesselModel(Nomoto1(K=np.array([0.4, 0.6]), T=2.0),
                               vessel=Vessel(length=5.0, speed=2.0)),
                   Turning(delta=math.radians(20)), t_end=20.0)
    tr = virtual_trial(res, SensorModel(dropout=0.2, jitter_s=0.0), seed=1, i=1)
    assert tr.meta["truth"].dynamics.K == 0.6  # the run's member of the batch
    n_r = np.isfinite(tr.data["r"]).sum()
    # 1001 gyro stamps, 20 % lost: binomial std sqrt(1001 * 0.16) = 12.7; 4 sigma
    assert abs(n_r - 0.8 * 1001) < 51
