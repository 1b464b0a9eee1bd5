"""Current (usvid.models.environment.current): body-frame current and water-relative velocity
against hand values (Fossen 2021, ch. 10.3), the round trip through the ground velocity."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.models.environment.current import (
    current_body,
    current_ned,
    ground_velocity,
    ground_velocity_scalar,
    water_relative_scalar,
    water_relative_velocity,
)

# (speed, towards, psi) -> (u_c, v_c) by hand
HAND = [
    (0.5, math.pi / 2, 0.0, 0.0, 0.5),  # heading north, current to the east: from port
    (0.5, math.pi / 2, math.pi / 2, 0.5, 0.0),  # heading east with it: all surge
    (0.5, 0.0, math.pi / 4, 0.5 * math.cos(-math.pi / 4), 0.5 * math.sin(-math.pi / 4)),
    (1.0, math.pi, 0.0, -1.0, 0.0),  # head current
]


@pytest.mark.parametrize(("V", "beta", "psi", "uc", "vc"), HAND)
def test_body_frame_current_by_hand(V, beta, psi, uc, vc):
    assert current_body(V, beta, psi) == pytest.approx((uc, vc), abs=1e-15)
    u_r, v_r = water_relative_velocity(2.0, 0.1, psi, V, beta)
    assert (u_r, v_r) == pytest.approx((2.0 - uc, 0.1 - vc), abs=1e-15)


def test_cross_current_drift_keeps_the_water_relative_speed():
    """Zero rudder, heading north at 1 m/s through the water in a 0.5 m/s current towards the
    east: over ground the vessel makes (1, 0.5) m/s, a 0.5 m/s drift; from that ground velocity
    the water-relative velocity is (1, 0) again."""
    vn, ve = ground_velocity_scalar(1.0, 0.0, 0.5, math.pi / 2, 0.0)
    assert (vn, ve) == pytest.approx((1.0, 0.5), abs=1e-15)
    # body velocity over ground at psi = 0 is (vn, ve)
    assert water_relative_scalar(vn, ve, 0.5, math.pi / 2, 0.0) == pytest.approx((1.0, 0.0),
                                                                                abs=1e-15)


def test_round_trip_arrays_and_shapes():
    rng = np.random.default_rng(5)
    shape = (3, 40)  # a batch of time series
    u_r, v_r, psi = rng.normal(size=shape), rng.normal(size=shape), rng.uniform(-7, 7, shape)
    V, beta = rng.uniform(0, 2, shape), rng.uniform(0, 2 * np.pi, shape)
    vn, ve = ground_velocity(u_r, v_r, psi, V, beta)
    assert vn.shape == shape
    c, s = np.cos(psi), np.sin(psi)
    u, v = c * vn + s * ve, -s * vn + c * ve  # body velocity over ground
    ur2, vr2 = water_relative_velocity(u, v, psi, V, beta)
    np.testing.assert_allclose(ur2, u_r, atol=1e-12)
    np.testing.assert_allclose(vr2, v_r, atol=1e-12)
    cn, ce = current_ned(V, beta)
    np.testing.assert_allclose(vn - (c * u_r - s * v_r), cn, atol=1e-12)
    np.testing.assert_allclose(ve - (s * u_r + c * v_r), ce, atol=1e-12)
    # constants broadcast against a series
    assert water_relative_velocity(np.zeros(5), 0.0, 0.0, 0.5, 0.0)[0].shape == (5,)
