"""usvid.manoeuvres.detect and .measure: zig-zags and turning circles found in a long log, and
measured."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from usvid.manoeuvres.detect import (
    find_execute,
    find_manoeuvres,
    nominal_switch,
    plateau_level,
    rudder_amplitude,
    rudder_rate,
    steady_turn,
    zigzag_crossings,
)
from usvid.manoeuvres.measure import manoeuvre_metrics, measured_metrics
from usvid.manoeuvres.metrics import turning_metrics, zigzag_metrics
from usvid.models import IdealServo, Nomoto1, SecondOrderServo, VesselModel
from usvid.prep import prepare
from usvid.sim import Turning, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Trial, Vessel

K, T, U = 0.2, 8.0, 1.5  # Nomoto gain [1/s], time constant [s]; speed [m/s]
RATE = math.radians(5.0)  # rudder rate [rad/s]
DELAY = 0.5  # helm reaction time [s]: the rudder reverses 0.5 s after the switching heading


def simulate_log(seed: int = 0, dt: float = 0.1):
    """Straight 20 s, zig-zag 10/10 (starboard first) to t = 220 s, straight to 300 s, a 20-deg
    port turning circle to 520 s, straight to 560 s. Nomoto-1 (T r' + r = K delta), rate-limited
    rudder, 2-cm positions, 0.1-deg heading. Returns (trial, truth dict)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 560, dt)
    n = t.size
    psi = np.zeros(n)
    r = np.zeros(n)
    delta = np.zeros(n)
    cmd = 0.0
    side = 1
    pending: float | None = None
    amp, sw = math.radians(10), math.radians(10)
    for k in range(1, n):
        tk = t[k - 1]
        if 20 <= tk < 220:
            if cmd == 0.0:
                cmd = side * amp
            dev = psi[k - 1] - 0.0
            if pending is None and side * dev >= sw:
                pending = tk + DELAY
            if pending is not None and tk >= pending:
                side = -side
                cmd = side * amp
                pending = None
        elif 300 <= tk < 520:
            cmd = -math.radians(20)
        else:
            cmd = 0.0
        step = np.clip(cmd - delta[k - 1], -RATE * dt, RATE * dt)
        delta[k] = delta[k - 1] + step
        r[k] = r[k - 1] + dt * (K * delta[k] - r[k - 1]) / T
        psi[k] = psi[k - 1] + dt * r[k]
    v = -1.0 * r
    xd = U * np.cos(psi) - v * np.sin(psi)
    yd = U * np.sin(psi) + v * np.cos(psi)
    x = np.cumsum(xd) * dt
    y = np.cumsum(yd) * dt
    data = pd.DataFrame({
        "t": t,
        "x": x + rng.normal(0, 0.02, n),
        "y": y + rng.normal(0, 0.02, n),
        "psi": psi + rng.normal(0, math.radians(0.1), n),
        "r": r,
        "delta": delta,
    })
    truth = {"t": t, "psi": psi, "delta": delta, "x": x, "y": y}
    return Trial(data, name="synthetic"), truth


@pytest.fixture(scope="module")
def synthetic():
    return simulate_log()


def test_nominal_switch_hand_values():
    deg = math.radians

    def sw(*a, **k):
        v, how = nominal_switch(*a, **k)
        return round(math.degrees(v), 6), how

    # a logged rudder order reverses at the switching heading: taken as measured, any value
    assert sw(deg(12.3), deg(20.0), deg(5.0), order=True) == (12.3, "order")
    # the rudder angle of an n/n zig-zag lags the order: 18.4 deg at 7 deg/s is 8.4 deg late,
    # 1.2 s of steering lag (<= 1.5 s): the amplitude, to the whole degree (9.94 -> 10)
    assert sw(deg(18.4), deg(9.94), deg(7.0)) == (10.0, "amplitude")
    assert sw(deg(12.6), deg(12.4), deg(3.0)) == (12.4, "amplitude")  # not near a whole degree
    # a 10/5 of the HSVA model tests: 5.54 deg at 2.4 deg/s is 0.23 s after the 5 deg crossing
    assert sw(deg(5.54), deg(9.99), deg(2.4)) == (5.0, "standard")
    # 12.5 deg at 4 deg/s: 10 deg would mean 0.63 s of helm lag (> 0.45 s + 0.3 deg): measured,
    # not rounded
    assert sw(deg(12.5), deg(20.0), deg(4.0)) == (12.5, "measured")
    # an amplitude 2.1 s behind (> 1.5 s) is not this test's switching angle
    assert sw(deg(25.0), deg(10.0), deg(7.0)) == (25.0, "standard")
    assert sw(deg(0.5)) == (0.5, "measured")


