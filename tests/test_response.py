"""Response models (Nomoto 1/2, Norrbin): numpy dynamics, hand values, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from usvid.errors import UsvidError
from usvid.models import Nomoto1, Nomoto2, Norrbin, VesselModel, nomoto1_f, nomoto2_f, norrbin_f
from usvid.sim import Commanded, simulate
from usvid.trial import Vessel


def test_nomoto1_f_hand_value():
    p = Nomoto1(K=0.707, T=0.332, delta0=0.01)
    s = np.array([1.0, 2.0, math.pi / 2, 0.05])
    out = nomoto1_f(s, np.array([0.1]), p, U=5.0)
    # x' = 5 cos(pi/2) = 0, y' = 5, psi' = r, r' = (0.707 * 0.11 - 0.05)/0.332
    np.testing.assert_allclose(out, [0.0, 5.0, 0.05, (0.707 * 0.11 - 0.05) / 0.332], atol=1e-15)
    assert np.allclose(p.f(s, np.array([0.1]), U=5.0), out)


def test_norrbin_f_hand_value_and_batch():
    p = Norrbin(K=np.array([0.7, 0.5]), T=2.0, n1=np.array([1.0, -0.2]), n3=3.0)
    s = np.array([[0, 0, 0, 0.1], [0, 0, 0, 0.2]], dtype=float)
    out = norrbin_f(s, np.array([[0.05], [0.05]]), p, U=1.0)
    want = [(0.7 * 0.05 - 0.1 - 3 * 0.001) / 2, (0.5 * 0.05 + 0.2 * 0.2 - 3 * 0.008) / 2]
    np.testing.assert_allclose(out[:, 3], want)
    np.testing.assert_allclose(out[:, 0], 1.0)


def test_nomoto2_f_realisation_has_right_transfer_function():
    # z'' + a1 z' + a0 z = delta, r = K a0 (z + T3 z'): check at s = j w against
    # K (1 + T3 s)/((1 + T1 s)(1 + T2 s)) using the state-space matrices from f
    p = Nomoto2(K=0.4, T1=5.0, T2=0.7, T3=1.5)
    base = np.zeros(5)
    A = np.zeros((2, 2))
    for j in range(2):
        e = base.copy()
        e[3 + j] = 1.0
        A[:, j] = nomoto2_f(e, np.array([0.0]), p, U=0.0)[3:]
    Bv = nomoto2_f(base, np.array([1.0]), p, U=0.0)[3:]
    C = np.array([p.yaw_rate(np.r_[0, 0, 0, 1.0, 0]), p.yaw_rate(np.r_[0, 0, 0, 0, 1.0])])
    for w in (0.01, 0.3, 2.0):
        s = 1j * w
        H = C @ np.linalg.solve(s * np.eye(2) - A, Bv)
        assert H == pytest.approx(0.4 * (1 + 1.5 * s) / ((1 + 5.0 * s) * (1 + 0.7 * s)))


def test_nomoto2_state_from_yaw_rate():
    p = Nomoto2(K=0.4, T1=5.0, T2=0.7)
    z, zd = p.state_from_yaw_rate(0.1)
    assert p.yaw_rate(np.array([0, 0, 0, z, zd])) == pytest.approx(0.1)
    assert nomoto2_f(np.array([0, 0, 0, z, zd]), np.array([0.25]), p, U=1.0)[4] == \
        pytest.approx(0.0, abs=1e-15)  # steady for delta = r/K


def test_norrbin_steady_roots():
    p = Norrbin(K=0.707, T=0.332, n1=1.0, n3=1.102)
    r = p.steady_yaw_rate(math.radians(10))
    assert r + 1.102 * r**3 == pytest.approx(0.707 * math.radians(10), rel=1e-12)
    q = Norrbin(K=0.707, T=0.332, n1=-0.19, n3=1.102)
    r = q.steady_yaw_rate(math.radians(1))
    assert -0.19 * r + 1.102 * r**3 == pytest.approx(0.707 * math.radians(1), rel=1e-9)
    assert r > math.sqrt(0.19 / 1.102)  # the outer (stable) branch


@pytest.mark.parametrize("kind", ["nomoto1", "nomoto2", "norrbin"])
def test_simulator_matches_solve_ivp_of_numpy_f(kind):
    """The numba kernel integrates the same equations as the numpy f (independent check)."""
    p = {"nomoto1": Nomoto1(K=0.6, T=1.5, delta0=0.01),
         "nomoto2": Nomoto2(K=0.6, T1=3.0, T2=0.4, T3=0.8),
         "norrbin": Norrbin(K=0.6, T=1.5, n1=-0.3, n3=2.0)}[kind]
    U = 3.0
    dt = 0.01
    t = np.arange(3001) * dt
    cmd = 0.2 * np.sin(0.4 * t)
    res = simulate(VesselModel(p, vessel=Vessel(speed=U)), Commanded(t, delta_cmd=cmd),
                   t_end=30.0, dt=dt)
    nx = len(p.state_names)

    def rhs(tt, s):
        # the simulator holds each command over its step: to second order a delay of dt/2
        return p.f(s, np.array([0.2 * np.sin(0.4 * (tt - dt / 2))]), U=U)

    sol = solve_ivp(rhs, (0, 30), np.zeros(nx), t_eval=res.t[::100], rtol=1e-10, atol=1e-12)
    # tolerances: hold vs half-step delay differ by O(dt^2 |cmd''|) = 3e-6 rad of rudder,
    # giving < 1e-5 rad of heading and < 1e-4 m of position over 30 s
    np.testing.assert_allclose(res["psi"][0, ::100], sol.y[2], atol=1e-5)
    np.testing.assert_allclose(res["x"][0, ::100], sol.y[0], atol=1e-4)
    np.testing.assert_allclose(res["y"][0, ::100], sol.y[1], atol=1e-4)


def test_response_validation():
    with pytest.raises(UsvidError, match="parameters.T"):
        Nomoto1(K=0.7, T=0.0)
    with pytest.raises(UsvidError, match="parameters.T1"):
        Nomoto2(K=0.7, T1=-1.0, T2=1.0)
    with pytest.raises(UsvidError, match="parameters.n3"):
        Norrbin(K=0.7, T=1.0, n3=float("nan"))
