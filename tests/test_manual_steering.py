"""A virtual "manually steered" campaign: free-running tests of a 3 m model in a pond, started
from rest, with small steering corrections (3-7 deg) before every rudder order and heading
glitches in the compass. Every manoeuvre must be found, its execute within 0.5 s, its switching
angle within 0.5 deg (any value, not a rounded standard one) and its metrics within 0.3 deg
(angles) or 2 % (times, lengths) of the truth measured on the noise-free record."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from usvid.manoeuvres import find_manoeuvres, measured_metrics, turning_metrics, zigzag_metrics
from usvid.sim import ZigZag, simulate
from usvid.trial import Trial, Vessel

L, U_MAX, T_U = 3.0, 1.5, 8.0  # length [m], top speed [m/s], surge time constant [s]
K_P, T_P = 0.8, 1.0  # non-dimensional Nomoto K' and T' (K = K' U/L, T = T' L/U)
RATE = math.radians(20.0)  # hand-held RC steering: 20 deg/s
H = 0.02  # integration step [s]
LOG_DT = 0.1  # 10 Hz logger
DEG = math.radians


def _corrections(rng, t_order):
    """Steering corrections before an order: 2-3 holds of 3-7 deg, alternating sides, over the
    12 s before ``t_order``."""
    out, t, side = [], t_order - 12.0, int(rng.choice([-1, 1]))
    while t < t_order - 1.0:
        dur = float(rng.uniform(1.5, 4.0))
        out.append((t, min(t + dur, t_order), side * DEG(float(rng.uniform(3.0, 7.0)))))
        t += dur
        side = -side
    a, _, v = out[-1]
    out[-1] = (a, t_order, v)  # the last correction is held until the order
    return out


def steer(kind, amp, sw, t_order, duration, side=1, seed=0, *, corr=None, bias=0.0, late=0.0):
    """Simulate one manually steered run from rest (Euler at 50 Hz, a loop: the helm's decisions
    depend on the heading); the helm orders the zig-zag's reversals exactly at the switching
    heading (the IMO definition of the switching angle), the third ``late`` [rad] beyond it.
    ``corr`` the corrections before the order ((start, end, rudder) [s, s, rad]; default
    :func:`_corrections`), ``bias`` [rad] a steady rudder-equivalent yaw moment (a beam wind:
    the helm holds ``-bias`` to keep the course). Returns (truth dict, logged Trial)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration / H)) + 1
    t = np.arange(n) * H
    u, r, psi, x, y, d = (np.zeros(n) for _ in range(6))
    corr = _corrections(rng, t_order) if corr is None else corr
    cmd, cur, psi0, nrev = 0.0, side, None, 0
    for k in range(n - 1):
        tk = t[k]
        if tk < t_order:
            cmd = next((v for a, b, v in corr if a <= tk < b), 0.0)
        else:
            if psi0 is None:
                psi0, cmd = psi[k], side * amp
            if kind == "zigzag" and cur * (psi[k] - psi0) >= sw + (late if nrev == 2 else 0.0):
                cur, nrev = -cur, nrev + 1
                cmd = cur * amp
        d[k + 1] = d[k] + float(np.clip(cmd - d[k], -RATE * H, RATE * H))
        us = max(u[k], 0.3)
        K, T = K_P * us / L, T_P * L / us
        u[k + 1] = u[k] + H * (U_MAX - u[k]) / T_U
        r[k + 1] = r[k] + H * (K * (d[k + 1] + bias) - r[k]) / T
        psi[k + 1] = psi[k] + H * r[k]
        x[k + 1] = x[k] + H * u[k] * math.cos(psi[k])
        y[k + 1] = y[k] + H * u[k] * math.sin(psi[k])
    truth = {"t": t, "psi": psi, "delta": d, "x": x, "y": y, "u": u}
    m = int(round(LOG_DT / H))
    sl = slice(0, n, m)
    tl = t[sl]
    psi_log = psi[sl] + rng.normal(0, DEG(0.1), tl.size)
    glitch = rng.choice(np.arange(20, tl.size - 20), size=6, replace=False)
    psi_log[glitch] += np.radians(rng.choice([-1, 1], 6) * np.array([1.0, 1.5, 2.0, 4.0, 6.0, 8.0]))
    data = pd.DataFrame({"t": tl, "psi": psi_log, "delta": d[sl] + rng.normal(0, DEG(0.1), tl.size),
                         "x": x[sl] + rng.normal(0, 0.02, tl.size),
                         "y": y[sl] + rng.normal(0, 0.02, tl.size), "U": u[sl]})
    return truth, Trial(data, vessel=Vessel(length=L), name=f"{kind}-{seed}")


# the campaign: 20/20 and 30/30 to both sides, a 20/13 (a switching angle no standard names)
# and a 30-deg turning circle, each ordered 15 s after the start from rest
CAMPAIGN = [("zigzag", 20, 20, 1, 1), ("zigzag", 20, 20, -1, 2), ("zigzag", 30, 30, 1, 3),
            ("zigzag", 30, 30, -1, 4), ("zigzag", 20, 13, 1, 5), ("turning", 30, None, 1, 6)]


