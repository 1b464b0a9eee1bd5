"""Under way (usvid.prep.under_way): the one definition the identification's data check, the
manoeuvre detection's turning circles and the audit's rudder-sign check use."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import usvid.identify.checks as checks
import usvid.manoeuvres.detect as detect
import usvid.prep.channel_audit as channel_audit
from usvid.prep import prepare
from usvid.prep.under_way import MIN_MOVING_S, MIN_SPEED, moving, speed, under_way
from usvid.trial import Trial

T = np.round(np.arange(0.0, 100.0, 0.1), 10)  # 10 Hz, 1,000 samples


def _trial(**channels) -> Trial:
    return Trial(pd.DataFrame({"t": T, **channels}), name="uw")


def test_one_definition_everywhere():
    # the threshold and the verdict are the prep module's, imported, not redefined
    assert checks.MIN_SPEED is MIN_SPEED and channel_audit.MIN_SPEED is MIN_SPEED
    assert channel_audit.MIN_MOVING_S is MIN_MOVING_S
    assert checks.under_way is under_way and detect.under_way is under_way
    assert MIN_SPEED == 0.2


def test_a_logged_speed_wins_and_the_median_decides():
    # 1 m/s for the first 30 s, then 0.05 m/s (drifting): the median is 0.05 m/s, 30 s moving
    U = np.where(T < 30.0, 1.0, 0.05)
    uw = under_way(_trial(U=U, sog=np.ones_like(T), psi=np.zeros_like(T)))
    assert uw.source == "U" and uw.median_speed == pytest.approx(0.05)
    assert uw.moving_s == pytest.approx(30.0) and uw.is_under_way is False
    assert uw.reason() == ("its median speed is 0.05 m/s (U), below 0.2 m/s, above it for 30 s "
                           "of 100 s (under way needs 20 s and 25 %)")
    # for identification it made way: 30 s (at least 20 s) and 30 % (at least a quarter) above
    # 0.2 m/s, as a run from rest whose turns are slower; 20 s of 100 s is not
    assert uw.made_way is True
    short = under_way(_trial(U=np.where(T < 20.0, 1.0, 0.05), psi=np.zeros_like(T)))
    assert short.moving_s == pytest.approx(20.0) and short.made_way is False
    # over the first 30 s only (a mask on the grid)
    part = under_way(_trial(U=U, psi=np.zeros_like(T)), T < 30.0)
    assert part.is_under_way is True and part.median_speed == pytest.approx(1.0)
    assert "at least 0.2 m/s" in part.reason()
    # the audit's samples: the same threshold
    m = moving(prepare(_trial(U=U, psi=np.zeros_like(T)), derivatives=False))
    assert m.sum() == 300


def test_the_order_of_the_speed_sources():
    z = np.zeros_like(T)
    assert speed(_trial(sog=np.full_like(T, 2.0), u=z, v=z, psi=z))[1] == "sog"
    # body velocities: hypot(0.3, 0.4) = 0.5 m/s
    sp, src = speed(_trial(u=np.full_like(T, 0.3), v=np.full_like(T, 0.4), psi=z))
    assert src == "hypot(u, v)" and sp == pytest.approx(np.full_like(T, 0.5))
    sp, src = speed(_trial(u=np.full_like(T, -0.3), psi=z))
    assert src == "u" and sp == pytest.approx(np.full_like(T, 0.3))  # astern makes way too
    # only positions: north at 0.5 m/s (derived through the heading, or directly without one)
    x = 0.5 * T
    assert under_way(_trial(x=x, y=z, psi=z)).source == "U from the positions"
    for tr in (_trial(x=x, y=z, psi=z), _trial(x=x, y=z)):
        uw = under_way(tr)
        assert uw.median_speed == pytest.approx(0.5, abs=1e-9)  # a line: the derivative exact
        assert uw.is_under_way is True


def test_no_speed_at_all_is_unknown():
    z = np.zeros_like(T)
    uw = under_way(_trial(psi=z, delta=np.sin(T)))
    assert not uw.known and uw.is_under_way is None and uw.moving_s == 0.0
    assert uw.reason() == ("no speed (U, sog, u) and no positions: usvid cannot tell that the "
                           "vessel was under way")
    assert moving(prepare(_trial(psi=z), derivatives=False)) is None


def _spin(track_speed: float) -> Trial:
    """A vehicle turning at 9 deg/s for 60 s (540 deg) with no rudder logged (a turn found from
    the heading alone), after 20 s straight; on a circle at ``track_speed`` [m/s] (0: on the
    spot, the positions still with 2 cm of GNSS noise, seeded)."""
    t = np.round(np.arange(0.0, 80.0, 0.1), 10)
    r = np.where(t >= 20.0, math.radians(9.0), 0.0)
    psi = np.concatenate([[0.0], np.cumsum(0.1 * r[:-1])])
    rng = np.random.default_rng(4)
    x = np.cumsum(0.1 * track_speed * np.cos(psi)) + rng.normal(0, 0.02, t.size)
    y = np.cumsum(0.1 * track_speed * np.sin(psi)) + rng.normal(0, 0.02, t.size)
    return Trial(pd.DataFrame({"t": t, "x": x, "y": y, "psi": psi}), name="spin")


def test_a_turn_on_the_spot_is_no_turning_circle():
    """The heading alone turns 540 deg in both; at 1 m/s it is a circle of diameter
    2 U / r = 2 x 1 / (9 deg/s) = 12.7 m, on the spot it is none (and says why)."""
    from usvid.manoeuvres import find_manoeuvres, manoeuvre_findings, measured_metrics

    (m,) = measured_metrics(_spin(1.0))
    assert m["kind"] == "turning" and m["execute_from"] == "heading"
    assert m["steady_diameter_m"] == pytest.approx(2.0 / math.radians(9.0), rel=0.02)
    assert manoeuvre_findings(_spin(1.0)) == []
    still = _spin(0.0)
    assert find_manoeuvres(still) == [] and measured_metrics(still) == []
    (f,) = manoeuvre_findings(still)
    assert f.code == "turn_not_under_way" and f.data["speed_from"] == "U from the positions"
    assert f.data["median_speed_m_s"] < MIN_SPEED
    assert "the heading turns 5" in f.message and "not under way" in f.message
