"""usvid.prep.prepare: from a raw, multi-rate, geodetic log to a uniform NED trial with u, v, r."""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
import pymap3d
import pytest

from usvid.errors import UsvidError
from usvid.prep import prepare
from usvid.prep.kinematics import body_to_earth, body_velocity_from_cog, earth_to_body
from usvid.trial import Trial

U0, V0, R0 = 2.0, -0.3, 0.05  # body velocities [m/s] and yaw rate [rad/s] of a steady turn


def steady_turn(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact positions [m] and heading [rad] of a steady turn with constant u, v, r.

    psi = r t; (x' + i y') = (u + i v) e^{i psi}  =>  x + i y = (u + i v)(e^{i r t} - 1)/(i r).
    """
    psi = R0 * t
    z = (U0 + 1j * V0) * (np.exp(1j * psi) - 1) / (1j * R0)
    return z.real, z.imag, psi


def test_rotation_hand_values():
    # heading east (psi = 90 deg): moving north is moving to port (v = -1)
    u, v = earth_to_body(np.array(1.0), np.array(0.0), np.array(np.pi / 2))
    assert u == pytest.approx(0.0, abs=1e-15) and v == pytest.approx(-1.0)
    xd, yd = body_to_earth(np.array(1.0), np.array(0.5), np.array(0.3))
    u2, v2 = earth_to_body(xd, yd, np.array(0.3))
    assert (u2, v2) == (pytest.approx(1.0), pytest.approx(0.5))
    # course 10 deg right of the heading at 2 m/s: drift to starboard
    u3, v3 = body_velocity_from_cog(2.0, np.radians(40.0), np.radians(30.0))
    assert u3 == pytest.approx(2 * np.cos(np.radians(10))) and v3 == pytest.approx(
        2 * np.sin(np.radians(10)))


def test_recovers_u_v_r_from_noisy_positions_and_heading():
    rng = np.random.default_rng(7)
    dt = 0.1
    t = np.arange(0, 120, dt)
    x, y, psi = steady_turn(t)
    # RTK-grade positions (1 cm) and a 0.1-deg compass
    x = x + rng.normal(0, 0.01, t.size)
    y = y + rng.normal(0, 0.01, t.size)
    psi_m = np.angle(np.exp(1j * (psi + rng.normal(0, np.radians(0.1), t.size))))  # wrapped
    tr = Trial(pd.DataFrame({"t": t, "x": x, "y": y, "psi": psi_m}))
    p = prepare(tr, window_s=2.0)
    assert {"u", "v", "r", "U", "u_dot", "v_dot", "r_dot"} <= set(p.channels)
    assert set(p.derived) >= {"u", "v", "r", "U"}
    np.testing.assert_allclose(p["psi"], psi, atol=np.radians(0.5))  # unwrapped again
    core = slice(20, -20)
    # noise gain of a 21-sample cubic SG derivative at 0.1 s is 0.908 /s (sqrt of the sum of
    # squared coefficients): 1-cm position noise -> 0.009 m/s, plus U x 0.0017 rad heading noise
    # in the rotation -> 0.0035 m/s; together ~0.01 m/s, 0.05 m/s is 5 sigma. Yaw rate:
    # 0.0017 rad x 0.908 /s = 0.0016 rad/s, 0.008 rad/s is 5 sigma
    np.testing.assert_allclose(p["u"][core], U0, atol=0.05)
    np.testing.assert_allclose(p["v"][core], V0, atol=0.05)
    np.testing.assert_allclose(p["r"][core], R0, atol=0.008)
    # bias check: the means are far tighter (1160 samples, correlated over 21)
    assert np.mean(p["v"][core]) == pytest.approx(V0, abs=0.005)
    assert np.nanmean(p["U"][core]) == pytest.approx(np.hypot(U0, V0), abs=0.005)


def test_multirate_geodetic_log():
    """GNSS at 5 Hz (every fix logged twice: stale), compass at 10 Hz, union of stamps."""
    dt = 0.1
    t_c = np.arange(0, 90, dt)
    t_g = np.arange(0.05, 90, 0.1)  # logger rows for GNSS, offset from the compass clock
    x, y, _ = steady_turn(np.floor(t_g / 0.2) * 0.2)  # fix updated every 0.2 s, repeated
    lat0, lon0 = 54.3, 10.1
    lat, lon, _ = pymap3d.ned2geodetic(x, y, 0.0, lat0, lon0, 0.0)
    t = np.union1d(t_c, t_g)
    df = pd.DataFrame({"t": t})
    df["psi"] = np.interp(t, t_c, R0 * t_c)
    df.loc[~np.isin(t, t_c), "psi"] = np.nan
    g = np.isin(t, t_g)
    df["lat"] = np.where(g, np.interp(t, t_g, lat), np.nan)
    df["lon"] = np.where(g, np.interp(t, t_g, lon), np.nan)
    df.loc[g, "lat"] = lat
    df.loc[g, "lon"] = lon
    p = prepare(Trial(df), rate_hz=10.0, window_s=1.0)
    assert p.sample_rate == pytest.approx(10.0)
    assert p.meta["stale_fixes"]["rate"] == pytest.approx(0.5, abs=0.01)
    assert p.meta["ned_origin"]["lat_deg"] == pytest.approx(lat0)
    core = slice(30, -30)
    # fixes are exact; the stamps are 0.05 s late (they are the row times of repeated fixes, the
    # first row of each fix is 0.05 s after the fix): u is still exact for a steady turn and v is
    # off by at most r * U * 0.05 s ~ 0.005 m/s
    np.testing.assert_allclose(p["u"][core], U0, atol=0.01)
    np.testing.assert_allclose(p["v"][core], V0, atol=0.01)
    np.testing.assert_allclose(p["r"][core], R0, atol=1e-6)


def test_time_reversals_sorted_and_reported():
    t = np.array([0.0, 0.1, 0.3, 0.2, 0.4, 0.4, 0.5, 0.6])
    tr = Trial(pd.DataFrame({"t": t, "psi": t * 0.1}))
    p = prepare(tr, rate_hz=10.0)
    codes = {f.code: f.count for f in p.findings}
    assert codes["time_reversal"] == 1 and codes["time_duplicate"] == 1
    np.testing.assert_allclose(p.t, np.arange(7) * 0.1, atol=1e-12)
    with pytest.raises(UsvidError, match="fewer than three"):
        prepare(Trial(pd.DataFrame({"t": [0.0, 1.0], "psi": [0.0, 0.1]})))


def test_one_hour_50hz_prepares_in_seconds():
    rng = np.random.default_rng(0)
    dt = 0.02
    t = np.arange(0, 3600, dt)  # 180 000 rows
    x, y, psi = steady_turn(t)
    df = pd.DataFrame({"t": t, "x": x + rng.normal(0, 0.01, t.size),
                       "y": y + rng.normal(0, 0.01, t.size), "psi": psi,
                       "delta": rng.normal(0, 0.1, t.size), "n": np.full(t.size, 10.0)})
    df.loc[rng.choice(t.size, 2000, replace=False), "x"] = np.nan  # dropouts -> resampling
    t0 = time.perf_counter()
    p = prepare(Trial(df))
    elapsed = time.perf_counter() - t0
    assert len(p) == t.size
    # about 1 s on one core; 10 s leaves room for a machine shared with other jobs
    assert elapsed < 10.0, f"prepare took {elapsed:.1f} s"


def test_nmea0183_round_trip_prepares(tmp_path):
    """A multi-rate NMEA log (GNSS 5 Hz, heading 10 Hz) read by usvid.io, then prepared."""
    from usvid.io import read_trial, write_nmea0183

    t = np.round(np.arange(0, 60, 0.1), 6)
    x, y, psi = steady_turn(t)
    lat, lon, _ = pymap3d.ned2geodetic(x, y, 0.0, 59.4, 10.5, 0.0)
    gnss = (np.round(t * 10) % 2) == 0  # every other row: 5 Hz
    df = pd.DataFrame({"t": t, "psi": np.angle(np.exp(1j * psi)),
                       "lat": np.where(gnss, lat, np.nan), "lon": np.where(gnss, lon, np.nan)})
    path = write_nmea0183(Trial(df), tmp_path / "log.nmea")
    raw = read_trial(path)
    # the reader gives the union of stamps: heading rows without a fix exist
    assert (np.isfinite(raw["psi"]) & np.isnan(raw["lat"])).sum() >= 250
    p = prepare(raw, rate_hz=10.0)
    assert p.sample_rate == pytest.approx(10.0)
    core = slice(30, -30)
    # positions quantised to 1e-6 arc-minute (< 2 mm) at 5 Hz over a 1-s window: ~5 mm/s;
    # heading to 1e-3 deg
    np.testing.assert_allclose(p["u"][core], U0, atol=0.02)
    np.testing.assert_allclose(p["v"][core], V0, atol=0.02)
    np.testing.assert_allclose(p["r"][core], R0, atol=1e-3)


def test_prepare_counts_nan_time_as_rejected_not_as_reversal() -> None:
    n = 50
    t = np.arange(n) * 0.1
    t[10] = np.nan  # one row without a time, no time reversal at all
    tr = Trial(data=pd.DataFrame({"t": t, "psi": np.linspace(0.0, 1.0, n)}), name="nan_t")
    out = prepare(tr)
    # before the fix the NaN time was reported as a "time stamp earlier than its predecessor"
    assert not [f for f in out.findings if f.code == "time_reversal"]
    assert out.rejected.get("nan_time") == 1
