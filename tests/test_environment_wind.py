"""The wind triangle (usvid.models.environment.wind) against hand-worked triangles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.models.environment.wind import (
    apparent_to_true,
    true_to_apparent,
    true_to_apparent_scalar,
)

# (true speed, true dir from, v_north, v_east, psi) -> (apparent speed, apparent angle from bow)
TRIANGLES = [
    # heading north at 5 m/s into a 10 m/s northerly: 15 m/s dead ahead
    (10.0, 0.0, 5.0, 0.0, 0.0, 15.0, 0.0),
    # heading north at 5 m/s, 5 m/s easterly: air relative (-5, -5) m/s, from the north-east,
    # 5 sqrt(2) = 7.0711 m/s at 45 deg on the starboard bow
    (5.0, math.pi / 2, 5.0, 0.0, 0.0, 5.0 * math.sqrt(2.0), math.pi / 4),
    # heading east at 10 m/s with a 4 m/s westerly behind: the vessel outruns the wind, which
    # then comes from dead ahead at 10 - 4 = 6 m/s
    (4.0, 1.5 * math.pi, 0.0, 10.0, math.pi / 2, 6.0, 0.0),
    # heading north but crabbing east at 3 m/s in calm air: 3 m/s from starboard abeam
    (0.0, 0.0, 0.0, 3.0, 0.0, 3.0, math.pi / 2),
    # heading west (270 deg) at 2 m/s, 2 m/s southerly: air relative (2, 2) m/s from the south-
    # west, i.e. 45 deg on the port bow: -pi/4, speed 2 sqrt(2)
    (2.0, math.pi, 0.0, -2.0, 1.5 * math.pi, 2.0 * math.sqrt(2.0), -math.pi / 4),
    # at rest, wind from astern (heading north, wind from south): +pi (not -pi)
    (3.0, math.pi, 0.0, 0.0, 0.0, 3.0, math.pi),
]


@pytest.mark.parametrize("vt,bt,vn,ve,psi,va,ga", TRIANGLES)
def test_hand_worked_triangles(vt, bt, vn, ve, psi, va, ga):
    s, a = true_to_apparent(vt, bt, vn, ve, psi)
    assert s == pytest.approx(va, abs=1e-12)  # exact arithmetic up to rounding
    assert a == pytest.approx(ga, abs=1e-12)
    s2, b2 = apparent_to_true(va, ga, vn, ve, psi)
    if vt > 0:
        assert s2 == pytest.approx(vt, abs=1e-12)
        assert b2 == pytest.approx(bt % (2 * math.pi), abs=1e-12)
    else:
        assert s2 == pytest.approx(0.0, abs=1e-12)


def test_round_trip_and_ranges():
    rng = np.random.default_rng(7)
    n = 10_000
    vt = rng.uniform(0.1, 20.0, n)
    bt = rng.uniform(0.0, 2 * math.pi, n)
    vn, ve = rng.normal(0.0, 5.0, (2, n))
    psi = rng.uniform(-4.0, 10.0, n)  # any heading, not only [0, 2 pi)
    va, ga = true_to_apparent(vt, bt, vn, ve, psi)
    assert np.all((ga > -math.pi) & (ga <= math.pi))
    vt2, bt2 = apparent_to_true(va, ga, vn, ve, psi)
    assert np.all((bt2 >= 0) & (bt2 < 2 * math.pi))
    # round trip to rounding (speeds up to ~40 m/s: 1e-9 is far above double rounding)
    np.testing.assert_allclose(vt2, vt, atol=1e-9)
    d = np.angle(np.exp(1j * (bt2 - bt)))
    np.testing.assert_allclose(d, 0.0, atol=1e-9)


def test_zero_speed_has_direction_zero():
    s, a = true_to_apparent(0.0, 1.0, 0.0, 0.0, 0.3)
    assert s == 0.0 and a == 0.0
    s, b = apparent_to_true(0.0, 1.0, 0.0, 0.0, 0.3)
    assert s == 0.0 and b == 0.0


def test_scalar_twin_matches_the_array_function():
    for vt, bt, vn, ve, psi, va, ga in TRIANGLES:
        s, a = true_to_apparent_scalar(vt, bt, vn, ve, psi)
        assert (s, a) == pytest.approx((va, ga), abs=1e-12)
    rng = np.random.default_rng(11)
    args = rng.uniform(0.1, 10, 200), rng.uniform(0, 7, 200), *rng.normal(0, 3, (2, 200)), \
        rng.uniform(-5, 5, 200)
    va, ga = true_to_apparent(*args)
    for i in range(200):
        assert true_to_apparent_scalar(*(a[i] for a in args)) == pytest.approx(
            (va[i], ga[i]), abs=1e-12)
    assert true_to_apparent_scalar(0.0, 0.0, 0.0, 0.0, 1.0) == (0.0, 0.0)
