"""The seed papers' headline numbers, reproduced or explained (README "Reproducing the papers":
every number of that table is asserted here)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from usvid.control import nomoto_equivalent
from usvid.errors import UsvidError
from usvid.io.modelfile import load_model
from usvid.models import Catamaran, VesselModel
from usvid.models.propulsion import (
    effective_thrust,
    heckscher_twin_screw,
    open_water_coefficient,
    open_water_efficiency,
    open_water_thrust,
    propeller_torque,
)
from usvid.models.response_params import (
    norrbin_alpha,
    second_order_nonlinear_rhs,
    threedof_response,
)
from usvid.sim import Commanded, simulate
from usvid.sim.runs import run_course, run_turning, run_zigzag

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def lanxin3():
    return load_model(EXAMPLES / "lanxin_threedof.json")


def test_mu2018_eq29_closed_form_from_eq37(lanxin3):
    # eq. 37 (signs restored) at U = 10 kn = 5.1444 m/s; the thrust balances the surge
    # resistance (eq. 26: X0 + XP = 0): T = d11 U
    d, U = lanxin3.dynamics, 5.1444
    rp = threedof_response(d, U, d.d11 * U)
    # by hand in eq. 37's per-mass coefficients: C / (m22 m33) = 3.5 * 5.407752 -
    # 0.938753 * 0.041187 * U^2 = 17.90389; T1 T2 = 1 / 17.90389, T1 + T2 = (3.5 + 5.407752)
    # / 17.90389, T3 = m22 / d22 = 1 / 3.5
    c = 3.5 * 5.407752 - 0.938753 * 0.041187 * U**2
    assert rp.T1 * rp.T2 == pytest.approx(1 / c, rel=1e-4)  # eq. 37 printed to 4-7 digits
    assert rp.T1 + rp.T2 == pytest.approx(8.907752 / c, rel=1e-4)
    assert rp.T3 == pytest.approx(1 / 3.5, rel=1e-4)
    assert rp.course_stable
    # eq. 35's first-order T = T1 + T2 - T3: 0.212 s, not the 0.332 s eq. 38-40 print
    assert rp.T == pytest.approx(0.2118, abs=5e-4)
    # K = x_l T d22 / C: 0.7105 1/s with x_l = 3.5 m (not printed), close to the printed 0.707
    assert rp.K == pytest.approx(0.7105, abs=5e-4)
    # the same numbers from the simulator's own equations, linearised numerically
    eq = nomoto_equivalent(lanxin3)
    assert eq.T[0] == pytest.approx(rp.T, rel=1e-5) and eq.K[0] == pytest.approx(rp.K, rel=1e-5)


def test_mu2018_eq37_gives_a_negative_norrbin_alpha(lanxin3):
    # steady turns of the 3-DOF model at 5 .. 35 deg fitted with eq. 36, r + alpha r^3 = K delta
    degs = (5.0, 15.0, 25.0, 35.0)
    r = [run_turning(lanxin3, x)[1].steady_yaw_rate_rad_s for x in degs]
    K, alpha = norrbin_alpha(r, np.radians(degs))
    # the printed alpha = 1.102 (fitted to the measured turns) has the other sign: the model of
    # eq. 37 turns relatively faster at large angles (it slows down, the Munk moment drops)
    assert alpha == pytest.approx(-0.44, abs=0.02)  # the LS fit of four turns, 2 digits
    assert K == pytest.approx(0.719, abs=0.005)


def test_mu2018_eq34_second_order_nonlinear_response():
    # T1 T2 r'' + (T1 + T2) r' + r + alpha r^3 = K delta + K T3 delta', by hand at
    # T1 = 2, T2 = 0.5, T3 = 0.25, K = 0.7, alpha = 1.1, r = 0.2, r' = 0.1, delta = 0.3,
    # delta' = 0.4: r'' = (0.21 + 0.07 - 0.2 - 0.0088 - 0.25) / 1 = -0.1788
    assert second_order_nonlinear_rhs(0.2, 0.1, 0.3, 0.4, 0.7, 2.0, 0.5, 0.25, 1.1) == \
        pytest.approx(-0.1788, abs=1e-12)


def test_mu2016_podded_usv_turning_radius_and_zigzag_period():
    m = load_model(EXAMPLES / "pod_usv.json")
    _, t = run_turning(m, 5.0)
    # closed form of the Nomoto model: R = U / (K gain delta) = 4.6814 / (0.707 * 0.923 *
    # 5 deg) = 82.2 m; the paper's 85.76 m (simulated) needs U = 4.88 m/s (9.5 kn): the speed
    # is only given as about 9.1 kn
    R = 4.6814 / (0.707 * 0.923 * math.radians(5.0))
    assert t.steady_diameter_m / 2 == pytest.approx(R, rel=2e-3)  # circle fit on 0.02 s steps
    assert t.steady_diameter_m / 2 == pytest.approx(82.21, abs=0.05)
    assert 85.76 * 0.707 * 0.923 * math.radians(5.0) == pytest.approx(4.884, abs=1e-3)
    _, z = run_zigzag(m, 15.0, 15.0)
    # 15/15 period 14.3 s against 11.3 s (paper's simulation) and 12.9 s (measured): the
    # printed model (eq. 25, 27) is not self-consistent with eq. 23-24 (tests/test_d2c.py)
    assert z.period_s == pytest.approx(14.30, abs=0.02)


def test_mu2018_table3_itae_needs_horizon_and_intensity():
    m = load_model(EXAMPLES / "lanxin.json")
    calm = {c: run_course(m, controller=c, kp=0.7, ki=ki, kd=1.0, noise_deg=0.0,
                          t_end=100.0)[1]["itae"] for c, ki in (("pid", 0.00095), ("pd", 0.0))}
    # calm water, rad and s, horizon 100 s: PID 36.8 (Table 3: 37.98), PD 21.2 (38.6)
    assert calm["pid"] == pytest.approx(36.78, abs=0.05)
    assert calm["pd"] == pytest.approx(21.24, abs=0.05)
    # the PD value no longer grows after the transient (horizon-independent) ...
    assert run_course(m, controller="pd", noise_deg=0.0, t_end=60.0)[1]["itae"] == \
        pytest.approx(calm["pd"], abs=0.01)
    # ... the PID one does (the slow integrator): 26.1 over 60 s
    pid60 = run_course(m, controller="pid", noise_deg=0.0, t_end=60.0)[1]["itae"]
    assert pid60 == pytest.approx(26.06, abs=0.05)
    # with the 1 deg disturbance (seed 1, 100 s) the disturbance dominates: 130.1
    assert run_course(m, controller="pid", t_end=100.0, seed=1)[1]["itae"] == \
        pytest.approx(130.11, abs=0.05)


def _codes_turn(model):
    # the catamaran paper's stated conditions: codes 20 (port) / 15 (starboard), from rest
    t = np.array([0.0, 1.0])
    res = simulate(model, Commanded(t, n_port=np.array([20.0, 20.0]),
                                    n_stbd=np.array([15.0, 15.0])),
                   t_end=600.0, dt=0.05, u0=0.0)
    return res.turning_metrics()[0]


def test_catamaran_example_turns_at_the_papers_stated_diameter():
    m = load_model(EXAMPLES / "catamaran.json")
    tm = _codes_turn(m)
    # 7.38 m at 0.209 m/s simulated in the paper (about 8 m measured at 0.246 m/s); the
    # example's d11 and d33 were solved from that steady turn (the paper's tables are lost), so
    # this checks the calibration and the measurement (circle fit on 0.05 s steps: 0.1 %)
    assert tm.steady_diameter_m == pytest.approx(7.38, rel=2e-3)
    assert tm.steady_speed_m_s == pytest.approx(0.209, rel=2e-3)
    # the paper's symbol is each thruster's distance from the centreline: read as the spacing
    # b (usvid's former reading) the same 0.25 m halves the yaw moment and doubles the diameter
    d = m.dynamics.replace(arm=None, b=0.25)
    tm_b = _codes_turn(VesselModel(d, m.servo, m.vessel))
    assert tm_b.steady_diameter_m == pytest.approx(14.78, abs=0.02)
    assert d.half_spacing == 0.125 and m.dynamics.half_spacing == 0.25


def test_catamaran_arm_and_spacing_are_one_parameter():
    base = dict(m11=30.0, m22=45.0, m33=6.0, d11=8.0, d22=40.0, d33=1.6, thrust=0.05)
    a, b = Catamaran(**base, arm=0.25), Catamaran(**base, b=0.5)
    # tau_r = (T_p - T_s) arm: codes 20/15 at 0.05 N per code -> 0.25 N * 0.25 m
    assert a.tau(20.0, 15.0)[1] == pytest.approx(0.0625, rel=1e-12)
    assert b.tau(20.0, 15.0)[1] == pytest.approx(0.0625, rel=1e-12)
    Catamaran(**base, arm=0.25, b=0.5)  # consistent: accepted
    with pytest.raises(UsvidError, match="arm must be b/2"):
        Catamaran(**base, arm=0.5, b=0.5)
    with pytest.raises(UsvidError, match="parameters.arm"):
        Catamaran(**base)


def test_open_water_thrust_torque_and_heckscher_by_hand():
    # K_T = 0.3 - 0.25 J - 0.1 J^2 at J = 0.4: 0.3 - 0.1 - 0.016 = 0.184
    KT = open_water_coefficient(0.4, (0.3, -0.25, -0.1))
    assert KT == pytest.approx(0.184, abs=1e-12)
    KQ = open_water_coefficient(0.4, (0.04, -0.03, -0.01))  # 0.04 - 0.012 - 0.0016 = 0.0264
    assert KQ == pytest.approx(0.0264, abs=1e-12)
    # n = 10 rps, D = 0.1 m, rho = 1000: T = 1000 * 100 * 1e-4 * 0.184 = 1.84 N,
    # Q = 1000 * 100 * 1e-5 * 0.0264 = 0.0264 N m, eta_0 = 0.4 * 0.184 / (2 pi 0.0264)
    assert open_water_thrust(10.0, 0.1, KT, rho=1000.0) == pytest.approx(1.84, rel=1e-12)
    assert open_water_thrust(-10.0, 0.1, KT, rho=1000.0) == pytest.approx(-1.84, rel=1e-12)
    assert propeller_torque(10.0, 0.1, KQ, rho=1000.0) == pytest.approx(0.0264, rel=1e-12)
    assert open_water_efficiency(0.4, KT, KQ) == pytest.approx(0.4437, abs=1e-4)
    # Heckscher, twin screw, C_p = 0.6: w = 0.42 - 0.30 = 0.12, t = 0.30 - 0.18 = 0.12
    w, t = heckscher_twin_screw(0.6)
    assert (w, t) == (pytest.approx(0.12), pytest.approx(0.12))
    assert effective_thrust(10.0, t) == pytest.approx(8.8)
    assert heckscher_twin_screw(0.3) == (0.0, 0.0)  # slender: clipped at 0
    with pytest.raises(UsvidError, match="prismatic"):
        heckscher_twin_screw(1.2)
