"""Several senders on one bus, shared time stamps and gateway clocks: NMEA 2000 and NMEA 0183 logs
built record by record (each a small case of a problem met in real logs), read truthfully."""

from __future__ import annotations

import math
from datetime import UTC, datetime

import numpy as np
import pandas as pd
import pytest

from usvid import Trial
from usvid.errors import LogReadError
from usvid.io import read_trial
from usvid.io.n2k import _Encoder
from usvid.io.nmea0183 import sentence
from usvid.prep import audit, prepare
from usvid.prep.resample import stream_rate
from usvid.trial import merge_shared_stamp_rows, merge_shared_stamps

T0 = 1_700_000_000.0


def heading_frames(src: int, t: np.ndarray, psi: np.ndarray, r: np.ndarray | None = None
                   ) -> list[tuple[float, str]]:
    """(stamp, candump line) of PGN 127250 (true heading) and 127251 from source ``src``."""
    enc = _Encoder(src, "can0")
    out = []
    for i, (tk, h) in enumerate(zip(t, psi, strict=True)):
        for ln in enc.lines(T0 + tk, 127250, {"sid": i % 250, "heading": float(h) % (2 * math.pi),
                                               "deviation": None, "variation": None,
                                               "reference": 0}):
            out.append((tk, ln))
        if r is not None:
            for ln in enc.lines(T0 + tk, 127251, {"sid": i % 250, "rate": float(r[i])}):
                out.append((tk, ln))
    return out


def nomoto_turns(T: float = 120.0, dt: float = 0.1):
    """A boat weaving: r = 5 deg/s sin(2 pi t / 30), psi its integral [rad]."""
    t = np.arange(0.0, T, dt)
    r = np.radians(5.0) * np.sin(2 * np.pi * t / 30.0)
    psi = 1.0 + np.radians(5.0) * 30.0 / (2 * np.pi) * (1 - np.cos(2 * np.pi * t / 30.0))
    return t, psi, r


def write_lines(path, frames):
    frames = sorted(frames, key=lambda f: f[0])
    path.write_text("\n".join(ln for _, ln in frames) + "\n")
    return path


# --- two compasses on one bus ------------------------------------------------------------------
def test_two_heading_sources_are_kept_apart_and_reported(tmp_path):
    t, psi, r = nomoto_turns()
    # 0x17: heading and rate at 10 Hz; 0x80: a second compass 115 deg off, at 5 Hz
    frames = heading_frames(0x17, t, psi, r) + heading_frames(0x80, t[::2] + 0.05,
                                                                psi[::2] + np.radians(115))
    p = write_lines(tmp_path / "two.log", frames)
    tr = read_trial(p)
    # never interleaved: the heading is the 0x17 compass's, sample for sample
    ok = np.isfinite(tr["psi"])
    assert ok.sum() == len(t)
    np.testing.assert_allclose(np.unwrap(tr["psi"][ok]), psi, atol=1e-4)  # 1e-4 rad PGN res.
    f = next(x for x in tr.findings if x.code == "several_sources" and x.channel == "psi")
    assert f.severity == "warning"  # they disagree
    assert f.data["chosen"] == "0x17" and f.data["samples"] == {"0x17": 1200, "0x80": 600}
    assert f.data["median_difference"]["0x80"] == pytest.approx(math.radians(115), abs=1e-3)
    assert "source: 128" in f.message
    assert tr.meta["sources"]["psi"]["chosen"] == "0x17"
    # the audit finds the gyro agreeing with the heading (the mixed heading made a false error)
    assert not [x for x in audit(tr) if x.severity == "error"]
    # the spec names the other compass; a second column keeps the first one's samples
    tr2 = read_trial(p, {"reader": "nmea2000", "columns": {
        "psi": {"col": "psi", "source": 128}, "psi_b": {"col": "psi", "source": 0x17}}})
    ok2 = np.isfinite(tr2["psi"])
    assert ok2.sum() == 600
    np.testing.assert_allclose(np.unwrap(tr2["psi"][ok2]),
                               np.unwrap(psi[::2] + np.radians(115)), atol=1e-4)
    assert np.isfinite(tr2["psi_b"]).sum() == 1200
    with pytest.raises(LogReadError, match=r"columns\.psi\.source: no source address 5 gives "
                                           r"'psi' in this log \(sources of 'psi': 23, 128\)"):
        read_trial(p, {"reader": "nmea2000", "columns": {"psi": {"col": "psi", "source": 5}}})


