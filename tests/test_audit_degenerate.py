"""The audit on degenerate and real-world data: errors for a position jump no vessel makes, a
steering channel that never moves and time running backwards; verdicts only where the data
support them; every error with the format-spec line that fixes it, and that line works; one
definition of heading glitches for the audit and the metrics; robot logs (servo functions,
vehicle kind, fixes without a fix, several MAVLink senders)."""

from __future__ import annotations

import re
import struct
import warnings

import numpy as np
import pandas as pd
import pytest
import yaml
from scipy.integrate import cumulative_trapezoid
from scipy.signal import lsim

from usvid import Trial
from usvid.cli import main
from usvid.io import read_trial
from usvid.prep import audit

K, T = 0.2, 8.0  # Nomoto gain [1/s] and time constant [s] of a small vessel


def steered(t_end=200.0, dt=0.1, speed=1.5, seed=0):
    """A Nomoto-1 vessel on a 20-deg square-wave rudder (positive delta turns to starboard)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, t_end, dt)
    delta = np.radians(20) * np.sign(np.sin(2 * np.pi * t / 50 + 0.1))
    _, r, _ = lsim(([K], [T, 1.0]), delta, t)
    psi = cumulative_trapezoid(r, t, initial=0.0)
    x = cumulative_trapezoid(speed * np.cos(psi), t, initial=0.0)
    y = cumulative_trapezoid(speed * np.sin(psi), t, initial=0.0)
    n = len(t)
    return pd.DataFrame({"t": t, "x": x + rng.normal(0, 0.02, n), "y": y + rng.normal(0, 0.02, n),
                         "psi": psi + rng.normal(0, np.radians(0.1), n),
                         "r": r + rng.normal(0, np.radians(0.2), n),
                         "U": np.full(n, speed), "delta": delta, "delta_cmd": delta})


def zigzag(t_end=150.0, dt=0.1, speed=1.5, amp=20.0, switch=20.0):
    """A 20/20 zig-zag of the same Nomoto vessel (the rudder reverses when the heading passes
    +-20 deg), Euler steps of 0.1 s (T / 80)."""
    n = int(t_end / dt)
    t = np.arange(n) * dt
    r = np.zeros(n)
    psi = np.zeros(n)
    delta = np.zeros(n)
    d = np.radians(amp)
    for i in range(1, n):
        if t[i] >= 10.0:
            if psi[i - 1] > np.radians(switch):
                d = -np.radians(amp)
            elif psi[i - 1] < -np.radians(switch):
                d = np.radians(amp)
            delta[i] = d
        r[i] = r[i - 1] + dt * (K * delta[i] - r[i - 1]) / T
        psi[i] = psi[i - 1] + dt * r[i]
    x = cumulative_trapezoid(speed * np.cos(psi), t, initial=0.0)
    y = cumulative_trapezoid(speed * np.sin(psi), t, initial=0.0)
    return pd.DataFrame({"t": t, "x": x, "y": y, "psi": psi, "r": r, "U": speed,
                         "delta": delta})


def csv_log(tmp_path, d, name="log.csv"):
    """The frame as a CSV in degrees, and the spec that reads it."""
    out = d.copy()
    for c in ("psi", "r", "delta", "delta_cmd"):
        if c in out:
            out[c] = np.degrees(out[c])
    p = tmp_path / name
    out.to_csv(p, index=False)
    units = {"t": "s", "x": "m", "y": "m", "psi": "deg", "r": "deg/s", "U": "m/s",
             "delta": "deg", "delta_cmd": "deg", "lat": "deg", "lon": "deg"}
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {c: {"col": c, "unit": units[c]} for c in out.columns}}
    sp = tmp_path / "spec.yaml"
    sp.write_text(yaml.safe_dump(spec))
    return p, sp


def codes(findings):
    return {f.code: f for f in findings}


def apply_hint(spec_path, message):
    """Apply the ``columns: {...}`` line an error message gives to the spec file."""
    m = re.search(r"`columns: (\{.*?\}\})`", message)
    assert m, message
    new = yaml.safe_load(m.group(1))
    spec = yaml.safe_load(spec_path.read_text())
    spec["columns"].update(new)
    spec_path.write_text(yaml.safe_dump(spec))


# --- issue: degenerate data are errors ---------------------------------------------------------
def test_position_jump_of_1000_km_is_an_error(tmp_path):
    import pymap3d

    d = steered()
    lat, lon, _ = pymap3d.ned2geodetic(d["x"], d["y"], 0.0, 54.0, 10.0, 0.0)
    d = d.drop(columns=["x", "y"]).assign(lat=lat, lon=lon)
    d.loc[1000:, "lat"] += 9.0  # 1000 km north from t = 100 s on
    p, sp = csv_log(tmp_path, d)
    f = codes(audit(read_trial(p, sp)))
    assert f["position_jump"].severity == "error"
    assert f["position_jump"].data["largest_m"] == pytest.approx(1.0e6, rel=0.01)
    assert "LOG:T0:T1" in f["position_jump"].message
    assert "position_jump" not in codes(audit(read_trial(p, sp).slice_time(0.0, 99.0)))


def test_constant_rudder_is_an_error_and_the_hint_works(tmp_path):
    d = steered()
    d["delta_port"] = d["delta"]  # the moving rudder is logged under another name
    d["delta"] = np.radians(-3.0)
    d = d.drop(columns=["delta_cmd"])
    out = d.copy()
    out["delta"] = -3.0
    out["delta_port"] = np.degrees(d["delta_port"])
    for c in ("psi", "r"):
        out[c] = np.degrees(d[c])
    p = tmp_path / "c.csv"
    out.to_csv(p, index=False)
    units = {"t": "s", "x": "m", "y": "m", "psi": "deg", "r": "deg/s", "U": "m/s",
             "delta": "deg", "delta_port": "deg"}
    sp = tmp_path / "c.yaml"
    sp.write_text(yaml.safe_dump({"reader": "table", "delimiter": ",", "header": True,
                                  "columns": {c: {"col": c, "unit": u} for c, u in units.items()}}))
    f = codes(audit(read_trial(p, sp)))
    err = f["actuator_constant"]
    assert err.severity == "error" and "-3.00 deg" in err.message
    assert "`columns: {delta: {col: delta_port, unit: deg}}`" in err.message
    apply_hint(sp, err.message)
    assert not [x for x in audit(read_trial(p, sp)) if x.severity == "error"]


def test_time_running_backwards_is_an_error(tmp_path):
    d = steered(t_end=100.0)
    t = d["t"].to_numpy().copy()
    t[500:] -= 30.0  # the clock set back by 30 s (two runs joined)
    p, sp = csv_log(tmp_path, d.assign(t=t))
    f = codes(audit(read_trial(p, sp)))
    assert f["time_backwards"].severity == "error"
    assert "non_monotonic: reject" in f["time_backwards"].message
    # jitter (a few records slightly out of order) stays a warning of the reader
    t = d["t"].to_numpy().copy()
    t[[100, 101]] = t[[101, 100]]
    p, sp = csv_log(tmp_path, d.assign(t=t), "j.csv")
    tr = read_trial(p, sp)
    assert any(x.code == "non_monotonic_time" for x in tr.findings)
    assert "time_backwards" not in codes(audit(tr))


# --- verdicts only where the data support them -------------------------------------------------
def test_rudder_sign_not_judged_at_the_dock_and_both_channels_flipped_under_way(tmp_path):
    d = steered(speed=0.1)  # at the dock: 0.1 m/s
    d["delta"] = -d["delta"]
    d["delta_cmd"] = -d["delta_cmd"]
    p, sp = csv_log(tmp_path, d)
    f = codes(audit(read_trial(p, sp)))
    assert "rudder_sign" not in f and f["not_under_way"].severity == "info"
    d = steered()
    d["delta"] = -d["delta"]
    d["delta_cmd"] = -d["delta_cmd"]
    p, sp = csv_log(tmp_path, d, "w.csv")
    errs = [x for x in audit(read_trial(p, sp)) if x.code == "rudder_sign"]
    assert {x.channel for x in errs} == {"delta", "delta_cmd"}
    for err in errs:
        apply_hint(sp, err.message)
    assert not [x for x in audit(read_trial(p, sp)) if x.severity == "error"]
    # the command is logged but too flat to judge: the angle's error flips both (they share
    # the convention)
    d["delta_cmd"] = 0.001 * np.sign(d["delta_cmd"])
    p, sp = csv_log(tmp_path, d, "v.csv")
    err = codes(audit(read_trial(p, sp)))["rudder_sign"]
    assert "delta: {col: delta, unit: deg, sign: -1}" in err.message
    assert "delta_cmd: {col: delta_cmd, unit: deg, sign: -1}" in err.message


def test_yaw_rate_sign_hint_works_for_a_table(tmp_path):
    d = steered()
    d["r"] = -d["r"]
    p, sp = csv_log(tmp_path, d)
    err = codes(audit(read_trial(p, sp)))["yaw_rate_sign"]
    assert "`columns: {r: {col: r, unit: deg/s, sign: -1}}`" in err.message
    apply_hint(sp, err.message)
    assert not [x for x in audit(read_trial(p, sp)) if x.severity == "error"]


def test_hints_for_the_nmea_readers_and_presets():
    from usvid.prep.channel_audit import spec_hint

    tr = Trial(pd.DataFrame({"t": [0.0], "delta": [0.0]}),
               meta={"reader": "nmea2000", "spec": None})
    h = spec_hint(tr, "delta", sign=True)
    assert "`reader: nmea2000` and `columns: {delta: {col: delta, sign: -1}}`" in h
    tr = Trial(pd.DataFrame({"t": [0.0], "delta": [0.0]}), meta={
        "reader": "dataflash", "spec": "ardupilot_rover.yaml", "format_detected": "...",
        "spec_shipped": "ardupilot_rover",
        "spec_columns": {"delta": {"message": "STER", "field": "SteerOut", "scale": 0.0078,
                                   "unit": "deg", "optional": True}}})
    h = spec_hint(tr, "delta", sign=True)
    assert "copy the shipped spec 'ardupilot_rover'" in h
    assert "`delta: {message: STER, field: SteerOut, scale: 0.0078, unit: deg, sign: -1}`" in h


def test_rudder_beyond_its_travel_is_explained_not_hard_over():
    d = steered()
    d["delta"] = np.radians(-105.06) + 1e-4 * np.sin(d["t"])
    f = codes(audit(Trial(d.drop(columns=["delta_cmd"]))))
    assert f["rudder_out_of_range"].severity == "warning"
    assert "-105.1 deg" in f["rudder_out_of_range"].message
    assert "saturation" not in f


def test_no_numpy_warnings_and_no_nan_in_messages():
    # a log whose measured speed is zero throughout and whose heading has NaN stretches
    d = steered()
    d["U"] = 0.0
    d.loc[200:400, "psi"] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = audit(Trial(d))
    assert not any("nan" in x.message.lower().replace("nan_", "") for x in f)


def test_cli_lists_errors_first(capsys, tmp_path):
    d = steered()
    d["r"] = -d["r"]
    p, sp = csv_log(tmp_path, d)
    code = main(["audit", str(p), "--format", str(sp), "--json"])
    import json

    out = json.loads(capsys.readouterr().out)
    assert code == 3
    sev = [x["severity"] for x in out["findings"]]
    assert sev == sorted(sev, key=["error", "warning", "info"].index)


def test_audit_and_metrics_see_the_same_heading_glitches():
    from usvid.manoeuvres.measure import measured_metrics
    from usvid.prep.glitches import repair_trial_heading

    d = zigzag()
    for i in (300, 900, 1300):
        d.loc[i, "psi"] += np.radians(3.0)  # three one-sample compass glitches
    tr = Trial(d)
    n = repair_trial_heading(tr)[1]
    assert n == 3
    assert codes(audit(tr))["heading_glitch"].count == n
    ms = measured_metrics(tr)
    assert ms and all(m["heading_glitches"] == n for m in ms)


def test_held_heading_samples_are_missing_not_a_staircase():
    # a compass logged at 10 Hz that updates at 1 Hz (held, then catching up) while the gyro
    # turns the boat: the held samples are treated as missing and the gyro agrees
    from usvid.prep.glitches import repair_trial_heading

    d = steered()
    held = d["psi"].to_numpy().copy()
    held = held[(np.arange(len(held)) // 10) * 10]
    tr = Trial(d.assign(psi=held))
    fixed, _ = repair_trial_heading(tr)
    # (the first sample of each second is fresh; seconds the boat turned less than 1 deg in
    # are not judged: 1512 of 2000 measured)
    assert fixed.meta["heading_held"] > 0.7 * len(held)
    f = codes(audit(tr))
    assert not [x for x in f.values() if x.severity == "error"]
    assert "heading_jump" not in f


# --- robot logs: servo functions, vehicle kind, fixes without a fix, several senders -----------
def _tlog(path, *, servo_functions, null_fixes=5, second_attitude=False):
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    other = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    out = []
    us0 = 1_700_000_000_000_000

    def put(us, msg, m=mav):
        out.append(struct.pack(">Q", us) + msg.pack(m))

    put(us0, mavlink.MAVLink_heartbeat_message(11, 3, 0, 0, 0, 3))  # surface boat, ArduPilot
    for k, fn in servo_functions.items():
        put(us0, mavlink.MAVLink_param_value_message(f"SERVO{k}_FUNCTION".encode(), fn, 9, 3, 0))
    d = steered(t_end=60.0)
    for i in range(len(d)):
        us = us0 + int(d.t[i] * 1e6)
        bm = int(d.t[i] * 1000)
        nofix = i < null_fixes
        lat = 0 if nofix else int(round((54.0 + d.x[i] / 111195.0) * 1e7))
        lon = 0 if nofix else int(round((10.0 + d.y[i] / 65360.0) * 1e7))
        put(us, mavlink.MAVLink_global_position_int_message(bm, lat, lon, 0, 0, 0, 0, 0, 65535))
        put(us, mavlink.MAVLink_gps_raw_int_message(bm * 1000, 1 if nofix else 3, lat, lon, 0,
                                                    80, 65535, 150, 0, 12))
        put(us, mavlink.MAVLink_attitude_message(bm, 0.0, 0.0, float(d.psi[i]), 0.0, 0.0,
                                                 float(d.r[i])))
        if second_attitude and i % 4 == 0:
            put(us + 500, mavlink.MAVLink_attitude_message(bm, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
                other)
        rudder = int(round(1500 + 400 * float(d.delta[i]) / np.radians(35)))
        servo = [1900, 1500, rudder] + [1500] * 13  # servo 1: an RC pass-through
        put(us, mavlink.MAVLink_servo_output_raw_message(bm * 1000, 0, *servo))
    path.write_bytes(b"".join(out))
    return path, d


def test_rudder_from_the_servo_with_steering_function(tmp_path):
    p, d = _tlog(tmp_path / "b.tlog", servo_functions={1: 51, 3: 26})
    tr = read_trial(p)
    note = tr.meta["format_detected"]
    assert "SERVO3_FUNCTION 26" in note and "'delta' from SERVO_OUTPUT_RAW.servo3_raw" in note
    # the rudder (servo 3), not the pass-through held at 1900 us on servo 1
    delta = tr["delta"][np.isfinite(tr["delta"])]
    assert np.degrees(delta).min() == pytest.approx(-20.0, abs=0.1)
    # the vehicle named; the first fixes (lat = lon = 0, fix type 'no fix') dropped
    assert tr.meta["vehicle"]["kind"] == "surface boat"
    assert tr.rejected["no_fix"] == 5
    assert np.nanmin(tr["lat"]) > 53.9
    assert not [x for x in audit(tr) if x.severity == "error"]


def test_messages_of_two_mavlink_systems_are_kept_apart(tmp_path):
    p, d = _tlog(tmp_path / "two.tlog", servo_functions={1: 26}, null_fixes=0,
                 second_attitude=True)
    tr = read_trial(p)
    psi = tr["psi"][np.isfinite(tr["psi"])]
    assert len(psi) == len(d)  # only system 1's ATTITUDE
    np.testing.assert_allclose(np.mod(psi, 2 * np.pi), np.mod(d.psi, 2 * np.pi), atol=1e-6)
    f = next(x for x in tr.findings if x.code == "several_sources")
    assert f.data["chosen"] == "1/1" and "message ATTITUDE" in f.message


def test_constant_thruster_differential_finds_no_manoeuvre_and_does_not_crash():
    # two thrusters always equal (a differential of zero: its 95th percentile is 0, the level
    # threshold 0): no pulse, and the heading alone may still show a turn (ZeroDivisionError
    # before, in the ratio of two pulse levels)
    from usvid.manoeuvres.detect import find_manoeuvres

    d = steered().drop(columns=["delta", "delta_cmd"])
    d["n_port"] = d["n_stbd"] = 0.6
    segs = find_manoeuvres(Trial(d))
    assert all(s.command == "heading" for s in segs)
