"""usvid.sim.runs: the standard manoeuvre runs of ``usvid simulate`` as library functions."""

from __future__ import annotations

import math

import pytest
from scipy.integrate import solve_ivp

from usvid.errors import SimulationError, UsvidError
from usvid.models import IdealServo, Nomoto1, ThreeDOF, VesselModel
from usvid.sim import run_course, run_turning, run_zigzag
from usvid.sim.runs import MAX_T_END, default_t_end
from usvid.trial import Vessel

K, T, U = 0.5, 2.0, 2.0  # a simple Nomoto vessel with an ideal servo
MODEL = VesselModel(Nomoto1(K=K, T=T), servo=IdealServo(max_angle=math.radians(35)),
                    vessel=Vessel(length=5.0, speed=U))


def test_run_turning_matches_ode_solution():
    res, m = run_turning(MODEL, 20.0, u0=U)
    delta = math.radians(20)

    def f(t, s):
        return [U * math.cos(s[2]), U * math.sin(s[2]), s[3], (K * delta - s[3]) / T]

    ev90 = lambda t, s: s[2] - math.pi / 2  # noqa: E731
    ev180 = lambda t, s: s[2] - math.pi  # noqa: E731
    sol = solve_ivp(f, (0, 60), [0, 0, 0, 0], rtol=1e-10, atol=1e-10, events=[ev90, ev180])
    s90, s180 = sol.y_events[0][0], sol.y_events[1][0]
    # RK4 at 0.02 s and linear interpolation between samples: 1 mm is ample
    assert m.advance_m == pytest.approx(s90[0], abs=1e-3)
    assert m.tactical_diameter_m == pytest.approx(s180[1], abs=1e-3)
    assert m.steady_yaw_rate_rad_s == pytest.approx(K * delta, rel=1e-3)
    # the default length is extended until 540 deg of heading change
    assert abs(res["psi"][0][-1]) >= 3 * math.pi
    # the approach speed defaults to the model's vessel.speed
    assert run_turning(MODEL, 20.0)[1].tactical_diameter_m == m.tactical_diameter_m


def test_run_zigzag_extends_to_four_reversals_and_port_mirror():
    _, stbd = run_zigzag(MODEL, 10.0, 10.0, u0=U)
    assert len(stbd.reversal_times_s) >= 4 and len(stbd.overshoot_deg) >= 3
    _, port = run_zigzag(MODEL, 10.0, 10.0, first=-1, u0=U)
    assert port.first_side == "port"
    assert port.overshoot_deg[:3] == pytest.approx(stbd.overshoot_deg[:3], abs=1e-9)
    # a given t_end is kept: 8 s show the first reversal only
    res, short = run_zigzag(MODEL, 10.0, 10.0, t_end=8.0, u0=U)
    assert res.t[-1] == pytest.approx(8.0) and len(short.reversal_times_s) < 4


def test_run_course_and_defaults():
    _, m = run_course(MODEL, controller="pid", noise_deg=0.0, t_end=60.0, u0=U)
    assert list(m) == ["itae", "iae", "max_rudder_deg"]
    assert m["max_rudder_deg"] == pytest.approx(35.0)  # a 100 deg step saturates the rudder
    with pytest.raises(UsvidError, match="pid"):
        run_course(MODEL, controller="pd", ki=0.1, u0=U)
    # 20 T + 40 L / U = 40 + 100 s; a crawling vessel is capped
    assert default_t_end(MODEL, U) == pytest.approx(140.0)
    assert default_t_end(MODEL, 1e-6) == MAX_T_END


def test_run_bad_angles_and_divergence():
    with pytest.raises(SimulationError, match="delta_deg"):
        run_turning(MODEL, 0.0, u0=U)
    with pytest.raises(SimulationError, match="psi_deg"):
        run_zigzag(MODEL, 10.0, 200.0, u0=U)
    with pytest.raises(UsvidError, match="u0"):
        run_zigzag(MODEL, 10.0, 10.0, u0=-1.0)
    # sway mode d22/m22 = 3.5 1/s: RK4 is unstable for dt * 3.5 > 2.79, so dt = 1 s diverges
    tdof = VesselModel(ThreeDOF(m11=2652.5, m22=2825.6, m33=4201.7, d11=848.1, d22=9889.5,
                                d33=22721.6, x_l=3.5, thrust=4000.0),
                       servo=IdealServo(), vessel=Vessel(length=7.02, speed=4.7))
    with pytest.raises(SimulationError, match="diverged"):
        run_course(tdof, t_end=20.0, dt=1.0, u0=4.7)