def test_two_talkers_of_one_quantity(tmp_path):
    # a GNSS compass (GP) and a gyro compass (HE) both send HDT, 20 deg apart
    lines = []
    for k in range(60):
        hms = f"1200{k:02d}.00"
        lines.append(sentence(f"GPRMC,{hms},A,5400.000,N,01000.000,E,4.0,90.0,241125,,,A"))
        lines.append(sentence(f"HEHDT,{90.0 + 0.1 * k:.2f},T"))
        lines.append(sentence(f"GPHDT,{110.0 + 0.1 * k:.2f},T"))
        lines.append(sentence(f"HEHDT,{90.05 + 0.1 * k:.2f},T"))
    p = tmp_path / "t.nmea"
    p.write_text("\r\n".join(lines) + "\r\n")
    tr = read_trial(p)
    psi = np.degrees(tr["psi"][np.isfinite(tr["psi"])])
    # only the HE compass (twice as many samples); its last two sentences come after the last
    # fix and share its time (one supersedes the other)
    assert len(psi) == 119 and psi.max() < 100
    f = next(x for x in tr.findings if x.code == "several_sources")
    assert f.data["chosen"] == "talker HE" and f.severity == "warning"
    assert 'source: "GP"' in f.message
    tr2 = read_trial(p, {"reader": "nmea0183", "columns": {"psi": {"col": "psi", "source": "GP"}}})
    assert np.nanmin(np.degrees(tr2["psi"])) == pytest.approx(110.0)


# --- gateway clocks ----------------------------------------------------------------------------
def test_bursty_gateway_stamps_rates_from_the_streams(tmp_path):
    """A gateway that stamps its frames in bursts (ten frames within a few ms every 0.5 s): the
    audit's grid follows the message streams (10 Hz), not the 1-ms spacing of the records, and
    finds the gyro and the compass agreeing (a 1 kHz grid flagged nearly every sample)."""
    t, psi, r = nomoto_turns()
    burst = np.floor(t / 0.5) * 0.5 + 0.45 + 0.001 * (np.round(t / 0.1) % 5)  # ms stamps
    frames = heading_frames(7, burst, psi, r)
    p = write_lines(tmp_path / "burst.log", frames)
    tr = read_trial(p)
    assert stream_rate(tr.t, tr["psi"]) == pytest.approx(10.0, rel=0.02)
    assert np.median(np.diff(tr.t[np.isfinite(tr["psi"])])) < 0.002  # the records' spacing
    assert prepare(tr, derivatives=False).sample_rate == pytest.approx(10.0, rel=0.02)
    f = {x.code: x for x in audit(tr)}
    assert not [x for x in f.values() if x.severity == "error"]
    assert "heading_jump" not in f


def test_records_stamped_faster_than_a_bus_are_reported(tmp_path):
    # 2,000 heading frames of a 10 Hz sender stamped within 50 ms (a buffer dumped)
    t, psi, r = nomoto_turns(T=200.0)
    frames = heading_frames(0xCC, np.floor(np.arange(len(t)) / 40) * 0.001, psi, r)
    p = write_lines(tmp_path / "dump.log", frames)
    tr = read_trial(p)
    codes = {x.code: x for x in tr.findings}
    assert codes["time_stamps_collapsed"].severity == "warning"
    # 1,950 superseded, less those equal to the sample that wins (a 1e-4 rad heading repeats)
    assert 1900 < codes["shared_time_stamp"].data["superseded"]["psi"] <= 2000 - 50
    assert codes["shared_time_stamp"].severity == "warning"
    a = {x.code for x in audit(tr)}
    assert "too_short" in a and not {"yaw_rate_column", "yaw_rate_weak"} & a


def test_log_holding_a_copy_of_itself(tmp_path):
    t, psi, r = nomoto_turns(T=30.0)
    lines = [ln for _, ln in sorted(heading_frames(7, t, psi, r), key=lambda f: f[0])]
    p = tmp_path / "twice.log"
    p.write_text("\n".join(lines + lines) + "\n")
    tr = read_trial(p)
    # the copy's records (a heading and a rate frame per sample) dropped and counted
    assert len(tr) == len(t) and tr.rejected == {"repeated_records": 2 * len(t)}
    assert any(x.code == "log_repeated" for x in tr.findings)
    assert "time_breaks" not in tr.meta


