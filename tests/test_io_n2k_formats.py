"""Every NMEA 2000 wire format the ``nmea2000`` package decodes: a small log written in each reads
back (detected, and with ``n2k_format:`` given) as the trial within the PGN and time-stamp
quantisation; the framing agrees with nmea2000's own encoders; bad input is counted or a one-line
error; hypothesis mutations never escape."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from test_io_fuzz import _mutate, mutation  # noqa: E402  (shared mutation strategy)
from usvid import Trial
from usvid.errors import LogReadError, UsvidError
from usvid.io import detect_reader, read_trial
from usvid.io.n2k import (
    _FIELDS,
    FORMATS,
    SYSTEM_TIME_PGN,
    _channels,
    _system_time,
    bdtp_frames,
    binary_records,
    decode_payloads,
    detect_n2k_format,
    nmea2000_bytes,
    parse_text_record,
    valid_raw,
    write_nmea2000,
)
from usvid.io.spec import N2K_FORMATS

EXT = {"python_can": ".blf"}
#: time-stamp resolution of each format [s] (half of it is the largest error): milliseconds for
#: ISO / time-of-day / gateway-clock formats, 1/1024 s SeaSmart, 1e-4 s System Time, 1 us candump
RES_T = {"basic_string": 1e-3, "can_frame_ascii": 1e-3, "n2k_ascii": 1e-3, "pdgy": 1e-3,
         "bst_d0": 1e-3, "bst_95": 1e-3, "ngt1": 1e-3, "pcdin": 1 / 1024, "candump3": 1e-6,
         "python_can": 1e-6}


def trial(T=2.0, dt=0.1, t0="2025-03-01T10:00:00+00:00"):
    t = np.round(np.arange(0.0, T, dt), 6)
    return Trial(pd.DataFrame({
        "t": t, "lat": 38.8 + 1e-5 * t, "lon": 121.5 - 1e-5 * t, "sog": 2 + 0.1 * t,
        "cog": 0.3 + 0.1 * t, "psi": 0.3 + 0.1 * t, "r": 0.1 - 0.01 * t,
        "delta": 0.1 * np.sin(t), "n": 40 + t}), meta={"t0_utc": t0})


def ang(a, b):
    return np.abs((a - b + np.pi) % (2 * np.pi) - np.pi)


def test_every_package_input_format_is_read():
    """The list is the package's: every decodable N2KFormat (pdgy_debug is refused by nmea2000
    itself; can_frame_ascii_raw_out is an output variant) and python-can log files."""
    from nmea2000.decoder import NMEA2000Decoder
    from nmea2000.input_formats import N2KFormat

    decodable = {f.value for f in N2KFormat if f in NMEA2000Decoder.HANDLERS}
    assert decodable - set(FORMATS) == {"pdgy_debug", "can_frame_ascii_raw_out"}
    assert set(N2K_FORMATS) == {"auto", *FORMATS}


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("n2k")
    return {f: write_nmea2000(trial(), d / f"log_{f}{EXT.get(f, '.log')}", f) for f in FORMATS}


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_format_reads_back(logs, fmt):
    ref = trial()
    p = logs[fmt]
    assert detect_reader(p) == "nmea2000"
    for spec in (None, {"reader": "nmea2000", "n2k_format": fmt}):
        tr = read_trial(p, spec)
        assert tr.meta["n2k_format"] == fmt
        assert tr.rejected == {}
        assert len(tr) == len(ref)
        # t = 0 at the first sample; the date from the stamps or the System Time (PGN 126992)
        assert tr.meta["t0_utc"] == "2025-03-01T10:00:00+00:00"
        assert np.max(np.abs(tr.t - ref.t)) <= RES_T.get(fmt, 1e-4) / 2 + 1e-9
        # half the PGN resolutions (as the candump round trip in test_io_nmea)
        assert np.max(np.abs(tr["lat"] - ref["lat"])) <= 0.5e-7 + 1e-12
        assert np.max(np.abs(tr["lon"] - ref["lon"])) <= 0.5e-7 + 1e-12
        assert np.max(ang(tr["psi"], ref["psi"])) <= 0.5e-4 + 1e-12
        assert np.max(ang(tr["cog"], ref["cog"])) <= 0.5e-4 + 1e-12
        assert np.max(np.abs(tr["delta"] - ref["delta"])) <= 0.5e-4 + 1e-12
        assert np.max(np.abs(tr["r"] - ref["r"])) <= 0.5 * 3.125e-8 + 1e-15
        assert np.max(np.abs(tr["sog"] - ref["sog"])) <= 0.005 + 1e-12
        assert np.max(np.abs(tr["n"] - ref["n"])) <= 0.125 / 60 + 1e-12


def _library_frames(fmt: str, tr: Trial):
    """nmea2000's own encoding of the log's messages (decoded from its candump -L lines)."""
    from nmea2000.decoder import NMEA2000Decoder
    from nmea2000.encoder import create_encoder
    from nmea2000.input_formats import N2KFormat

    dec = NMEA2000Decoder(N2KFormat.CANDUMP3, units="si")
    enc = create_encoder(fmt, units="si")
    out = []
    for line in nmea2000_bytes(tr, "candump3").decode().splitlines():
        m = dec.decode(line)
        e = enc.encode(m)
        out += e if isinstance(e, list) else [e]
    return out


@pytest.mark.parametrize("fmt", ["candump1", "candump2", "n2k_ascii_raw", "mxpgn", "ebyte",
                                 "waveshare"])
def test_framing_matches_the_package_encoders(fmt):
    """Formats without time stamps: usvid's records are the package's, byte for byte (usvid adds
    a System Time frame before each sample, the clock of these formats)."""
    tr = trial(T=0.3)
    lib = _library_frames(fmt, tr)
    blob = nmea2000_bytes(tr, fmt)
    if fmt in ("ebyte", "waveshare"):
        size = 13 if fmt == "ebyte" else 20
        ours = [blob[i:i + size] for i in range(0, len(blob), size)]
        ours = [p for p in ours if (int.from_bytes(p[1:5] if fmt == "ebyte" else p[5:9],
                                                   "big" if fmt == "ebyte" else "little")
                                    >> 8) & 0x3FFFF != 126992]
    else:
        ours = [ln for ln in blob.decode().splitlines()
                if parse_text_record(fmt, ln)[1] != SYSTEM_TIME_PGN]
    assert ours == lib


def test_vectorised_decode_matches_the_package():
    """usvid decodes the payloads of its PGNs at once (numpy; layouts from the package's canboat
    database, valid raw intervals found by asking its decoder): on random payloads, "not
    available" markers and out-of-range values, every value equals the package's own decoder
    exactly."""
    from nmea2000.backend import decode

    rng = np.random.default_rng(11)
    pgn = np.repeat(np.array(list(_FIELDS)), 400)
    pay = rng.integers(0, 256, (len(pgn), 8), dtype=np.uint8)
    pay[::9, :] = 0xFF  # "not available" everywhere
    pay[1::13, 1:3] = [0xFD, 0xFF]  # u16 0xFFFD at byte 1 (reserved marker)
    pay[3::13, 1:3] = [0xFC, 0xFF]  # the largest valid u16
    pay[2::17, 7] = 0x01  # magnetic reference
    pay[4::19, 0:2] = [1, 0]  # rudder / engine instance 1
    chans, sys_epoch = decode_payloads(pgn, pay)
    for i in range(len(pgn)):
        msg = decode(int(pgn[i]), bytes(pay[i]), units="si")
        if pgn[i] == SYSTEM_TIME_PGN:
            np.testing.assert_equal(sys_epoch[i], _system_time(msg))
            continue
        want = _channels(msg)
        got = {k: v[i] for k, v in chans.items() if not np.isnan(v[i])}
        assert got == {k: v for k, v in want.items() if not np.isnan(v)}, (pgn[i], pay[i])
    # canboat's limits as found: -pi for a signed angle, the top three codes reserved
    assert valid_raw(127250, "deviation") == (-31416, 32764)
    assert valid_raw(129025, "latitude")[0] == -900_000_000


@pytest.mark.parametrize("fmt", sorted(set(FORMATS) - {"python_can", "ngt1"}))
def test_records_parse_as_the_package_decoders(fmt):
    """usvid's framing of each format gives the PGN and payload that nmea2000's own decoder for
    the format finds (the same decoded fields, record by record), and the sender's source
    address (3, as written; -1 for the PDGY form without one)."""
    from nmea2000.backend import decode
    from nmea2000.decoder import NMEA2000Decoder
    from nmea2000.input_formats import N2KFormat

    dec = NMEA2000Decoder(N2KFormat(fmt), units="si")
    blob = nmea2000_bytes(trial(T=0.2), fmt)
    if FORMATS[fmt].binary:
        recs = list(binary_records(fmt, blob))
        size = {"ebyte": 13, "waveshare": 20}.get(fmt)
        items = ([blob[i:i + size] for i in range(0, len(blob), size)] if size else
                 [blk for _, _, blk in bdtp_frames(blob)])
    else:
        items = blob.decode().splitlines()
        recs = [parse_text_record(fmt, ln) for ln in items]
    assert len(recs) == len(items) > 10
    for (_, pgn, payload, src), item in zip(recs, items, strict=True):
        lib = dec.decode(item)
        ours = decode(pgn, payload, units="si")
        assert lib.PGN == pgn
        assert src == lib.source == 3
        assert [(f.id, f.value) for f in lib.fields] == [(f.id, f.value) for f in ours.fields]


def test_untimed_log_without_system_time_is_one_line(tmp_path):
    p = tmp_path / "x.log"
    lines = [ln for ln in nmea2000_bytes(trial(), "candump1").decode().splitlines()
             if parse_text_record("candump1", ln)[1] != SYSTEM_TIME_PGN]  # no System Time
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogReadError, match=r"candump1 format has no time stamps .*126992") as e:
        read_trial(p)
    assert "\n" not in str(e.value)


def test_relative_clocks_unwrap_and_midnight(tmp_path):
    # BST 95 counts 16-bit milliseconds (wraps every 65.536 s); time of day wraps at midnight
    slow = trial(T=150.0, dt=1.0)
    tr = read_trial(write_nmea2000(slow, tmp_path / "a.bst", "bst_95"))
    np.testing.assert_allclose(tr.t, slow.t, atol=0.5e-3)
    late = trial(T=4.0, t0="2025-03-01T23:59:58+00:00")
    for fmt in ("can_frame_ascii", "n2k_ascii"):
        tr = read_trial(write_nmea2000(late, tmp_path / f"{fmt}.log", fmt))
        np.testing.assert_allclose(tr.t, late.t, atol=0.5e-3)
        assert tr.meta["t0_utc"] == "2025-03-01T23:59:58+00:00"


def test_bad_records_counted(tmp_path):
    lines = nmea2000_bytes(trial(T=0.5), "pcdin").decode().splitlines()
    lines[0] = lines[0][:-2] + ("00" if lines[0][-2:] != "00" else "11")  # wrong checksum
    lines[1] = "this is not a sentence"
    body = "$PCDIN,01F112,0LIM0E3K,03,0139"  # PGN 127250 with a 2-byte payload
    lines[2] = f"{body}*{np.bitwise_xor.reduce([ord(c) for c in body[1:]]):02X}"
    p = tmp_path / "p.log"
    p.write_text("\n".join(lines) + "\n")
    tr = read_trial(p, {"reader": "nmea2000", "n2k_format": "pcdin"})
    assert tr.rejected == {"checksum": 1, "garbage": 1, "truncated": 1}


def test_wrong_format_and_debug_lines_are_one_line(logs, tmp_path):
    with pytest.raises(LogReadError, match=r"no usable NMEA 2000 frame \(pcdin\).*garbage"):
        read_trial(logs["candump3"], {"reader": "nmea2000", "n2k_format": "pcdin"})
    dbg = tmp_path / "d.log"
    dbg.write_text("$PDGY,000000,4,,5,482,1,0\n" * 3)
    with pytest.raises(LogReadError, match=r"debug lines \(\$PDGY\) carry no PGN data"):
        read_trial(dbg, {"reader": "nmea2000"})
    junk = tmp_path / "j.log"
    junk.write_text("hello\nworld\n")
    with pytest.raises(LogReadError, match="not an NMEA 2000 log"):
        read_trial(junk, {"reader": "nmea2000"})
    bad_blf = tmp_path / "b.blf"
    bad_blf.write_bytes(b"LOGG" + bytes(40))
    with pytest.raises(UsvidError, match=r"b\.blf"):
        read_trial(bad_blf)


def test_detection_leaves_nmea0183_and_tables_alone(tmp_path):
    p = tmp_path / "t.txt"
    p.write_text("10000 20000 30000\n10001 20001 30001\n")  # hex-looking integer table
    assert detect_n2k_format(p, p.read_bytes()) is None
    q = tmp_path / "n.nmea"
    q.write_text("$HEHDT,45.0,T*1E\n$HEHDT,46.0,T*1D\n$PCDIN,01F112,00000000,03,01*00\n")
    assert detect_reader(q) == "nmea0183"


# --- fuzzing -----------------------------------------------------------------------------------
_BASE = {f: nmea2000_bytes(trial(T=0.3), f) for f in FORMATS}


@settings(max_examples=48, deadline=None, derandomize=True,
          phases=[Phase.explicit, Phase.reuse, Phase.generate],
          suppress_health_check=[HealthCheck.too_slow])
@given(fmt=st.sampled_from(sorted(FORMATS)), ops=st.lists(mutation, min_size=1, max_size=4))
def test_mutated_n2k_logs_never_escape(fmt, ops):
    blob = _mutate(_BASE[fmt], ops)
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"log{EXT.get(fmt, '.log')}"
        p.write_bytes(blob)
        for spec in (None, {"reader": "nmea2000", "n2k_format": fmt}):
            try:
                tr = read_trial(p, spec)
            except UsvidError:
                continue
            t = tr.t
            assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
            assert all(isinstance(v, int) and v > 0 for v in tr.rejected.values())
            assert not math.isnan(float(t[0]))
