"""Regression tests from the io/prep review (R1): each test failed before its fix."""

from __future__ import annotations

from pathlib import Path

from usvid.io.nmea0183 import read_nmea0183, sentence


def test_nmea_sentence_time_date_before_midnight_rollover(tmp_path: Path) -> None:
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


def test_candump_short_single_frame_is_truncated_not_decoded(tmp_path: Path) -> None:
    from usvid.io import read_candump

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


def test_merge_trials_mixed_naive_and_utc_epochs() -> None:
    import pandas as pd
    import pytest

    from usvid.errors import UsvidError
    from usvid.prep import merge_trials
    from usvid.trial import Trial

    # NMEA readers give "+00:00" epochs, the Excel reader a naive date-time: before the fix the
    # comparison raised pandas' TypeError (tz-naive vs tz-aware). Naive is taken as UTC.
    a = Trial(data=pd.DataFrame({"t": [0.0, 1.0, 2.0], "psi": [0.0, 0.1, 0.2]}), name="a",
              meta={"t0_utc": "2025-01-01T00:00:00+00:00"})
    b = Trial(data=pd.DataFrame({"t": [0.0, 1.0, 2.0], "delta": [0.0, 0.1, 0.2]}), name="b",
              meta={"t0_utc": "2025-01-01T00:00:01"})
    m = merge_trials([a, b])
    assert list(m.t) == [0.0, 1.0, 2.0, 3.0]
    assert list(m.data["delta"].iloc[1:]) == [0.0, 0.1, 0.2]  # b shifted by +1 s
    with pytest.raises(UsvidError, match="t0_utc"):
        merge_trials([a, b], t0_utc="garbage")


def test_prepare_counts_nan_time_as_rejected_not_as_reversal() -> None:
    import numpy as np
    import pandas as pd

    from usvid.prep import prepare
    from usvid.trial import Trial

    n = 50
    t = np.arange(n) * 0.1
    t[10] = np.nan  # one row without a time, no time reversal at all
    tr = Trial(data=pd.DataFrame({"t": t, "psi": np.linspace(0.0, 1.0, n)}), name="nan_t")
    out = prepare(tr)
    # before the fix the NaN time was reported as a "time stamp earlier than its predecessor"
    assert not [f for f in out.findings if f.code == "time_reversal"]
    assert out.rejected.get("nan_time") == 1


def test_read_table_only_header_lines_says_no_data(tmp_path: Path) -> None:
    import pytest

    from usvid.errors import LogReadError
    from usvid.io import read_trial

    p = tmp_path / "hdr.dat"
    p.write_text("a\nb\nc\nd\n")
    # four lines, skip_rows 4: it is "no data rows", not "fewer lines than skip_rows"
    with pytest.raises(LogReadError, match="no data rows"):
        read_trial(p, "hsva_kvlcc2")


def test_table_bad_value_names_column_and_line(tmp_path: Path) -> None:
    import pytest

    from usvid.errors import LogReadError
    from usvid.io import read_trial

    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "time", "unit": "s"}, "psi": {"col": "hdg", "unit": "deg"}}}
    p = tmp_path / "a.csv"
    p.write_text("time,hdg\n0,1\n1,2\n2,x\n3,4\n")
    tr = read_trial(p, spec)
    assert tr.rejected == {"bad_value": 1}
    f = [x for x in tr.findings if x.code == "bad_value"]
    # before the fix the rejected row was only counted: no column, no line
    assert len(f) == 1 and f[0].channel == "psi"
    assert "'hdg'" in f[0].message and "line 4" in f[0].message and "'x'" in f[0].message
    q = tmp_path / "b.csv"
    q.write_text("time,hdg\n0,y\n1,z\n")
    with pytest.raises(LogReadError, match=r"bad_value: 2\).*hdg.*line 2: 'y'"):
        read_trial(q, spec)


