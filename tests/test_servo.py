"""Servo models: their equations and behaviour inside the simulator (the integration core)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from usvid.errors import UsvidError
from usvid.models import (
    FirstOrderServo,
    IdealServo,
    Nomoto1,
    SecondOrderServo,
    VesselModel,
    mu2018_servo,
)
from usvid.sim import Commanded, Turning, simulate
from usvid.trial import Vessel


def _run(servo, logic, t_end, dt=0.01, **kw):
    m = VesselModel(Nomoto1(K=0.5, T=1.0), servo=servo, vessel=Vessel(speed=2.0))
    return simulate(m, logic, t_end=t_end, dt=dt, **kw)


def test_mu2018_servo_from_transfer_function():
    s = mu2018_servo()  # 1.95 / (s^2 + 2.38125 s + 1.95) e^{-s}
    assert s.omega_n == pytest.approx(math.sqrt(1.95))
    assert 2 * s.zeta * s.omega_n == pytest.approx(2.38125)
    assert s.gain == pytest.approx(1.0)
    assert s.delay == 1.0
    assert s.max_angle == pytest.approx(math.radians(35))
    assert s.delay_samples(0.02) == 50


def test_first_order_rate_and_limits_hand_values():
    # the servo equations live in the integration core only: their hand values are checked on
    # simulated angles
    dt = 0.01
    s = FirstOrderServo(T=0.5, max_rate=math.radians(10))
    # (0.1 - 0)/0.5 = 0.2 rad/s, clipped to 10 deg/s = 0.1745 while delta < 0.0127
    d = _run(s, Turning(0.1), t_end=0.05, dt=dt)["delta"][0]
    np.testing.assert_allclose(np.diff(d) / dt, math.radians(10), rtol=1e-12)
    # from 0.05: (0.1 - 0.05)/0.5 = 0.1 rad/s, below the limit: the exponential approach
    res = _run(s, Turning(0.1), t_end=2.0, dt=dt, initial={"delta": 0.05})
    np.testing.assert_allclose(res["delta"][0], 0.1 - 0.05 * np.exp(-res.t / 0.5), atol=1e-9)
    # at the angle limit a rate pushing outwards is zeroed, inwards allowed (at the rate limit)
    lim = s.max_angle
    out = _run(s, Turning(1.0), t_end=0.05, dt=dt, initial={"delta": lim})["delta"][0]
    np.testing.assert_allclose(out, lim, rtol=1e-15)
    inw = _run(s, Turning(-1.0), t_end=0.05, dt=dt, initial={"delta": lim})["delta"][0]
    np.testing.assert_allclose(np.diff(inw) / dt, -math.radians(10), rtol=1e-9)


def test_second_order_equation_hand_values():
    # delta'' = omega_n^2 (gain delta_cmd - delta) - 2 zeta omega_n delta': from delta = 0.1,
    # delta' = 0.3 under a command of 0.2, delta''(0) = 4 (1.2 * 0.2 - 0.1) - 2 * 0.5 * 2 * 0.3
    # = -0.04; the simulated angle follows the equation's exact solution
    s = SecondOrderServo(omega_n=2.0, zeta=0.5, gain=1.2, max_angle=1.0)
    res = _run(s, Turning(0.2), t_end=5.0, dt=0.01, initial={"delta": 0.1, "delta_dot": 0.3})
    sol = solve_ivp(lambda t, z: [z[1], 4 * (1.2 * 0.2 - z[0]) - 2 * z[1]], (0, 5.0),
                    [0.1, 0.3], t_eval=res.t, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(res["delta"][0], sol.y[0], atol=1e-9)
    d0, d1 = res["delta"][0][:2]
    # initial angular acceleration from the first step, 2 (d1 - d0 - 0.3 h)/h^2, off by
    # h/3 times the third derivative (-1.12 rad/s^3): -0.004 rad/s^2
    assert 2 * (d1 - d0 - 0.3 * 0.01) / 0.01**2 == pytest.approx(-0.04, abs=0.005)


@pytest.mark.parametrize(("wn", "zeta"), [(2.0, 0.3), (1.3964, 0.5), (5.0, 0.15)])
def test_second_order_step_overshoot_and_peak_time(wn, zeta):
    s = SecondOrderServo(omega_n=wn, zeta=zeta, max_angle=1.0)
    amp = 0.2
    res = _run(s, Turning(amp), t_end=6.0, dt=0.001)
    d = res["delta"][0]
    i = int(np.argmax(d))
    mp = d[i] / amp - 1
    tp = res.t[i]
    mp_exact = math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    tp_exact = math.pi / (wn * math.sqrt(1 - zeta**2))
    assert mp_exact == pytest.approx(s.overshoot())
    assert tp_exact == pytest.approx(s.peak_time())
    # 1 % (brief); the sampled peak is within dt/2 = 0.0005 s of the true one: < 0.1 % of tp
    assert mp == pytest.approx(mp_exact, rel=0.01)
    assert tp == pytest.approx(tp_exact, rel=0.01)


@pytest.mark.parametrize("delay", [0.0, 0.5, 1.0, 0.13])
def test_second_order_dead_time_to_one_sample(delay):
    dt = 0.02
    s = SecondOrderServo(omega_n=2.0, zeta=0.7, delay=delay)
    t_step = 1.0
    res = _run(s, Turning(0.1, t_start=t_step), t_end=4.0, dt=dt)
    d = res["delta"][0]
    first_moving = int(np.flatnonzero(d > 0)[0])
    # the command changes at sample t_step/dt, the servo input round(delay/dt) samples later, and
    # the angle is nonzero from the next sample on
    expected = round(t_step / dt) + round(delay / dt) + 1
    assert first_moving == expected


def test_first_order_servo_time_constant_and_gainless():
    T = 0.8
    res = _run(FirstOrderServo(T=T), Turning(0.2), t_end=5.0, dt=0.01)
    d = res["delta"][0]
    np.testing.assert_allclose(d, 0.2 * (1 - np.exp(-res.t / T)), atol=1e-8)


def test_rate_limit_ideal_and_first_order():
    rate = math.radians(5)
    for servo in (IdealServo(max_rate=rate), FirstOrderServo(T=0.01, max_rate=rate)):
        res = _run(servo, Turning(math.radians(30)), t_end=8.0, dt=0.01)
        d = res["delta"][0]
        slope = np.diff(d) / 0.01
        assert slope.max() <= rate * (1 + 1e-9)
        # reaches 30 deg after 6 s at 5 deg/s (plus < 0.1 s of first-order settling)
        i = int(np.argmax(d >= math.radians(30) - 1e-3))
        assert res.t[i] == pytest.approx(6.0, abs=0.1)


def test_second_order_rate_limit():
    rate = math.radians(8)
    res = _run(SecondOrderServo(omega_n=5.0, zeta=0.7, max_rate=rate), Turning(0.5), 6.0)
    slope = np.diff(res["delta"][0]) / 0.01
    assert slope.max() <= rate * (1 + 1e-6)


@pytest.mark.parametrize("servo", [IdealServo(), FirstOrderServo(T=0.3),
                                   SecondOrderServo(omega_n=3.0, zeta=0.2)])
def test_angle_limit(servo):
    res = _run(servo, Turning(math.radians(60)), t_end=6.0)
    d = res["delta"][0]
    assert d.max() <= math.radians(35) + 1e-12
    assert d[-1] == pytest.approx(math.radians(35))
    assert res["delta_cmd"][0, -1] == pytest.approx(math.radians(60))  # command kept as given


def test_commanded_series_drives_servo():
    t = np.array([0.0, 1.0, 2.0, 10.0])
    cmd = np.array([0.0, 0.0, 0.2, 0.2])  # ramp between 1 and 2 s
    res = _run(IdealServo(), Commanded(t, delta_cmd=cmd), t_end=3.0, dt=0.01)
    np.testing.assert_allclose(res["delta"][0], np.interp(res.t, t, cmd), atol=1e-12)


def test_bad_servo_parameters():
    with pytest.raises(UsvidError, match="servo.T"):
        FirstOrderServo(T=-1.0)
    with pytest.raises(UsvidError, match="omega_n"):
        SecondOrderServo(omega_n=0.0, zeta=0.5)
    with pytest.raises(UsvidError, match="max_rate"):
        IdealServo(max_rate=0.0)
