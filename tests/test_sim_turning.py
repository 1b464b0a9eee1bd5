"""Turning circles: simulated steady diameter against the Nomoto closed form; the sign
convention of every kind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.models import Catamaran, Nomoto1, Nomoto2, Norrbin, VesselModel, mu2018_threedof
from usvid.sim import Turning, run_turning, simulate
from usvid.trial import Vessel


@pytest.mark.parametrize("delta_deg", [10.0, 35.0, -20.0])
def test_nomoto1_steady_diameter(delta_deg):
    K, T, U = 0.707, 0.332, 5.144
    delta = math.radians(delta_deg)
    m = VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=U))
    res, tm = run_turning(m, delta_deg)
    expected = 2 * U / (K * abs(delta))  # steady r = K delta, radius U / r
    # 0.5 % is the acceptance tolerance; the RK4 trajectory error is ~1e-10 m here.
    assert tm.steady_diameter_m == pytest.approx(expected, rel=0.005)
    assert tm.side == ("starboard" if delta > 0 else "port")
    # geometry straight from the track: the diameter across the last full circle
    last = res.t > res.t[-1] - 2 * math.pi / (K * abs(delta))
    span = np.ptp(res["x"][0][last])
    assert span == pytest.approx(expected, rel=0.005)


def test_turning_batch_and_rudder_step_at_t_start():
    m = VesselModel(Nomoto1(K=np.array([0.5, 0.7]), T=1.0), vessel=Vessel(speed=2.0))
    res = simulate(m, Turning(math.radians(20), t_start=5.0), t_end=120.0)
    assert res["psi"].shape == (2, len(res.t))
    before = res.t < 5.0 - 1e-9
    assert np.all(res["psi"][:, before] == 0.0)
    r_end = res["r"][:, -1]
    np.testing.assert_allclose(r_end, np.array([0.5, 0.7]) * math.radians(20), rtol=1e-9)
    tms = res.turning_metrics()
    assert tms[0].steady_diameter_m > tms[1].steady_diameter_m


@pytest.mark.parametrize(("n1", "n3"), [(1.0, 1.102), (-0.19, 1.102), (0.5, 0.0)])
def test_norrbin_steady_yaw_rate(n1, n3):
    """Steady r solves n1 r + n3 r^3 = K delta (Mu et al. 2018 eq. 36 generalised), n1 < 0
    included."""
    K, T, delta = 0.707, 0.332, math.radians(15)
    p = Norrbin(K=K, T=T, n1=n1, n3=n3)
    m = VesselModel(p, vessel=Vessel(speed=5.0))
    r = simulate(m, Turning(delta), t_end=60.0)["r"][0, -1]
    assert abs(n1 * r + n3 * r**3 - K * delta) <= 1e-6 * K * delta
    assert r == pytest.approx(p.steady_yaw_rate(delta), rel=1e-6)


def test_norrbin_course_unstable_small_rudder_goes_to_outer_branch():
    # n1 < 0: with zero rudder the straight course is unstable and a tiny offset grows into a
    # steady turn at r = sqrt(-n1/n3) (the loop of the spiral curve)
    p = Norrbin(K=0.7, T=0.5, n1=-0.2, n3=1.0)
    m = VesselModel(p, vessel=Vessel(speed=3.0))
    r = simulate(m, Turning(1e-6), t_end=400.0)["r"][0, -1]
    assert r == pytest.approx(math.sqrt(0.2), rel=1e-4)


def test_nomoto2_step_response_matches_partial_fractions():
    K, T1, T2, T3 = 0.5, 4.0, 0.5, 1.0
    m = VesselModel(Nomoto2(K=K, T1=T1, T2=T2, T3=T3), vessel=Vessel(speed=3.0))
    res = simulate(m, Turning(math.radians(10)), t_end=80.0)
    # after 80 s = 20 T1 the transient left is e^-20 ~ 2e-9 relative
    assert res["r"][0, -1] == pytest.approx(K * math.radians(10), rel=1e-7)
    # step response of K (1 + T3 s)/((1 + T1 s)(1 + T2 s)), by partial fractions:
    # r(t)/(K d) = 1 - (T1 - T3)/(T1 - T2) e^{-t/T1} - (T3 - T2)/(T1 - T2) e^{-t/T2}
    t = res.t
    exact = K * math.radians(10) * (1 - (T1 - T3) / (T1 - T2) * np.exp(-t / T1)
                                     - (T3 - T2) / (T1 - T2) * np.exp(-t / T2))
    np.testing.assert_allclose(res["r"][0], exact, atol=1e-8)


def test_nomoto1_step_response_is_exponential():
    K, T = 0.3, 2.0
    m = VesselModel(Nomoto1(K=K, T=T, delta0=0.01), vessel=Vessel(speed=2.0))
    res = simulate(m, Turning(0.1), t_end=10.0)
    exact = K * 0.11 * (1 - np.exp(-res.t / T))  # delta0 adds to the rudder
    np.testing.assert_allclose(res["r"][0], exact, atol=1e-9)  # RK4 at dt/T = 0.01: ~1e-11


# --- sign conventions for every kind (ARCHITECTURE.md) ----------------------------------------
def _models():
    v = Vessel(length=7.0, speed=2.0)
    t3 = mu2018_threedof(thrust=848.1 * 2.0)  # constant thrust holding 2 m/s
    cat = Catamaran(m11=100.0, m22=120.0, m33=30.0, d11=50.0, d22=200.0, d33=60.0, b=1.0,
                    thrust=1.0, cmd=50.0, steer_gain=40.0)
    return [VesselModel(Nomoto1(K=0.5, T=2.0), vessel=v),
            VesselModel(Nomoto2(K=0.5, T1=2.0, T2=0.3, T3=0.5), vessel=v),
            VesselModel(Norrbin(K=0.5, T=2.0, n1=1.0, n3=0.5), vessel=v),
            VesselModel(t3, vessel=v), VesselModel(cat, vessel=v)]


@pytest.mark.parametrize("model", _models(), ids=lambda m: m.kind)
def test_positive_rudder_turns_to_starboard_in_ned(model):
    res = simulate(model, Turning(math.radians(10.0)), t_end=20.0, dt=0.02)
    r, psi, y = res["r"][0], res["psi"][0], res["y"][0]
    assert r[-1] > 0 and psi[-1] > 0  # r and psi clockwise positive
    # heading north at first, turning to starboard: the track bends east (y > 0)
    assert y[-1] > 0
