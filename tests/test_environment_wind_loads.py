"""Wind loads (usvid.models.environment.wind_loads): the coefficient models against published
table values and hand arithmetic, the sign conventions, the model selection, wind_scale, the
numba scalar against the array version, and the rudder equivalent of the response kinds."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.models.environment.wind import true_to_apparent
from usvid.models.environment.wind_loads import (
    AIR_DENSITY,
    BLENDERMANN_TYPES,
    WIND_PACK,
    fujiwara1998_fourier,
    rudder_equivalent,
    wind_coefficients,
    wind_load,
    wind_load_model,
    wind_load_true,
    wind_loads,
)
from usvid.trial import Vessel

DEG = math.pi / 180.0
ANGLES = np.array([0.0, 30.0, 90.0, 150.0, 180.0]) * DEG

#: Esso Osaka 3 m model windage (the laboratory's values: A_T, A_L as in the data README;
#: A_OD, C, H_C, C_BR, H_BR from the same source; L_OA 3.0 m, B 0.489 m).
ESSO = dict(length=3.0, beam=0.489, frontal_area=0.13544, lateral_area=0.52038,
            extra=dict(superstructure_area=0.14230, lateral_centroid_x=-0.01299,
                       lateral_centroid_height=0.10359, superstructure_x=-1.23339,
                       superstructure_height=0.2940))


def test_blendermann_speed_boat_against_table_and_hand_values():
    """Blendermann (1994) "speed boat" (C_Dt 0.90, C_Dl,AF 0.55 bow / 0.60 stern, delta 0.60,
    kappa 1.1) with A_T / A_L = 0.25. Wind from starboard (usvid angles 0..180 deg, clockwise):
    the published angle is the negative, so C_Y < 0 (pushed to port).

    angle | paper (table / hand)                 | usvid
      0   | C_X = -C_Dl,AF(0)  = -0.55 (table)     | see below
     30   | C_X -0.588496, C_Y -0.555985, C_N -0.104801 (hand: den = 1 - 0.3 * 0.847222 * 0.75
          | = 0.809375; C_X = -0.55 cos30 / den; C_Y = -0.45 / den; C_N = 0.18 pi/3 C_Y)
     90   | C_Y = -C_Dt = -0.90 (table), C_X 0, C_N 0, C_K = 1.1 * 0.5 * C_Y = -0.495
    150   | C_X 0.639526, C_Y -0.553846, C_N 0.104398 (hand: den = 1 - 0.3 * 0.833333 * 0.75
          | = 0.8125; C_X = 0.60 cos30 / den; C_Y = -0.45 / den; C_N = -0.18 pi/3 C_Y)
    180   | C_X = +C_Dl,AF(pi) = +0.60 (table)
    """
    m = wind_load_model(Vessel(length=2.0, frontal_area=0.1, lateral_area=0.4),
                        model="blendermann1994", vessel_type="speed_boat")
    cx, cy, cn, ck = wind_coefficients(m, ANGLES)
    paper_cx = [-0.55, -0.588496, 0.0, 0.639526, 0.60]
    paper_cy = [0.0, -0.555985, -0.90, -0.553846, 0.0]
    paper_cn = [0.0, -0.104801, 0.0, 0.104398, 0.0]
    # hand values carry 6 digits: 2e-6 absolute is their rounding
    np.testing.assert_allclose(cx, paper_cx, atol=2e-6)
    np.testing.assert_allclose(cy, paper_cy, atol=2e-6)
    np.testing.assert_allclose(cn, paper_cn, atol=2e-6)
    assert ck[2] == pytest.approx(-0.495, abs=1e-12)


def test_blendermann_every_type_reproduces_its_table_row():
    v = Vessel(length=10.0, frontal_area=5.0, lateral_area=20.0)
    for name, (cdt, bow, stern, _, _) in BLENDERMANN_TYPES.items():
        m = wind_load_model(v, model="blendermann1994", vessel_type=name)
        cx, cy, _, _ = wind_coefficients(m, np.array([0.0, -90.0, 180.0]) * DEG)
        # at 0, 90 and 180 deg the denominator is 1: the table values, exactly
        assert cx[0] == pytest.approx(-bow, abs=1e-12), name
        assert cy[1] == pytest.approx(cdt, abs=1e-12), name  # wind from port: to starboard
        assert cx[2] == pytest.approx(stern, abs=1e-12), name


def test_fujiwara1998_coefficients_for_the_esso_osaka_particulars():
    """The Fourier coefficients by hand arithmetic from the regression table (independent of the
    implementation's arrays), and the coefficients at the five angles.

    Ratios: B H_BR/A_T = 1.061474, C/H_C = -0.125398, A_OD/L^2 = 0.015811,
    A_L/(L B) = 0.354724, L H_C/A_L = 0.597198, L H_BR/A_L = 1.694915, A_OD/A_L = 0.273454,
    A_T/(L B) = 0.092324, L^2/A_T = 66.450089, L/H_C = 28.960324, ...
    """
    v = Vessel(**ESSO)
    m = wind_load_model(v)
    assert m.name == "fujiwara1998"
    c = m.coefficients
    X0 = -0.330 + 0.293 * 1.061474 + 0.0193 * (-0.125398) + 0.682 * 0.015811
    X1 = (-1.353 + 1.700 * 0.354724 + 2.870 * 0.597198 - 0.463 * 1.694915 - 0.570 * 0.273454
          - 6.640 * 0.092324 - 0.0123 * 66.450089 + 0.0202 * 28.960324)
    assert c["X0"] == pytest.approx(X0, abs=1e-5)  # 6-digit ratios: 1e-5 is their rounding
    assert c["X1"] == pytest.approx(X1, abs=1e-4)  # (L^2/A_T = 66.45 times 0.0123)
    direct = fujiwara1998_fourier(0.13544, 0.52038, 0.14230, -0.01299, -1.23339, 0.2940,
                                  0.10359, 3.0, 0.489)
    assert direct == pytest.approx(c)
    cx, cy, cn, ck = wind_coefficients(m, ANGLES)
    # C_X(0) = X0 + X1 + X3 + X5 (head wind, decelerates), C_Y(90 deg from starboard) =
    # -(Y1 - Y3 + Y5) (pushes to port)
    assert cx[0] == pytest.approx(c["X0"] + c["X1"] + c["X3"] + c["X5"], abs=1e-12)
    assert cx[4] == pytest.approx(c["X0"] - c["X1"] - c["X3"] - c["X5"], abs=1e-12)
    assert cy[2] == pytest.approx(-(c["Y1"] - c["Y3"] + c["Y5"]), abs=1e-12)
    # usvid's values for the report (published figure values for this ship are not available;
    # these are checked for plausibility: head-wind drag 0.5-0.9, beam side force 0.7-1.0)
    np.testing.assert_allclose(cx, [-0.6360, -0.7959, -0.0106, 0.7747, 0.6148], atol=1e-4)
    np.testing.assert_allclose(cy, [0.0, -0.3730, -0.7998, -0.3730, 0.0], atol=1e-4)
    np.testing.assert_allclose(cn, [0.0, -0.0114, 0.0267, 0.0858, 0.0], atol=1e-4)
    assert np.all(np.isnan(ck))  # Fujiwara's roll regression is not used


def test_sign_conventions_and_symmetry_of_both_models():
    for m in (wind_load_model(Vessel(**ESSO)),
              wind_load_model(Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52))):
        g = np.linspace(-np.pi, np.pi, 73)
        cx, cy, cn, _ = wind_coefficients(m, g)
        cx2, cy2, cn2, _ = wind_coefficients(m, -g)
        np.testing.assert_allclose(cx, cx2, atol=1e-12)  # even in the angle
        np.testing.assert_allclose(cy, -cy2, atol=1e-12)  # odd
        np.testing.assert_allclose(cn, -cn2, atol=1e-12)
        L = wind_loads(m, 5.0, np.array([0.0, 90.0, -90.0]) * DEG)
        assert L.X[0] < 0  # head wind pushes astern
        assert L.Y[1] < 0 < L.Y[2]  # wind from starboard pushes to port and vice versa
        # wind from the starboard quarter: the stern goes downwind, the bow to starboard
        assert wind_loads(m, 5.0, 150 * DEG).N > 0


def test_dimensional_loads_and_wind_scale():
    v = Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52)
    m = wind_load_model(v, wind_scale=1.0)
    q = 0.5 * AIR_DENSITY * 4.0**2
    cx, cy, cn, ck = wind_coefficients(m, 30 * DEG)
    L = wind_loads(m, 4.0, 30 * DEG)
    assert L.X == pytest.approx(q * 0.135 * cx, rel=1e-12)
    assert L.Y == pytest.approx(q * 0.52 * cy, rel=1e-12)
    assert L.N == pytest.approx(q * 0.52 * 3.0 * cn, rel=1e-12)
    assert L.K == pytest.approx(q * 0.52 * (0.52 / 3.0) * ck, rel=1e-12)
    # wind_scale multiplies every load (linear: identifiable), from the argument, the packed
    # vector or vessel.extra
    L2 = wind_loads(m.packed(wind_scale=0.7), 4.0, 30 * DEG)
    for a, b in ((L2.X, L.X), (L2.Y, L.Y), (L2.N, L.N), (L2.K, L.K)):
        assert a == pytest.approx(0.7 * b, rel=1e-12)
    v2 = Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52,
                extra={"wind_scale": 0.7, "air_density": 1.2})
    m2 = wind_load_model(v2)
    assert m2.wind_scale == 0.7 and m2.air_density == 1.2
    assert wind_loads(m2, 4.0, 30 * DEG).Y == pytest.approx(0.7 * 1.2 / AIR_DENSITY * L.Y)


def test_selection_says_which_and_why():
    m = wind_load_model(Vessel(**ESSO))
    assert m.name == "fujiwara1998" and "every particular" in m.reason
    v = Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52, beam=0.5)
    m = wind_load_model(v)
    assert m.name == "blendermann1994"
    assert "superstructure_area" in m.reason and "speed_boat" in m.reason
    assert any("lateral_centroid_x" in a for a in m.assumed)
    d = m.to_dict()
    assert d["model"] == "blendermann1994" and d["particulars"]["frontal_area"] == 0.135
    # forcing Blendermann on a vessel with every particular works too
    assert wind_load_model(Vessel(**ESSO), model="blendermann1994").name == "blendermann1994"


@pytest.mark.parametrize(("kwargs", "model", "match"), [
    (dict(length=3.0, lateral_area=0.5), "auto", "frontal_area"),
    (dict(frontal_area=0.1, lateral_area=0.5), "auto", "vessel.length"),
    (dict(length=3.0, frontal_area=0.1, lateral_area=0.5), "fujiwara1998", "superstructure_area"),
    (dict(length=3.0, frontal_area=-0.1, lateral_area=0.5), "auto", "frontal_area must be > 0"),
    (dict(length=3.0, frontal_area=0.1, lateral_area=0.5), "isherwood", "model must be"),
])
def test_missing_or_bad_particulars_are_named(kwargs, model, match):
    with pytest.raises(UsvidError, match=match):
        wind_load_model(Vessel(**kwargs), model=model)


def test_bad_type_scale_and_density_are_named():
    v = Vessel(length=3.0, frontal_area=0.1, lateral_area=0.5)
    with pytest.raises(UsvidError, match="vessel_type"):
        wind_load_model(v, vessel_type="yacht")
    with pytest.raises(UsvidError, match="wind_scale"):
        wind_load_model(v, wind_scale=-1.0)
    with pytest.raises(UsvidError, match="air_density"):
        wind_load_model(v, air_density=0.0)
    with pytest.raises(UsvidError, match="16 entries"):
        wind_loads(np.zeros(3), 1.0, 0.0)


def test_scalar_and_array_agree_and_calm_is_zero():
    m = wind_load_model(Vessel(**ESSO))
    p = m.packed()
    assert p.shape == (WIND_PACK,)
    rng = np.random.default_rng(3)
    s, a = rng.uniform(0, 10, 50), rng.uniform(-np.pi, np.pi, 50)
    L = wind_loads(m, s, a)
    for i in range(50):
        x, y, n, _ = wind_load(p, s[i], a[i])
        assert (x, y, n) == (L.X[i], L.Y[i], L.N[i])
    assert wind_load(np.zeros(WIND_PACK), 5.0, 0.3) == (0.0, 0.0, 0.0, 0.0)
    assert wind_load(p, 0.0, 0.3) == (0.0, 0.0, 0.0, 0.0)
    # a (batch, time) input keeps its shape
    assert wind_loads(m, np.ones((2, 3)), 0.1).Y.shape == (2, 3)


def test_true_wind_version_uses_the_wind_triangle():
    m = wind_load_model(Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52))
    p = m.packed()
    # heading east at 0.3 m/s over ground, 2 m/s true wind from the north
    x, y, n, k, va, ga = wind_load_true(p, 2.0, 0.0, 0.0, 0.3, math.pi / 2)
    va2, ga2 = true_to_apparent(2.0, 0.0, 0.0, 0.3, math.pi / 2)
    assert (va, ga) == pytest.approx((float(va2), float(ga2)), abs=1e-12)
    assert (x, y, n, k) == pytest.approx(wind_load(p, va, ga))
    assert y > 0  # the wind comes from port (north, heading east): pushed to starboard


def test_callable_from_compiled_code():
    """The core calls the scalar from its own numba code: check that this compiles."""

    @numba.njit
    def total_yaw_moment(p, speeds, angles):
        s = 0.0
        for i in range(speeds.shape[0]):
            s += wind_load(p, speeds[i], angles[i])[2]
        return s

    m = wind_load_model(Vessel(length=3.0, frontal_area=0.135, lateral_area=0.52))
    sp, an = np.array([1.0, 2.0]), np.array([0.5, -0.2])
    assert total_yaw_moment(m.packed(), sp, an) == pytest.approx(wind_loads(m, sp, an).N.sum())


def test_rudder_equivalent_by_hand():
    """m66 = I_z + J_z with I_z = m (0.25 L)^2 = 240 * 0.75^2 = 135 kg m^2 and J_z = I_z assumed
    (no beam, draft): 270 kg m^2. Nomoto K = 0.5 1/s, T = 10 s: N_delta = K m66 / T =
    13.5 N m/rad, so 1.35 N m is 0.1 rad of rudder."""
    v = Vessel(length=3.0, mass=240.0)
    eq = rudder_equivalent("nomoto1", {"K": 0.5, "T": 10.0}, v)
    assert eq.m66 == pytest.approx(270.0)
    assert eq.N_delta == pytest.approx(13.5)
    assert 1.35 * eq.gain == pytest.approx(0.1)
    assert any("J_z = I_z" in a for a in eq.assumed)
    # Norrbin: the same inertia term; Nomoto 2nd order: T1 + T2 - T3 = 9 s
    assert rudder_equivalent("norrbin", {"K": 0.5, "T": 10.0, "n1": 1, "n3": 0.2},
                             v).N_delta == pytest.approx(13.5)
    assert rudder_equivalent("nomoto2", {"K": 0.5, "T1": 10.0, "T2": 2.0, "T3": 3.0},
                             v).T_eff == pytest.approx(9.0)
    # given yaw inertia and full particulars: I_z from the vessel, J_z from the regression
    v2 = Vessel(length=3.0, beam=0.489, draft=0.201, mass=244.6,
                extra={"yaw_inertia": 140.0})
    eq2 = rudder_equivalent("nomoto1", {"K": 0.5, "T": 10.0}, v2)
    assert 140.0 < eq2.m66 < 2 * 140.0 and not eq2.assumed


def test_rudder_equivalent_refuses_what_it_cannot_do():
    v = Vessel(length=3.0, mass=240.0)
    with pytest.raises(UsvidError, match="not a response kind"):
        rudder_equivalent("mmg", {}, v)
    with pytest.raises(UsvidError, match="lack T"):
        rudder_equivalent("nomoto1", {"K": 0.5}, v)
    with pytest.raises(UsvidError, match="yaw inertia"):
        rudder_equivalent("nomoto1", {"K": 0.5, "T": 1.0}, Vessel(length=3.0))
    with pytest.raises(UsvidError, match="time constant"):
        rudder_equivalent("nomoto2", {"K": 0.5, "T1": 1.0, "T2": 1.0, "T3": 3.0}, v)