@pytest.mark.parametrize("kind,amp,sw,side,seed", CAMPAIGN)
def test_manually_steered_manoeuvre_is_found_and_measured(kind, amp, sw, side, seed):
    t_order = 15.0
    dur = 110.0 if kind == "zigzag" else 100.0
    truth, trial = steer(kind, DEG(amp), DEG(sw or 0), t_order, dur, side, seed)
    segs = [s for s in find_manoeuvres(trial) if s.kind in ("zigzag", "turning")]
    assert [s.kind for s in segs] == [kind]  # found, and the corrections are no manoeuvre
    seg = segs[0]
    # the order (ramp start) within 0.5 s: the corrections before it are not the execute
    assert seg.t_execute == pytest.approx(t_order, abs=0.5)
    assert seg.side == side
    assert math.degrees(seg.level) == pytest.approx(amp, abs=0.3)
    ms = measured_metrics(trial)
    m = next(x for x in ms if x["kind"] == kind)
    assert m["heading_glitches"] >= 4  # the 1.5-8 deg glitches (the 1-deg one may hide in noise)
    if kind == "zigzag":
        assert math.degrees(seg.psi_switch) == pytest.approx(sw, abs=0.5)
        ref = zigzag_metrics(truth["t"], truth["psi"], truth["delta"], psi_switch=DEG(sw),
                             t_execute=t_order, first=side)
        n = min(3, len(ref.overshoot_deg))
        assert n >= 2
        np.testing.assert_allclose(m["overshoot_deg"][:n], ref.overshoot_deg[:n], atol=0.3)
        for key in ("period_s", "initial_turning_time_s"):
            assert m[key] == pytest.approx(getattr(ref, key), rel=0.02), key
    else:
        ref = turning_metrics(truth["t"], truth["x"], truth["y"], truth["psi"],
                              U=truth["u"], t_execute=t_order)
        for key in ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"):
            assert m[key] == pytest.approx(getattr(ref, key), rel=0.02), key


def test_zigzag_after_corrections_of_its_own_size_and_a_late_reversal():
    """A pond run from rest in a beam wind (the Esso Osaka zig-zags): the helm first steers
    with corrections as large as the zig-zag's rudder (16 deg to port, then 10 deg to starboard
    held against the wind until the 20 deg order: one pulse with a shelf), and reverses the
    third time 9 deg late. The zig-zag is the order's pulses up to that reversal; its execute is
    the order, not the start of the shelf; its overshoots are the truth's."""
    amp, sw, t_order = DEG(20.0), DEG(20.0), 30.0
    corr = [(2.0, 8.0, -DEG(16.0)), (8.0, t_order, DEG(10.0))]
    truth, trial = steer("zigzag", amp, sw, t_order, 140.0, side=1, seed=7, corr=corr,
                         bias=-DEG(10.0), late=DEG(9.0))
    segs = find_manoeuvres(trial)
    assert [s.kind for s in segs] == ["zigzag"]
    seg = segs[0]
    assert seg.t_execute == pytest.approx(t_order, abs=0.5)  # as the campaign above
    assert seg.n_pulses == 3  # the order and two reversals; the late third one ends it
    assert math.degrees(seg.psi_switch) == pytest.approx(20.0, abs=0.5)
    # the shelf held against the wind is the approach's rudder offset: the amplitude is 20 deg
    # about zero (rudder_amplitude measures from zero once the rudder reverses), within the
    # 0.1-deg rudder noise and the 0.3 deg of the campaign above
    assert math.degrees(seg.level) == pytest.approx(20.0, abs=0.3)
    (m,) = [x for x in measured_metrics(trial) if x["kind"] == "zigzag"]
    ref = zigzag_metrics(truth["t"], truth["psi"], truth["delta"], psi_switch=sw,
                         t_execute=t_order, first=1)
    np.testing.assert_allclose(m["overshoot_deg"][:2], ref.overshoot_deg[:2], atol=0.3)
    # without the late reversal and the corrections' size it is a zig-zag as a whole: the same
    # execute and switching angle
    _, plain = steer("zigzag", amp, sw, t_order, 140.0, side=1, seed=7,
                     corr=[(8.0, t_order, DEG(10.0))], bias=-DEG(10.0))
    (p,) = find_manoeuvres(plain)
    assert p.t_execute == pytest.approx(t_order, abs=0.5) and p.n_pulses > 3


def test_demo_zigzag_log_switch_angle_and_overshoots():
    """The demo's 10/10 zig-zag log (the Lanxin 3-DOF model, a servo with 1 s dead time, the
    rudder angle logged but not the order, 0.3-deg compass): its rudder reverses ~1.2 s after
    the 10-deg crossings, at 18.4 deg of heading change; the switch is the 10-deg amplitude
    (a steering lag explains the rest), and the overshoots are the truth model's."""
    from usvid.demo.campaign import SENSORS, lanxin_model
    from usvid.sim import run_zigzag
    from usvid.sim.virtual import SensorModel, virtual_trial

    model = lanxin_model()
    res = simulate(model, ZigZag(DEG(10), DEG(10), t_start=5.0), t_end=80.0, dt=0.02,
                   u0=float(model.vessel.speed))
    trial = virtual_trial(res, SensorModel(**SENSORS), seed=3)
    trial = trial.with_data(trial.data.drop(columns=["delta_cmd"], errors="ignore"))
    (m,) = [x for x in measured_metrics(trial) if x["kind"] == "zigzag"]
    assert m["psi_switch_deg"] == pytest.approx(10.0) and m["psi_switch_from"] == "amplitude"
    assert 0.8 < m["rudder_lag_s"] < 1.5  # 1 s dead time + the servo's second-order lag
    _, truth = run_zigzag(model, 10.0, 10.0)
    # 0.3-deg compass smoothed over 2 s and 0.2-deg rudder: within 0.3 deg of the truth's
    np.testing.assert_allclose(m["overshoot_deg"][:3], truth.overshoot_deg[:3], atol=0.3)
