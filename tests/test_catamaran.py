"""Twin-thruster catamaran (the catamaran paper): forces, right-hand side, simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference import reference_run
from usvid.errors import UsvidError
from usvid.models import Catamaran, VesselModel, get_kind
from usvid.models.thrust import TwinThrust
from usvid.sim import Commanded, Turning, simulate

BASE = dict(m11=60.0, m22=90.0, m33=15.0, d11=30.0, d22=120.0, d33=25.0, b=0.6)
KIND = get_kind("catamaran")


def test_tau_signs_and_values():
    p = Catamaran(**BASE, thrust=2.0)  # T = 2 N per command unit
    tu, tr = p.tau(10.0, 6.0)
    assert tu == pytest.approx(32.0)
    assert tr == pytest.approx((20.0 - 12.0) * 0.3)  # more port thrust -> r > 0 (starboard)


def test_rhs_hand_value():
    p = Catamaran(**BASE, thrust=2.0)
    u, v, r = 1.0, 0.1, 0.2
    uu, vv, rr, d = KIND.derivatives(p, [u, v, r], n_port=10.0, n_stbd=6.0)
    assert (uu, vv, rr) == (u, v, r)
    np.testing.assert_allclose(d, [(90 * v * r - 30 * u + 32) / 60,
                                   (-60 * u * r - 120 * v) / 90,
                                   ((60 - 90) * u * v - 25 * r + 2.4) / 15], rtol=1e-14)
    # without commands the thrusters follow the steering angle: cmd +- steer_gain delta
    q = Catamaran(**BASE, thrust=2.0, cmd=8.0, steer_gain=20.0)
    np.testing.assert_allclose(KIND.derivatives(q, [u, v, r], delta=0.1)[3], d, rtol=1e-14)
    with pytest.raises(UsvidError, match="3 columns"):
        KIND.derivatives(p, [u, v])


def test_twin_thrust_code_model_in_kernel_matches_solve_ivp():
    tw = TwinThrust(coeffs=(0.0, 1.5, 0.8), command="code")
    p = Catamaran(**BASE, thrust=tw)
    dt = 0.01
    t = np.arange(3001) * dt
    cp = 80.0 + 20.0 * np.sin(0.2 * t)
    cs = 80.0 - 20.0 * np.sin(0.2 * t)
    res = simulate(VesselModel(p), Commanded(t, n_port=cp, n_stbd=cs), t_end=30.0, dt=dt,
                   u0=1.0)
    ref = reference_run(p, lambda tt: {"n_port": 80 + 20 * np.sin(0.2 * tt),
                                       "n_stbd": 80 - 20 * np.sin(0.2 * tt)},
                        [0, 0, 0, 1.0, 0, 0], res.t[::100])
    for j, name in enumerate(("x", "y", "psi", "u", "v", "r")):
        # the core holds the commands linear between steps (first-order hold), off the sine by
        # up to dt^2/8 |c''| = 1e-5 command units: an O(dt^2) error, 1.1e-6 of x's range here
        # (4x smaller at dt/2). Was 5e-5 for the old zero-order hold's half-step delay; a
        # half-step delay now would exceed 1e-5.
        scale = max(1.0, float(np.max(np.abs(ref[j]))))
        np.testing.assert_allclose(res[name][0, ::100], ref[j], atol=1e-5 * scale)
    np.testing.assert_allclose(res["n_port"][0], cp)


def test_steering_through_rudder_equivalent_and_default_speed():
    p = Catamaran(**BASE, thrust=0.5, cmd=60.0, steer_gain=40.0)
    res = simulate(VesselModel(p), Turning(math.radians(20)), t_end=60.0)
    # default initial speed: straight-line equilibrium 2 k cmd / d11 = 2 * 0.5 * 60 / 30 = 2 m/s
    assert res["u"][0, 0] == pytest.approx(2.0)
    assert res["r"][0, -1] > 0  # positive delta -> more port thrust -> starboard turn
    dn = math.radians(20) * 40.0
    np.testing.assert_allclose(res["n_port"][0, -1], 60.0 + dn)
    np.testing.assert_allclose(res["n_stbd"][0, -1], 60.0 - dn)
    # steady turn: r' = 0 and u' = 0 at the end
    _, _, _, d = KIND.derivatives(p, [res["u"][0, -1], res["v"][0, -1], res["r"][0, -1]],
                                  n_port=60.0 + dn, n_stbd=60.0 - dn)
    np.testing.assert_allclose(d, 0.0, atol=1e-8)


def test_catamaran_validation():
    with pytest.raises(UsvidError, match="parameters.b"):
        Catamaran(**dict(BASE, b=0.0))
