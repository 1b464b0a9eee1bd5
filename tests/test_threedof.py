"""3-DOF vector-thruster model (Mu et al. 2018 eq. 13-17, 37) and its simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference import reference_run
from usvid.errors import UsvidError
from usvid.models import (
    MU2018_EQ37,
    IdealServo,
    ThreeDOF,
    VesselModel,
    get_kind,
    mu2018_servo,
    mu2018_threedof,
)
from usvid.models.thrust import PodThrust, Propeller
from usvid.sim import Commanded, Turning, ZigZag, simulate
from usvid.trial import Vessel

KIND = get_kind("threedof")


def _accelerations(p: ThreeDOF, nu, tau) -> np.ndarray:
    """(u', v', r') of the right-hand side under the force (tau_u, tau_v, tau_r) [N, N, N m],
    made by a constant thrust T at the angle delta: tau = (T cos delta, -T sin delta,
    x_l T sin delta) (tau_v only with ``sway_force``)."""
    tu, tv, tr = tau
    T = math.hypot(tu, tr / p.x_l)
    delta = math.atan2(tr / p.x_l, tu)
    if p.sway_force:
        assert -T * math.sin(delta) == pytest.approx(tv)
    return KIND.derivatives(p.replace(thrust=T), nu, delta=delta)[3]


def test_mu2018_eq37_is_consistent_with_eq17():
    """Reading of the printed eq. 37 coefficients as the eq. 17 ratios (signs restored)."""
    c = MU2018_EQ37
    m11 = 1 / c["a_tau"]
    m22 = c["a_vr"] * m11
    m33 = 1 / c["c_tau"]
    assert -m11 / m22 == pytest.approx(c["b_ur"], rel=1e-5)  # 0.938753 = m11/m22
    assert (m11 - m22) / m33 == pytest.approx(c["c_uv"], rel=1e-3)  # 0.041187 = (m22-m11)/m33
    model = mu2018_threedof()
    assert model.m11 == pytest.approx(2652.52, rel=1e-5)
    assert model.d11 / model.m11 == pytest.approx(0.3197455)
    assert model.d22 / model.m22 == pytest.approx(3.5)
    assert model.d33 / model.m33 == pytest.approx(5.407752)
    back = model.regression_coefficients()
    for k in ("a_vr", "a_u", "a_tau", "b_v", "c_r", "c_tau"):
        assert back[k] == pytest.approx(c[k], rel=1e-12)


def test_from_regression_rejects_inconsistent_coefficients():
    bad = dict(MU2018_EQ37, b_ur=-0.5)
    with pytest.raises(UsvidError, match="b_ur"):
        ThreeDOF.from_regression(**bad, x_l=3.5)
    m = ThreeDOF.from_regression(**bad, x_l=3.5, strict=False)
    assert m.regression_coefficients()["b_ur"] == pytest.approx(MU2018_EQ37["b_ur"], rel=1e-5)


def test_rhs_reduces_to_eq17():
    p = ThreeDOF(m11=100.0, m22=150.0, m33=40.0, d11=20.0, d22=60.0, d33=30.0, x_l=1.0)
    u, v, r = 2.0, 0.1, 0.2
    out = _accelerations(p, [u, v, r], (50.0, 0.0, 5.0))
    np.testing.assert_allclose(out, [(150 * v * r - 20 * u + 50) / 100,
                                     (-100 * u * r - 60 * v) / 150,
                                     ((100 - 150) * u * v - 30 * r + 5) / 40], rtol=1e-12)
    # the body velocities the kinematics integrate are the states
    assert KIND.derivatives(p.replace(thrust=1.0), [u, v, r])[:3] == (u, v, r)


def test_rhs_general_coupling_solves_m_nu_dot():
    p = ThreeDOF(m11=100.0, m22=150.0, m33=40.0, d11=20.0, d22=60.0, d33=30.0, x_l=1.25,
                 m23=8.0, m32=5.0, d23=3.0, d32=-2.0, sway_force=True)
    u, v, r = 2.0, 0.1, 0.2
    tau = np.array([50.0, -4.0, 5.0])
    M = np.array([[100, 0, 0], [0, 150, 8], [0, 5, 40]], float)
    C = np.array([[0, 0, -(150 * v + 8 * r)], [0, 0, 100 * u], [150 * v + 8 * r, -100 * u, 0]])
    D = np.array([[20, 0, 0], [0, 60, 3], [0, -2, 30]], float)
    nu = np.array([u, v, r])
    want = np.linalg.solve(M, tau - C @ nu - D @ nu)  # Mu et al. 2018 eq. 13
    np.testing.assert_allclose(_accelerations(p, nu, tau), want, rtol=1e-12)


def test_vector_thrust_signs():
    # at rest the accelerations are tau / M: tau = (T cos delta, -T sin delta, x_l T sin delta)
    p = ThreeDOF(m11=100.0, m22=150.0, m33=40.0, d11=20.0, d22=60.0, d33=30.0, x_l=3.0,
                 thrust=100.0, sway_force=True)
    d30 = math.radians(30)
    out = KIND.derivatives(p, [0.0, 0.0, 0.0], delta=d30)[3]
    np.testing.assert_allclose(out * [100, 150, 40], [100 * math.cos(d30), -50.0, 150.0],
                               rtol=1e-12)
    q = p.replace(sway_force=False)  # Mu et al. 2018: tau_v neglected
    assert KIND.derivatives(q, [0.0, 0.0, 0.0], delta=0.1)[3][1] == 0.0
    # positive delta -> positive yaw acceleration -> turns to starboard
    p = mu2018_threedof(thrust=1000.0)
    out = KIND.derivatives(p, [5.0, 0.0, 0.0], delta=0.1)[3]
    assert out[2] == pytest.approx((3.5 * 1000 * math.sin(0.1)) / p.m33 - 0.0)
    assert out[2] > 0


def test_positive_delta_turns_to_starboard_and_straight_speed():
    m = VesselModel(mu2018_threedof(thrust=4000.0), vessel=Vessel(length=7.02))
    res = simulate(m, Turning(math.radians(10)), t_end=60.0)
    assert res["r"][0, -1] > 0 and res["psi"][0, -1] > 0
    # straight: u0 defaults to T/d11 and stays there
    st = simulate(m, Turning(0.0), t_end=20.0)
    np.testing.assert_allclose(st["u"][0], 4000.0 / m.dynamics.d11, rtol=1e-12)
    np.testing.assert_allclose(st["y"][0], 0.0, atol=1e-12)


def test_thrust_none_holds_initial_speed():
    m = VesselModel(mu2018_threedof(), vessel=Vessel(speed=5.144))
    res = simulate(m, Turning(0.0), t_end=10.0)
    np.testing.assert_allclose(res["u"][0], 5.144, rtol=1e-12)
    with pytest.raises(UsvidError, match="u0"):
        simulate(VesselModel(mu2018_threedof()), Turning(0.0), t_end=1.0)


def _compare_with_solve_ivp(p: ThreeDOF, u0: float, n_series=None):
    dt = 0.01
    t = np.arange(4001) * dt
    cmd = 0.3 * np.sin(0.3 * t)
    logic = Commanded(t, delta=cmd, n=n_series(t) if n_series else None)
    res = simulate(VesselModel(p, servo=IdealServo(max_angle=1.0)), logic, t_end=40.0, dt=dt,
                   u0=u0)

    def inputs(tt):
        n = n_series(tt) if n_series else p.n
        return {"delta": 0.3 * np.sin(0.3 * tt), "n": math.nan if n is None else n}

    ref = reference_run(p, inputs, [0, 0, 0, u0, 0, 0], res.t[::200])
    for j, name in enumerate(("x", "y", "psi", "u", "v", "r")):
        # the measured inputs are linear between steps (first-order hold), off the sines by
        # O(dt^2): over 40 s at most 1.7e-6 of a channel's range. Was 5e-5 for the old zero-order
        # hold's half-step delay (such a delay now gives 7e-4 and fails)
        scale = max(1.0, float(np.max(np.abs(ref[j]))))
        np.testing.assert_allclose(res[name][0, ::200], ref[j], atol=1e-5 * scale)


def test_kernel_matches_solve_ivp_constant_thrust_with_coupling():
    p = ThreeDOF(m11=300.0, m22=450.0, m33=200.0, d11=60.0, d22=400.0, d33=500.0, x_l=2.0,
                 m23=20.0, m32=15.0, d23=10.0, d32=5.0, thrust=300.0, sway_force=True)
    _compare_with_solve_ivp(p, 5.0)


def test_kernel_matches_solve_ivp_propeller_thrust():
    prop = Propeller(D=0.46, pitch_ratio=0.9, disk_ratio=0.55, t_P=0.05, w_P=0.04)
    p = mu2018_threedof(thrust=prop, n=20.0)
    _compare_with_solve_ivp(p, 4.0, n_series=lambda t: 20.0 + 3.0 * np.sin(0.2 * t))


def test_kernel_matches_solve_ivp_pod_thrust():
    p = mu2018_threedof(thrust=PodThrust(c=-5.0, d=12.0), n=20.0)
    _compare_with_solve_ivp(p, 4.0)


def test_default_speed_from_propeller_is_equilibrium():
    prop = Propeller(D=0.46, pitch_ratio=0.9, disk_ratio=0.55, t_P=0.05, w_P=0.04)
    p = mu2018_threedof(thrust=prop, n=20.0)
    res = simulate(VesselModel(p), Turning(0.0), t_end=5.0)
    u = res["u"][0]
    assert u[0] > 0
    np.testing.assert_allclose(u, u[0], rtol=1e-9)  # equilibrium: stays put
    np.testing.assert_allclose(res["n"][0], 20.0)


def test_zigzag_with_mu2018_servo_runs_and_is_sane():
    m = VesselModel(mu2018_threedof(), servo=mu2018_servo(), vessel=Vessel(speed=5.144))
    res = simulate(m, ZigZag(math.radians(10), math.radians(10)), t_end=80.0)
    zm = res.zigzag_metrics()[0]
    assert len(zm.overshoot_deg) >= 3
    assert all(0 < o < 30 for o in zm.overshoot_deg)
    assert np.max(np.abs(res["delta"][0])) <= math.radians(35) + 1e-12


def test_threedof_validation():
    with pytest.raises(UsvidError, match="m11"):
        ThreeDOF(m11=0.0, m22=1.0, m33=1.0, d11=1.0, d22=1.0, d33=1.0, x_l=1.0)
    with pytest.raises(UsvidError, match="singular"):
        ThreeDOF(m11=1.0, m22=1.0, m33=1.0, d11=1.0, d22=1.0, d33=1.0, x_l=1.0, m23=1, m32=1)
