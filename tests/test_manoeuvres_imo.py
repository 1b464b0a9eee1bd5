"""IMO MSC.137(76) criteria: limits computed by hand from the resolution's text."""

from __future__ import annotations

import math

import pytest

from usvid.errors import UsvidError
from usvid.manoeuvres.imo import (
    first_overshoot_limit_10_10,
    imo_turning_applies,
    imo_turning_check,
    imo_zigzag_check,
    second_overshoot_limit_10_10,
    zigzag_kind,
)
from usvid.manoeuvres.metrics import TurningMetrics, ZigZagMetrics


@pytest.mark.parametrize(
    "L,U,first,second",
    [
        (50.0, 10.0, 10.0, 25.0),  # L/U = 5 s < 10 s
        (100.0, 10.0, 10.0, 25.0),  # L/U = 10 s: the in-between formula starts, 5 + 5 = 10
        (200.0, 10.0, 15.0, 32.5),  # L/U = 20 s: 5 + 10 = 15; 17.5 + 15 = 32.5
        (299.0, 10.0, 19.95, 39.925),  # L/U = 29.9 s: 5 + 14.95; 17.5 + 22.425
        (300.0, 10.0, 20.0, 40.0),  # L/U = 30 s
        (7.02, 5.144, 10.0, 25.0),  # the Lanxin USV: L/U = 1.36 s
    ],
)
def test_overshoot_limits(L, U, first, second):
    assert first_overshoot_limit_10_10(L, U) == pytest.approx(first)
    assert second_overshoot_limit_10_10(L, U) == pytest.approx(second)


def test_turning_check_pass_and_fail():
    m = TurningMetrics(advance_m=30.0, transfer_m=15.0, tactical_diameter_m=36.0,
                       steady_diameter_m=30.0, steady_yaw_rate_rad_s=0.3, steady_speed_m_s=4.0)
    c = imo_turning_check(m, L=7.0)  # limits 31.5 m and 35 m
    d = {x.name: x for x in c.criteria}
    assert d["advance"].limit == pytest.approx(31.5) and d["advance"].passed is True
    assert d["tactical_diameter"].limit == pytest.approx(35.0)
    assert d["tactical_diameter"].passed is False
    assert c.passed is False
    assert imo_turning_check(m.to_dict(), L=8.0).passed is True  # 36 <= 40


def test_zigzag_check_10_10():
    m = ZigZagMetrics(overshoot_deg=[9.0, 26.0], period_s=20.0, initial_turning_time_s=3.0,
                      time_to_check_yaw_s=2.0)
    c = imo_zigzag_check(m, L=100.0, U=5.0, kind="10/10")  # L/U = 20 s: 15 deg and 32.5 deg
    d = {x.name: x for x in c.criteria}
    assert d["first_overshoot"].passed and d["first_overshoot"].limit == pytest.approx(15.0)
    assert d["second_overshoot"].passed and d["second_overshoot"].limit == pytest.approx(32.5)
    # distance from U * t = 15 m <= 2.5 L = 250 m
    assert d["initial_turning_distance"].value == pytest.approx(15.0)
    assert c.passed is True
    c2 = imo_zigzag_check({**m.to_dict(), "overshoot_deg": [16.0]}, L=100.0, U=5.0)
    d2 = {x.name: x for x in c2.criteria}
    assert d2["first_overshoot"].passed is False
    assert d2["second_overshoot"].passed is None and math.isnan(d2["second_overshoot"].value)
    assert c2.passed is False
    assert c2.to_dict()["criteria"][1]["passed"] is None


def test_zigzag_check_20_20_and_bad_kind():
    m = {"overshoot_deg": [24.0, 30.0]}
    assert imo_zigzag_check(m, 10.0, 2.0, "20/20").passed is True
    assert imo_zigzag_check({"overshoot_deg": [25.5]}, 10.0, 2.0, "20/20").passed is False
    with pytest.raises(UsvidError, match="10/10"):
        imo_zigzag_check(m, 10.0, 2.0, "15/15")
    with pytest.raises(UsvidError, match="length"):
        imo_turning_check({}, L=0.0)
    with pytest.raises(UsvidError, match="speed"):
        imo_zigzag_check(m, 10.0, -1.0)


def test_zigzag_kind():
    assert zigzag_kind(10, 10) == "10/10"
    assert zigzag_kind(20.0, 20.0) == "20/20"
    assert zigzag_kind(15, 15) is None


def test_imo_turning_check_judges_magnitudes():
    # a signed (negative) tactical diameter of 50 m on a 7 m vessel (limit 35 m) used to pass
    # because -50 <= 35
    c = imo_turning_check({"advance_m": -40.0, "tactical_diameter_m": -50.0}, L=7.0)
    assert [x.passed for x in c.criteria] == [False, False]
    assert c.criteria[1].value == 50.0


def test_imo_turning_applies_at_the_maximum_rudder_only():
    # MSC.137(76) 5.2.1: 35 deg, or the steering gear's limit when that is smaller
    d = math.radians
    assert imo_turning_applies(d(35.0), d(35.0)) and imo_turning_applies(d(-35.0), d(40.0))
    assert not imo_turning_applies(d(20.0), d(35.0))
    assert imo_turning_applies(d(25.0), d(25.0)) and imo_turning_applies(d(30.0), d(25.0))
    assert not imo_turning_applies(d(24.0), d(25.0))
