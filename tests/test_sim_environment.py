"""The environment in the integration core: a current and an external force, for every kind.

* calm water (zero current, zero force) gives the runs without an environment;
* a current (Fossen 2021 ch. 10.3): a vessel with zero rudder in a 0.5 m/s cross current drifts
  at 0.5 m/s over ground with unchanged speed through the water;
* the external force enters each force kind's balance through its mass matrix (by hand), and a
  constant side force gives the steady drift of the kind's own equations;
* a response kind takes the external yaw moment as the rudder angle N / N_delta, and refuses one
  without N_delta.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from usvid.errors import SimulationError
from usvid.models import IdealServo, Nomoto1, VesselModel, mu2018_servo, mu2018_threedof, registry
from usvid.models.kinds.fourdof import FourDOF
from usvid.models.kinds.mmg import from_physics, kvlcc2
from usvid.sim import Commanded, Environment, ZigZag, simulate
from usvid.trial import Vessel

#: The environment's runs take another variant of the vector step (with input series) than the
#: calm ones: the same arithmetic, FMA contraction may differ in the last bit.
RTOL = 1e-12


def _threedof() -> VesselModel:
    return VesselModel(mu2018_threedof(x_l=3.5), servo=mu2018_servo(),
                       vessel=Vessel(length=7.02, speed=5.14))


@pytest.mark.parametrize("kind", ["nomoto1", "threedof"])
def test_calm_environment_is_no_environment(kind):
    model = _threedof() if kind == "threedof" else VesselModel(
        Nomoto1(K=0.2, T=5.0), servo=mu2018_servo(), vessel=Vessel(length=7.0, speed=3.0))
    amp = np.radians(np.linspace(10.0, 20.0, 40))
    kw = dict(t_end=40.0, dt=0.02, psi0=np.linspace(-1.0, 1.0, 40))
    a = simulate(model, ZigZag(amp, amp), **kw)
    b = simulate(model, ZigZag(amp, amp), environment=Environment(
        current_speed=0.0, current_dir=1.0, force=(0.0, 0.0, 0.0, 0.0)), **kw)
    for name, x in a.channels.items():
        if np.all(np.isnan(x)):  # a channel the kind does not have (n without a thrust law)
            assert np.all(np.isnan(b.channels[name]))
            continue
        scale = max(float(np.nanmax(np.abs(x))), 1e-3)
        np.testing.assert_allclose(b.channels[name], x, rtol=0.0, atol=RTOL * scale,
                                   err_msg=name)


def test_cross_current_drift_over_ground():
    """Heading north, rudder 0, a 0.5 m/s current towards the east: y' = 0.5 m/s over ground,
    the speed through the water (and x) as in calm water; recorded v (over ground, body y =
    east) 0.5 m/s, U = sqrt(u^2 + 0.25)."""
    model = _threedof()
    t = np.array([0.0, 60.0])
    logic = Commanded(t, delta_cmd=np.zeros(2))
    calm = simulate(model, logic, t_end=60.0, dt=0.02)
    res = simulate(model, logic, t_end=60.0, dt=0.02,
                   environment=Environment(current_speed=0.5, current_dir=math.pi / 2))
    np.testing.assert_allclose(res["y"][0], 0.5 * res.t, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(res["x"][0], calm["x"][0], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(res["u"][0], calm["u"][0], rtol=1e-12)  # through the water
    np.testing.assert_allclose(res["v"][0], 0.5, atol=1e-12)
    np.testing.assert_allclose(res["U"][0], np.hypot(calm["u"][0], 0.5), rtol=1e-12)


def _force_kinds():
    out = {"threedof": mu2018_threedof(x_l=3.5), "catamaran":
           registry.get("catamaran").dynamics.example(),
           "fourdof": FourDOF(m11=80.0, m22=130.0, m44=12.0, m66=30.0, d11=40.0, d22=150.0,
                              d44=15.0, d66=200.0, w_gm=120.0, x_l=0.5, m24=8.5, m26=3.0,
                              mzg=-7.0, thrust=80.0),
           "mmg": from_physics(kvlcc2(), n=10.0)}
    return out


def _inverse_mass(name: str, dyn) -> np.ndarray:
    """The inverse of the kind's mass matrix acting on (X, Y, K, N), by hand (4 x 4; zero rows
    and columns for what the kind does not have)."""
    M = np.zeros((4, 4))
    if name in ("threedof", "catamaran"):
        M[0, 0], M[1, 1], M[3, 3] = dyn.m11, dyn.m22, dyn.m33
        M[2, 2] = 1.0
    elif name == "fourdof":
        M[0, 0] = dyn.m11
        M[1:, 1:] = [[dyn.m22, dyn.m24, dyn.m26], [dyn.m24, dyn.m44, 0.0],
                     [dyn.m26, 0.0, dyn.m66]]
    else:  # MMG, Y&Y 2015 eq. 4 about midship
        ph = dyn.physics()
        Mm = ph.mass_matrix()
        M[0, 0], M[2, 2] = Mm[0, 0], 1.0
        M[np.ix_([1, 3], [1, 3])] = Mm[1:, 1:]
    Minv = np.linalg.inv(M)
    if name != "fourdof":
        Minv[2, :] = Minv[:, 2] = 0.0  # no roll
    return Minv


@pytest.mark.parametrize("name", ["threedof", "catamaran", "fourdof", "mmg"])
def test_external_force_through_the_mass_matrix(name):
    dyn = _force_kinds()[name]
    kind = registry.get(name)
    state = np.zeros(kind.n_states)
    state[0] = 1.0  # u
    f = np.array([30.0, -20.0, 5.0, 40.0])
    a = kind.derivatives(dyn, state, delta=0.1, force=f, speed=1.0)
    b = kind.derivatives(dyn, state, delta=0.1, speed=1.0)
    got = np.asarray(a[3]) - np.asarray(b[3])
    want = _inverse_mass(name, dyn) @ f  # (u', v', p', r')
    order = {"u": 0, "v": 1, "p": 2, "r": 3}
    for i, s in enumerate(kind.states):
        if s in order:
            assert got[i] == pytest.approx(want[order[s]], rel=1e-9, abs=1e-15), (name, s)


def test_constant_side_force_gives_the_kinds_steady_drift():
    """A constant sway force Y = 2 kN on the Lanxin 3-DOF model with zero rudder: the run
    settles on the steady state of the kind's own equations (solved by fsolve)."""
    model = _threedof()
    kind = registry.get("threedof")
    Y = 2000.0
    res = simulate(model, Commanded(np.array([0.0, 200.0]), delta_cmd=np.zeros(2)),
                   t_end=200.0, dt=0.02, environment=Environment(force=(0.0, Y, 0.0, 0.0)))
    speed = 5.14

    def resid(s):
        return np.ravel(kind.derivatives(model.dynamics, s, force=(0.0, Y, 0.0, 0.0),
                                         speed=speed)[3])

    steady = fsolve(resid, [speed, 0.0, 0.0], xtol=1e-13)
    assert np.max(np.abs(resid(steady))) < 1e-10
    for i, ch in enumerate(("u", "v", "r")):
        assert res[ch][0, -1] == pytest.approx(steady[i], rel=1e-6, abs=1e-9), ch
    assert steady[1] > 0  # pushed to starboard


