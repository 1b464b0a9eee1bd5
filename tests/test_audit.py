"""usvid.prep.audit: every channel checked against the physics, problems said in plain words."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid
from scipy.signal import lsim

from usvid.prep import audit, position_scale
from usvid.trial import Trial

K, T = 0.2, 8.0  # Nomoto gain [1/s] and time constant [s] of a small vessel


def nomoto_trial(seed: int = 0, dt: float = 0.1, t_end: float = 200.0) -> Trial:
    """A Nomoto-1 vessel (T r' + r = K delta, Mu et al. 2018) on a 20-deg square-wave rudder.

    Sensors: 2-cm positions, 0.1-deg heading, 0.2 deg/s gyro; v = -1.5 m x r (sway with yaw),
    plus a roll-rate-like channel 'p' that is not the yaw rate.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0, t_end, dt)
    delta = np.radians(20) * np.sign(np.sin(2 * np.pi * t / 50 + 0.1))
    _, r, _ = lsim(([K], [T, 1.0]), delta, t)
    psi = cumulative_trapezoid(r, t, initial=0.0)
    u = np.full(t.size, 1.5)
    v = -1.5 * r
    xd = u * np.cos(psi) - v * np.sin(psi)
    yd = u * np.sin(psi) + v * np.cos(psi)
    x = cumulative_trapezoid(xd, t, initial=0.0)
    y = cumulative_trapezoid(yd, t, initial=0.0)
    n = t.size
    return Trial(pd.DataFrame({
        "t": t,
        "x": x + rng.normal(0, 0.02, n),
        "y": y + rng.normal(0, 0.02, n),
        "psi": psi + rng.normal(0, np.radians(0.1), n),
        "u": u + rng.normal(0, 0.01, n),
        "v": v + rng.normal(0, 0.01, n),
        "r": r + rng.normal(0, np.radians(0.2), n),
        "p": np.radians(3) * np.sin(2 * np.pi * t / 7) + rng.normal(0, 0.01, n),
        "delta": delta,
    }), name="nomoto")


def codes(findings) -> dict:
    return {f.code: f for f in findings}


def test_clean_synthetic_log_has_no_problems():
    f = audit(nomoto_trial())
    assert [x for x in f if x.severity in ("error", "warning")] == []


def test_wrong_yaw_rate_column_is_found_and_the_right_one_named():
    tr = nomoto_trial()
    d = tr.data.copy()
    d["q"], d["r"] = d["r"], d["p"]  # the yaw rate is in 'q'; 'r' holds the roll rate
    f = codes(audit(tr.with_data(d)))
    assert "yaw_rate_column" in f
    assert f["yaw_rate_column"].severity == "error"
    assert f["yaw_rate_column"].data["yaw_rate_channel"] == "q"
    assert "'q' is the yaw rate" in f["yaw_rate_column"].message


@pytest.mark.parametrize(
    ("factor", "code", "words"),
    [(-1.0, "yaw_rate_sign", "opposite sign"),
     (np.pi / 180, "yaw_rate_scale", "57.3 times too small"),
     (180 / np.pi, "yaw_rate_scale", "57.3 times too large")],
)
def test_yaw_rate_sign_and_unit_factor(factor, code, words):
    tr = nomoto_trial()
    d = tr.data.copy()
    d["r"] = d["r"] * factor
    f = codes(audit(tr.with_data(d)))
    assert code in f and words in f[code].message
    assert f[code].data["gain"] == pytest.approx(1 / factor, rel=0.05)  # 0.2 deg/s gyro noise


def test_heading_glitch_reported_and_kept_out_of_the_checks():
    tr = nomoto_trial()
    d = tr.data.copy()
    d.loc[800, "psi"] += np.radians(40)  # one bad compass sample
    d.loc[1500:, "psi"] += np.radians(90)  # and a 90-deg step (two records joined)
    f = codes(audit(tr.with_data(d)))
    assert f["heading_jump"].severity == "warning"
    # the bad sample leaves the course and comes back: one heading glitch, repaired; the step
    # blanks itself and 21 samples (the 2-s derivative window at 10 Hz) each side: 43
    assert f["heading_glitch"].count == 1 and f["heading_glitch"].t_start == pytest.approx(80.0)
    assert f["heading_jump"].count == 43
    assert not {"yaw_rate_column", "yaw_rate_sign", "rudder_sign"} & set(f)


