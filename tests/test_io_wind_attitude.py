"""Wind, attitude and magnetic headings in every reader: NMEA 0183 (MWV R/T, MWD, VWR, VWT, HDM
and variation, XDR), NMEA 2000 (PGN 130306 by reference, 127257, 127258), tables, and the
quaternion conversions of the message logs. Conventions: wind angle from the bow clockwise and
wind direction from north clockwise, both where the wind comes FROM; roll positive starboard
down, pitch bow up."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from usvid.io import read_trial
from usvid.io._derived import heading_at
from usvid.io._messages import convert_raw, roll_pitch, yaw_ned
from usvid.io.n2k import _Encoder, pdgy_time
from usvid.io.nmea0183 import sentence
from usvid.io.spec import parse_spec

KN = 1852 / 3600


def _nmea(tmp_path, lines, name="w.nmea"):
    p = tmp_path / name
    p.write_text("\r\n".join(lines) + "\r\n")
    return p


def test_mwv_mwd_vwr_vwt_hand_values(tmp_path):
    lines = []
    for k in range(10):
        hms = f"1200{k:02d}.00"
        lines.append(sentence(f"GPRMC,{hms},A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A"))
        lines.append(sentence("HEHDT,90.0,T"))
        lines.append(sentence("WIMWV,300.0,R,10.0,N,A"))  # apparent: 60 deg off the port bow
        lines.append(sentence("WIMWV,45.0,T,5.0,M,A"))  # true, from the bow: 45 deg starboard
        lines.append(sentence("WIMWD,135.0,T,130.0,M,9.7,N,5.0,M"))
    tr = read_trial(_nmea(tmp_path, lines))
    # MWV R: 300 deg clockwise from the bow = -60 deg; 10 knots
    assert np.nanmax(tr["wind_angle"]) == pytest.approx(math.radians(-60.0))
    assert np.nanmax(tr["wind_speed"]) == pytest.approx(10 * KN)
    # MWV T from the bow and MWD from north: heading 90 + 45 = 135 deg = MWD's direction
    assert np.nanmax(tr["wind_angle_true"]) == pytest.approx(math.radians(45.0))
    assert np.nanmax(tr["wind_dir_true"]) == pytest.approx(math.radians(135.0))
    assert np.nanmax(tr["wind_speed_true"]) == pytest.approx(5.0)
    # VWR / VWT: 0-180 deg and L/R (L = from port: negative)
    lines = [sentence(f"GPRMC,1200{k:02d}.00,A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A")
             for k in range(3)]
    lines.insert(1, sentence("IIVWR,060,L,10.0,N,,M,,K"))
    lines.insert(2, sentence("IIVWT,045,R,,N,5.0,M,,K"))
    tr = read_trial(_nmea(tmp_path, lines, "v.nmea"))
    assert np.nanmax(tr["wind_angle"]) == pytest.approx(math.radians(-60.0))
    assert np.nanmax(tr["wind_speed"]) == pytest.approx(10 * KN)
    assert np.nanmax(tr["wind_angle_true"]) == pytest.approx(math.radians(45.0))
    assert np.nanmax(tr["wind_speed_true"]) == pytest.approx(5.0)
    # no heading: the true wind angle is kept, its direction from north is not known
    assert "wind_dir_true" not in tr.channels
    assert any(f.code == "wind_direction_unknown" for f in tr.findings)


def test_true_wind_direction_from_the_bow_angle_and_the_heading(tmp_path):
    # MWV T only (no MWD): wind_dir_true = angle from the bow + heading at the wind's time
    lines = []
    for k in range(10):
        lines.append(sentence(f"GPRMC,1200{k:02d}.00,A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A"))
        lines.append(sentence(f"HEHDT,{350.0 + 2 * k:.1f},T"))  # through north
        lines.append(sentence("WIMWV,20.0,T,5.0,M,A"))
    tr = read_trial(_nmea(tmp_path, lines))
    d = np.degrees(tr["wind_dir_true"][np.isfinite(tr["wind_dir_true"])])
    # the MWV sits 2/3 s after its fix, the heading 1/3 s (interpolated between the fixes: 2
    # deg/s), so the heading at the wind's time is 350 + 2 k + 2/3 deg, wrapped past north (the
    # last fix's sentences are clamped to its time: left out)
    want = np.mod(20.0 + 350.0 + 2 * np.arange(8) + 2 / 3, 360.0)
    np.testing.assert_allclose(d[:8], want, atol=1e-6)
    assert any(f.code == "wind_direction_from_heading" for f in tr.findings)


def test_heading_at_interpolates_across_north_and_not_across_gaps():
    t = np.array([0.0, 1.0, 2.0, 10.0])
    psi = np.radians([359.0, 1.0, 3.0, 40.0])
    h = np.degrees(heading_at(t, psi, np.array([0.5, 1.5, 6.0, 11.0])))
    np.testing.assert_allclose(h[:2], [0.0, 2.0], atol=1e-9)
    assert np.isnan(h[2:]).all()  # a gap of 8 s and beyond the last sample


def test_hdm_with_variation_and_xdr_attitude(tmp_path):
    lines = []
    for k in range(5):
        lines.append(sentence(f"GPRMC,1200{k:02d}.00,A,5400.000,N,01000.000,E,4.0,90.0,241125,"
                              "3.5,W,A"))
        lines.append(sentence("IIHDM,100.0,M"))
        # a damaged group (TRIM) does not spoil the others; temperature groups are no channel
        lines.append(sentence("IIXDR,C,10.7,C,AIRTEMP,A,2.5,D,HEEL,A,-1.-3,D,TRIM,A,-4.0,D,RUDDER"))
    tr = read_trial(_nmea(tmp_path, lines))
    # no true heading: the magnetic heading plus the logged variation (3.5 W = -3.5 deg)
    assert np.nanmax(np.degrees(tr["psi"])) == pytest.approx(96.5)
    f = next(f for f in tr.findings if f.code == "heading_from_magnetic")
    assert f.data["variation_deg"] == pytest.approx(-3.5)
    assert np.nanmax(np.degrees(tr["phi"])) == pytest.approx(2.5)
    assert np.nanmax(np.degrees(tr["delta"])) == pytest.approx(-4.0)
    assert "theta" not in tr.channels
    # without a variation anywhere: psi is the magnetic heading, and a warning says so
    lines = [ln for ln in lines if "RMC" not in ln] + [
        sentence("GPGGA,120009.00,5400.000,N,01000.000,E,1,08,0.9,1.0,M,0.0,M,,")]
    tr = read_trial(_nmea(tmp_path, lines, "m.nmea"))
    assert any(f.code == "heading_magnetic" and f.severity == "warning" for f in tr.findings)


def test_rsa_both_rudders(tmp_path):
    lines = [sentence(f"GPRMC,1200{k:02d}.00,A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A")
             for k in range(3)]
    lines.insert(1, sentence("IIRSA,10.0,A,-12.0,A"))
    tr = read_trial(_nmea(tmp_path, lines))
    assert np.nanmax(np.degrees(tr["delta"])) == pytest.approx(10.0)
    assert np.nanmax(np.degrees(tr["delta_port"])) == pytest.approx(-12.0)


def _n2k(tmp_path, records, name="n.log"):
    lines = []
    for t, pgn, src, fields in records:
        lines += _Encoder(src, "can0").lines(1.7e9 + t, pgn, fields)
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def test_pgn_130306_every_reference_and_127257_attitude(tmp_path):
    recs = []
    for k in range(20):
        t = 0.1 * k
        recs.append((t, 127257, 5, {"sid": k, "yaw": math.radians(-20.0),
                                    "pitch": math.radians(3.0), "roll": math.radians(-4.0)}))
        recs.append((t, 130306, 9, {"sid": k, "windSpeed": 6.0, "windAngle": math.radians(300.0),
                                    "reference": 2}))  # apparent
        recs.append((t + 0.05, 130306, 9, {"sid": k, "windSpeed": 4.0,
                                           "windAngle": math.radians(30.0),
                                           "reference": 3}))  # true, boat referenced
    tr = read_trial(_n2k(tmp_path, recs))
    # no 127250: the heading is the attitude's yaw (taken as true), wrapped to [0, 2 pi)
    assert np.nanmax(np.degrees(tr["psi"])) == pytest.approx(340.0, abs=0.01)
    assert any(f.code == "heading_from_attitude" for f in tr.findings)
    assert np.nanmax(np.degrees(tr["theta"])) == pytest.approx(3.0, abs=0.01)
    assert np.nanmax(np.degrees(tr["phi"])) == pytest.approx(-4.0, abs=0.01)
    assert np.nanmax(np.degrees(tr["wind_angle"])) == pytest.approx(-60.0, abs=0.01)
    assert np.nanmax(tr["wind_speed"]) == pytest.approx(6.0)
    assert np.nanmax(np.degrees(tr["wind_angle_true"])) == pytest.approx(30.0, abs=0.01)
    assert np.nanmax(tr["wind_speed_true"]) == pytest.approx(4.0)
    # boat-referenced true wind + heading 340 deg = 10 deg from north
    d = np.degrees(tr["wind_dir_true"])
    assert np.nanmin(d) == pytest.approx(10.0, abs=0.01) and np.nanmax(d) == pytest.approx(
        10.0, abs=0.01)
    # a ground-referenced true wind (reference 0) is taken as it is, the magnetic one (1) with
    # the variation of PGN 127258
    recs = [(0.1 * k, 130306, 9, {"sid": k, "windSpeed": 5.0, "windAngle": math.radians(200.0),
                                  "reference": 1}) for k in range(10)]
    recs += [(0.05, 127258, 4, {"sid": 0, "source": 0, "ageOfService": 0,
                                "variation": math.radians(-10.0)})]
    tr = read_trial(_n2k(tmp_path, recs, "m.log"))
    assert np.nanmax(np.degrees(tr["wind_dir_true"])) == pytest.approx(190.0, abs=0.01)
    assert any(f.code == "wind_direction_magnetic" and f.severity == "info"
               for f in tr.findings)


def test_pdgy_milliseconds_without_padding():
    assert pdgy_time("482.36") == pytest.approx(482.036)
    assert pdgy_time("482.117") == pytest.approx(482.117)
    assert pdgy_time("481.936") == pytest.approx(481.936)
    assert pdgy_time("482") == 482.0
    assert math.isnan(pdgy_time("48a.3")) and math.isnan(pdgy_time("1.2345"))


def test_pdgy_log_keeps_its_order(tmp_path):
    import base64

    from usvid.io.n2k import _Encoder

    enc = _Encoder(3, "can0")
    stamps = ["481.835", "481.936", "482.36", "482.137", "482.238"]  # as iKonvert writes them
    lines = [f"!PDGY,127250,2,3,255,{s},"
             + base64.b64encode(enc.payload(127250, {"sid": k, "heading": 0.1 * k,
                                                     "deviation": None, "variation": None,
                                                     "reference": 0})).decode()
             for k, s in enumerate(stamps)]
    p = tmp_path / "i.log"
    p.write_text("\n".join(lines) + "\n")
    tr = read_trial(p)
    np.testing.assert_allclose(tr.t, [0.0, 0.101, 0.201, 0.302, 0.403], atol=1e-9)
    np.testing.assert_allclose(tr["psi"], 0.1 * np.arange(5), atol=1e-4)
    assert not any(f.code == "non_monotonic_time" for f in tr.findings)


def test_table_wind_columns_wrapped(tmp_path):
    p = tmp_path / "w.csv"
    pd.DataFrame({"time": [0.0, 0.1, 0.2], "aw": [350.0, 10.0, 180.0],
                  "tw": [-10.0, 370.0, 0.0]}).to_csv(p, index=False)
    spec = {"reader": "table", "delimiter": ",", "header": True, "columns": {
        "t": {"col": "time", "unit": "s"}, "wind_angle": {"col": "aw", "unit": "deg"},
        "wind_dir_true": {"col": "tw", "unit": "deg"}}}
    tr = read_trial(p, spec)
    # apparent angle in (-180, 180], true direction in [0, 360)
    np.testing.assert_allclose(np.degrees(tr["wind_angle"]), [-10.0, 10.0, 180.0], atol=1e-9)
    np.testing.assert_allclose(np.degrees(tr["wind_dir_true"]), [350.0, 10.0, 0.0], atol=1e-9)


# --- roll and pitch from quaternions -------------------------------------------------------
@pytest.mark.parametrize(("roll", "pitch", "yaw"), [(10.0, 5.0, 30.0), (-20.0, -3.0, 200.0)])
def test_roll_pitch_from_quaternions_ned_and_enu(roll, pitch, yaw):
    # NED / FRD (PX4, ArduPilot): body to earth = Rz(yaw) Ry(pitch) Rx(roll)
    q = Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).as_quat()  # x, y, z, w
    wxyz = np.array([[q[3], q[0], q[1], q[2]]])
    phi, theta = roll_pitch(wxyz, "ned")
    assert math.degrees(phi[0]) == pytest.approx(roll) and math.degrees(theta[0]) == \
        pytest.approx(pitch)
    assert math.degrees(yaw_ned(wxyz, "ned")[0]) == pytest.approx(yaw % 360)
    # ENU / FLU (ROS): the same attitude - starboard down is a positive rotation about x
    # forward in both; bow up is a negative rotation about y to port
    q = Rotation.from_euler("ZYX", [90.0 - yaw, -pitch, roll], degrees=True).as_quat()
    wxyz = np.array([[q[3], q[0], q[1], q[2]]])
    phi, theta = roll_pitch(wxyz, "enu")
    assert math.degrees(phi[0]) == pytest.approx(roll) and math.degrees(theta[0]) == \
        pytest.approx(pitch)
    assert math.degrees(yaw_ned(wxyz, "enu")[0]) == pytest.approx(yaw % 360)
    # through a spec column as the presets write it
    col = parse_spec({"reader": "rosbag", "columns": {"phi": {
        "topic": "/imu/data", "field": "orientation", "convert": "roll", "frame": "enu"}}}
    ).columns["phi"]
    assert math.degrees(convert_raw(col, wxyz)[0]) == pytest.approx(roll)


@pytest.mark.parametrize("fmt", ["rosbag", "ulog", "dataflash", "tlog"])
def test_roll_pitch_roll_rate_round_trip_through_every_message_log(tmp_path, fmt):
    """phi, theta, p written by usvid's writer of each robot-log format (ROS Imu orientation and
    angular_velocity.x, PX4 vehicle_attitude.q and vehicle_angular_velocity.xyz[0], ArduPilot
    ATT.Roll/Pitch and IMU.GyrX, MAVLink ATTITUDE.roll/pitch/rollspeed) and read back with the
    shipped preset, within the formats' quantisation."""
    from usvid import Trial
    from usvid.io.ardupilot import write_dataflash, write_tlog
    from usvid.io.rosbag import write_rosbag
    from usvid.io.ulog import write_ulog

    t = np.round(np.arange(0.0, 4.0, 0.1), 6)
    tr = Trial(pd.DataFrame({
        "t": t, "lat": 38.8 + 1e-5 * t, "lon": 121.5 + 1e-5 * t, "sog": 2.0 + 0 * t,
        "cog": 0.3 + 0 * t, "psi": 0.3 + 0.1 * t, "r": 0.1 + 0 * t, "delta": 0.05 + 0 * t,
        "phi": np.radians(8.0) * np.sin(t), "theta": np.radians(-3.0) * np.cos(t),
        "p": np.radians(8.0) * np.cos(t)}), meta={"t0_utc": "2025-03-01T10:00:00+00:00"})
    writer = {"rosbag": lambda p: write_rosbag(tr, p / "bag"),
              "ulog": lambda p: write_ulog(tr, p / "log.ulg"),
              "dataflash": lambda p: write_dataflash(tr, p / "log.bin"),
              "tlog": lambda p: write_tlog(tr, p / "log.tlog")}[fmt]
    back = read_trial(writer(tmp_path))
    # tolerances: DataFlash ATT in centidegrees (0.005 deg), float32 elsewhere
    tol = {"dataflash": math.radians(0.005) + 1e-9}.get(fmt, 1e-6)
    for ch in ("phi", "theta", "p"):
        ok = np.isfinite(back[ch])
        np.testing.assert_allclose(back[ch][ok], tr[ch][:ok.sum()], atol=tol, err_msg=ch)
