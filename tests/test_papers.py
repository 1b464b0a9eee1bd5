"""The seed papers' headline numbers, reproduced or explained: every usvid value that
docs/papers.md states is asserted here (tolerances with their reasons)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from usvid.control import nomoto_equivalent
from usvid.control.itae_reading import integral_effect, paired_itae
from usvid.errors import UsvidError
from usvid.identify.turning_diameter import fit_turning_diameter, load_turning_table
from usvid.identify.turning_diameter_interval import prediction_interval
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
from usvid.models.servo import IdealServo, SecondOrderServo
from usvid.models.turning_diameter import MA_BOUNDS, MA_EQ3, relative_turning_diameter
from usvid.sim import Commanded, simulate
from usvid.sim.runs import run_course, run_turning, run_zigzag

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
KNOT = 1852.0 / 3600.0


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
    # docs/papers.md: -0.431 (deterministic steady turns; 1e-3 is the printed rounding)
    assert alpha == pytest.approx(-0.431, abs=1e-3)
    assert K == pytest.approx(0.719, abs=1e-3)


def test_mu2018_eq34_second_order_nonlinear_response():
    # T1 T2 r'' + (T1 + T2) r' + r + alpha r^3 = K delta + K T3 delta', by hand at
    # T1 = 2, T2 = 0.5, T3 = 0.25, K = 0.7, alpha = 1.1, r = 0.2, r' = 0.1, delta = 0.3,
    # delta' = 0.4: r'' = (0.21 + 0.07 - 0.2 - 0.0088 - 0.25) / 1 = -0.1788
    assert second_order_nonlinear_rhs(0.2, 0.1, 0.3, 0.4, 0.7, 2.0, 0.5, 0.25, 1.1) == \
        pytest.approx(-0.1788, abs=1e-12)


def test_mu2016_turning_radius_under_eq25_as_printed():
    # R = U / (K g delta), g the servo gain 0.923; eq. 25 as printed: K = 225.9 / 332
    K25 = 225.9 / 332.0
    m = load_model(EXAMPLES / "pod_usv_eq25.json")
    assert m.dynamics.K == pytest.approx(K25, abs=5e-7)  # stored to 6 decimals
    assert m.dynamics.T == pytest.approx(106.8 / 332.0, abs=5e-7)
    R = 9.1 * KNOT / (K25 * 0.923 * math.radians(5.0))
    assert R == pytest.approx(85.42, abs=0.005)
    _, t = run_turning(m, 5.0)
    # docs/papers.md: 85.42 m (-0.40 % of 85.76 m); circle fit on 0.02 s steps within 0.1 %
    assert t.steady_diameter_m / 2 == pytest.approx(R, rel=1e-3)
    assert t.steady_diameter_m / 2 == pytest.approx(85.42, abs=0.01)
    assert abs(t.steady_diameter_m / 2 / 85.76 - 1) < 0.01  # the acceptance: within 1 %
    # the speed each reading needs for 85.76 m [kn]: eq. 25 9.14 (inside Table 1's
    # 8.91-9.21), the text's K = 0.707 9.49, eq. 24's 322 s term 9.42 (both outside)
    need = {K: 85.76 * K * 0.923 * math.radians(5.0) / KNOT
            for K in (K25, 0.707, 225.9 / 322.0)}
    assert list(need.values()) == [pytest.approx(v, abs=0.005) for v in (9.136, 9.493, 9.420)]
    # the text's reading (pod_usv.json): 82.21 m
    _, t707 = run_turning(load_model(EXAMPLES / "pod_usv.json"), 5.0)
    assert t707.steady_diameter_m / 2 == pytest.approx(82.21, abs=0.01)


def test_mu2016_zigzag_period_under_the_printed_parameter_sets():
    base = load_model(EXAMPLES / "pod_usv.json")

    def period(K=0.707, T=0.332, ideal=False, **servo):
        s = IdealServo() if ideal else SecondOrderServo(
            **{"omega_n": 0.958, "zeta": 0.811, "gain": 0.923, **servo})
        return run_zigzag(VesselModel(base.dynamics.replace(K=K, T=T), s, base.vessel),
                          15.0, 15.0)[1].period_s

    # docs/papers.md table (event-located switching: periods to 0.01 s at dt 0.02 s)
    assert run_zigzag(base, 15.0, 15.0)[1].period_s == pytest.approx(14.29, abs=0.01)
    assert period(omega_n=0.985) == pytest.approx(14.10, abs=0.01)
    assert period(gain=1.0) == pytest.approx(13.84, abs=0.01)
    assert period(ideal=True) == pytest.approx(6.99, abs=0.01)
    assert period(K=225.9 / 332, T=106.8 / 332) == pytest.approx(14.49, abs=0.01)
    # 11.3 s needs a servo about 1.8 times faster than printed (omega_n 1.69 rad/s)
    assert period(omega_n=1.69) == pytest.approx(11.3, abs=0.03)
    assert period(omega_n=1.20) == pytest.approx(12.9, abs=0.03)  # the measured period


def test_mu2016_discrete_models_eq23_eq26():
    # eq. 23's poles: one outside the unit circle (unstable), one negative real
    z = np.sort(np.roots([1.0, -0.9537, -0.5476, 0.007182]).real)
    assert z == pytest.approx([-0.4133, 0.0128, 1.3542], abs=5e-5)
    # eq. 27's servo is eq. 26's z-polynomial read as an s-polynomial
    wn = math.sqrt(0.9169)
    assert (wn, 1.553 / (2 * wn), 0.8464 / 0.9169) == (
        pytest.approx(0.9575, abs=5e-5), pytest.approx(0.8109, abs=5e-5),
        pytest.approx(0.9231, abs=5e-5))
    # eq. 24's constant -0.7904 puts a pole at +0.0025 rad/s; as the conversion of eq. 23's
    # 1.3542 it would need dt = ln(1.3542) / 0.0025 = 124 s
    s = np.roots([1.0, 14.26, 106.8, 322.0, -0.7904])
    p = float(s[np.argmin(np.abs(s))].real)
    assert p == pytest.approx(0.002455, abs=5e-6)
    assert math.log(1.3542) / p == pytest.approx(123.5, abs=0.5)


@pytest.fixture(scope="module")
def lanxin():
    return load_model(EXAMPLES / "lanxin.json")


def test_mu2018_table3_documented_reading(lanxin):
    # docs/papers.md: disturbance 0.75 deg, horizon 50 s, one realisation (seed 12), ITAE in
    # rad s^2 from the course order: PID 38.06, PD 38.55 (Table 3: 37.98, 38.6). Seeded noise
    # and fixed-step RK4: deterministic to rounding (5e-3 covers FMA/SIMD differences)
    itae = {c: run_course(lanxin, controller=c, noise_deg=0.75, t_end=50.0, seed=12)[1]["itae"]
            for c in ("pid", "pd")}
    assert itae["pid"] == pytest.approx(38.06, abs=5e-3)
    assert itae["pd"] == pytest.approx(38.55, abs=5e-3)
    assert itae["pid"] < itae["pd"]  # the paper's order
    assert abs(itae["pid"] / 37.98 - 1) < 0.1 and abs(itae["pd"] / 38.6 - 1) < 0.1
    # paired_itae runs the same realisation (seed s, stream 0) and the same trapezoid
    p = paired_itae(lanxin, noise_deg=0.75, seeds=[12], horizons=[30.0, 50.0])
    assert p.pid[0, 1] == pytest.approx(itae["pid"], rel=1e-9)
    assert p.pd[0, 1] == pytest.approx(itae["pd"], rel=1e-9)
    # the same reading on the 3-DOF model: PID 36.38 < PD 36.72
    m3 = load_model(EXAMPLES / "lanxin_threedof.json")
    p3 = paired_itae(m3, noise_deg=0.75, seeds=[12], horizons=[50.0])
    assert (p3.pid[0, 0], p3.pd[0, 0]) == (pytest.approx(36.38, abs=5e-3),
                                           pytest.approx(36.72, abs=5e-3))


def test_mu2018_table3_integral_term_in_calm_water(lanxin):
    ie = integral_effect(lanxin, [20.0, 30.0, 50.0, 60.0, 100.0])
    # the integral term adds at most 0.39 deg of rudder; it helps during the approach (PID -
    # PD -0.181 at 19.3 s) and then costs: +0.310, +2.919, +4.823, +15.534 (deterministic
    # calm runs: to 1e-3)
    assert math.degrees(ie.max_integral_rudder) == pytest.approx(0.39, abs=0.005)
    assert ie.min_difference == pytest.approx(-0.181, abs=1e-3)
    assert ie.t_min_difference == pytest.approx(19.3, abs=0.05)
    assert ie.difference[1:] == pytest.approx([0.310, 2.919, 4.823, 15.534], abs=1e-3)
    # the benefit B (bounds every seed-averaged gain): 0.550 < 0.62, the paper's gap
    assert ie.benefit[1:] == pytest.approx([0.550] * 4, abs=1e-3)
    assert ie.offset[-1] == pytest.approx(math.radians(-0.187), abs=math.radians(1e-3))
    # the old calm figures of this model: PID 36.78, PD 21.24 over 100 s
    p = paired_itae(lanxin, noise_deg=0.0, seeds=[1], horizons=[60.0, 100.0])
    assert p.pd[0] == pytest.approx([21.24, 21.24], abs=5e-3)
    assert p.pid[0] == pytest.approx([26.06, 36.78], abs=5e-3)
    # in degrees: the heading does not move during the 1 s dead time, so ITAE >= 50 deg s^2
    res, _ = run_course(lanxin, controller="pid", noise_deg=0.0, t_end=2.0)
    assert np.all(res["psi"][0][res.t <= 1.0] == 0.0)
    assert 100.0 * 1.0**2 / 2 > 1.1 * 38.6


def test_mu2018_table3_readings_excluded_in_calm_water(lanxin):
    # the printed "K = 0.332, T = 0.707": calm PD 52.86 (20 s), 53.4 from 30 s on (> 42.5)
    sw = VesselModel(lanxin.dynamics.replace(K=0.332, T=0.707), lanxin.servo, lanxin.vessel)
    p = paired_itae(sw, noise_deg=0.0, seeds=[1], horizons=[20.0, 30.0, 60.0])
    assert p.pd[0] == pytest.approx([52.86, 53.39, 53.42], abs=5e-3)
    # the integral as a sum of samples (ki / dt = 0.0475 1/s): PID 35.92, 50.14, 63.54 against
    # PD 20.28, 21.06, 21.24 over 20, 30, 60 s
    p = paired_itae(lanxin, noise_deg=0.0, seeds=[1], horizons=[20.0, 30.0, 60.0],
                    gains=(0.7, 0.00095 / 0.02, 1.0))
    assert p.pid[0] == pytest.approx([35.92, 50.14, 63.54], abs=5e-3)
    assert p.pd[0] == pytest.approx([20.28, 21.06, 21.24], abs=5e-3)
    # the sum of t_k |e_k| without dt: >= 50 x (1.745 rad x 1 s^2 / 2) = 43.6 > 42.5
    assert math.radians(100.0) / 2 / 0.02 == pytest.approx(43.6, abs=0.05)


def test_mu2018_table3_seed_averages(lanxin):
    # docs/papers.md family table (1000 realisations, common random numbers); the seeds are
    # fixed, so the numbers are deterministic (to rounding)
    seeds = np.arange(1, 1001)
    p = paired_itae(lanxin, noise_deg=0.75, seeds=seeds, horizons=[50.0])
    d = p.difference[:, 0]
    assert (p.pid.mean(), p.pd.mean()) == (pytest.approx(38.28, abs=5e-3),
                                           pytest.approx(38.06, abs=5e-3))
    assert d.mean() == pytest.approx(0.220, abs=1e-3)
    assert np.mean(d < 0) == pytest.approx(0.314, abs=1e-3)
    assert np.mean(-d >= 0.62) == pytest.approx(0.026, abs=1e-3)
    # at large noise and a short horizon the means tie (PID lower by 0.020 +- 0.007)
    p2 = paired_itae(lanxin, noise_deg=2.0, seeds=seeds, horizons=[30.0])
    d2 = p2.difference[:, 0]
    assert (p2.pid.mean(), p2.pd.mean()) == (pytest.approx(35.18, abs=5e-3),
                                             pytest.approx(35.20, abs=5e-3))
    assert d2.mean() == pytest.approx(-0.020, abs=1e-3)
    # the bound: no mean difference below -B = -0.55
    assert d.mean() > -0.55 and d2.mean() > -0.55


def _codes_turn(model):
    # the catamaran paper's stated conditions: codes 20 (port) / 15 (starboard), from rest
    t = np.array([0.0, 1.0])
    res = simulate(model, Commanded(t, n_port=np.array([20.0, 20.0]),
                                    n_stbd=np.array([15.0, 15.0])),
                   t_end=600.0, dt=0.05, u0=0.0)
    return res.turning_metrics()[0]


def test_catamaran_example_predicts_the_measured_turn():
    m = load_model(EXAMPLES / "catamaran.json")
    tm = _codes_turn(m)
    # the example carries the damping of the paper's model as its simulated turn shows it:
    # 7.38 m at 0.209 m/s by construction (circle fit on 0.05 s steps: 0.1 %)
    assert tm.steady_diameter_m == pytest.approx(7.38, rel=2e-3)
    assert tm.steady_speed_m_s == pytest.approx(0.209, rel=2e-3)
    # the prediction of the measured turn (about 8 m at 0.246 m/s): -0.61 m (-7.7 %), -15 %
    assert tm.steady_diameter_m - 8.0 == pytest.approx(-0.61, abs=0.005)
    assert 100 * (tm.steady_diameter_m / 8.0 - 1) == pytest.approx(-7.7, abs=0.05)
    assert 100 * (tm.steady_speed_m_s / 0.246 - 1) == pytest.approx(-15.0, abs=0.1)
    # once the paper's simulated steady turn is reproduced the assumed masses do not matter:
    # doubled, with d11 and d33 re-solved from the surge and yaw balances, 7.41 m
    d = m.dynamics
    u, r = 0.209, 2 * 0.209 / 7.38
    m11, m22 = 2 * d.m11, 2 * d.m22
    v = -m11 * u * r / d.d22
    tu, tr = d.tau(20.0, 15.0)
    d2 = d.replace(m11=m11, m22=m22, m33=2 * d.m33, d11=(tu + m22 * v * r) / u,
                   d33=((m11 - m22) * u * v + tr) / r)
    assert _codes_turn(VesselModel(d2, m.servo, m.vessel)).steady_diameter_m == \
        pytest.approx(7.41, abs=0.005)
    # matching the measured speed instead: 18 % more thrust per code -> 6.16 m
    k = 0.246 / 0.209
    tk = _codes_turn(VesselModel(d.replace(thrust=d.thrust * k), m.servo, m.vessel))
    assert tk.steady_diameter_m == pytest.approx(6.16, abs=0.005)
    # the paper's symbol is each thruster's distance from the centreline: read as the spacing
    # b (usvid's former reading) the same 0.25 m halves the yaw moment and doubles the diameter
    db = d.replace(arm=None, b=0.25)
    tm_b = _codes_turn(VesselModel(db, m.servo, m.vessel))
    assert tm_b.steady_diameter_m == pytest.approx(14.78, abs=0.02)
    assert db.half_spacing == 0.125 and m.dynamics.half_spacing == 0.25


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


def test_mu2018_lanxin_turning_at_10_deg():
    # Fig. 8: 1.5 m is 3.8 % of the measured radius -> 39.47 m; usvid at 10 deg (circle fit on
    # 0.02 s steps: 0.01 m)
    assert 1.5 / 0.038 == pytest.approx(39.47, abs=0.005)
    R = {k: run_turning(load_model(EXAMPLES / f"{k}.json"), 10.0)[1].steady_diameter_m / 2
         for k in ("lanxin_threedof", "lanxin", "lanxin_norrbin")}
    assert R["lanxin_threedof"] == pytest.approx(40.58, abs=0.01)
    assert R["lanxin"] == pytest.approx(5.1444 / (0.707 * math.radians(10.0)), rel=1e-3)
    assert R["lanxin"] == pytest.approx(41.69, abs=0.01)
    assert R["lanxin_norrbin"] == pytest.approx(42.37, abs=0.01)


def test_mu2018_thruster_arm_is_not_table1s_0_35_m(lanxin3):
    # Table 1's 0.35 m is x_g; as the thruster arm x_l it would make the 3-DOF model's K ten
    # times smaller (K proportional to x_l, eq. 33) and the 10 deg turn 410.9 m across
    d = lanxin3.dynamics.replace(x_l=0.35)
    U = 5.1444
    assert threedof_response(d, U, d.d11 * U).K == pytest.approx(0.07105, abs=5e-5)
    _, t = run_turning(VesselModel(d, lanxin3.servo, lanxin3.vessel), 10.0)
    assert t.steady_diameter_m / 2 == pytest.approx(410.9, abs=0.1)


@pytest.fixture(scope="module")
def ma_interval():
    # started from eq. 3 alone: the interval's own search finds the bounded optimum (the
    # least-squares fit of tests/test_fit_turning_diameter.py, F 0.43152)
    Fr, delta, DL = load_turning_table()
    fits = fit_turning_diameter(Fr, delta, DL, methods=["published_eq3"], loo=False)
    coeffs = {"published_eq3": MA_EQ3}
    return (Fr, delta, DL, fits,
            prediction_interval(Fr, delta, DL, 0.3, math.radians(10.0), coeffs),
            prediction_interval(Fr, delta, DL, 0.15, math.radians(25.0), coeffs))


def test_ma_extrapolation_interval(ma_interval):
    Fr, delta, DL, fits, out, inside = ma_interval
    # eq. 3 on Table 2: F 0.466495 (printed 0.4665), largest relative error 13.3 %
    assert fits["published_eq3"].F == pytest.approx(0.466495, abs=5e-7)
    assert fits["published_eq3"].max_rel_error == pytest.approx(0.133, abs=5e-4)
    # the bounded optimum F 0.43152 (a1, a3 on their bounds), found by the interval's own search
    assert math.sqrt(out.ssr_min / Fr.size) == pytest.approx(0.43152, abs=5e-6)
    assert out.a_opt[0] == pytest.approx(700.0) and out.a_opt[2] == pytest.approx(5.0)
    # docs/papers.md: at Fr 0.3, 10 deg the optimum 9.69, eq. 3 4.42, interval -1.90 .. 13.72
    # (the DE optimum to 1e-6 relative; 5e-3 is the printed rounding)
    assert not out.inside_data
    opt = float(relative_turning_diameter(0.3, math.radians(10.0), out.a_opt))
    assert opt == pytest.approx(9.69, abs=5e-3)
    assert out.by_fit["published_eq3"] == pytest.approx(4.42, abs=5e-3)
    assert (out.low, out.high) == (pytest.approx(-1.90, abs=5e-3), pytest.approx(13.72, abs=5e-3))
    # inside the tests it is narrow: 7.76 .. 8.10 around 7.92 at Fr 0.15, 25 deg
    assert inside.inside_data
    assert (inside.low, inside.high) == (pytest.approx(7.765, abs=5e-3),
                                         pytest.approx(8.10, abs=5e-3))
    # eq. 3 itself is outside the 95 % set: SSR 7.83 against the bound 7.46
    ssr3 = float(np.sum((relative_turning_diameter(Fr, delta, MA_EQ3) - DL) ** 2))
    assert ssr3 == pytest.approx(7.83, abs=5e-3) and out.ssr_limit == pytest.approx(7.46, abs=5e-3)


def test_ma_interval_ends_bound_every_admissible_fit(ma_interval):
    Fr, delta, DL, _, out, _ = ma_interval
    ssr = lambda a: np.sum((relative_turning_diameter(Fr, delta, a) - DL) ** 2, axis=-1)  # noqa: E731
    # the ends are admissible (SSR within the bound) and give the interval's values
    for a, v in ((out.a_low, out.low), (out.a_high, out.high)):
        assert ssr(a) <= out.ssr_limit * (1 + 1e-9)
        assert float(relative_turning_diameter(0.3, math.radians(10.0), a)) == pytest.approx(v)
    # no admissible coefficient set near the optimum or the ends predicts outside them
    lo, hi = np.asarray(MA_BOUNDS).T
    rng = np.random.default_rng(3)
    centres = np.stack([out.a_opt, out.a_low, out.a_high])
    A = np.clip(centres[rng.integers(0, 3, 20000)]
                + rng.normal(scale=0.01, size=(20000, 5)) * (hi - lo), lo, hi)
    ok = ssr(A) <= out.ssr_limit
    assert ok.sum() > 100  # the check has admissible samples to look at
    p = relative_turning_diameter(0.3, math.radians(10.0), A[ok])
    assert p.min() >= out.low - 1e-6 and p.max() <= out.high + 1e-6


def test_fit_turning_diameter_predict_options_go_together(capsys):
    from usvid.cli import main

    assert main(["fit-turning-diameter", "--predict-fr", "0.3"]) == 2
    assert "--predict-delta-deg" in capsys.readouterr().err
    assert main(["fit-turning-diameter", "--predict-fr", "0.3", "--predict-delta-deg", "10",
                 "--level", "1.5"]) == 2
    assert "--level" in capsys.readouterr().err


def test_shipped_examples_are_the_repository_examples():
    # usvid example NAME copies package data: the same files as examples/
    data = REPO / "src" / "usvid" / "data" / "examples"
    for f in sorted(data.glob("*.json")):
        assert f.read_bytes() == (EXAMPLES / f.name).read_bytes(), f.name


def test_papers_page_is_linked_from_the_readme():
    assert (REPO / "docs" / "papers.md").is_file()
    assert "docs/papers.md" in (REPO / "README.md").read_text(encoding="utf-8")
