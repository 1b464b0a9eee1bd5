"""Tests of usvid.models.hull (Clarke et al. 1983, Soding 1982, Zhou et al. 1983) by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.models.hull import (
    LANXIN,
    AddedMass,
    HullParticulars,
    clarke83_added_mass,
    clarke83_damping,
    soding_surge_added_mass,
    zhou_added_mass,
)

# Test hull with round ratios: L 100, B 20, T 5, Cb 0.75 -> B/T = 4, B/L = 0.2, T/L = 0.05,
# S = pi (T/L)^2 = 0.0025 pi. rho = 1000 keeps the dimensional factors round.
L, B, T, CB, RHO = 100.0, 20.0, 5.0, 0.75, 1000.0
S = math.pi * 0.0025
# Bracketed terms are hand arithmetic exact in decimals; 1e-12 relative is float rounding only.
REL = 1e-12


def test_clarke83_added_mass_by_hand():
    #   -Y_vdot'/S = 1 + 0.16*0.75*4 - 5.1*0.04 = 1 + 0.48 - 0.204 = 1.276
    #   -Y_rdot'/S = 0.67*0.2 - 0.0033*16 = 0.134 - 0.0528 = 0.0812
    #   -N_vdot'/S = 1.1*0.2 - 0.041*4 = 0.22 - 0.164 = 0.056
    #   -N_rdot'/S = 1/12 + 0.017*0.75*4 - 0.33*0.2 = 1/12 + 0.051 - 0.066 = 1/12 - 0.015
    # Dimensional: rho/2 L^3 = 5e8 (Y_vdot), rho/2 L^4 = 5e10 (Y_rdot, N_vdot), rho/2 L^5 = 5e12.
    am = clarke83_added_mass(L, B, T, CB, rho=RHO)
    assert am.Y_vdot == pytest.approx(-S * 1.276 * 5e8, rel=REL)
    assert am.Y_rdot == pytest.approx(-S * 0.0812 * 5e10, rel=REL)
    assert am.N_vdot == pytest.approx(-S * 0.056 * 5e10, rel=REL)
    assert am.N_rdot == pytest.approx(-S * (1 / 12 - 0.015) * 5e12, rel=REL)
    # Soding surge: volume = 0.75*100*20*5 = 7500 m^3; A11 = 2.7 rho V^(5/3) / L^2.
    # A11/m = 2.7 V^(2/3)/L^2 = 2.7 * 383.15472 / 1e4 = 0.1034518 (7500^(2/3) = 383.15472)
    assert -am.X_udot / (RHO * 7500.0) == pytest.approx(0.1034518, abs=1e-7)
    am10 = clarke83_added_mass(L, B, T, CB, rho=RHO, surge="ten_percent")
    assert am10.X_udot == pytest.approx(-0.1 * RHO * 7500.0, rel=REL)


def test_clarke83_dimensionalisation_matches_fossen_transform():
    # Independent route (Fossen 2021 App. D, as in MSS clarke83): M_A = rho/2 L^3 Ti Ti T MA' Ti
    # with T = diag(1, 1, 1/L), Ti = diag(1, 1, L), MA' the non-dimensional matrix.
    Lq, Bq, Tq, Cbq = 7.02, 2.6, 0.32, 0.6976
    Sq = math.pi * (Tq / Lq) ** 2
    MAp = np.array([[0.0, 0.0, 0.0],
                    [0.0, Sq * (1 + 0.16 * Cbq * Bq / Tq - 5.1 * (Bq / Lq) ** 2),
                     Sq * (0.67 * Bq / Lq - 0.0033 * (Bq / Tq) ** 2)],
                    [0.0, Sq * (1.1 * Bq / Lq - 0.041 * Bq / Tq),
                     Sq * (1 / 12 + 0.017 * Cbq * Bq / Tq - 0.33 * Bq / Lq)]])
    Tm, Ti = np.diag([1, 1, 1 / Lq]), np.diag([1, 1, Lq])
    MA = 0.5 * 1025 * Lq ** 3 * Ti @ Ti @ Tm @ MAp @ Ti
    got = clarke83_added_mass(Lq, Bq, Tq, Cbq).matrix()
    assert np.allclose(got[1:, 1:], MA[1:, 1:], rtol=1e-12, atol=0)  # float rounding only


def test_clarke83_damping_by_hand():
    #   -Y_v'/S = 1 + 0.4*0.75*4 = 2.2
    #   -Y_r'/S = -0.5 + 2.2*0.2 - 0.08*4 = -0.5 + 0.44 - 0.32 = -0.38
    #   -N_v'/S = 0.5 + 2.4*0.05 = 0.62
    #   -N_r'/S = 0.25 + 0.039*4 - 0.56*0.2 = 0.25 + 0.156 - 0.112 = 0.294
    # U = 2: rho/2 U = 1000; times L^2 = 1e4, L^3 = 1e6, L^4 = 1e8.
    d = clarke83_damping(2.0, L, B, T, CB, rho=RHO)
    assert d.Y_v == pytest.approx(-S * 2.2 * 1e3 * 1e4, rel=REL)
    assert d.Y_r == pytest.approx(S * 0.38 * 1e3 * 1e6, rel=REL)
    assert d.N_v == pytest.approx(-S * 0.62 * 1e3 * 1e6, rel=REL)
    assert d.N_r == pytest.approx(-S * 0.294 * 1e3 * 1e8, rel=REL)


def test_zhou_added_mass_by_hand():
    # L/B = 5, d/B = 0.25, Cb = 0.75, m = 1 kg (ratios):
    # 100 m_x/m = 0.398 + 11.97*0.75*(1 + 0.9325) - 2.89*0.75*5*(1 + 0.2825)
    #             + 0.175*0.75*25*(1 + 0.13525) - 1.107*5*0.25
    #           = 0.398 + 17.34901875 - 13.89909375 + 3.7250390625 - 1.38375 = 6.1892140625
    # m_y/m = 0.882 - 0.54*0.75*0.6 - 0.156*(1 - 0.50475)*5 + 0.826*1.25*(1 - 0.1695)
    #         - 0.638*0.75*1.25*(1 - 0.16725)
    #       = 0.882 - 0.243 - 0.386295 + 0.85749125 - 0.49808859375 = 0.61210765625
    # k_zz = 100/100 * (33 - 76.85*0.75*(1 - 0.588) + 3.43*5*(1 - 0.4725))
    #      = 33 - 23.74665 + 9.046625 = 18.299975 m;  J_zz/m = k_zz^2
    z = zhou_added_mass(L, B, T, CB, 1.0)
    assert z.m_x == pytest.approx(0.061892140625, rel=REL)
    assert z.m_y == pytest.approx(0.61210765625, rel=REL)
    assert z.J_zz == pytest.approx(18.299975 ** 2, rel=REL)
    am = z.as_added_mass()
    assert am.X_udot == -z.m_x and am.N_rdot == -z.J_zz and am.Y_rdot == 0.0


def test_regressions_vectorise_over_arrays():
    Ls = np.array([50.0, 100.0, 150.0])
    z = zhou_added_mass(Ls, B, T, CB, 1.0)
    c = clarke83_added_mass(Ls, B, T, CB, rho=RHO)
    assert np.shape(z.m_y) == (3,) and np.shape(c.N_rdot) == (3,)
    assert z.m_y[1] == pytest.approx(0.61210765625, rel=REL)
    assert c.Y_vdot[1] == pytest.approx(-S * 1.276 * 5e8, rel=REL)


def test_clarke_and_zhou_agree_roughly_on_sway_added_mass_for_lanxin():
    # Two independent regressions of the same physics: for the Lanxin they agree within 10 %
    # (computed: Clarke -Y_vdot = 1397 kg, Zhou m_y = 1320 kg with m = 1025*2.73 kg).
    c = clarke83_added_mass(LANXIN.L, LANXIN.B, LANXIN.T, LANXIN.Cb)
    z = zhou_added_mass(LANXIN.L, LANXIN.B, LANXIN.T, LANXIN.Cb, 1025.0 * LANXIN.volume)
    assert abs(-c.Y_vdot - z.m_y) / z.m_y < 0.10


def test_inertia_terms_mu2018_eq15():
    am = AddedMass(X_udot=-10.0, Y_vdot=-20.0, Y_rdot=-3.0, N_vdot=-4.0, N_rdot=-50.0)
    got = am.inertia_terms(m=100.0, Iz=400.0, x_g=0.5)
    assert got == {"m11": 110.0, "m22": 120.0, "m23": 53.0, "m32": 54.0, "m33": 450.0}


def test_soding_and_particulars():
    assert soding_surge_added_mass(1.0, 1.0, rho=1000.0) == pytest.approx(2700.0, rel=REL)
    assert HullParticulars(L=2.0, B=1.0, T=0.5, Cb=0.5).displaced_volume == pytest.approx(0.5)
    assert LANXIN.displaced_volume == pytest.approx(2.73)


def test_bad_input_raises():
    with pytest.raises(UsvidError, match="clarke83.L must be > 0"):
        clarke83_added_mass(-1.0, B, T, CB)
    with pytest.raises(UsvidError, match="surge must be 'soding' or 'ten_percent'"):
        clarke83_added_mass(L, B, T, CB, surge="other")
    with pytest.raises(UsvidError, match="clarke83.U must be > 0"):
        clarke83_damping(0.0, L, B, T, CB)
    with pytest.raises(UsvidError, match="zhou.Cb must be finite"):
        zhou_added_mass(L, B, T, float("nan"), 1.0)
    with pytest.raises(UsvidError, match="hull.T must be > 0"):
        HullParticulars(L=1.0, B=1.0, T=0.0, Cb=0.5)