def test_rudder_sign_reversed():
    tr = nomoto_trial()
    d = tr.data.copy()
    d["delta"] = -d["delta"]
    f = codes(audit(tr.with_data(d)))
    assert f["rudder_sign"].severity == "error"
    assert "sign: -1" in f["rudder_sign"].message
    # and the fitted K/T is about -K/T = -0.025 1/s^2 (2nd derivative of a noisy heading: 30 %)
    assert f["rudder_sign"].data["a"] == pytest.approx(-K / T, rel=0.3)


def test_u_v_mismatch_and_sign():
    tr = nomoto_trial()
    d = tr.data.copy()
    d["v"] = -d["v"]
    d["u"] = d["u"] * 0.5
    f = codes(audit(tr.with_data(d)))
    assert "opposite sign" in f["v_mismatch"].message
    assert "(gain 2)" in f["u_mismatch"].message  # kinematic u = 2 x logged u


def test_speed_scale_from_a_slow_clock():
    tr = nomoto_trial()
    d = tr.data.copy()
    d["U"] = np.hypot(1.5, 1.5 * d["r"])  # true speed over ground of the reference point
    assert "speed_scale" not in codes(audit(tr.with_data(d)))
    d["t"] = d["t"] / 1.1  # the logger's clock runs slow (0.909 s per s): positions seem faster
    f = codes(audit(tr.with_data(d)))
    # 2-cm positions over 2 s and 1.5 m/s: the factor is known to well under 1 %
    assert f["speed_scale"].data["factor"] == pytest.approx(1.1, abs=0.01)
    assert "run slow" in f["speed_scale"].message and "advance 0.909 s" in f["speed_scale"].message


def test_time_problems_duplicates_nan_saturation():
    tr = nomoto_trial(t_end=100.0)
    d = tr.data.copy()
    d = d.drop(index=range(300, 330)).reset_index(drop=True)  # a 3-s hole at t = 30 s
    d.loc[500, "t"] = d.loc[499, "t"] - 0.05  # one reversal
    dup = d.iloc[[700]]
    d = pd.concat([d.iloc[:701], dup, d.iloc[701:]]).reset_index(drop=True)  # one duplicated row
    d.loc[100:140, "u"] = np.nan  # 4 s without u
    d["n_port"] = np.clip(np.linspace(0, 30, len(d)), None, 20.0)  # clipped at 20 rps
    f = codes(audit(Trial(d)))
    assert f["time_gap"].count == 1 and f["time_gap"].data["longest_s"] == pytest.approx(3.1)
    assert f["time_reversal"].count == 1 and f["time_reversal"].severity == "error"
    assert f["time_repeated"].count >= 1
    assert f["duplicate_rows"].count == 1
    assert f["nan_run"].channel == "u" and f["nan_run"].count == 41
    assert f["nan_run"].t_start == pytest.approx(10.0)
    assert f["saturation"].channel == "n_port" and "maximum 20" in f["saturation"].message


def test_thruster_swap_found():
    tr = nomoto_trial()
    d = tr.data.copy()
    diff = d.pop("delta").to_numpy()
    d["n_port"] = 10.0 - 20 * diff  # port - stbd = -40 delta: more port thrust turns to port
    d["n_stbd"] = 10.0 + 20 * diff
    f = codes(audit(tr.with_data(d)))
    assert "thruster_sign" in f and "swapped" in f["thruster_sign"].message
    d["n_port"], d["n_stbd"] = d["n_stbd"].copy(), d["n_port"].copy()
    assert "thruster_sign" not in codes(audit(tr.with_data(d)))


def test_position_scale_hand_value():
    a = np.array([0.0, 1.0, 2.0, 3.0] * 5)
    b = np.array([1.0, 0.0, -1.0, 2.0] * 5)
    fit = position_scale(a, b, 1.1 * a + 7.0, 1.1 * b - 2.0)  # scaled and shifted
    assert fit["factor"] == pytest.approx(1.1) and fit["residual_m"] == pytest.approx(0, abs=1e-12)