def test_finds_zigzag_and_turning_in_long_log(synthetic):
    trial, truth = synthetic
    segs = find_manoeuvres(trial)
    assert [s.kind for s in segs] == ["zigzag", "turning"]
    zz, tc = segs
    # the rudder leaves zero at t = 20 s (first sample after the order)
    assert zz.t_execute == pytest.approx(20.0, abs=0.15)
    assert zz.side == 1 and zz.command == "delta"
    assert math.degrees(zz.level) == pytest.approx(10.0, abs=0.01)
    assert math.degrees(zz.psi_switch) == pytest.approx(10.0)
    # measured at the reversals: 10 deg + 0.5 s x ~2 deg/s
    assert 10.0 < zz.extra["psi_switch_measured_deg"] < 12.0
    assert zz.n_pulses >= 5
    assert tc.side == -1 and tc.t_execute == pytest.approx(300.0, abs=0.15)
    assert math.degrees(tc.heading_change) > 360


def test_measured_metrics_equal_direct_metrics(synthetic):
    trial, truth = synthetic
    ms = measured_metrics(trial)
    zz, tc = ms
    sel = (truth["t"] >= 15.0) & (truth["t"] <= 221.0)
    # the rudder starts to move at t = 20 s: the reference is the noise-free record from there
    ref = zigzag_metrics(truth["t"][sel], truth["psi"][sel], truth["delta"][sel],
                         psi_switch=math.radians(10.0), t_execute=20.0)
    # 0.1-deg heading noise smoothed over 2 s (21 samples, cubic: gain 0.35) leaves ~0.035 deg
    # on the peak and on psi0: 0.15 deg is 3 sigma of their sum (seeds 0-3: at most 0.083)
    np.testing.assert_allclose(zz["overshoot_deg"][:4], ref.overshoot_deg[:4], atol=0.15)
    # crossings of a heading moving at ~2 deg/s: 0.035 deg noise is 0.02 s
    assert zz["period_s"] == pytest.approx(ref.period_s, abs=0.05)
    assert zz["initial_turning_time_s"] == pytest.approx(ref.initial_turning_time_s, abs=0.05)
    for key in ("overshoot_deg", "period_s", "initial_turning_time_s", "time_to_check_yaw_s"):
        assert key in zz
    sel = (truth["t"] >= 299.0) & (truth["t"] <= 520.0)
    ref_t = turning_metrics(truth["t"][sel], truth["x"][sel], truth["y"][sel],
                            truth["psi"][sel], t_execute=300.0)
    # 2-cm position noise against 10-m scales
    assert tc["advance_m"] == pytest.approx(ref_t.advance_m, abs=0.1)
    assert tc["tactical_diameter_m"] == pytest.approx(ref_t.tactical_diameter_m, abs=0.1)
    # steady turn of Nomoto-1: r = K delta = 0.0698 rad/s; D = 2 U / r with v = -r: U_tot ~ U
    d_ss = 2 * math.hypot(U, 0.0698) / (K * math.radians(20))
    assert tc["steady_diameter_m"] == pytest.approx(d_ss, rel=0.02)  # 2 %: residual transient


def test_given_switch_angle_is_used(synthetic):
    trial, _ = synthetic
    zz = find_manoeuvres(trial, psi_switch=math.radians(11.0))[0]
    assert math.degrees(zz.psi_switch) == pytest.approx(11.0)
    assert zz.extra["psi_switch_from"] == "given"