# --- one rule for records that share a stamp ---------------------------------------------------
def test_shared_stamps_one_rule_last_wins_and_counted():
    t = np.array([0.0, 0.0, 0.1, 0.1, 0.1, 0.2])
    a = np.array([1.0, 2.0, 5.0, np.nan, 6.0, 7.0])  # 0.0: 1 then 2; 0.1: 5 then 6
    b = np.array([np.nan, 9.0, np.nan, 8.0, np.nan, np.nan])
    tu, m, lost = merge_shared_stamps(t, {"a": a, "b": b})
    np.testing.assert_array_equal(tu, [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(m["a"], [2.0, 6.0, 7.0])  # the last in log order
    np.testing.assert_array_equal(m["b"], [9.0, 8.0, np.nan])
    assert lost == {"a": 2}
    # equal values lose nothing; another stream's different value is no loss either
    tu, m, lost = merge_shared_stamps(t, {"a": a}, streams=np.array([1, 2, 1, 1, 1, 1]))
    assert lost == {"a": 1}  # only 5 -> 6 (one stream); 1 -> 2 is another sender's
    # prepare uses the same rule on a table (it kept the first row before)
    d = pd.DataFrame({"t": t, "a": a, "b": b})
    merged, n = merge_shared_stamp_rows(d)
    assert n == 3 and merged["a"].tolist() == [2.0, 6.0, 7.0]
    tr = prepare(Trial(pd.DataFrame({"t": [0.0, 0.1, 0.1, 0.2, 0.3], "psi": [0.0, 0.1, 0.2,
                                                                             0.3, 0.4]})),
                 10.0, derivatives=False)
    assert tr["psi"][1] == pytest.approx(0.2)
    assert any(f.code == "time_duplicate" and "last value" in f.message for f in tr.findings)


# --- NMEA 0183 timing --------------------------------------------------------------------------
def test_vtg_takes_the_time_of_its_fix_no_doubled_rows(tmp_path):
    lines = []
    for k in range(30):
        hms = f"0854{k:02d}.000"
        lines.append(sentence(f"GPGGA,{hms},5222.3215,N,00454.5778,E,1,4,2.95,16.0,M,47.0,M,,"))
        lines.append(sentence(f"GPRMC,{hms},A,5222.3215,N,00454.5778,E,0.58,251.34,030414,,,A"))
        lines.append(sentence("GPVTG,251.34,T,,M,0.58,N,1.07,K,A"))
        lines.append(sentence("GPGSA,A,3,16,23,13,29,,,,,,,,,3.11,2.95,0.99"))
    p = tmp_path / "gps.log"
    p.write_text("\r\n".join(lines) + "\r\n")
    tr = read_trial(p)
    assert len(tr) == 30  # one row per fix (VTG half a second later doubled them)
    assert np.diff(tr.t) == pytest.approx(np.ones(29))
    assert any(f.code == "time_from_epoch" and f.count == 30 for f in tr.findings)


def test_time_from_gll_and_zda(tmp_path):
    lines = []
    for k in range(20):
        hms = f"0955{k:02d}"
        lines.append(sentence(f"GPZDA,{hms},14,03,2021,00,00"))
        lines.append(sentence(f"GPGLL,6005.071,N,02332.346,E,{hms},A,D"))
        lines.append(sentence(f"IIHDT,{180 + k:.1f},T"))
    p = tmp_path / "gll.log"
    p.write_text("\r\n".join(lines) + "\r\n")
    tr = read_trial(p)
    assert tr.meta["t0_utc"] == datetime(2021, 3, 14, 9, 55, tzinfo=UTC).isoformat()
    # the heading (another talker) interpolated between the fixes, the last one clamped
    assert tr.duration == pytest.approx(19.0, abs=1e-9)
    assert np.isfinite(tr["lat"]).sum() == 20 and np.isfinite(tr["psi"]).sum() == 20
    assert tr["lat"][0] == pytest.approx(60 + 5.071 / 60)