# --- real data -------------------------------------------------------------------------------
def test_hsva_catalogue_spec_problems(hsva_dir):
    from usvid.io import read_trial

    for run in ("10_10_S", "20_10_P"):
        tr = read_trial(hsva_dir / f"HSVA_CPMC_KVLCC2_Z_{run}.dat", "hsva_kvlcc2_catalogue")
        f = codes(audit(tr))
        assert f["yaw_rate_column"].data["yaw_rate_channel"] == "p", run
        assert f["yaw_rate_column"].data["gain"] == pytest.approx(1.0, abs=0.02)
        assert f["rudder_sign"].severity == "error"
        assert "v_mismatch" in f


def test_hsva_shipped_spec_is_clean(hsva_dir):
    from usvid.io import read_trial

    for path in sorted(hsva_dir.glob("*.dat")):
        f = audit(read_trial(path, "hsva_kvlcc2"))
        bad = [x.code for x in f if x.severity in ("error", "warning")]
        assert bad == [], (path.name, bad)


def test_twin_thruster_stale_rate_and_scale(twin_dir):
    import yaml

    from usvid.io import read_trial, shipped_spec_path

    for name in ("boat1_2_circle.xlsx", "boat1_2_sin.xlsx"):
        f = codes(audit(read_trial(twin_dir / name, "twin_thruster_xlsx")))
        # 1064 of 2354 (circle) and 695 of 1536 (sin) fixes repeat: 45.2 %
        assert f["stale_gnss_fix"].data["rate"] == pytest.approx(0.452, abs=0.002)
        assert f["position_scale"].data["factor"] == pytest.approx(1.1117, abs=0.001)
        assert "+11.2 %" in f["position_scale"].message
        assert not {"thruster_sign", "yaw_rate_column", "rudder_sign"} & set(f)
        # the shipped spec takes time from DateTime, so position-derived speed agrees with the
        # receiver's Speed
        assert "speed_scale" not in f
        # the file's t runs 9.5 % fast against its DateTime column (235.3 s of t for 257.8 s of
        # wall clock in the circle log, 153.5 for 168.0 in the sin log): read on "t", positions
        # differentiated on it are 1.09-1.10 times too fast, and the audit says so
        spec = yaml.safe_load(shipped_spec_path("twin_thruster_xlsx").read_text())
        spec["columns"]["t"] = {"col": "t", "unit": "s"}
        f = codes(audit(read_trial(twin_dir / name, spec)))
        assert f["speed_scale"].data["factor"] == pytest.approx(1.095, abs=0.01)


def test_swapped_position_axes_and_minimal_logs():
    import pymap3d

    t = np.arange(0, 60, 0.1)
    north, east = 20 * np.sin(t / 10), 30 * np.cos(t / 7)
    lat, lon, _ = pymap3d.ned2geodetic(north, east, 0.0, 38.0, 121.0, 0.0)
    tr = Trial(pd.DataFrame({"t": t, "lat": lat, "lon": lon, "x_src": east, "y_src": north}))
    f = codes(audit(tr))
    assert f["position_axes"].data["factor"] == pytest.approx(1.0, abs=1e-6)
    assert f["stale_gnss_fix"].count == 0 and "no stale fixes" in f["stale_gnss_fix"].message
    # a log without heading: said so, nothing else breaks
    f = codes(audit(Trial(pd.DataFrame({"t": t, "delta": 0.1 * np.sin(t)}))))
    assert set(f) == {"no_heading"}


def test_multirate_rows_with_one_repeated_sample_are_not_duplicates():
    # a merged multi-rate log: heading rows (quantised, often equal to the previous one), rudder
    # rows (saturated: angle and command repeat) and GNSS rows at other instants; NaN wherever
    # a sensor has no sample
    t = np.arange(0, 20, 0.02)
    psi = np.round(0.01 * t, 2)  # 0.01 rad quantisation: many consecutive equal samples
    lat = np.full_like(t, np.nan)
    lat[::10] = 38.0 + 1e-6 * t[::10]
    psi[::10] = np.nan
    delta = np.where(np.arange(t.size) % 10 >= 5, 0.61, np.nan)  # five rudder rows in a row
    psi[np.isfinite(delta)] = np.nan
    tr = Trial(pd.DataFrame({"t": t, "psi": psi, "lat": lat, "delta": delta,
                             "delta_cmd": delta}))
    assert "duplicate_rows" not in codes(audit(tr))
    # a dense table with a row written twice is still caught
    d = pd.DataFrame({"t": t, "psi": 0.01 * t, "r": np.full_like(t, 0.01)})
    d.loc[500, ["psi", "r"]] = d.loc[499, ["psi", "r"]].to_numpy()
    assert codes(audit(Trial(d)))["duplicate_rows"].count == 1


