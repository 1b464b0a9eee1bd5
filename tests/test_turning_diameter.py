"""Tests of usvid.models.turning_diameter: Ma et al. eq. 1-3 and its Tables 1-2 (package data)."""

from __future__ import annotations

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.models.turning_diameter import (
    MA_BOUNDS,
    MA_EQ3,
    TurningDiameterCoeffs,
    load_ma_table1,
    load_ma_table2,
    relative_turning_diameter,
    rms_objective,
    turning_diameter,
)


def test_eq3_rms_on_table2_reproduces_paper():
    # Acceptance: Ma et al. states F(eq. 3, Table 2) = 0.4665; computed 0.466495. Tolerance: half a
    # unit of the paper's last printed digit (5e-5).
    t2 = load_ma_table2()
    F = rms_objective(MA_EQ3, t2.Fr, t2.delta_rad, t2.DL_test)
    assert abs(F - 0.4665) < 5e-5


def test_delta_must_be_radians():
    # The same objective with delta in degrees is far off (D/L ~ 0.2 instead of ~ 7).
    t2 = load_ma_table2()
    F_deg = rms_objective(MA_EQ3, t2.Fr, np.rad2deg(t2.delta_rad), t2.DL_test)
    assert F_deg > 5.0


def test_eq3_reproduces_identified_column():
    # Table 2's "identification results" column is eq. 3 evaluated at unrounded inputs; our inputs
    # are Table 2's rounded ones (delta to 1e-3 rad: dDL/ddelta ~ 28 per rad -> up to ~0.014;
    # Fr to 1e-4). Observed max difference 0.0068; tolerance 0.01.
    t2 = load_ma_table2()
    pred = relative_turning_diameter(t2.Fr, t2.delta_rad, MA_EQ3)
    assert np.max(np.abs(pred - t2.DL_identified)) < 0.01


def test_relative_turning_diameter_by_hand():
    # Fr = 0.15, delta = 1 rad (so delta^a4 = 1): numerator 0.15 - 3.7937*0.0225 + 2.1316*0.003375
    #   = 0.15 - 0.08535825 + 0.00719415 = 0.0718359; D/L = 297.4084*0.0718359/(1 + 5.1594)
    #   = 21.3646001/6.1594 = 3.4686171
    assert relative_turning_diameter(0.15, 1.0) == pytest.approx(3.4686171, abs=1e-7)
    # simple coefficients a = (2, 0, 0, 1, 0): D/L = 2 Fr / delta
    a = TurningDiameterCoeffs(2.0, 0.0, 0.0, 1.0, 0.0)
    assert relative_turning_diameter(0.2, 0.5, a) == pytest.approx(0.8, abs=1e-12)
    # port/starboard symmetric, and D [m] = L * D/L with Fr = V/sqrt(g L)
    assert relative_turning_diameter(0.15, -1.0) == relative_turning_diameter(0.15, 1.0)
    V = 0.15 * np.sqrt(9.81 * 1.5)
    assert turning_diameter(V, 1.0, 1.5) == pytest.approx(1.5 * 3.4686171, abs=1e-6)


def test_batch_of_coefficient_sets():
    t2 = load_ma_table2()
    pop = np.stack([MA_EQ3.as_array(), MA_EQ3.as_array() * [1.0, 1, 1, 1, 1.1]])
    DL = relative_turning_diameter(t2.Fr, t2.delta_rad, pop)
    assert DL.shape == (2, 36)
    F = rms_objective(pop, t2.Fr, t2.delta_rad, t2.DL_test)
    assert F.shape == (2,)
    assert F[0] == pytest.approx(float(rms_objective(MA_EQ3, t2.Fr, t2.delta_rad,
                                                     t2.DL_test)), abs=1e-12)
    assert F[1] > F[0]  # perturbing the published optimum makes the fit worse


def test_table1_derives_table2_inputs():
    t1 = load_ma_table1()
    t2 = load_ma_table2()
    assert t1.turning_diameter_m.shape == (36,)
    Fr, delta, DL = t1.fit_inputs()
    # D/L = D/1.5 printed to 3 decimals; delta printed to 3 decimals: half a unit each.
    assert np.max(np.abs(DL - t2.DL_test)) <= 5e-4
    assert np.max(np.abs(delta - t2.delta_rad)) <= 5e-4
    # Fr printed to 4 decimals (half unit 5e-5); one speed (1.21 kn -> 0.162355) sits on a
    # rounding boundary, so allow 6e-5.
    assert np.max(np.abs(Fr - t2.Fr)) <= 6e-5


def test_published_coefficients_and_bounds():
    assert MA_EQ3.as_array() == pytest.approx([297.4084, -3.7937, 2.1316, 0.9707, 5.1594])
    for value, (lo, hi) in zip(MA_EQ3.as_array(), MA_BOUNDS, strict=True):
        assert lo <= value <= hi  # the published optimum lies inside the published GA bounds
    assert TurningDiameterCoeffs.from_array(MA_EQ3.as_array()) == MA_EQ3


def test_bad_coefficients_and_shapes_raise():
    with pytest.raises(UsvidError, match="last axis must hold a1..a5"):
        relative_turning_diameter(0.1, 0.5, [1.0, 2.0, 3.0])
    with pytest.raises(UsvidError, match="expected 5 values"):
        TurningDiameterCoeffs.from_array([1.0, 2.0])
    with pytest.raises(UsvidError, match="1-D arrays of equal length"):
        rms_objective(MA_EQ3, np.ones(3), np.ones(4), np.ones(3))