def test_zigzags_found_through_compass_noise():
    # a 0.5-deg compass at 20 Hz: the straight approach before the execute is judged on the
    # smoothed heading (two raw samples 3 s apart differ by 0.24 deg/s of noise, near the
    # 0.3 deg/s limit: with the raw heading 3 of these 40 zig-zags were not found)
    model = VesselModel(Nomoto1(K=0.25, T=8.0), servo=IdealServo(max_rate=math.radians(15.8)),
                        vessel=Vessel(speed=1.2))
    res = simulate(model, ZigZag(np.full(40, math.radians(10.0)), math.radians(10.0),
                                 t_start=5.0), t_end=60.0, dt=0.02)
    kinds = [[g.kind for g in find_manoeuvres(virtual_trial_uniform(res, SensorModel(), seed=i,
                                                                    i=i, rate_hz=20.0))]
             for i in range(res.batch_size)]
    assert kinds == [["zigzag"]] * res.batch_size


def test_straight_log_has_no_manoeuvre():
    t = np.arange(0, 100, 0.1)
    tr = Trial(pd.DataFrame({"t": t, "x": 1.5 * t, "y": 0 * t, "psi": 0 * t,
                             "delta": np.radians(0.3) * np.sin(t)}))
    assert find_manoeuvres(tr) == []


def test_hsva_first_overshoots(hsva_dir):
    from usvid.io import read_trial

    cases = {"10_10_S": (9.7, "starboard", 3), "20_10_P": (12.0, "port", 8)}
    for run, (first, side, pulses) in cases.items():
        tr = read_trial(hsva_dir / f"HSVA_CPMC_KVLCC2_Z_{run}.dat", "hsva_kvlcc2")
        ms = measured_metrics(tr)
        assert len(ms) == 1 and ms[0]["kind"] == "zigzag"
        m = ms[0]
        # acceptance: +-0.3 deg (measured 9.69 and 11.97)
        assert m["overshoot_deg"][0] == pytest.approx(first, abs=0.3), run
        assert m["first_side"] == side and m["n_pulses"] == pulses
        assert m["psi_switch_deg"] == pytest.approx(10.0)


def test_hsva_all_runs_switch_angles(hsva_dir):
    from usvid.io import read_trial

    for path in sorted(hsva_dir.glob("*.dat")):
        parts = path.stem.split("_Z_")[1].split("_")
        tr = read_trial(path, "hsva_kvlcc2")
        segs = find_manoeuvres(tr)
        assert [s.kind for s in segs] == ["zigzag"], path.name
        assert math.degrees(segs[0].psi_switch) == pytest.approx(float(parts[1])), path.name
        assert math.degrees(segs[0].level) == pytest.approx(float(parts[0]), abs=0.1)
        # one rule: the segment's execute and side are those of the rudder record alone
        tr = prepare(tr, derivatives=False)
        t_e, side = find_execute(tr.t, tr["delta"])
        assert segs[0].t_execute == pytest.approx(t_e, abs=1e-9) and segs[0].side == side


def test_twin_circle_found_from_heading(twin_dir):
    from usvid.io import read_trial

    tr = read_trial(twin_dir / "boat1_2_circle.xlsx", "twin_thruster_xlsx")
    segs = find_manoeuvres(tr)
    assert [s.kind for s in segs] == ["turning"]
    assert segs[0].execute_from == "heading" and segs[0].side == 1
    m = manoeuvre_metrics(tr, segs[0])  # prepares (lat/lon -> x, y) itself
    # the guidance circle has radius 25 m in the file's x/y, which are 11.17 % too large:
    # 50 / 1.1117 = 45.0 m in true metres; 1 m for the tracking error of the controller
    assert m["steady_diameter_m"] == pytest.approx(45.0, abs=1.0)
    assert find_manoeuvres(read_trial(twin_dir / "boat1_2_sin.xlsx", "twin_thruster_xlsx")) == []


