"""Manoeuvre metrics on hand-made trajectories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.manoeuvres.detect import rudder_amplitude
from usvid.manoeuvres.metrics import (
    fit_circle,
    parabolic_peak,
    turning_metrics,
    zigzag_metrics,
)

# --------------------------------------------------------------------------------------------
# a synthetic zig-zag: straight approach, then psi = A sin(w t); known peaks and crossings
# --------------------------------------------------------------------------------------------
A = math.radians(20.0)  # heading amplitude
SW = math.radians(10.0)  # switching heading
PER = 20.0  # s
W = 2 * math.pi / PER
DT = 0.3  # s, chosen so that the peaks (t = 5, 15, 25 s) fall between samples


def _zigzag(sign: float = 1.0, dt: float = DT):
    t = np.round(np.arange(-3.0, 62.0, dt), 10)
    psi = np.where(t > 0, A * np.sin(W * t), 0.0)
    # rudder: +10 deg from the first execute at t = 0, reversed at each switching crossing
    t1 = math.asin(SW / A) / W
    delta = np.where(t > 0, -SW * np.sign(np.sin(W * (t - t1))), 0.0)
    return t, sign * psi, sign * delta


def test_synthetic_zigzag_known_values():
    t, psi, delta = _zigzag()
    m = zigzag_metrics(t, psi, delta, psi_switch=SW)
    t1 = math.asin(SW / A) / W  # first crossing of +10 deg
    # sine: every overshoot is A - psi_switch = 10 deg; parabolic interpolation of a sine peak
    # sampled at w*dt = 0.094 rad errs by ~A (w dt)^4 / 24 ~ 1e-4 deg; the bare sample max would
    # err by up to A (1 - cos(w dt / 2)) = 0.022 deg, so 5e-3 deg proves the interpolation
    assert len(m.overshoot_deg) >= 5
    assert m.overshoot_deg == pytest.approx([10.0] * len(m.overshoot_deg), abs=5e-3)
    # crossings are linearly interpolated: error <= A (w dt)^2 / 8 in heading -> < 2e-3 s
    assert m.initial_turning_time_s == pytest.approx(t1, abs=5e-3)
    assert m.period_s == pytest.approx(PER, abs=5e-3)
    assert m.time_to_check_yaw_s == pytest.approx(PER / 4 - t1, abs=5e-3)
    assert m.time_to_check_yaw_all_s[1] == pytest.approx(PER / 4 - t1, abs=5e-3)
    assert m.first_side == "starboard"
    assert m.execute_time_s == 0.0
    assert m.psi_switch_deg == pytest.approx(10.0)
    d = m.to_dict()
    assert list(d)[:4] == [
        "overshoot_deg", "period_s", "initial_turning_time_s", "time_to_check_yaw_s"]
    assert "time_to_check_yaw_all_s" in d


def test_zigzag_port_first_is_mirror():
    t, psi, delta = _zigzag(-1.0)
    m = zigzag_metrics(t, psi, delta)  # psi_switch defaults to the rudder amplitude (10 deg)
    assert m.first_side == "port"
    assert m.overshoot_deg[0] == pytest.approx(10.0, abs=5e-3)
    assert m.delta_amp_deg == pytest.approx(10.0)


def test_zigzag_growing_overshoots_first_first():
    # different amplitudes per half cycle: 15 deg, then 25 deg, then 30 deg -> 5, 15, 20 deg
    t = np.arange(0.0, 30.0, 0.01)
    amps = np.where(t < 10, 15.0, np.where(t < 20, 25.0, 30.0))
    psi = np.radians(amps * np.sin(2 * math.pi * t / 20.0))
    # continuity is irrelevant for the peaks at t = 5, 15, 25 s
    m = zigzag_metrics(t, psi, psi_switch=SW, t_execute=0.0, first=1)
    assert m.overshoot_deg == pytest.approx([5.0, 15.0, 20.0], abs=1e-3)


def test_zigzag_short_record_gives_nan_not_crash():
    t, psi, delta = _zigzag()
    keep = t < 4.0  # heading still rising: first crossing seen, no extremum yet
    m = zigzag_metrics(t[keep], psi[keep], delta[keep], psi_switch=SW)
    assert m.overshoot_deg == []
    assert math.isnan(m.period_s)
    assert math.isnan(m.time_to_check_yaw_s)
    assert not math.isnan(m.initial_turning_time_s)


def test_zigzag_nan_gaps_are_skipped():
    t, psi, delta = _zigzag()
    psi = psi.copy()
    psi[::7] = np.nan  # multi-rate style gaps
    m = zigzag_metrics(t, psi, delta, psi_switch=SW)
    # the peak at t = 5 s is still bracketed by valid samples (dt up to 0.6 s): parabola error
    # ~A (w*0.6)^4/24 ~ 1e-3 deg
    assert m.overshoot_deg[0] == pytest.approx(10.0, abs=1e-2)


def test_zigzag_bad_input():
    with pytest.raises(UsvidError, match="psi_switch"):
        zigzag_metrics([0, 1, 2], [0, 0.1, 0.2])
    with pytest.raises(UsvidError, match="samples"):
        zigzag_metrics([0, 1, 2], [0, 0.1], psi_switch=0.1)
    with pytest.raises(UsvidError, match="increasing"):
        zigzag_metrics([0, 2, 1], [0, 0.1, 0.2], psi_switch=0.1)


def test_initial_turning_distance_from_track():
    t, psi, delta = _zigzag()
    U = 2.0
    x = U * t  # straight line at 2 m/s: track length = U * time
    m = zigzag_metrics(t, psi, delta, psi_switch=SW, x=x, y=np.zeros_like(x))
    assert m.initial_turning_distance_m == pytest.approx(U * m.initial_turning_time_s, rel=1e-9)


def test_parabolic_peak_exact_for_parabola():
    t = np.array([0.0, 0.7, 1.5])
    y = -((t - 0.9) ** 2) + 3.0
    tp, yp = parabolic_peak(t, y, 1)
    assert tp == pytest.approx(0.9, abs=1e-12)
    assert yp == pytest.approx(3.0, abs=1e-12)


# --------------------------------------------------------------------------------------------
# turning circle: exact circle after a straight approach
# --------------------------------------------------------------------------------------------
R = 50.0
U = 5.0


def _circle(side: float = 1.0, psi0_deg: float = 0.0, dt: float = 0.33):
    w = U / R
    t = np.round(np.arange(-30 * dt, 200.0, dt), 10)  # has a sample at t = 0
    tc = np.clip(t, 0, None)
    # body frame along/across, then rotate by psi0
    along = np.where(t < 0, U * t, R * np.sin(w * tc))
    across = np.where(t < 0, 0.0, R * (1 - np.cos(w * tc)))
    psi_rel = np.where(t < 0, 0.0, w * tc)
    p0 = math.radians(psi0_deg)
    x = along * math.cos(p0) - side * across * math.sin(p0)
    y = along * math.sin(p0) + side * across * math.cos(p0)
    psi = p0 + side * psi_rel
    delta = np.where(t > 0, side * math.radians(35), 0.0)  # rudder order at t = 0
    r = np.where(t >= 0, side * w, 0.0)
    return t, x, y, psi, delta, r


@pytest.mark.parametrize("side,psi0", [(1.0, 0.0), (-1.0, 0.0), (1.0, 37.0), (-1.0, -120.0)])
def test_exact_circle(side, psi0):
    t, x, y, psi, delta, r = _circle(side, psi0)
    m = turning_metrics(t, x, y, psi, delta=delta, U=np.full_like(t, U), r=r)
    # the 90/180 deg instants fall between samples; linear interpolation of a circle arc errs by
    # at most the chord sag R (w dt)^2 / 8 = 6.8e-3 m (nearest-sample rounding: R w dt / 2 = 0.8 m)
    assert m.advance_m == pytest.approx(R, abs=1e-2)
    assert m.transfer_m == pytest.approx(R, abs=1e-2)
    assert m.tactical_diameter_m == pytest.approx(2 * R, abs=1e-2)
    assert m.steady_diameter_m == pytest.approx(2 * R, rel=1e-6)  # circle fit on exact points
    assert m.steady_yaw_rate_rad_s == pytest.approx(U / R, rel=1e-9)
    assert m.steady_speed_m_s == pytest.approx(U, rel=1e-9)
    assert m.side == ("starboard" if side > 0 else "port")
    assert m.execute_time_s == 0.0
    assert m.steady_diameter_method == "circle_fit"


def test_circle_without_U_and_r():
    t, x, y, psi, delta, r = _circle(1.0)
    m = turning_metrics(t, x, y, psi, t_execute=0.0)
    # path speed from the chords underestimates U by (w dt)^2/24 ~ 1e-5 relative
    assert m.steady_speed_m_s == pytest.approx(U, rel=1e-4)
    assert m.steady_yaw_rate_rad_s == pytest.approx(U / R, rel=1e-9)
    assert list(m.to_dict())[:6] == [
        "advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m",
        "steady_yaw_rate_rad_s", "steady_speed_m_s"]


def test_short_turn_uses_2U_over_r_and_nan_tactical():
    t, x, y, psi, delta, r = _circle(1.0)
    keep = t < 0.4 * math.pi * R / U  # heading change 72 deg only
    m = turning_metrics(t[keep], x[keep], y[keep], psi[keep], t_execute=0.0,
                        U=np.full(keep.sum(), U), r=r[keep])
    assert math.isnan(m.advance_m) and math.isnan(m.tactical_diameter_m)
    assert m.steady_diameter_method == "2U/r"
    assert m.steady_diameter_m == pytest.approx(2 * R, rel=1e-6)


def test_circle_fit_noisy_points():
    rng = np.random.default_rng(3)
    a = np.linspace(0, 2 * math.pi, 400)
    x = 10 + 30 * np.cos(a) + rng.normal(0, 0.5, a.size)
    y = -4 + 30 * np.sin(a) + rng.normal(0, 0.5, a.size)
    xc, yc, rad = fit_circle(x, y)
    # 400 points with 0.5 m noise: radius standard error ~0.5/sqrt(400) = 0.025 m; 4 sigma
    assert rad == pytest.approx(30.0, abs=0.1)
    assert (xc, yc) == pytest.approx((10.0, -4.0), abs=0.15)


def test_metrics_nan_inputs_raise_usvid_error_or_nan():
    t = np.arange(5.0)
    # before the fix: numpy ValueError (np.interp on an empty array)
    with pytest.raises(UsvidError, match="with a heading"):
        zigzag_metrics(t, np.full(5, np.nan), np.array([0.0, 0.0, 0.1, 0.1, 0.1]))
    assert math.isnan(rudder_amplitude(np.array([]), np.array([]), 0.0))
    # before the fix: LinAlgError (SVD did not converge)
    with pytest.raises(UsvidError, match="3 finite points"):
        fit_circle(np.full(4, np.nan), np.full(4, np.nan))
    # NaN points are left out of the fit: unit circle plus one NaN point
    a = np.linspace(0.0, 3.0, 7)
    x = np.r_[np.cos(a), np.nan]
    y = np.r_[np.sin(a), 0.5]
    xc, yc, r = fit_circle(x, y)
    assert abs(xc) < 1e-9 and abs(yc) < 1e-9 and abs(r - 1.0) < 1e-9  # exact points: exact fit


def test_roll_metrics_only_with_a_roll_angle():
    """max_heel_deg is the largest |phi| after the execute, steady_heel_deg the mean phi over
    the steady turn (the last 360 deg); both absent from to_dict without phi."""
    t, x, y, psi, delta, r = _circle(1.0)
    # heel to port settling on -3 deg in the turn, a -5 deg first swing at t = 10 s, and a -20
    # deg roll before the execute that must not count
    phi = np.radians(np.where(t < 0, -20.0, -3.0 * (1 - np.exp(-t / 2.0)))
                     - 2.0 * np.exp(-((t - 10.0) / 1.5) ** 2))
    m = turning_metrics(t, x, y, psi, delta=delta, U=np.full_like(t, U), r=r, phi=phi)
    assert m.max_heel_deg == pytest.approx(float(np.degrees(np.max(np.abs(phi[t >= 0])))),
                                           rel=1e-12)
    assert 4.9 < m.max_heel_deg < 5.1
    # the steady window (last 360 deg, t > 137 s) sees -3 deg to 1e-12
    assert m.steady_heel_deg == pytest.approx(-3.0, abs=1e-9)
    assert {"max_heel_deg", "steady_heel_deg"} <= set(m.to_dict())
    m0 = turning_metrics(t, x, y, psi, delta=delta, U=np.full_like(t, U), r=r)
    assert m0.max_heel_deg is None and "max_heel_deg" not in m0.to_dict()
    t, psi, delta = _zigzag()
    phi = 0.1 * np.sin(t)
    z = zigzag_metrics(t, psi, delta, psi_switch=SW, phi=phi)
    assert z.max_heel_deg == pytest.approx(math.degrees(0.1), rel=1e-3)  # sampled sine peak
    assert "max_heel_deg" not in zigzag_metrics(t, psi, delta, psi_switch=SW).to_dict()
