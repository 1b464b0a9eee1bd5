"""The optional current states of the EKF + RTS smoother (usvid.prep.state_estimation,
``current=True``): the measurement and transition Jacobians against finite differences, a
steady turn in a current (the case a kinematic model can separate), a straight run (the case it
cannot: said by the correlation), the settings at the edge."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from usvid.prep import state_estimation as se
from usvid.trial import Trial


def _fd(f, s, eps=1e-6):
    cols = []
    for i in range(s.size):
        sp, sm = s.copy(), s.copy()
        sp[i] += eps
        sm[i] -= eps
        cols.append((f(sp) - f(sm)) / (2 * eps))
    return np.array(cols).T


STATE = np.array([3.0, -2.0, 0.7, 1.8, 0.25, 0.12, 0.05, -0.03, 0.01, 0.2, -0.15])


@pytest.mark.parametrize("j", [4, 5, 6, 7])
def test_measurement_jacobian_over_ground(j):
    """u, v, U, cog over ground with the current: the Jacobian row of the kernel equals the
    central difference of its prediction (tolerance 1e-7: the difference's error with a 1e-6
    step on these O(1) functions is ~1e-10)."""
    hv = np.empty(11)
    pred, _, ok = se._measure(j, STATE, hv, 0.1)
    assert ok

    def f(s):
        return np.array([se._measure(j, s, np.empty(11), 0.1)[0]])

    np.testing.assert_allclose(hv, _fd(f, STATE)[0], atol=1e-7)
    # the values by hand: ground velocity = rotated velocity through the water + current
    c, s = math.cos(0.7), math.sin(0.7)
    gx = 1.8 * c - 0.25 * s + 0.2
    gy = 1.8 * s + 0.25 * c - 0.15
    want = {4: gx * c + gy * s, 5: -gx * s + gy * c, 6: math.hypot(gx, gy),
            7: math.atan2(gy, gx)}[j]
    assert pred == pytest.approx(want, abs=1e-12)


def test_transition_jacobian_with_current():
    """The 11-state step: F equals the central difference of the step; the position moves by
    h times the current; Q adds q_c h on the current's diagonal."""
    h = 0.1
    q = np.array([1e-3, 2e-3, 1e-4, 5e-6])
    sn, F, Q = np.empty(11), np.empty((11, 11)), np.empty((11, 11))
    se._transition(STATE, h, q, sn, F, Q)

    def f(s):
        out = np.empty(11)
        se._transition(s, h, q, out, np.empty((11, 11)), np.empty((11, 11)))
        return out

    np.testing.assert_allclose(F, _fd(f, STATE), atol=1e-8)
    sn0 = np.empty(11)
    se._transition(np.concatenate([STATE[:9], [0.0, 0.0]]), h, q, sn0, F, Q)
    assert sn[0] - sn0[0] == pytest.approx(0.2 * h) and sn[1] - sn0[1] == pytest.approx(-0.15 * h)
    assert Q[9, 9] == pytest.approx(5e-6 * h) and Q[10, 10] == pytest.approx(5e-6 * h)


def _track(r: float, t_end: float, cn: float, ce: float, seed: int = 0) -> Trial:
    """A kinematic track: u = 2 m/s, v = 0.1 m/s through the water, yaw rate r, in a current
    (cn, ce) [m/s]; 10 Hz GNSS with 5 cm white noise, 0.3 deg compass, 0.2 deg/s gyro."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, t_end, 0.1)
    psi = 0.3 + r * t
    u, v = 2.0, 0.1
    if r:
        x = (u * np.sin(psi) + v * np.cos(psi)) / r
        y = (-u * np.cos(psi) + v * np.sin(psi)) / r
        x, y = x - x[0], y - y[0]
    else:
        x = (u * math.cos(0.3) - v * math.sin(0.3)) * t
        y = (u * math.sin(0.3) + v * math.cos(0.3)) * t
    x, y = x + cn * t, y + ce * t
    df = pd.DataFrame({"t": t, "x": x + rng.normal(0, 0.05, t.size),
                       "y": y + rng.normal(0, 0.05, t.size),
                       "psi": psi + rng.normal(0, math.radians(0.3), t.size),
                       "r": r + rng.normal(0, math.radians(0.2), t.size)})
    return Trial(df, name="track")


def test_steady_turn_separates_the_current():
    """Circles at 0.2 rad/s (11 deg/s, an agile USV) for 120 s in 0.3 m/s towards 045 deg:
    constant u, v through the water explain the trochoid exactly, the current-free alternative
    needs u, v oscillating with the heading (jerk 0.3 r^2), which the white-jerk prior rejects.
    Tolerance 0.03 m/s (10 % of the current); the interval covers the truth."""
    cn = ce = 0.3 / math.sqrt(2)
    est = se.estimate_states(_track(0.2, 120.0, cn, ce), current=True)
    c = est.current
    print(c)
    assert c["current_north"]["value"] == pytest.approx(cn, abs=0.03)
    assert c["current_east"]["value"] == pytest.approx(ce, abs=0.03)
    assert c["speed_m_s"] == pytest.approx(0.3, abs=0.03)
    for k, v in (("current_north", cn), ("current_east", ce)):
        lo, hi = c[k]["ci95"]
        assert lo < v < hi
    assert np.median(est["u"]) == pytest.approx(2.0, abs=0.03)  # through the water
    tr = est.to_trial()
    assert "current_north" in tr.channels and "current_east" in tr.channels
    assert est.info["q"]["q_c"] == se.Q_CURRENT and est.info["q_source"]["q_c"] == "default"


def test_straight_run_does_not_separate_the_current():
    """A straight run: the data see only u + the current along the track; the correlation says
    so (measured -1.00), and the interval stays about as wide as the prior (1 m/s std)."""
    est = se.estimate_states(_track(0.0, 120.0, 0.2, 0.0), current=True)
    c = est.current
    print(c)
    assert c["correlation"] < -0.95
    assert max(c["current_north"]["std_error"], c["current_east"]["std_error"]) > 0.3


def test_settings_at_the_edge():
    tr = _track(0.2, 30.0, 0.0, 0.0)
    with pytest.raises(se.StateEstimationError, match="current=True"):
        se.estimate_states(tr, q_c=1e-5)
    with pytest.raises(se.StateEstimationError, match="current_sd must be"):
        se.estimate_states(tr, current=True, current_sd=-1.0)
    assert se.estimate_states(tr).current is None