def test_thruster_differential_zigzag(synthetic):
    """No rudder: the same manoeuvres commanded by a twin-thruster differential (the catamaran
    paper)."""
    trial, truth = synthetic
    rng = np.random.default_rng(5)
    d = trial.data.drop(columns=["delta"])
    diff = 1000.0 * truth["delta"]  # port - stbd [command units]: +10 deg ~ +175
    d["pwm_port"] = 1600 + diff / 2 + rng.normal(0, 5, len(d))  # noisy PWM commands
    d["pwm_stbd"] = 1600 - diff / 2 + rng.normal(0, 5, len(d))
    segs = find_manoeuvres(trial.with_data(d))
    assert [s.kind for s in segs] == ["zigzag", "turning"]
    zz = segs[0]
    assert zz.command == "pwm_port-pwm_stbd" and zz.side == 1
    assert math.degrees(zz.psi_switch) == pytest.approx(10.0)
    # 5-s smoothing of the command delays the detected execute by at most ~1 s
    assert zz.t_execute == pytest.approx(20.0, abs=1.0)
    m = manoeuvre_metrics(trial.with_data(d), zz)
    # no rudder angle: the level is in command units, 1000 x 10 deg in rad = 174.5
    assert math.isnan(m["delta_amp_deg"])
    assert m["command_level"] == pytest.approx(174.5, rel=0.05)
    assert len(m["overshoot_deg"]) >= 4


# --------------------------------------------------------------------------------------------
# the one definition of each manoeuvre quantity (usvid.manoeuvres.detect)
# --------------------------------------------------------------------------------------------
DEG = math.radians
#: Nomoto-1 vessel with a rate-limited (5 deg/s) ideal servo: every rule has a known answer.
RATE_MODEL = VesselModel(Nomoto1(K=0.5, T=2.0),
                         servo=IdealServo(max_angle=DEG(35), max_rate=DEG(5)),
                         vessel=Vessel(length=5.0, speed=2.0))


def test_find_execute_step_and_ramp():
    t = np.arange(0, 10, 0.1)
    delta = np.clip((t - 2.0) * 0.2, 0, 0.35)  # ramps from t = 2 s
    te, side = find_execute(t, -delta)
    # the ramp starts at t = 2 s: the line through the last sample within 10 % of the plateau
    # (2.1 s, 0.02 rad) and the first beyond 50 % (2.9 s, 0.18 rad) reaches zero there (the
    # earlier rule returned the 10 % sample itself, 2.1 s)
    assert te == pytest.approx(2.0, abs=1e-9)
    assert side == -1.0


def test_find_execute_zigzag_and_record_starting_at_execute():
    t = np.arange(0, 30, 0.1)
    zz = np.where(t < 3, 0.01, np.where(t < 10, 0.17, np.where(t < 20, -0.17, 0.17)))
    te, side = find_execute(t, zz)  # largest deviation is the 20 deg swing, not the first order
    assert te == pytest.approx(2.9, abs=1e-9) and side == 1.0
    te, side = find_execute(t, np.where(t < 10, -0.17, 0.17))  # already over at the start
    assert te == 0.0 and side == -1.0


def test_find_execute_ramp_between_samples_with_zero_offset():
    # a rudder reading 0.02 rad when straight (zero offset), ramp at 0.2 rad/s from t = 2.03 s
    # (between two samples) to 0.37 rad: the line through the 10 % and 50 % samples is the ramp
    # itself, so the execute is 2.03 s exactly; the offset is the median of the 5-s approach
    t = np.arange(0, 10, 0.1)
    delta = 0.02 + np.clip((t - 2.03) * 0.2, 0, 0.35)
    te, side = find_execute(t, delta)
    assert te == pytest.approx(2.03, abs=1e-9) and side == 1
    te, side = find_execute(t, -delta)
    assert te == pytest.approx(2.03, abs=1e-9) and side == -1


@pytest.fixture(scope="module")
def sim_manoeuvres():
    """A port turning circle (-20 deg from t = 5 s) and a 10/10 port-first zig-zag (from
    t = 3 s), both with the rudder at 5 deg/s: execute, side, amplitude, rate and reversals are
    the logic's own."""
    turn = simulate(RATE_MODEL, Turning(DEG(-20), t_start=5.0), t_end=60.0, dt=0.02)
    zz = simulate(RATE_MODEL, ZigZag(DEG(10), DEG(10), first=-1, t_start=3.0), t_end=80.0,
                  dt=0.02)
    return turn, zz


