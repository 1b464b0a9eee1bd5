"""Zig-zag logic of the batch simulator against an independent event-located reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from usvid.models import IdealServo, Nomoto1, VesselModel
from usvid.sim import ZigZag, simulate
from usvid.trial import Vessel

K, T, U = 0.707, 0.332, 5.144  # Mu et al. 2018 Nomoto (T/K read as in models.kinds.nomoto1), 10 kn


def reference_zigzag(amp: float, switch: float, first: int, t_end: float) -> list[float]:
    """Overshoots [deg] of a Nomoto-1 zig-zag by solve_ivp with the switches located as events
    (exact switching instants, rtol 1e-10) and the heading peaks located as r = 0 events."""
    cur = first
    y = np.array([0.0, 0.0])  # psi, r
    t0 = 0.0
    peaks: list[float] = []
    overs: list[float] = []
    n_rev = 0
    while t0 < t_end:
        c = cur

        def rhs(t, s, c=c):
            return [s[1], (K * c * amp - s[1]) / T]

        def switch_ev(t, s, c=c):
            return c * s[0] - switch

        switch_ev.terminal = True
        switch_ev.direction = 1

        def peak_ev(t, s):
            return s[1]

        sol = solve_ivp(rhs, (t0, t_end), y, events=(switch_ev, peak_ev), rtol=1e-10,
                        atol=1e-12, max_step=0.05)
        peaks += [abs(p[0]) for p in sol.y_events[1]]
        if n_rev >= 1 and sol.y_events[1].size:
            overs.append(math.degrees(abs(sol.y_events[1][0][0]) - switch))
        if sol.status != 1:
            break
        y = sol.y_events[0][0]
        t0 = sol.t_events[0][0]
        cur = -cur
        n_rev += 1
    return overs


@pytest.mark.parametrize(("amp_deg", "sw_deg", "first"), [(10, 10, 1), (20, 20, -1), (20, 10, 1)])
def test_zigzag_overshoots_match_event_reference(amp_deg, sw_deg, first):
    amp, sw = math.radians(amp_deg), math.radians(sw_deg)
    ref = reference_zigzag(amp, sw, first, 60.0)
    m = VesselModel(Nomoto1(K=K, T=T), servo=IdealServo(), vessel=Vessel(speed=U))
    res = simulate(m, ZigZag(amp, sw, first=first), t_end=60.0, dt=0.02)
    got = res.zigzag_metrics()[0].overshoot_deg
    n = min(len(ref), len(got), 6)
    assert n >= 4
    # The simulator samples the switching condition at the step start, so a reversal is late by
    # less than one step dt = 0.02 s; at the steady yaw rate K amp (<= 14.1 deg/s for 20 deg)
    # ... the heading gained meanwhile is < 0.02 * 7.1 = 0.14 deg for 10 deg rudder. 0.2 deg is
    # the acceptance tolerance of the brief; 20 deg rudder is checked at dt = 0.01 (same bound).
    if amp_deg == 20:
        res = simulate(m, ZigZag(amp, sw, first=first), t_end=60.0, dt=0.01)
        got = res.zigzag_metrics()[0].overshoot_deg
    np.testing.assert_allclose(got[:n], ref[:n], atol=0.2)
    # and the error shrinks with the step (the discrepancy is the switch sampling, not a bug)
    fine = simulate(m, ZigZag(amp, sw, first=first), t_end=60.0, dt=0.002).zigzag_metrics()[0]
    np.testing.assert_allclose(fine.overshoot_deg[:n], ref[:n], atol=0.03)
    assert res.zigzag_metrics()[0].first_side == ("starboard" if first > 0 else "port")


def test_zigzag_first_side_and_symmetry():
    m = VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=U))
    res = simulate(m, ZigZag(math.radians(10), math.radians(10), first=np.array([1, -1])),
                   t_end=30.0)
    # mirror image: psi(first=-1) = -psi(first=+1) exactly (same arithmetic with signs flipped)
    np.testing.assert_allclose(res["psi"][1], -res["psi"][0], atol=1e-12)
    np.testing.assert_allclose(res["delta_cmd"][0][:3], math.radians(10))
    np.testing.assert_allclose(res["delta_cmd"][1][:3], -math.radians(10))


def test_online_overshoots_agree_with_metrics():
    m = VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=U))
    res = simulate(m, ZigZag(math.radians(10), math.radians(10)), t_end=40.0)
    full = res.zigzag_metrics()[0].overshoot_deg
    online = np.degrees(res.zigzag_online["overshoot"][0])
    ok = np.isfinite(online)
    assert ok.sum() >= 3
    # online = sampled maximum (no peak interpolation): below the interpolated peak by at most
    # r_max^2 dt^2/(8 |r'|)-ish, well under 0.01 deg here
    np.testing.assert_allclose(online[ok], full[: ok.sum()], atol=0.01)
    rev = res.zigzag_online["reversal_t"][0]
    np.testing.assert_allclose(rev[1:4], res.zigzag_metrics()[0].reversal_times_s[:3], atol=0.021)


def test_zigzag_t_start_and_batch_of_amplitudes():
    m = VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=U))
    amps = np.radians([10.0, 20.0])
    res = simulate(m, ZigZag(amps, amps, t_start=2.0), t_end=40.0)
    assert res.batch_size == 2
    assert np.all(res["delta_cmd"][:, res.t < 2.0 - 1e-9] == 0.0)
    zm = res.zigzag_metrics()
    assert zm[1].overshoot_deg[0] > zm[0].overshoot_deg[0]  # bigger rudder, bigger overshoot
    assert zm[0].execute_time_s == pytest.approx(2.0)


def test_metrics_use_the_logic_reference_heading():
    # ZigZag(psi_ref=3 deg): the logic switches at 3 +- 10 deg; SimResult.zigzag_metrics
    # measures from the same reference, so its reversals are the logic's (event-located; linear
    # interpolation between 0.02-s samples of the curving heading errs by ~2e-4 s, a 3-deg
    # reference error would be ~0.5 s)
    m = VesselModel(Nomoto1(K=K, T=T), vessel=Vessel(speed=U))
    res = simulate(m, ZigZag(math.radians(10), math.radians(10), psi_ref=math.radians(3)),
                   t_end=40.0)
    rev = res.zigzag_online["reversal_t"][0]
    n = int(np.sum(np.isfinite(rev[1:])))
    assert n >= 3
    np.testing.assert_allclose(res.zigzag_metrics()[0].reversal_times_s[:n], rev[1:n + 1],
                               atol=1e-3)
