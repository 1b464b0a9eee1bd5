"""usvid.prep.geodesy (lat/lon -> NED) and usvid.prep.stale (duplicated GNSS fixes)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from usvid.errors import UsvidError
from usvid.prep.geodesy import geodetic_to_ned, to_ned
from usvid.prep.stale import detect_stale, drop_stale, repeats_previous
from usvid.trial import Trial

WGS84_A = 6378137.0
WGS84_F = 1 / 298.257223563


def hand_ned(lat, lon, lat0, lon0):
    """Independent geodetic -> ECEF -> NED (written out here, not pymap3d), height 0."""
    e2 = WGS84_F * (2 - WGS84_F)

    def ecef(la, lo):
        la, lo = np.radians(la), np.radians(lo)
        N = WGS84_A / np.sqrt(1 - e2 * np.sin(la) ** 2)
        return np.array([N * np.cos(la) * np.cos(lo), N * np.cos(la) * np.sin(lo),
                         N * (1 - e2) * np.sin(la)])

    d = ecef(np.asarray(lat), np.asarray(lon)) - ecef(lat0, lon0)[:, None]
    la0, lo0 = np.radians(lat0), np.radians(lon0)
    north = (-np.sin(la0) * np.cos(lo0) * d[0] - np.sin(la0) * np.sin(lo0) * d[1]
             + np.cos(la0) * d[2])
    east = -np.sin(lo0) * d[0] + np.cos(lo0) * d[1]
    return north, east


def test_degree_lengths_at_the_equator():
    # textbook WGS84 values: 1 deg of latitude at the equator 110574.3 m, of longitude 111319.5 m
    n, e, org = geodetic_to_ned(np.array([0.0, 0.001, 0.0]), np.array([0.0, 0.0, 0.001]))
    assert org == (0.0, 0.0)
    assert n[1] == pytest.approx(110.5743, abs=2e-3)  # 1e-3 deg; curvature adds < 1 um
    assert e[2] == pytest.approx(111.3195, abs=2e-3)


def test_matches_independent_ecef_computation():
    rng = np.random.default_rng(3)
    lat = 38.8658 + rng.uniform(-0.01, 0.01, 200)  # +-1.1 km around Dalian
    lon = 121.5344 + rng.uniform(-0.01, 0.01, 200)
    n, e, _ = geodetic_to_ned(lat, lon, (38.8658, 121.5344))
    hn, he = hand_ned(lat, lon, 38.8658, 121.5344)
    # the NED of pymap3d also drops the "down" of the tangent plane: horizontal parts agree to
    # rounding (1e-6 m at 1 km); 1 mm is generous
    np.testing.assert_allclose(n, hn, atol=1e-3)
    np.testing.assert_allclose(e, he, atol=1e-3)


def test_nan_fixes_stay_nan_and_origin_is_first_valid():
    lat = np.array([np.nan, 10.0, 10.001])
    lon = np.array([np.nan, 20.0, 20.0])
    n, e, org = geodetic_to_ned(lat, lon)
    assert org == (10.0, 20.0)
    assert np.isnan(n[0]) and n[1] == 0.0 and n[2] > 100
    with pytest.raises(UsvidError, match="no valid position"):
        geodetic_to_ned(np.array([np.nan]), np.array([np.nan]))
    with pytest.raises(UsvidError, match="latitude/longitude"):
        geodetic_to_ned(np.array([10.0, 95.0]), np.array([20.0, 20.0]))


def test_to_ned_keeps_existing_xy():
    d = pd.DataFrame({"t": [0.0, 1.0], "lat": [10.0, 10.0001], "lon": [20.0, 20.0]})
    out = to_ned(Trial(d))
    assert out.meta["ned_origin"] == {"lat_deg": 10.0, "lon_deg": 20.0}
    assert out["x"][1] == pytest.approx(11.06, abs=0.01)  # 1e-4 deg at 10 deg N
    d["x"] = [5.0, 6.0]
    d["y"] = [0.0, 0.0]
    assert to_ned(Trial(d))["x"][1] == 6.0
    assert to_ned(Trial(d), overwrite=True)["x"][1] == pytest.approx(11.06, abs=0.01)


def test_twin_positions_agree_with_independent_conversion(twin_dir):
    from usvid.io import read_trial
    from usvid.prep import prepare

    tr = read_trial(twin_dir / "boat1_2_circle.xlsx", "twin_thruster_xlsx")
    out = to_ned(tr)
    lat, lon = tr["lat"], tr["lon"]
    hn, he = hand_ned(lat, lon, lat[0], lon[0])
    # acceptance: within 0.05 m (they agree to ~1e-6 m)
    assert np.max(np.abs(out["x"] - hn)) < 0.05
    assert np.max(np.abs(out["y"] - he)) < 0.05
    # and after prepare (stale fixes removed, resampled at 10 Hz) on the fixes that are kept
    p = prepare(tr, rate_hz=10.0)  # the logger's clock jitters around 9.1 Hz: ask for 10 Hz
    assert p.sample_rate == pytest.approx(10.0, rel=1e-3)
    ok = np.isfinite(p["lat"])
    hn, he = hand_ned(p["lat"][ok], p["lon"][ok], lat[0], lon[0])
    assert np.max(np.abs(p["x"][ok] - hn)) < 0.05


# --- stale fixes -------------------------------------------------------------------------------
def _stale_track(every: int = 3, rate: float = 10.0, n: int = 600) -> Trial:
    """1 m/s due north, logged at ``rate`` Hz, the fix updated every ``every`` rows."""
    t = np.arange(n) / rate
    t_fix = t[(np.arange(n) // every) * every]  # the time of the fix each row repeats
    lat0 = 38.0
    north = 1.0 * t_fix
    lat = lat0 + north / 111_000.0
    lon = np.full(n, 121.0)
    psi = np.zeros(n)
    return Trial(pd.DataFrame({"t": t, "lat": lat, "lon": lon, "psi": psi}), name="stale")


def test_stale_fixes_detected_with_rate():
    tr = _stale_track(every=3)
    rep = detect_stale(tr)
    assert rep.group == ("lat", "lon")
    assert rep.n_stale == 400 and rep.n_fixes == 600  # 2 of every 3 rows repeat
    assert rep.rate == pytest.approx(2 / 3)
    np.testing.assert_array_equal(repeats_previous(np.array([1.0, 1.0, np.nan, 1.0, 2.0])),
                                  [False, True, False, True, False])


def test_stale_fixes_are_missing_not_zero_speed():
    from usvid.prep import prepare

    tr = _stale_track(every=3)
    p = prepare(tr, window_s=0.5)
    assert p.meta["stale_fixes"]["rate"] == pytest.approx(2 / 3)
    assert any(f.code == "stale_gnss_fix" for f in p.findings)
    u = p["u"][20:-20]
    # the fixes themselves are exact, so interpolation restores a straight 1 m/s track
    np.testing.assert_allclose(u, 1.0, atol=0.02)
    # without stale handling the staircase (0, 0, 3 m/s per row) leaks through the 0.5-s
    # filter as a ripple of several tenths of a m/s
    raw = prepare(tr, window_s=0.5, drop_stale_fixes=False)["u"][20:-20]
    assert raw.max() - raw.min() > 0.3


def test_follower_channel_blanked_only_on_stale_rows():
    tr = _stale_track(every=2, n=100)
    d = tr.data.copy()
    d["U"] = np.repeat(np.arange(50, dtype=float), 2)  # repeats with the fix
    d["psi"] = np.linspace(0, 1, 100)  # independent sensor: never repeats
    out, rep = drop_stale(Trial(d))
    assert "U" in rep.channels and "psi" not in rep.channels
    assert np.isnan(out["U"][1::2]).all() and np.isfinite(out["U"][0::2]).all()
    assert np.isfinite(out["psi"]).all()


def test_geodetic_to_ned_scalar_fix() -> None:
    # one fix as scalars raised IndexError (0-d array indexed) before the fix
    n, e, org = geodetic_to_ned(54.0, 10.0)
    assert org == (54.0, 10.0) and float(n) == 0.0 and float(e) == 0.0
    n, e, _ = geodetic_to_ned(54.001, 10.0, (54.0, 10.0))
    assert abs(float(n) - 111.4) < 0.5  # 0.001 deg of latitude at 54 N is about 111.4 m
    assert n.shape == ()
