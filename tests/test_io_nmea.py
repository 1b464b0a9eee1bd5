"""NMEA 0183 and NMEA 2000 (candump -L) readers and writers: round trips, hand-checked encodings,
bad input (checksum, truncation, garbage, empty, non-monotonic time)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from usvid import Trial
from usvid.errors import LogReadError
from usvid.io import read_candump, read_nmea0183, read_trial, write_candump, write_nmea0183
from usvid.io.n2k import candump_lines
from usvid.io.nmea0183 import checksum, sentence


def circle_trial(dt=0.1, T=30.0):
    """A 50 m circle at 2 m/s with heading, yaw rate, rudder, speed, course and shaft rate."""
    t = np.round(np.arange(0.0, T, dt), 6)
    R, U = 50.0, 2.0
    w = U / R
    psi = (w * t) % (2 * np.pi)
    lat = 38.8 + R * np.sin(w * t) / 111_320.0
    lon = -121.5 + R * (1 - np.cos(w * t)) / (111_320.0 * np.cos(np.radians(38.8)))
    df = pd.DataFrame({
        "t": t, "lat": lat, "lon": lon, "psi": psi, "r": np.full_like(t, w),
        "delta": np.radians(-10.0 + 20.0 * np.sin(t / 5.0)), "sog": np.full_like(t, U),
        "cog": psi, "n": np.full_like(t, 10.23),
    })
    return Trial(df, name="circle", meta={"t0_utc": "2025-11-24T23:59:50+00:00"})


def ang_err(a, b):
    return np.abs((a - b + np.pi) % (2 * np.pi) - np.pi)


# --- NMEA 0183 -------------------------------------------------------------------------------
def test_checksum_hand_value():
    # the textbook GGA example (NMEA 0183 reference): checksum 47
    body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"
    assert checksum(body) == "47"
    # by hand: H^E^H^D^T = 0x55, ^',' 0x79, ^'4' 0x4D, ^'5' 0x78, ^'.' 0x56, ^'0' 0x66,
    # ^',' 0x4A, ^'T' 0x1E
    assert sentence("HEHDT,45.0,T") == "$HEHDT,45.0,T*1E"


@pytest.mark.parametrize("prefix", ["iso", "epoch"])
@pytest.mark.parametrize("engine", ["fast", "pynmeagps"])
def test_nmea0183_roundtrip(tmp_path, prefix, engine):
    tr = circle_trial()
    p = write_nmea0183(tr, tmp_path / "c.nmea", prefix=prefix)
    back = read_nmea0183(p, engine=engine)
    assert back.rejected == {}
    assert back.meta["t0_utc"] == "2025-11-24T23:59:50+00:00"
    # times survive to the microsecond of the prefix (the crossing of midnight included)
    assert back.t == pytest.approx(tr.t, abs=1e-6)
    # tolerances = half the written quantisation: 1e-6 arcmin (lat/lon), 1e-3 deg (heading,
    # rudder), 1e-3 deg/min (ROT), 1e-3 kn, 0.01 deg (course), plus float rounding
    assert np.max(np.abs(back["lat"] - tr["lat"])) < 1e-8
    assert np.max(np.abs(back["lon"] - tr["lon"])) < 1e-8
    assert np.max(ang_err(back["psi"], tr["psi"])) < math.radians(0.5e-3) + 1e-12
    assert np.max(np.abs(back["delta"] - tr["delta"])) < math.radians(0.5e-3) + 1e-12
    assert np.max(np.abs(back["r"] - tr["r"])) < math.radians(0.5e-3) / 60 + 1e-12
    assert np.max(np.abs(back["sog"] - tr["sog"])) < 0.5e-3 * 1852 / 3600 + 1e-12
    assert np.max(ang_err(back["cog"], tr["cog"])) < math.radians(0.005) + 1e-12


def test_engines_agree_on_a_damaged_log(tmp_path):
    lines = (write_nmea0183(circle_trial(T=5.0), tmp_path / "a.nmea")
             .read_bytes().split(b"\r\n"))
    lines[3] = lines[3][:-2] + b"00"  # wrong checksum
    lines[7] = lines[7][:45]  # truncated inside the sentence (the prefix is 28 chars)
    lines[9] = b"\x00\xff\xfe garbage \x07"
    lines[11] = lines[11].replace(b",A,", b",V,")  # RSA status V (invalid), checksum fixed next
    s = lines[11].split(b" ", 1)[1]
    lines[11] = lines[11].split(b" ", 1)[0] + b" " + sentence(s[1:-3].decode()).encode()
    lines.insert(13, b"2025-11-24T23:59:50.5Z $GPGSV,1,1,00*79")
    p = tmp_path / "b.nmea"
    p.write_bytes(b"\r\n".join(lines))
    a = read_nmea0183(p, engine="fast")
    b = read_nmea0183(p, engine="pynmeagps")
    assert a.rejected == {"checksum": 1, "truncated": 1, "garbage": 1, "invalid_flag": 1}
    assert a.rejected == b.rejected
    assert a.meta["ignored_sentences"] == {"GSV": 1} == b.meta["ignored_sentences"]
    pd.testing.assert_frame_equal(a.data, b.data, check_exact=False, atol=1e-9, rtol=0)


def test_nmea0183_empty_and_wholly_bad(tmp_path):
    e = tmp_path / "empty.nmea"
    e.write_bytes(b"")
    with pytest.raises(LogReadError, match=r"empty\.nmea: empty file"):
        read_nmea0183(e)
    g = tmp_path / "junk.nmea"
    g.write_bytes(bytes(range(256)) * 20)
    with pytest.raises(LogReadError, match=r"junk\.nmea: no usable NMEA 0183 sentence .*garbage"):
        read_nmea0183(g)
    c = tmp_path / "cks.nmea"
    c.write_text("\n$HEHDT,45.0,T*00\n$HEHDT,46.0,T*00\n")
    with pytest.raises(LogReadError, match=r"cks\.nmea: .*rejected checksum: 2; first bad line 2"):
        read_nmea0183(c)


def test_nmea0183_non_monotonic_prefix_time(tmp_path):
    ts = [0.0, 0.1, 0.3, 0.2, 0.4]
    text = "".join(f"{1700000000 + x:.3f} {sentence(f'HEHDT,{10 + i:.1f},T')}\n"
                   for i, x in enumerate(ts))
    p = tmp_path / "nm.nmea"
    p.write_text(text)
    tr = read_nmea0183(p)
    assert np.all(np.diff(tr.t) > 0) and len(tr) == 5
    assert tr["psi"][2] == pytest.approx(math.radians(13.0))  # 0.2 s record sorted into place
    assert any(f.code == "non_monotonic_time" and f.count == 1 for f in tr.findings)
    tr2 = read_trial(p, {"reader": "nmea0183", "non_monotonic": "reject"})
    assert tr2.rejected == {"non_monotonic": 1} and len(tr2) == 4


def test_nmea0183_sentence_time_interpolation_and_any_talker(tmp_path):
    # no prefix: 1 Hz GNRMC with date, 4 heading sentences between fixes get interpolated times
    out = []
    for k in range(3):
        out.append(sentence(f"GNRMC,1200{k:02d}.00,A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A"))
        out += [sentence(f"INTHS,{90 + k + j / 4:.2f},A") for j in range(1, 4)]
        out.append(sentence(f"IIROT,{-30.0:.1f},A"))
    out.append(sentence("HEHDG,80.0,1.0,E,2.0,W"))  # magnetic heading: kept as psi_mag
    p = tmp_path / "s.nmea"
    p.write_text("\r\n".join(out) + "\r\n")
    tr = read_nmea0183(p)
    assert tr.meta["time_source"] == "sentence"
    assert tr.meta["t0_utc"] == "2025-11-24T12:00:00+00:00"
    f = [x for x in tr.findings if x.code == "time_interpolated"]
    assert f and f[0].count == 13  # 9 THS + 3 ROT + 1 HDG
    psi = tr["psi"]
    ok = np.isfinite(psi)
    # the THS of second k, j/4 sits at k + j/5 s (5 lines per second, interpolated by line)
    assert tr.t[ok][:3] == pytest.approx([0.2, 0.4, 0.6], abs=1e-9)
    assert psi[ok][:3] == pytest.approx(np.radians([90.25, 90.5, 90.75]), rel=1e-12)
    assert np.nanmax(tr["r"]) == pytest.approx(math.radians(-30.0) / 60.0)  # deg/min, to port
    assert np.nanmax(tr["sog"]) == pytest.approx(4.0 * 1852 / 3600)
    # the magnetic heading plus its deviation (the variation is not added while a true
    # heading is logged)
    assert np.nanmax(tr["psi_mag"]) == pytest.approx(math.radians(80.0 + 1.0))


def test_nmea0183_midnight_rollover_without_prefix(tmp_path):
    out = [sentence(f"GPGGA,{h},5400.000,N,01000.000,E,1,08,0.9,1.0,M,0.0,M,,")
           for h in ("235959.50", "000000.00", "000000.50")]
    p = tmp_path / "m.nmea"
    p.write_text("\n".join(out))
    tr = read_nmea0183(p)
    assert tr.t == pytest.approx([0.0, 0.5, 1.0])


def test_nmea0183_spec_resign(tmp_path):
    p = write_nmea0183(circle_trial(T=1.0), tmp_path / "r.nmea")
    tr = read_trial(p, {"reader": "nmea0183", "columns": {"delta": {"col": "delta", "sign": -1}}})
    assert tr["delta"][0] == pytest.approx(math.radians(10.0), abs=1e-5)


# --- NMEA 2000 candump -----------------------------------------------------------------------
def test_candump_hand_encoded_heading_frame():
    tr = Trial(pd.DataFrame({"t": [0.0], "psi": [1.2345]}),
               meta={"t0_utc": "2023-11-14T22:13:20.123456+00:00"})
    # priority 2, PGN 127250 = 0x1F112, source 3 -> CAN id 0x09F11203; SID 0, heading
    # 12345 = 0x3039 (1e-4 rad) little endian, deviation/variation "not available" 0x7FFF,
    # reference 0 (true) + 6 reserved bits set = 0xFC
    assert candump_lines(tr) == ["(1700000000.123456) can0 09F11203#003930FF7FFF7FFC"]


def test_candump_roundtrip(tmp_path):
    tr = circle_trial()
    p = write_candump(tr, tmp_path / "c.log")
    back = read_candump(p)
    assert back.rejected == {}
    assert back.t == pytest.approx(tr.t, abs=1e-6)
    # tolerances = half the PGN resolutions: 1e-7 deg (129025), 1e-4 rad (127250, 127245,
    # 129026), 3.125e-8 rad/s (127251), 0.01 m/s (129026), 0.25 rpm (127488)
    assert np.max(np.abs(back["lat"] - tr["lat"])) <= 0.5e-7 + 1e-12
    assert np.max(np.abs(back["lon"] - tr["lon"])) <= 0.5e-7 + 1e-12
    assert np.max(ang_err(back["psi"], tr["psi"])) <= 0.5e-4 + 1e-12
    assert np.max(np.abs(back["delta"] - tr["delta"])) <= 0.5e-4 + 1e-12
    assert np.max(np.abs(back["r"] - tr["r"])) <= 0.5 * 3.125e-8 + 1e-15
    assert np.max(np.abs(back["sog"] - tr["sog"])) <= 0.005 + 1e-12
    assert np.max(ang_err(back["cog"], tr["cog"])) <= 0.5e-4 + 1e-12
    assert np.max(np.abs(back["n"] - tr["n"])) <= 0.125 / 60 + 1e-12
    assert "delta_cmd" not in back.channels  # written as "not available"


def test_candump_twin_engines(tmp_path):
    t = np.arange(0, 1, 0.1)
    tr = Trial(pd.DataFrame({"t": t, "n_port": 5 + t, "n_stbd": 6 - t}))
    back = read_trial(write_candump(tr, tmp_path / "e.log"), None)
    assert back["n_port"] == pytest.approx(5 + t, abs=0.125 / 60)
    assert back["n_stbd"] == pytest.approx(6 - t, abs=0.125 / 60)


def test_candump_bad_lines_counted_and_empty(tmp_path):
    lines = candump_lines(circle_trial(T=1.0))
    lines[2] = "this is not candump"
    lines[4] = lines[4].split("#")[0] + "#0"  # odd number of hex digits
    lines.insert(6, "(1700000000.5) can0 19F01403#0102030405060708")  # PGN 126996 fragment: ignored
    p = tmp_path / "b.log"
    p.write_text("\n".join(lines) + "\n")
    tr = read_candump(p)
    assert tr.rejected == {"garbage": 2}
    assert tr.meta["ignored_pgns"] == {"126996": 1}
    e = tmp_path / "e.log"
    e.write_text("   \n")
    with pytest.raises(LogReadError, match=r"e\.log: empty file"):
        read_candump(e)
    g = tmp_path / "g.log"
    g.write_bytes(b"\x00\x01\x02\n" * 5)
    with pytest.raises(LogReadError, match=r"g\.log: no usable NMEA 2000 frame .*garbage: 5"):
        read_candump(g)


def test_candump_non_monotonic_sorted(tmp_path):
    tr = Trial(pd.DataFrame({"t": [0.0, 0.1, 0.2, 0.3], "psi": [0.1, 0.2, 0.3, 0.4]}))
    lines = candump_lines(tr)
    lines[1], lines[2] = lines[2], lines[1]
    p = tmp_path / "nm.log"
    p.write_text("\n".join(lines) + "\n")
    back = read_candump(p)
    assert back["psi"] == pytest.approx([0.1, 0.2, 0.3, 0.4], abs=0.5e-4)  # 1e-4 rad resolution
    assert any(f.code == "non_monotonic_time" and f.count == 1 for f in back.findings)


def test_nmea_sentence_time_date_before_midnight_rollover(tmp_path) -> None:
    # the log starts at 23:59:59 on 1 Jan (GGA, no date); the first RMC with a date comes after
    # midnight (2 Jan). t = 0 is 1 Jan 23:59:59, not 2 Jan 23:59:59 (one day late before the fix).
    lines = [
        sentence("GPGGA,235959.00,5400.0000,N,01000.0000,E,1,08,1.0,0.0,M,0.0,M,,"),
        sentence("GPRMC,000001.00,A,5400.0010,N,01000.0000,E,5.0,10.0,020125,,,A"),
        sentence("GPGGA,000002.00,5400.0020,N,01000.0000,E,1,08,1.0,0.0,M,0.0,M,,"),
    ]
    p = tmp_path / "midnight.nmea"
    p.write_text("\n".join(lines) + "\n")
    tr = read_nmea0183(p)
    assert tr.meta["t0_utc"] == "2025-01-01T23:59:59+00:00"
    assert list(tr.t) == [0.0, 2.0, 3.0]


def test_nmea_utf8_byte_order_mark(tmp_path) -> None:
    # a BOM made the first sentence "garbage" (non-ASCII bytes) before the fix
    lines = [sentence("HEHDT,10.0,T"), sentence("HEHDT,11.0,T")]
    p = tmp_path / "bom.nmea"
    p.write_bytes(b"\xef\xbb\xbf" + ("1700000000.0 " + lines[0] + "\n1700000001.0 " + lines[1]
                                     + "\n").encode())
    for engine in ("fast", "pynmeagps"):
        tr = read_nmea0183(p, engine=engine)
        assert tr.rejected == {} and len(tr) == 2, engine


def test_candump_short_single_frame_is_truncated_not_decoded(tmp_path) -> None:
    # PGN 127250 (Vessel Heading) is one 8-byte frame; a 2-byte frame holds only the SID and the
    # low heading byte. Before the fix it was decoded as psi = 0x39 * 1e-4 rad = 0.0057 rad.
    p = tmp_path / "short.can"
    p.write_text(
        "(1700000000.1) can0 09F11203#0139\n"
        "(1700000000.2) can0 09F11203#\n"
        "(1700000000.4) can0 09F11203#013930FF7FFF7FFC\n"
    )
    tr = read_candump(p)
    assert tr.rejected == {"truncated": 2}
    assert len(tr) == 1
    assert abs(tr["psi"][0] - 1.2345) < 1e-9  # 0x3039 * 1e-4 rad