def test_excel_bad_value_names_sheet_row(tmp_path: Path) -> None:
    import pandas as pd

    from usvid.io import read_trial

    p = tmp_path / "x.xlsx"
    pd.DataFrame({"time": [0.0, 1.0, 2.0, 3.0], "hdg": [1.0, 2.0, "bad", 4.0]}).to_excel(
        p, index=False)
    spec = {"reader": "excel",
            "columns": {"t": {"col": "time", "unit": "s"}, "psi": {"col": "hdg", "unit": "deg"}}}
    tr = read_trial(p, spec)
    assert tr.rejected == {"bad_value": 1}
    (f,) = [x for x in tr.findings if x.code == "bad_value"]
    # header in spreadsheet row 1, data from row 2: the third data row is row 4
    assert "sheet 0 row 4" in f.message


def test_lowpass_zero_step_is_usvid_error() -> None:
    import numpy as np
    import pytest

    from usvid.errors import UsvidError
    from usvid.prep import lowpass

    # dt = 0 raised a bare ZeroDivisionError before the fix
    for dt in (0.0, -0.1, float("nan")):
        with pytest.raises(UsvidError, match="sample step"):
            lowpass(np.ones(100), dt, 1.0)


def test_geodetic_to_ned_scalar_fix() -> None:
    from usvid.prep import geodetic_to_ned

    # one fix as scalars raised IndexError (0-d array indexed) before the fix
    n, e, org = geodetic_to_ned(54.0, 10.0)
    assert org == (54.0, 10.0) and float(n) == 0.0 and float(e) == 0.0
    n, e, _ = geodetic_to_ned(54.001, 10.0, (54.0, 10.0))
    assert abs(float(n) - 111.4) < 0.5  # 0.001 deg of latitude at 54 N is about 111.4 m
    assert n.shape == ()


def test_table_datetime_with_mixed_utc_offsets(tmp_path: Path) -> None:
    from usvid.io import read_trial

    # a clock change inside the log (+01:00 then Z): pandas raised "Mixed timezones detected"
    # (ValueError, exit code 1) before the fix; now both are put on UTC
    p = tmp_path / "dt.csv"
    p.write_text("time,hdg\n2025-03-30T00:59:59+01:00,1\n2025-03-30T00:00:00Z,2\n"
                 "2025-03-30T00:00:01Z,3\n")
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "time", "unit": "datetime"},
                        "psi": {"col": "hdg", "unit": "deg"}}}
    tr = read_trial(p, spec)
    assert list(tr.t) == [0.0, 1.0, 2.0]  # 23:59:59Z, 00:00:00Z, 00:00:01Z
    assert tr.meta["t0_utc"] == "2025-03-29T23:59:59+00:00"


def test_table_utf8_byte_order_mark(tmp_path: Path) -> None:
    from usvid.io import read_trial

    # Excel's "CSV UTF-8" starts with a BOM: before the fix the first header name was
    # "\ufefftime" (FormatSpecError: no column named 'time'), and in a file without a header the
    # first data row was rejected as bad_value
    p = tmp_path / "bom.csv"
    p.write_bytes(b"\xef\xbb\xbftime,hdg\n0,1\n1,2\n2,3\n")
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "time", "unit": "s"}, "psi": {"col": "hdg", "unit": "deg"}}}
    tr = read_trial(p, spec)
    assert len(tr) == 3 and tr.rejected == {}
    q = tmp_path / "bom.dat"
    q.write_bytes(b"\xef\xbb\xbf0 1\n1 2\n2 3\n")
    tr = read_trial(q, {"reader": "table", "columns": {"t": {"col": 0, "unit": "s"},
                                                        "psi": {"col": 1, "unit": "deg"}}})
    assert len(tr) == 3 and tr.rejected == {}


def test_nmea_utf8_byte_order_mark(tmp_path: Path) -> None:
    # a BOM made the first sentence "garbage" (non-ASCII bytes) before the fix
    lines = [sentence("HEHDT,10.0,T"), sentence("HEHDT,11.0,T")]
    p = tmp_path / "bom.nmea"
    p.write_bytes(b"\xef\xbb\xbf" + ("1700000000.0 " + lines[0] + "\n1700000001.0 " + lines[1]
                                     + "\n").encode())
    for engine in ("fast", "pynmeagps"):
        tr = read_nmea0183(p, engine=engine)
        assert tr.rejected == {} and len(tr) == 2, engine


def test_audit_speed_scale_says_fast_clock_when_stamps_advance_too_much() -> None:
    import numpy as np
    import pandas as pd

    from usvid.prep import audit
    from usvid.trial import Trial

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