@pytest.mark.parametrize("heading_noise_deg", [0.2, 0.5])
def test_straight_run_with_noisy_heading_is_a_weak_yaw_rate_not_a_wrong_column(heading_noise_deg):
    # a nearly straight run (0.5 deg/s weave) with a noisy compass: d(psi)/dt correlates only
    # 0.5-0.8 with the gyro, but its regression gain on r stays ~1 (noise in the reference does
    # not bias it); a channel unrelated to the yaw rate would give a gain near 0
    rng = np.random.default_rng(3)
    t = np.arange(0, 120, 0.02)
    r_true = np.radians(0.5) * np.sin(2 * np.pi * t / 20)
    psi = np.cumsum(r_true) * 0.02 + rng.normal(0, np.radians(heading_noise_deg), t.size)
    r = r_true + rng.normal(0, np.radians(0.05), t.size)
    f = codes(audit(Trial(pd.DataFrame({"t": t, "psi": psi, "r": r}))))
    assert "yaw_rate_column" not in f
    if heading_noise_deg == 0.2:
        # d(psi)/dt and r over 2 s alike: the gyro agrees (correlation > 0.95), no false alarm
        assert "yaw_rate_weak" not in f
    else:
        assert f["yaw_rate_weak"].data["gain"] == pytest.approx(1.0, abs=0.1)
    # the same log with an unrelated channel under the name r is still an error
    other = np.radians(0.5) * np.sin(2 * np.pi * t / 7.3) + rng.normal(0, 0.001, t.size)
    f = codes(audit(Trial(pd.DataFrame({"t": t, "psi": psi, "r": other}))))
    assert f["yaw_rate_column"].severity == "error"


def test_audit_speed_scale_says_fast_clock_when_stamps_advance_too_much() -> None:
    # a slow turn at 1.5 m/s, positions exact; the logger's stamps advance 1.1 s per real second
    # (a fast clock): the speed from the positions is 1/1.1 of the measured one. Before the fix
    # the message said "run slow" here (and "run fast" for a slow clock).
    t = np.arange(0.0, 120.0, 0.1)
    psi = 0.05 * t
    x = 1.5 / 0.05 * np.sin(psi)
    y = 1.5 / 0.05 * (1.0 - np.cos(psi))
    tr = Trial(data=pd.DataFrame({"t": 1.1 * t, "x": x, "y": y, "psi": psi,
                                  "U": np.full(len(t), 1.5)}), name="clock")
    (f,) = [f for f in audit(tr) if f.code == "speed_scale"]
    assert abs(f.data["factor"] - 1 / 1.1) < 0.005  # exact positions: only the SG edge error
    assert "run fast" in f.message and "advance 1.100 s" in f.message


def test_rudder_is_not_reported_as_a_yaw_rate():
    # no yaw-rate channel: the rudder follows d(psi)/dt through the hull (correlation ~0.99 for
    # a fast Nomoto hull) with the hull's gain, not a unit's; it is no yaw rate
    tr = nomoto_trial()
    d = tr.data.drop(columns=["r", "p"], errors="ignore")
    f = codes(audit(tr.with_data(d)))
    assert "yaw_rate_found" not in f and "yaw_rate_column" not in f


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clean_gyro_with_heading_glitches_is_no_weak_yaw_rate(seed):
    # a clean gyro and a compass with five 1.5-6 deg single-sample glitches: the glitches are
    # counted and repaired, the gyro is not "weak" (the 1-s derivative of the glitchy heading
    # decorrelated it before)
    tr = nomoto_trial(seed=seed)
    d = tr.data.copy()
    rng = np.random.default_rng(seed)
    idx = rng.choice(np.arange(50, len(d) - 50), 5, replace=False)
    d.loc[idx, "psi"] += np.radians([1.5, -2.0, 3.0, -4.0, 6.0])
    f = codes(audit(tr.with_data(d)))
    assert f["heading_glitch"].count == 5
    assert not {"yaw_rate_weak", "yaw_rate_column", "heading_jump"} & set(f)
