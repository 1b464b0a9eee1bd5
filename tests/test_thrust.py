"""Tests of usvid.models.thrust by hand computations (Mu et al. 2018 sec. 3.1, seeds 001, 002)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.models.thrust import (
    MU2018_TABLE2,
    PodThrust,
    Propeller,
    TwinThrust,
    advance_ratio,
    froude_number,
    hollo_thrust_deduction,
    holtrop_c10,
    kt,
    kt_nb,
    lagrange_weights,
    pod_thrust_nb,
    propeller_thrust_nb,
    thrust_nb,
    thrust_row,
    wake_fraction,
)

# Decimal hand arithmetic below is exact to the digits written; 1e-9 only absorbs float rounding.
EXACT = 1e-9


def test_kt_at_table2_node_by_hand():
    # Point: J = 0.5, P/D = 1.0, theta = 0.8 (a node: Lagrange weights (0, 1, 0)), Table 2 column
    # theta = 0.8:
    #   A00                 = -0.0517
    #   A01 J   = -0.0315*0.5   = -0.01575
    #   A02 J^2 = -0.5822*0.25  = -0.14555
    #   A10 P   =  0.5853
    #   A20 P^2 = -0.1026
    #   A30 P^3 =  0
    #   A11 J P = -0.3381*0.5   = -0.16905
    #   A12 J^2 P = 0.6654*0.25 =  0.16635
    #   A21 J P^2 = 0.1417*0.5  =  0.07085
    #   A22 J^2 P^2 = -0.2215*0.25 = -0.055375
    #   sum = 0.282475
    assert kt(0.5, 1.0, 0.8) == pytest.approx(0.282475, abs=1e-4)  # acceptance tolerance
    assert kt(0.5, 1.0, 0.8) == pytest.approx(0.282475, abs=EXACT)


def test_lagrange_weights_between_nodes_by_hand():
    # theta = 0.65: (0.65-0.8)(0.65-1.1)/0.18 = 0.0675/0.18 = 0.375;
    # (0.65-0.5)(0.65-1.1)/(-0.09) = -0.0675/-0.09 = 0.75; (0.15)(-0.15)/0.18 = -0.125.
    w = lagrange_weights(0.65)
    assert [float(x) for x in w] == pytest.approx([0.375, 0.75, -0.125], abs=EXACT)
    # K_T(J=0, P/D=1) per column = A00 + A10 + A20 + A30:
    #   0.5: -0.1677 + 0.8042 - 0.1437 = 0.4928; 0.8: -0.0517 + 0.5853 - 0.1026 = 0.4310;
    #   1.1: -0.2191 + 0.8502 - 0.1080 = 0.5231 (A10 sign corrected, see MU2018_TABLE2)
    # K_T = 0.375*0.4928 + 0.75*0.4310 - 0.125*0.5231 = 0.1848 + 0.32325 - 0.0653875
    assert kt(0.0, 1.0, 0.65) == pytest.approx(0.4426625, abs=EXACT)


def test_bollard_kt_positive_for_all_disk_ratios():
    # Physics check of the A10 sign correction: a propeller at J = 0 pushes forward, and
    # K_T(J=0) of every B-series-like chart is 0.3-0.6 at P/D = 1 for disk ratios 0.5-1.1.
    th = np.linspace(0.5, 1.1, 13)
    k0 = kt(0.0, 1.0, th)
    assert np.all((k0 > 0.3) & (k0 < 0.6))


def test_lagrange_weights_partition_of_unity_and_nodes():
    th = np.linspace(0.3, 1.3, 41)
    w = np.stack(lagrange_weights(th))
    assert np.allclose(w.sum(axis=0), 1.0, atol=1e-12)  # float rounding only
    for k, node in enumerate((0.5, 0.8, 1.1)):
        assert np.allclose(np.stack(lagrange_weights(node)), np.eye(3)[k], atol=1e-12)


def test_kt_vectorised_broadcasts():
    J = np.linspace(0.0, 0.8, 5)
    P = np.array([[0.6], [1.0]])
    out = kt(J, P, 0.8)
    assert out.shape == (2, 5)
    assert out[1, 0] == pytest.approx(0.4310, abs=EXACT)  # J = 0, P/D = 1 column 0.8 (above)
    assert np.all(np.diff(out[1]) < 0)  # K_T falls with J: physics check of the table


def test_table2_has_ten_terms_per_disk_ratio():
    assert set(MU2018_TABLE2) == {0.5, 0.8, 1.1}
    assert all(len(row) == 10 for row in MU2018_TABLE2.values())


def test_propeller_thrust_by_hand():
    # D = 0.5 m, P/D = 1, theta = 0.8, t_P = 0.1, w_P = 0.2, n = 10 rps;
    # u chosen for J = 0.5: u = J n D / (1 - w_P) = 0.5*10*0.5/0.8 = 3.125 m/s.
    # T = (1 - 0.1) * 1025 * 10^2 * 0.5^4 * 0.282475 = 0.9*1025*100*0.0625*0.282475
    #   = 5765.625 * 0.282475 = 1628.66992... N
    p = Propeller(D=0.5, pitch_ratio=1.0, disk_ratio=0.8, t_P=0.1, w_P=0.2, rho=1025.0)
    assert p.advance_ratio(10.0, 3.125) == pytest.approx(0.5, abs=EXACT)
    assert p.thrust(10.0, 3.125) == pytest.approx(5765.625 * 0.282475, rel=1e-12)


def test_propeller_zero_shaft_speed_gives_zero_thrust_without_warning():
    p = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a division by zero would raise here
        T = p.thrust(np.array([0.0, 0.0, 40.0]), np.array([0.0, 5.0, 5.0]))
        J = advance_ratio(0.0, 5.0, 0.46)
    assert T[0] == 0.0 and T[1] == 0.0 and T[2] > 0.0
    assert J == 0.0
    assert propeller_thrust_nb(0.0, 5.0, 0.46, 0.3, 0.516, 0.05, 0.04, 1025.0) == 0.0


def test_propeller_negative_n_is_mirrored():
    p = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)
    assert p.thrust(-40.0, 3.0) == pytest.approx(-p.thrust(40.0, 3.0), rel=1e-12)


def test_numba_twins_match_vectorised():
    p = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04, rho=1025.0)
    for n, u in [(40.0, 5.144), (25.0, 2.0), (-30.0, 1.0), (10.0, -0.5), (0.0, 3.0)]:
        ref = float(p.thrust(n, u))
        got = propeller_thrust_nb(n, u, 0.46, 0.3, 0.516, 0.05, 0.04, 1025.0)
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-12)  # same arithmetic, float order
    for J, P, th in [(0.5, 1.0, 0.8), (0.0, 1.0, 0.65), (0.3, 0.3, 0.516)]:
        assert kt_nb(J, P, th) == pytest.approx(float(kt(J, P, th)), abs=1e-12)
    assert pod_thrust_nb(1.5, -4.0, 2.0, 3.0) == pytest.approx(-60.0, abs=EXACT)
    # random operating points, batch arguments: the vectorised class and the scalar twin agree
    rng = np.random.default_rng(7)
    n = rng.uniform(-50.0, 50.0, 200)
    u = rng.uniform(-1.0, 8.0, 200)
    th = rng.uniform(0.4, 1.2, 200)
    P = rng.uniform(0.3, 1.4, 200)
    batch = Propeller(D=0.46, pitch_ratio=P, disk_ratio=th, t_P=0.05, w_P=0.04).thrust(n, u)
    twin = [propeller_thrust_nb(a, b, 0.46, c, d, 0.05, 0.04, 1025.0)
            for a, b, c, d in zip(n, u, P, th, strict=True)]
    assert np.allclose(batch, twin, rtol=1e-12, atol=1e-9)  # float evaluation order only


def test_propeller_rejects_bad_parameters():
    with pytest.raises(UsvidError, match="propeller.D must be > 0"):
        Propeller(D=0.0, pitch_ratio=1.0, disk_ratio=0.8)
    with pytest.raises(UsvidError, match="propeller.t_P must be < 1"):
        Propeller(D=0.5, pitch_ratio=1.0, disk_ratio=0.8, t_P=1.0)
    with pytest.raises(UsvidError, match="propeller.w_P must be < 1"):
        Propeller(D=0.5, pitch_ratio=1.0, disk_ratio=0.8, w_P=1.2)
    with pytest.raises(UsvidError, match="finite"):
        Propeller(D=float("nan"), pitch_ratio=1.0, disk_ratio=0.8)


def test_holtrop_thrust_deduction_lanxin_by_hand():
    # Lanxin, Mu et al. 2018 Table 1: L 7.02, B 2.6, T 0.32, D_P 0.46; assumed C_P 0.71, lcb 0.
    # B/L = 0.370370; L/B = 2.7 < 5.2 -> C10 = 0.25 - 0.003328402/(0.370370 - 0.134615385)
    #   = 0.25 - 0.003328402/0.235755 = 0.25 - 0.0141181 = 0.2358819
    # C_P1 = 1.45*0.71 - 0.315 = 0.7145
    # t = 0.001979*7.02/(2.6*0.2855) + 1.0585*0.2358819 - 0.00524 - 0.1418*0.2116/0.832
    #   = 0.0187156 + 0.2496810 - 0.00524 - 0.0360636 = 0.2270930
    assert holtrop_c10(7.02, 2.6) == pytest.approx(0.2358819, abs=1e-7)  # 7 digits by hand
    t = hollo_thrust_deduction(7.02, 2.6, 0.32, 0.46, C_P=0.71, lcb=0.0, C_stern=0.0)
    assert t == pytest.approx(0.2270930, abs=1e-6)  # hand sum of 7-digit terms
    # stern-shape term: +0.0015 * C_stern exactly
    t_u = hollo_thrust_deduction(7.02, 2.6, 0.32, 0.46, C_P=0.71, C_stern=10.0)
    assert t_u - t == pytest.approx(0.015, abs=EXACT)


def test_holtrop_c10_slender_branch():
    # L/B = 100/15 = 6.67 > 5.2 -> C10 = B/L = 0.15
    assert holtrop_c10(100.0, 15.0) == pytest.approx(0.15, abs=EXACT)


def test_wake_fraction_lanxin_by_hand():
    # 10 kn = 5.14444 m/s; Fn = 5.14444/sqrt(9.81*7.02) = 5.14444/8.29865 = 0.619920
    # Delta_w = 0.1*(0.619920 - 0.2) = 0.0419920
    # 2.73^(1/3) = 1.397615; 0.165*0.6976*1.397615/0.46 = 0.3497197
    # w = 0.3497197 - 0.0419920 = 0.3077277
    Fn = froude_number(10 * 1852 / 3600, 7.02)
    assert Fn == pytest.approx(0.619920, abs=1e-6)
    assert wake_fraction(0.6976, 2.73, 0.46, Fn) == pytest.approx(0.3077277, abs=1e-6)
    # Fn <= 0.2: no correction; x = 2 (wing propellers) squares C_b
    assert wake_fraction(0.6976, 2.73, 0.46, 0.15) == pytest.approx(0.3497197, abs=1e-6)
    assert wake_fraction(0.6976, 2.73, 0.46, 0.15, x=2) == pytest.approx(0.3497197 * 0.6976,
                                                                          abs=1e-6)


def test_pod_thrust_by_hand():
    # c = 2, d = 3, V = 1.5 m/s, n = -4 rps: 2*1.5*(-4) + 3*4*(-4) = -12 - 48 = -60 N
    pod = PodThrust(c=2.0, d=3.0)
    assert pod.thrust(1.5, -4.0) == pytest.approx(-60.0, abs=EXACT)
    out = pod.thrust(np.array([0.0, 1.0]), np.array([2.0, 2.0]))  # 12, 4 + 12 = 16
    assert np.allclose(out, [12.0, 16.0], atol=EXACT)
    with pytest.raises(UsvidError, match="pod.c must be finite"):
        PodThrust(c=math.inf, d=1.0)


def test_twin_thrust_code_voltage_polynomial_by_hand():
    # T(U) = 2 U + 1.5 U^2 [N], U = 5 V * code / 120.
    tt = TwinThrust(coeffs=(0.0, 2.0, 1.5))
    # code 60 -> 2.5 V -> 5 + 9.375 = 14.375 N; code 150 clipped to 120 -> 5 V -> 10 + 37.5 = 47.5;
    # code -3 clipped to 0 -> 0 N
    assert tt.level(60.0) == pytest.approx(2.5, abs=EXACT)
    assert np.allclose(tt.thrust([60.0, 150.0, -3.0]), [14.375, 47.5, 0.0], atol=EXACT)
    # the catamaran paper eq. 26-27: tau_u = 47.5 + 14.375 = 61.875, tau_r = (47.5 - 14.375) 0.8/2 =
    # 13.25
    tau_u, tau_r = tt.combined(120.0, 60.0, b=0.8)
    assert tau_u == pytest.approx(61.875, abs=EXACT)
    assert tau_r == pytest.approx(13.25, abs=EXACT)
    for c in (60.0, 150.0, -3.0, 0.0, 119.5):
        assert thrust_nb(tuple(thrust_row(tt)), 0.0, c) == pytest.approx(float(tt.thrust(c)),
                                                                          abs=1e-12)


def test_twin_thrust_pwm_mapping_by_hand():
    # PWM: s = (pwm - 1500)/500 clipped to [-1, 1], dead band 25 us; forward 40 s^2, reverse 30 s^2.
    tt = TwinThrust(coeffs=(0.0, 0.0, 40.0), reverse_coeffs=(0.0, 0.0, 30.0), command="pwm",
                    pwm_deadband=25.0)
    pwm = np.array([1750.0, 1250.0, 1510.0, 2100.0, 900.0])
    # 1750: s=0.5 -> 10; 1250: s=-0.5 -> -30*0.25 = -7.5; 1510: dead band -> 0;
    # 2100: clipped s=1 -> 40; 900: clipped s=-1 -> -30
    assert np.allclose(tt.thrust(pwm), [10.0, -7.5, 0.0, 40.0, -30.0], atol=EXACT)
    for c in pwm:
        assert thrust_nb(tuple(thrust_row(tt)), 0.0, float(c)) == pytest.approx(float(tt.thrust(c)),
                                                                         abs=1e-12)


def test_twin_thrust_quadratic_helper():
    # T_max = 30 N at 5 V: coefficient 30/25 = 1.2 N/V^2; code 60 -> 2.5 V -> 7.5 N
    assert TwinThrust.quadratic(30.0).thrust(60.0) == pytest.approx(7.5, abs=EXACT)
    assert TwinThrust.quadratic(30.0, command="pwm").thrust(1250.0) == pytest.approx(-7.5,
                                                                                     abs=EXACT)


def test_twin_thrust_rejects_bad_input():
    with pytest.raises(UsvidError, match="command must be 'code' or 'pwm'"):
        TwinThrust(coeffs=(1.0,), command="volt")  # type: ignore[arg-type]
    with pytest.raises(UsvidError, match="coeffs must be a non-empty"):
        TwinThrust(coeffs=())
    with pytest.raises(UsvidError, match="code_max must be > 0"):
        TwinThrust(coeffs=(0.0, 1.0), code_max=0.0)
