"""Wind and waves inside the integration step, and a current in a turning test.

* the wind's loads follow the state: at each RK4 step's start the apparent wind of the
  velocity over ground and heading there through the wind-load model, less the still air's load
  (zero wind is calm water); a head wind gives the kind's steady speed with the hand-computed
  drag, a beam wind the hand-computed side force and yaw moment (their signs);
* a response kind takes the wind's yaw moment as the rudder-equivalent angle N / N_delta;
* the mean wave drift pushes where the waves travel; the first-order motion is added after;
* a 0.5 m/s cross current in a turning test: the IMO MSC/Circ.1053 estimate recovers it;
* refusals name what is missing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from usvid.errors import SimulationError
from usvid.manoeuvres.drift import imo_current
from usvid.models import IdealServo, Nomoto1, VesselModel, mu2018_servo, mu2018_threedof, registry
from usvid.models.environment import (
    AIR_DENSITY,
    BLENDERMANN_TYPES,
    SeaState,
    drift_coefficients,
    rudder_equivalent,
    true_to_apparent,
    wind_load_model,
    wind_loads,
)
from usvid.sim import Commanded, Environment, Turning, ZigZag, core, simulate
from usvid.trial import Vessel

A_T, A_L = 2.0, 6.0  # windage areas [m^2] of the test boat (Blendermann's form: A_T, A_L, L)


def _vessel(**kw) -> Vessel:
    base = dict(length=7.02, speed=5.14, beam=2.6, draft=0.32, frontal_area=A_T,
                lateral_area=A_L)
    base.update(kw)
    return Vessel(**base)


def _threedof() -> VesselModel:
    return VesselModel(mu2018_threedof(x_l=3.5), servo=mu2018_servo(), vessel=_vessel())


def _straight(t_end: float) -> Commanded:
    return Commanded(np.array([0.0, t_end]), delta_cmd=np.zeros(2))


def test_wind_of_zero_scale_is_calm():
    """The wind's own code (per-lane step with the environment block) with the loads scaled to
    zero gives the calm runs: the same arithmetic on another path (the calm batch takes the
    vector step, whose FMA contraction may differ in the last bits: 1e-12 of the scale)."""
    model = _threedof()
    amp = np.radians(np.array([10.0, 20.0]))
    kw = dict(t_end=40.0, dt=0.05)
    calm = simulate(model, ZigZag(amp, amp), **kw)
    wm = wind_load_model(model.vessel, wind_scale=0.0)
    res = simulate(model, ZigZag(amp, amp), environment=Environment(
        wind_speed=8.0, wind_dir=1.0, wind_model=wm), **kw)
    for name in ("x", "y", "psi", "u", "v", "r", "delta"):
        x = calm[name]
        np.testing.assert_allclose(res[name], x, rtol=0.0,
                                   atol=1e-12 * max(float(np.max(np.abs(x))), 1e-3), err_msg=name)


def _blendermann_by_hand(speed: float, angle: float) -> tuple[float, float, float]:
    """X, Y, N of Blendermann (1994) for the speed-boat row at the apparent wind ``speed``
    [m/s] and ``angle`` [rad, from the bow, clockwise, coming from], centroid at midship (the
    formulas of the paper as written in Fossen 2021 ch. 10.1, typed out again here)."""
    cdt, cdl_bow, cdl_stern, dlt, _ = BLENDERMANN_TYPES["speed_boat"]
    g = -angle
    cdl_af = cdl_bow if math.cos(g) >= 0 else cdl_stern
    cdl = cdl_af * A_T / A_L
    den = 1.0 - 0.5 * dlt * (1.0 - cdl / cdt) * math.sin(2.0 * g) ** 2
    cx = -cdl_af * math.cos(g) / den
    cy = cdt * math.sin(g) / den
    cn = (0.0 - 0.18 * (abs(g) - math.pi / 2)) * cy
    q = 0.5 * AIR_DENSITY * speed**2
    return q * A_T * cx, q * A_L * cy, q * A_L * 7.02 * cn


def test_head_wind_gives_the_steady_speed_of_the_hand_drag():
    """Heading north into a 10 m/s wind from the north, rudder 0: no side force or moment (v,
    r stay 0), the surge settles where the kind's balance holds with the drag of the apparent
    wind (V + u) less the still air's (u): X = 1/2 rho A_T C_X(0) ((V + u)^2 - u^2), C_X(0) =
    -C_Dl,AF(bow) (Blendermann 1994)."""
    model = _threedof()
    kind = registry.get("threedof")
    V = 10.0
    res = simulate(model, _straight(300.0), t_end=300.0, dt=0.05,
                   environment=Environment(wind_speed=V, wind_dir=0.0))
    assert np.max(np.abs(res["v"][0])) < 1e-12 and np.max(np.abs(res["r"][0])) < 1e-12
    cdl_bow = BLENDERMANN_TYPES["speed_boat"][1]

    def drag(u):
        return -0.5 * AIR_DENSITY * A_T * cdl_bow * ((V + u) ** 2 - u**2)

    u_end = float(res["u"][0, -1])
    # the library's loads are the hand formula's (the model and the triangle, 1e-12)
    lib = wind_loads(wind_load_model(model.vessel), V + u_end, 0.0).X - \
        wind_loads(wind_load_model(model.vessel), u_end, 0.0).X
    assert float(lib) == pytest.approx(drag(u_end), rel=1e-12)

    def resid(s):
        return np.ravel(kind.derivatives(model.dynamics, [s[0], 0.0, 0.0],
                                         force=(drag(s[0]), 0.0, 0.0, 0.0), speed=5.14)[3])[0]

    steady = float(fsolve(lambda s: [resid(s)], [5.0], xtol=1e-13)[0])
    calm = simulate(model, _straight(300.0), t_end=300.0, dt=0.05)
    assert steady < float(calm["u"][0, -1]) - 0.01  # the head wind slows it
    # 300 s are many surge time constants (m11/d11 of the Lanxin model ~ 10 s): settled to 1e-6
    assert u_end == pytest.approx(steady, rel=1e-6)


def test_beam_wind_side_force_and_yaw_moment_by_hand():
    """A 6 m/s wind from the east on the vessel heading north at u = 5.14 m/s: the apparent
    wind comes from 49.4 deg on the starboard bow; the hand-computed Blendermann loads (less
    the still air's head wind: X only) push to port (Y < 0) and turn the bow to port, downwind
    (N < 0: the centre of effort forward of midship for a wind forward of the beam). The core's
    first step (dt = 1 ms) accelerates v and r as the kind's equations with that load (RK4's
    first step: the derivative to O(dt), 0.5 %)."""
    model = _threedof()
    kind = registry.get("threedof")
    V, u0 = 6.0, 5.14
    va, ga = true_to_apparent(V, math.pi / 2, u0, 0.0, 0.0)
    assert float(ga) == pytest.approx(math.atan2(V, u0), rel=1e-12)
    X, Y, N = _blendermann_by_hand(float(va), float(ga))
    X0, Y0, N0 = _blendermann_by_hand(u0, 0.0)
    assert (Y0, N0) == (pytest.approx(0.0, abs=1e-12), pytest.approx(0.0, abs=1e-12))
    lib = wind_loads(wind_load_model(model.vessel), va, ga)
    assert (float(lib.X), float(lib.Y), float(lib.N)) == pytest.approx((X, Y, N), rel=1e-12)
    assert Y < 0 and N < 0
    dt = 1e-3
    res = simulate(model, _straight(2 * dt), t_end=2 * dt, dt=dt,
                   environment=Environment(wind_speed=V, wind_dir=math.pi / 2))
    d = kind.derivatives(model.dynamics, [u0, 0.0, 0.0], force=(X - X0, Y, 0.0, N),
                         speed=u0)[3]
    vdot, rdot = float(np.ravel(d)[1]), float(np.ravel(d)[2])
    assert rdot < 0
    assert float(res["v"][0, 1]) / dt == pytest.approx(vdot, rel=5e-3)
    assert float(res["r"][0, 1]) / dt == pytest.approx(rdot, rel=5e-3)


def test_response_kind_in_wind_is_the_rudder_equivalent_run():
    """Nomoto 1 (no N_delta given) in a 5 m/s wind from the east: N_delta from
    rudder_equivalent (K m66 / T); the run equals the calm run with the measured rudder angle
    N(t) / N_delta, N(t) the wind's yaw moment along the run's own heading. The run holds the
    moment of each step's start over the step: the reference's series places N(t_k) at the
    step's midpoint t_k + dt/2, whose first-order hold has the same mean over each step to
    O(dt^2 N'') (~1e-7 rad here, against 3e-4 rad for N(t_k) at t_k: the hold's half-step
    lag)."""
    vessel = _vessel(length=7.0, speed=3.0, mass=2800.0)
    dyn = Nomoto1(K=0.2, T=5.0)
    model = VesselModel(dyn, servo=IdealServo(), vessel=vessel)
    t_end, dt, V, wdir = 60.0, 0.02, 5.0, math.pi / 2
    # the loads of every step's start held over it (interval 0, no extrapolation), as the
    # reference's rudder series is: the multirate hold's own error is tests/test_sim_wind_hold.py's
    old = core.LOAD_EXTRAPOLATE
    try:
        core.LOAD_EXTRAPOLATE = False
        res = simulate(model, _straight(t_end), t_end=t_end, dt=dt,
                       environment=Environment(wind_speed=V, wind_dir=wdir, load_interval=0.0))
    finally:
        core.LOAD_EXTRAPOLATE = old
    re = rudder_equivalent("nomoto1", dyn.values(), vessel)
    env = res.meta["environment"]["wind"]
    assert env["rudder_equivalent"]["N_delta_N_m_per_rad"] == pytest.approx(re.N_delta)
    assert re.N_delta == pytest.approx(0.2 * re.m66 / 5.0)
    psi = res["psi"][0]
    U = 3.0
    wm = wind_load_model(vessel)
    va, ga = true_to_apparent(V, wdir, U * np.cos(psi), U * np.sin(psi), psi)
    va0, ga0 = true_to_apparent(0.0, 0.0, U * np.cos(psi), U * np.sin(psi), psi)
    N = wind_loads(wm, va, ga).N - wind_loads(wm, va0, ga0).N
    assert N[0] < 0  # forward of the beam: the bow goes downwind (to port)
    tm = np.concatenate([[0.0], res.t + 0.5 * dt])
    ref = simulate(model, Commanded(tm, delta=np.concatenate([N[:1], N]) / re.N_delta),
                   t_end=t_end, dt=dt)
    np.testing.assert_allclose(res["psi"][0], ref["psi"][0], rtol=0.0, atol=1e-5)
    assert abs(float(psi[-1])) > 0.05  # the wind turned it measurably


def test_response_kind_without_mass_is_refused():
    model = VesselModel(Nomoto1(K=0.2, T=5.0), servo=IdealServo(),
                        vessel=_vessel(length=7.0, speed=3.0))
    with pytest.raises(SimulationError, match="N_delta.*mass"):
        simulate(model, _straight(10.0), t_end=10.0, environment=Environment(wind_speed=5.0))


def test_wind_without_windage_is_refused():
    model = VesselModel(mu2018_threedof(x_l=3.5), servo=mu2018_servo(),
                        vessel=Vessel(length=7.02, speed=5.14))
    with pytest.raises(SimulationError, match="frontal_area.*lateral_area"):
        simulate(model, _straight(10.0), t_end=10.0, environment=Environment(wind_speed=5.0))


def test_wave_drift_pushes_where_the_waves_travel():
    """Head seas from the north on a vessel heading north (beta = pi): the mean drift is
    X = -fx0 (fx0 of drift_coefficients), Y = 0; the run equals the one with that constant
    external force (the per-lane and the force paths: 1e-9 of the scale)."""
    model = _threedof()
    sea = SeaState(hs=1.0, tp=5.0, direction=0.0)
    fx0, _ = drift_coefficients(sea, 7.02, 2.6, 0.32)
    res = simulate(model, _straight(60.0), t_end=60.0, dt=0.05,
                   environment=Environment(sea=sea, wave_motion=False))
    ref = simulate(model, _straight(60.0), t_end=60.0, dt=0.05,
                   environment=Environment(force=(-fx0, 0.0, 0.0, 0.0)))
    for ch in ("x", "u"):
        np.testing.assert_allclose(res[ch][0], ref[ch][0], rtol=1e-9, err_msg=ch)
    assert res.meta["environment"]["waves"]["drift_fx0_N"] == pytest.approx(fx0)


def test_first_order_wave_motion_added_after_the_run():
    """With wave_motion the recorded x, y, psi are the run's plus the first-order motion: the
    same seed gives the same motion, another seed another; the drift and the manoeuvring
    states (u, r) are those of the run without it."""
    model = _threedof()
    sea = SeaState(hs=1.0, tp=5.0, direction=math.radians(45.0))
    kw = dict(t_end=30.0, dt=0.05)
    a = simulate(model, _straight(30.0), environment=Environment(sea=sea, wave_seed=3), **kw)
    b = simulate(model, _straight(30.0), environment=Environment(sea=sea, wave_motion=False),
                 **kw)
    c = simulate(model, _straight(30.0), environment=Environment(sea=sea, wave_seed=4), **kw)
    np.testing.assert_array_equal(a["r"], b["r"])
    dpsi = a["psi"][0] - b["psi"][0]
    assert 1e-4 < float(np.std(dpsi)) < 0.5
    assert not np.allclose(a["psi"], c["psi"])


def test_cross_current_turning_imo_estimate():
    """A 35 deg turning test of the Lanxin 3-DOF model in a 0.5 m/s current towards the east:
    the positions 360 deg of heading apart differ by the current's drift, and the IMO
    MSC/Circ.1053 3.4.2.5 estimate recovers 0.5 m/s towards 90 deg within 0.005 m/s and 0.5 deg
    (the water-relative turn is steady after 180 deg to well below that; positions linear
    between samples 0.05 s apart)."""
    model = _threedof()
    env = Environment(current_speed=0.5, current_dir=math.pi / 2)
    res = simulate(model, Turning(math.radians(35.0)), t_end=150.0, dt=0.05, environment=env)
    calm = simulate(model, Turning(math.radians(35.0)), t_end=150.0, dt=0.05)
    # the turn through the water is the calm one: the ground track is it plus 0.5 t east
    np.testing.assert_allclose(res["y"][0], calm["y"][0] + 0.5 * res.t, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(res["x"][0], calm["x"][0], rtol=0.0, atol=1e-9)
    est = imo_current(res.t, res["x"][0], res["y"][0], res["psi"][0])
    assert est is not None and est.heading_change_deg >= 720.0
    assert est.speed_m_s == pytest.approx(0.5, abs=0.005)
    assert est.dir_deg == pytest.approx(90.0, abs=0.5)
    assert imo_current(calm.t, calm["x"][0], calm["y"][0], calm["psi"][0]).speed_m_s < 0.005


#: Final x, y [m], psi [rad] of calm 10/10-style runs (zig-zag 10 and 20 deg, 35 deg turn; 60 s,
#: dt = 0.05 s) of the example models, by the integration core before the wind entered it
#: (every recorded array of these runs was bit-identical after; 1e-9 leaves room for the
#: compiler's FMA contraction on another machine).
KERNEL_CALM = {
    ("lanxin_threedof", "zigzag"): (296.1552145659834, 4.9284919455438665, -0.40145518535126046),
    ("lanxin_threedof", "turning"): (18.94171389800022, 19.103594603074043, 28.013625977995563),
    ("lanxin", "zigzag"): (298.38197973763994, 8.390257668381592, -0.2378742779938716),
    ("lanxin", "turning"): (9.2419275419354, 1.3320176524881935, 24.805737951739115),
}


@pytest.mark.parametrize("name, manoeuvre", sorted(KERNEL_CALM))
def test_calm_runs_are_the_kernel_numbers(name, manoeuvre):
    from pathlib import Path

    from usvid.io.modelfile import load_model

    model = load_model(Path(__file__).resolve().parents[1] / "examples" / f"{name}.json")
    amp = np.radians([10.0, 20.0])
    logic = ZigZag(amp, amp) if manoeuvre == "zigzag" else Turning(np.radians(35.0), 0.0)
    res = simulate(model, logic, t_end=60.0, dt=0.05)
    got = tuple(float(res[c][0, -1]) for c in ("x", "y", "psi"))
    assert got == pytest.approx(KERNEL_CALM[(name, manoeuvre)], rel=1e-9, abs=1e-9)


def test_at_rest_in_wind_without_current_stays_finite():
    """A vessel at rest over ground (no current) in a steady wind: the still-air load of its own
    motion has no apparent wind at all, and Blendermann's yaw arm atan(-a_x/|a_y|) was 0/0 (a
    NaN moment: every Fossen kind from rest in wind diverged at the first step). The loads of a
    still apparent wind are zeros; from rest the vessel is pushed by the wind alone."""
    from usvid.models.environment.wind_loads import wind_load_body
    from usvid.models.kinds.catamaran import Catamaran

    v = _vessel()
    p = wind_load_model(v).packed(1.0)
    assert wind_load_body(p, 0.0, 0.0) == (0.0, 0.0, 0.0, 0.0)
    cat = Catamaran(m11=80.0, m22=120.0, m33=30.0, d11=25.0, d22=70.0, d33=40.0, b=0.8,
                    thrust=0.5)
    res = simulate(VesselModel(cat, vessel=v), Turning(0.0), t_end=5.0, dt=0.02, u0=0.0,
                   environment=Environment(wind_speed=6.0, wind_dir=math.radians(90.0)))
    assert res.success, res.message
    # a wind from the east pushes the boat west (to port, v < 0) from rest
    assert res["v"][0, -1] < 0.0 and np.all(np.isfinite(res["r"]))