def test_execute_side_amplitude_rate_of_simulated_manoeuvres(sim_manoeuvres):
    turn, zz = sim_manoeuvres
    for res, t_start, amp in ((turn, 5.0, 20.0), (zz, 3.0, 10.0)):
        d = res["delta"][0]
        # the rate-limited ramp starts at t_start: the line through its 10 % and 50 % samples
        te, side = find_execute(res.t, d)
        assert te == pytest.approx(t_start, abs=1e-9) and side == -1
        assert math.degrees(rudder_amplitude(res.t, d, te)) == pytest.approx(amp, abs=1e-9)
        assert math.degrees(rudder_rate(res.t, d)) == pytest.approx(5.0, abs=1e-6)


def test_zigzag_crossings_are_the_logic_reversals(sim_manoeuvres):
    _, zz = sim_manoeuvres
    psi = zz["psi"][0]
    z = -(psi - psi[0])  # port first: the first turn positive
    times, index = zigzag_crossings(zz.t, z, DEG(10), int(np.searchsorted(zz.t, 3.0)))
    # the simulator locates each switching event inside its step (sim.core); linear
    # interpolation of a heading turning at ~2 deg/s over 0.02 s errs by ~1e-7 s
    online = zz.zigzag_online["reversal_t"][0]
    n = int(np.sum(np.isfinite(online[1:])))
    assert n >= 4 and len(times) >= n
    np.testing.assert_allclose(times[:n], online[1:n + 1], atol=1e-6)
    # the index is the first sample at or after each crossing
    for tc, j in zip(times, index, strict=True):
        assert zz.t[j] >= tc > zz.t[j - 1]


def test_zigzag_crossings_hand_values():
    # z = A sin(w t): +sw first at asin(sw/A)/w, -sw half a period later, and so on
    A, sw, w = DEG(20), DEG(10), 2 * math.pi / 20.0
    t = np.arange(0.0, 45.0, 0.01)
    times, _ = zigzag_crossings(t, A * np.sin(w * t), sw)
    t1 = math.asin(0.5) / w  # 1.667 s
    expect = [t1, 10.0 + t1, 20.0 + t1, 30.0 + t1, 40.0 + t1]
    # linear interpolation of a sine: error below A w^2 dt^2 / 8 / (A w cos) ~ 1e-6 s
    np.testing.assert_allclose(times, expect, atol=1e-5)