def test_response_kind_takes_the_yaw_moment_as_a_rudder_angle():
    """Nomoto 1 with N_delta = 2000 N m/rad: a yaw moment of 200 N m acts as 0.1 rad of rudder
    (the same run as a measured rudder angle of 0.1 rad); without N_delta it is refused."""
    t = np.array([0.0, 30.0])
    model = VesselModel(Nomoto1(K=0.2, T=5.0, N_delta=2000.0), servo=IdealServo(),
                        vessel=Vessel(length=7.0, speed=3.0))
    a = simulate(model, Commanded(t, delta=np.full(2, 0.1)), t_end=30.0, dt=0.02)
    b = simulate(model, Commanded(t, delta=np.zeros(2)), t_end=30.0, dt=0.02,
                 environment=Environment(force=(0.0, 0.0, 0.0, 200.0)))
    for ch in ("psi", "r", "x", "y"):
        np.testing.assert_allclose(b[ch][0], a[ch][0], rtol=1e-12, atol=1e-12, err_msg=ch)
    bare = VesselModel(Nomoto1(K=0.2, T=5.0), servo=IdealServo(),
                       vessel=Vessel(length=7.0, speed=3.0))
    with pytest.raises(SimulationError, match="N_delta"):
        simulate(bare, Commanded(t, delta=np.zeros(2)), t_end=30.0, dt=0.02,
                 environment=Environment(force=(0.0, 0.0, 0.0, 200.0)))
