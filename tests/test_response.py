"""Response models (Nomoto 1/2, Norrbin): right-hand sides, hand values, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from reference import reference_run
from usvid.errors import UsvidError
from usvid.models import Nomoto1, Nomoto2, Norrbin, VesselModel, get_kind
from usvid.sim import Commanded, simulate
from usvid.trial import Vessel


def test_nomoto1_rhs_hand_value():
    p = Nomoto1(K=0.707, T=0.332, delta0=0.01)
    u, v, r, d = get_kind("nomoto1").derivatives(p, [0.05], delta=0.1, speed=5.0)
    # constant speed U = 5 without drift; r' = (0.707 * 0.11 - 0.05)/0.332
    assert (u, v, r) == (5.0, 0.0, 0.05)
    np.testing.assert_allclose(d, [(0.707 * 0.11 - 0.05) / 0.332], rtol=1e-14)


def test_norrbin_rhs_hand_value_and_batch():
    p = Norrbin(K=np.array([0.7, 0.5]), T=2.0, n1=np.array([1.0, -0.2]), n3=3.0)
    u, _, _, d = get_kind("norrbin").derivatives(p, [[0.1], [0.2]], delta=0.05, speed=1.0)
    want = [(0.7 * 0.05 - 0.1 - 3 * 0.001) / 2, (0.5 * 0.05 + 0.2 * 0.2 - 3 * 0.008) / 2]
    np.testing.assert_allclose(d[:, 0], want, rtol=1e-14)
    np.testing.assert_allclose(u, 1.0)


def test_nomoto2_realisation_has_right_transfer_function():
    # observable canonical form, states (r, x2): check the transfer function of the right-hand
    # side at s = j w against K (1 + T3 s)/((1 + T1 s)(1 + T2 s))
    p = Nomoto2(K=0.4, T1=5.0, T2=0.7, T3=1.5)
    kind = get_kind("nomoto2")
    assert kind.states == ("r", "x2")
    A = np.column_stack([kind.derivatives(p, e, delta=0.0)[3] for e in np.eye(2)])
    Bv = kind.derivatives(p, [0.0, 0.0], delta=1.0)[3]
    C = np.array([kind.derivatives(p, e)[2] for e in np.eye(2)])  # yaw rate of each state
    for w in (0.01, 0.3, 2.0):
        s = 1j * w
        H = C @ np.linalg.solve(s * np.eye(2) - A, Bv)
        assert H == pytest.approx(0.4 * (1 + 1.5 * s) / ((1 + 5.0 * s) * (1 + 0.7 * s)))


def test_nomoto2_state_from_yaw_rate():
    p = Nomoto2(K=0.4, T1=5.0, T2=0.7, T3=1.5)
    kind = get_kind("nomoto2")
    z = kind.initial(p, {"r": 0.1, "delta": 0.25})[:, 0]
    _, _, r, d = kind.derivatives(p, z, delta=0.25)
    assert r == pytest.approx(0.1)
    np.testing.assert_allclose(d, 0.0, atol=1e-15)  # steady for delta = r/K
    # a measured yaw acceleration is the initial r' of the realisation
    z = kind.initial(p, {"r": 0.1, "rdot": -0.02, "delta": 0.3})[:, 0]
    assert kind.derivatives(p, z, delta=0.3)[3][0] == pytest.approx(-0.02, abs=1e-15)


def test_norrbin_steady_roots():
    p = Norrbin(K=0.707, T=0.332, n1=1.0, n3=1.102)
    r = p.steady_yaw_rate(math.radians(10))
    assert r + 1.102 * r**3 == pytest.approx(0.707 * math.radians(10), rel=1e-12)
    q = Norrbin(K=0.707, T=0.332, n1=-0.19, n3=1.102)
    r = q.steady_yaw_rate(math.radians(1))
    assert -0.19 * r + 1.102 * r**3 == pytest.approx(0.707 * math.radians(1), rel=1e-9)
    assert r > math.sqrt(0.19 / 1.102)  # the outer (stable) branch


def test_norrbin_steady_yaw_rate_without_damping_terms():
    # n1 = n3 = 0: T r' = K delta has no steady turn (was ZeroDivisionError)
    assert Norrbin(K=0.5, T=2.0, n1=0.0, n3=0.0).steady_yaw_rate(0.1) == math.inf
    assert Norrbin(K=0.5, T=2.0, n1=0.0, n3=0.0).steady_yaw_rate(-0.1) == -math.inf


@pytest.mark.parametrize("kind", ["nomoto1", "nomoto2", "norrbin"])
def test_simulator_matches_solve_ivp_of_the_rhs(kind):
    """The integration core integrates the kind's right-hand side (independent integrator)."""
    p = {"nomoto1": Nomoto1(K=0.6, T=1.5, delta0=0.01),
         "nomoto2": Nomoto2(K=0.6, T1=3.0, T2=0.4, T3=0.8),
         "norrbin": Norrbin(K=0.6, T=1.5, n1=-0.3, n3=2.0)}[kind]
    U = 3.0
    dt = 0.01
    t = np.arange(3001) * dt
    cmd = 0.2 * np.sin(0.4 * t)
    res = simulate(VesselModel(p, vessel=Vessel(speed=U)), Commanded(t, delta=cmd),
                   t_end=30.0, dt=dt)
    nx = len(get_kind(kind).states)
    ref = reference_run(p, lambda tt: {"delta": 0.2 * np.sin(0.4 * tt)}, np.zeros(3 + nx),
                        res.t[::100], speed=U)
    # tolerances: the measured rudder is linear between steps (first-order hold), off the sine
    # by O(dt^2): 2.3e-6 rad of heading, 4e-5 m of position, 5e-7 rad/s of yaw rate at most
    # over 30 s (4x less at dt/2). The bounds are the old ones (the old zero-order hold was a
    # half-step delay of the rudder; such a delay now gives 5e-4 rad and 3e-3 m and fails them)
    np.testing.assert_allclose(res["psi"][0, ::100], ref[2], atol=1e-5)
    np.testing.assert_allclose(res["x"][0, ::100], ref[0], atol=1e-4)
    np.testing.assert_allclose(res["y"][0, ::100], ref[1], atol=1e-4)
    np.testing.assert_allclose(res["r"][0, ::100], ref[3], atol=2e-6)


def test_response_validation():
    with pytest.raises(UsvidError, match="parameters.T"):
        Nomoto1(K=0.7, T=0.0)
    with pytest.raises(UsvidError, match="parameters.T1"):
        Nomoto2(K=0.7, T1=-1.0, T2=1.0)
    with pytest.raises(UsvidError, match="parameters.n3"):
        Norrbin(K=0.7, T=1.0, n3=float("nan"))