def test_plateau_level_and_amplitude_by_hand():
    # plateau samples beyond half the largest: ramps and a noise spike do not count
    assert plateau_level([0.0, 1.0, 5.0, 10.0, 10.0, 10.0, 10.0, 13.0, 5.0]) == 10.0
    assert plateau_level([0.0, -1.0]) == 0.0 and math.isnan(plateau_level([np.nan]))
    # zig-zag on a rudder reading 0.5 deg when straight: +10.5 / -9.5 deg plateaux with ramps;
    # the amplitude is half the distance between them, 10 deg, whatever the zero offset
    t = np.arange(0.0, 60.0, 0.1)
    sq = np.where(t < 10, 0.0, np.where((t // 10) % 2 == 1, 10.0, -10.0))
    ramped = np.convolve(np.pad(sq, (10, 0), mode="edge"), np.ones(11) / 11, "valid")
    d = np.radians(ramped + 0.5)
    assert math.degrees(rudder_amplitude(t, d, 10.0)) == pytest.approx(10.0, abs=1e-9)
    # one-sided (turning): the plateau from the 5-s approach median (1 deg) to 21 deg = 20 deg
    turn = np.radians(np.where(t < 10, 1.0, np.clip(1.0 + (t - 10.0) * 5.0, 1.0, 21.0)))
    assert math.degrees(rudder_amplitude(t, turn, 10.0)) == pytest.approx(20.0, abs=1e-9)


def test_steady_turn_windows_on_an_exact_circle():
    # a circle of radius 50 m at 5 m/s from t = 0 (r = 0.1 rad/s, 62.83 s per 360 deg)
    R, U, dt = 50.0, 5.0, 0.1
    w = U / R
    for turn_deg, start_deg in ((720.0, 360.0), (400.0, 180.0), (120.0, 60.0)):
        t = np.arange(0.0, math.radians(turn_deg) / w + dt / 2, dt)
        psi = w * t
        x, y = R * np.sin(psi), R * (1 - np.cos(psi))
        st = steady_turn(t, psi, 0.0, x=x, y=y, delta=np.full_like(t, DEG(35)))
        # last 360 deg when the record turns 540 deg or more; else after 180 deg; else the
        # second half of the heading change
        assert math.degrees(w * st.t_start) == pytest.approx(start_deg, abs=math.degrees(w * dt))
        assert st.t_end == pytest.approx(t[-1])
        assert st.yaw_rate == pytest.approx(w, rel=1e-9) and st.side == 1
        assert st.speed == pytest.approx(U, rel=1e-4)  # chords: (w dt)^2 / 24 short
        assert st.delta == pytest.approx(DEG(35))


def test_steady_turn_of_simulated_nomoto(sim_manoeuvres):
    turn, _ = sim_manoeuvres
    st = steady_turn(turn.t, turn["psi"][0], 5.0, r=turn["r"][0], delta=turn["delta"][0])
    # Nomoto-1 steady turn: r = K delta = 0.5 * -20 deg; the window starts after 180 deg, 20 s
    # (10 T) after the execute, where the transient exp(-t/T) is below 1e-4 of r
    assert st.side == -1 and st.delta == pytest.approx(DEG(-20), abs=1e-12)
    assert st.yaw_rate == pytest.approx(0.5 * DEG(-20), rel=1e-4)


def test_segment_execute_and_level_are_the_array_rules(synthetic):
    """find_manoeuvres uses the same execute and amplitude as the array functions."""
    trial, truth = synthetic
    zz, tc = find_manoeuvres(trial)
    for seg, t1 in ((zz, 230.0), (tc, 530.0)):
        sel = (truth["t"] >= seg.t_execute - 10.0) & (truth["t"] <= t1)
        te, side = find_execute(truth["t"][sel], truth["delta"][sel])
        assert seg.t_execute == pytest.approx(te, abs=1e-9) and seg.side == side
        assert seg.level == pytest.approx(
            rudder_amplitude(truth["t"], truth["delta"], te, seg.t_end), abs=1e-12)


def test_logged_order_gives_execute_and_switch_angle():
    """A log with the rudder order and a delayed rudder (1 s dead time, as the Lanxin servo):
    the manoeuvre is read from the order, as IMO times it and as the simulator runs it."""
    servo = SecondOrderServo(omega_n=1.4, zeta=0.85, gain=1.0, delay=1.0, max_angle=DEG(35))
    model = VesselModel(Nomoto1(K=0.7, T=0.4), servo=servo, vessel=Vessel(length=7.0, speed=5.0))
    res = simulate(model, ZigZag(DEG(10), DEG(10), t_start=5.0), t_end=60.0, dt=0.02)
    trial = res.to_trial(0)
    d = trial.data.copy()
    d["psi"] += np.random.default_rng(1).normal(0.0, DEG(0.3), len(d))  # a 0.3-deg compass
    segs = find_manoeuvres(trial.with_data(d))
    assert [s.kind for s in segs] == ["zigzag"]
    zz = segs[0]
    assert zz.command == "delta_cmd" and zz.side == 1
    # the order steps at t = 5 s, sampled: the last sample before the step
    assert zz.t_execute == pytest.approx(5.0, abs=0.021)
    assert math.degrees(zz.level) == pytest.approx(10.0, abs=1e-9)
    # the order reverses at the crossing itself: 10 deg (the rudder angle, 1.3 s later at
    # ~7 deg/s, would suggest 20)
    assert math.degrees(zz.psi_switch) == pytest.approx(10.0)
    m = zz.extra["psi_switch_measured_deg"]
    assert 9.5 < m < 10.6
