"""Table readers (delimited text, Excel, Parquet) and the CSV/Parquet writers."""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
import pytest

from usvid import Trial
from usvid.errors import FormatSpecError, LogReadError
from usvid.io import parse_spec, read_trial, write_csv, write_parquet

WS = {
    "reader": "table",
    "skip_rows": 2,
    "columns": {
        "t": {"col": 0, "unit": "s"},
        "psi": {"col": 1, "unit": "deg"},
        "r": {"col": 2, "unit": "deg/s"},
        "delta": {"col": 3, "unit": "deg", "sign": -1},
    },
}


def _write(tmp_path, name, text, mode="w"):
    p = tmp_path / name
    if mode == "wb":
        p.write_bytes(text)
    else:
        p.write_text(text, encoding="utf-8")
    return p


def _ws_lines(n=5):
    return [f"  {0.05 * i:.2f}  {i * 1.0:.1f}  2.0  {-1.0 * i:.1f}" for i in range(n)]


def test_whitespace_table_units_and_sign(tmp_path):
    p = _write(tmp_path, "a.dat", "title\nunits\n" + "\n".join(_ws_lines()) + "\n")
    mtime = os.stat(p).st_mtime_ns
    tr = read_trial(p, WS)
    assert os.stat(p).st_mtime_ns == mtime
    assert tr.rejected == {} and len(tr) == 5
    assert tr["psi"][3] == pytest.approx(math.radians(3.0), rel=1e-12)
    assert tr["r"][0] == pytest.approx(math.radians(2.0), rel=1e-12)
    assert tr["delta"][2] == pytest.approx(math.radians(2.0), rel=1e-12)  # sign -1 of -2 deg
    assert tr.sample_rate == pytest.approx(20.0)


def test_csv_with_header_names_and_cp1252(tmp_path):
    text = "Zeit;Kurs °;Fahrt kn\n0,0;10;2\n0,5;11;4\n"
    text = text.replace(",", ".")
    p = _write(tmp_path, "b.csv", text.encode("cp1252"), mode="wb")
    spec = {
        "reader": "table",
        "delimiter": ";",
        "header": True,
        "encoding": "cp1252",
        "columns": {
            "t": {"col": "Zeit", "unit": "s"},
            "psi": {"col": "Kurs °", "unit": "deg"},
            "U": {"col": "Fahrt kn", "unit": "kn"},
        },
    }
    tr = read_trial(p, spec)
    assert tr["U"][1] == pytest.approx(4 * 1852 / 3600, rel=1e-12)
    assert tr["psi"][0] == pytest.approx(math.radians(10), rel=1e-12)


def test_column_index_out_of_range_names_file_field_and_range(tmp_path):
    p = _write(tmp_path, "c.dat", "h\nh\n" + "\n".join(_ws_lines()) + "\n")
    spec = {**WS, "columns": {**WS["columns"], "n": {"col": 7, "unit": "rpm"}}}
    with pytest.raises(FormatSpecError, match=r"c\.dat: .*columns\.n\.col: index 7 is out of "
                       r"range \(the file has 4 columns, indices 0\.\.3\)"):
        read_trial(p, spec)


def test_missing_header_column_names_what_exists(tmp_path):
    p = _write(tmp_path, "d.csv", "time,hdg\n0,1\n1,2\n")
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "time", "unit": "s"},
                        "psi": {"col": "heading", "unit": "deg"}}}
    with pytest.raises(FormatSpecError, match=r"columns\.psi\.col: no column named 'heading' "
                       r"\(the header has: time, hdg\)"):
        read_trial(p, spec)
    spec["columns"]["psi"]["optional"] = True
    assert read_trial(p, spec).channels == []


def test_empty_and_header_only_files(tmp_path):
    with pytest.raises(LogReadError, match=r"e\.dat: empty file"):
        read_trial(_write(tmp_path, "e.dat", ""), WS)
    with pytest.raises(LogReadError, match=r"f\.dat line 3: no data rows"):
        read_trial(_write(tmp_path, "f.dat", "a\nb\n\n"), WS)
    with pytest.raises(LogReadError, match="no such file"):
        read_trial(tmp_path / "nope.dat", WS)


def test_nan_rows_truncated_garbage_bad_values_counted(tmp_path):
    lines = _ws_lines(8)
    lines[2] = "  0.10  nan  nan  nan"  # NaN row: rejected nan_row
    lines[3] = "  0.15  3.0"  # truncated
    lines[4] = "  0.20  4.0  2.0  -4.0  99"  # too many fields
    lines[5] = "  0.25  abc  2.0  -5.0"  # not a number
    lines.insert(6, "\x00\x01\xff\xfe binary")  # garbage
    p = _write(tmp_path, "g.dat", ("h\nh\n" + "\n".join(lines) + "\n").encode("latin-1"), "wb")
    tr = read_trial(p, WS)
    assert tr.rejected == {"nan_row": 1, "truncated": 1, "field_count": 1, "bad_value": 1,
                           "garbage": 1}
    assert len(tr) == 4  # rows 0, 1, 6, 7 of 8


def test_non_monotonic_time_sorted_or_rejected(tmp_path):
    rows = ["0.0 1 2 3", "0.1 1 2 3", "0.3 1 2 3", "0.2 1 2 3", "0.4 1 2 3", "0.4 5 2 3"]
    p = _write(tmp_path, "h.dat", "h\nh\n" + "\n".join(rows) + "\n")
    tr = read_trial(p, WS)
    assert np.all(np.diff(tr.t) > 0) and len(tr) == 5
    assert tr.rejected == {"duplicate_time": 1}
    f = [x for x in tr.findings if x.code == "non_monotonic_time"]
    assert len(f) == 1 and f[0].count == 1 and "sorted" in f[0].message
    tr2 = read_trial(p, {**WS, "non_monotonic": "reject"})
    assert tr2.rejected == {"non_monotonic": 1, "duplicate_time": 1}
    assert list(tr2.t) == pytest.approx([0.0, 0.1, 0.3, 0.4])


def test_all_rows_bad_is_a_log_read_error(tmp_path):
    p = _write(tmp_path, "i.dat", "h\nh\nx y z w\nfoo bar baz qux\n")
    with pytest.raises(LogReadError, match=r"i\.dat: no usable records \(bad_value: 2\)"):
        read_trial(p, WS)


def test_datetime_time_column(tmp_path):
    p = _write(tmp_path, "j.csv",
               "when,hdg\n2025-07-24 17:18:48.200,1\n2025-07-24 17:18:48.450,2\n")
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "when", "unit": "datetime"}, "psi": {"col": 1, "unit": "deg"}}}
    tr = read_trial(p, spec)
    assert list(tr.t) == pytest.approx([0.0, 0.25], abs=1e-9)
    assert tr.meta["t0_utc"].startswith("2025-07-24T17:18:48.2")


def _trial():
    t = np.arange(0, 2, 0.1)
    return Trial(pd.DataFrame({"t": t, "psi": 0.1 * t, "U": np.full_like(t, 1.5),
                               "delta": np.where(t > 1, np.nan, 0.05)}), name="w")


def test_csv_and_parquet_roundtrip_exact(tmp_path):
    tr = _trial()
    write_csv(tr, tmp_path / "w.csv", spec_path=tmp_path / "w.yaml")
    write_parquet(tr, tmp_path / "w.parquet")
    for back in (read_trial(tmp_path / "w.csv", tmp_path / "w.yaml"),
                 read_trial(tmp_path / "w.csv", None),
                 read_trial(tmp_path / "w.parquet", None)):
        pd.testing.assert_frame_equal(back.data, tr.data, check_exact=True)


def test_excel_reader_and_bad_sheet(tmp_path):
    df = pd.DataFrame({"time": [0.0, 0.1, 0.2], "Heading": [10.0, 20.0, 30.0], "PWM": [1500] * 3})
    p = tmp_path / "k.xlsx"
    df.to_excel(p, sheet_name="Log", index=False)
    spec = {"reader": "excel", "sheet": "Log",
            "columns": {"t": {"col": "time", "unit": "s"}, "psi": {"col": "Heading", "unit": "deg"},
                        "pwm": {"col": 2, "unit": "1"}}}
    tr = read_trial(p, spec)
    assert tr["psi"] == pytest.approx(np.radians([10, 20, 30]), rel=1e-12)
    assert tr["pwm"][0] == 1500
    with pytest.raises(FormatSpecError, match=r"sheet: no sheet 'Sheet9' \(sheets: Log\)"):
        read_trial(p, {**spec, "sheet": "Sheet9"})
    bad = _write(tmp_path, "bad.xlsx", b"not a zip", "wb")
    with pytest.raises(LogReadError, match="not a readable .xlsx"):
        read_trial(bad, spec)


def test_excel_engine_reads_what_openpyxl_reads(twin_dir, tmp_path):
    """The reader's engine (calamine) gives the same table as openpyxl on a real log (the
    twin-thruster USV's 1,536 x 24 sheet: text time stamps, floats, integer PWM) and on a
    workbook with a date-time column, an empty cell and mixed text/number cells."""
    pytest.importorskip("openpyxl")
    import datetime

    p = tmp_path / "mixed.xlsx"
    pd.DataFrame({"when": [datetime.datetime(2026, 11, 24, 1, 2, 3, 456000)] * 3,
                  "x": [1.5, None, 3.0], "y": [1, "two", 3.25]}).to_excel(p, index=False)
    for f in (twin_dir / "boat1_2_sin.xlsx", p):
        a = pd.read_excel(f, engine="calamine")
        b = pd.read_excel(f, engine="openpyxl")
        pd.testing.assert_frame_equal(a, b)


def test_parquet_garbage(tmp_path):
    bad = _write(tmp_path, "bad.parquet", b"PAR1 but not really", "wb")
    spec = parse_spec({"reader": "parquet", "columns": {"t": {"col": "t", "unit": "s"}}})
    with pytest.raises(LogReadError, match="not a readable Parquet"):
        read_trial(bad, spec)


def test_unit_unknown_to_spec_in_file_spec(tmp_path):
    p = _write(tmp_path, "l.dat", "h\nh\n" + "\n".join(_ws_lines()) + "\n")
    spec = {**WS, "columns": {**WS["columns"], "n": {"col": 1, "unit": "furlong/fortnight"}}}
    with pytest.raises(FormatSpecError,
                       match=r"columns\.n\.unit: unknown unit 'furlong/fortnight'"):
        read_trial(p, spec)


def test_read_table_only_header_lines_says_no_data(tmp_path) -> None:
    p = tmp_path / "hdr.dat"
    p.write_text("a\nb\nc\nd\n")
    # four lines, skip_rows 4: it is "no data rows", not "fewer lines than skip_rows"
    with pytest.raises(LogReadError, match="no data rows"):
        read_trial(p, "hsva_kvlcc2")


def test_table_bad_value_names_column_and_line(tmp_path) -> None:
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


def test_excel_bad_value_names_sheet_row(tmp_path) -> None:
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


def test_table_datetime_with_mixed_utc_offsets(tmp_path) -> None:
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


def test_table_utf8_byte_order_mark(tmp_path) -> None:
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


_CSV_SPEC = {"reader": "table", "delimiter": ",", "columns": {
    "t": {"col": "t", "unit": "s"}, "psi": {"col": "psi", "unit": "deg"},
    "r": {"col": "r", "unit": "deg/s"}, "delta": {"col": "delta", "unit": "deg"}}}


def test_csv_quoted_fields_read_like_pandas(tmp_path) -> None:
    # a standard CSV whose text column holds the delimiter in quotes on every other row: every
    # row is a record (the naive splitter rejected half of them), as pandas reads it
    lines = ["t,psi,r,delta,note"] + [
        f'{0.1 * i:.1f},{i},0,0,{chr(34) + "ok, nominal" + chr(34) if i % 2 else "fine"}'
        for i in range(1201)]
    p = _write(tmp_path, "q.csv", "\n".join(lines) + "\n")
    tr = read_trial(p, parse_spec(_CSV_SPEC))
    ref = pd.read_csv(p)
    assert len(tr) == len(ref) == 1201 and not tr.rejected
    np.testing.assert_allclose(np.degrees(tr["psi"]), ref["psi"], rtol=0, atol=1e-9)


def test_csv_quoted_line_break_and_unbalanced_quote(tmp_path) -> None:
    # RFC 4180: a quoted field may hold a line break (one record over two lines); an unbalanced
    # quote is one bad line (its naive split has the right field count here: kept), and the
    # records after it are read, not swallowed into the open quote
    text = ('t,psi,r,delta,note\n0,1,0,0,"two\nlines"\n0.1,2,0,0,ok\n'
            '0.2,3,0,0,"open\n0.3,4,0,0,x\n0.4,5,0,0,"a ""quoted"" word"\n')
    tr = read_trial(_write(tmp_path, "q.csv", text), parse_spec(_CSV_SPEC))
    np.testing.assert_allclose(tr.t, [0.0, 0.1, 0.2, 0.3, 0.4], atol=1e-12)
    np.testing.assert_allclose(np.degrees(tr["psi"]), [1, 2, 3, 4, 5], atol=1e-9)
    assert not tr.rejected


def _fast_and_slow(monkeypatch, p, spec):
    """The trial read by the fast path (the line reader forbidden) and by the line reader
    (the fast path switched off)."""
    from usvid.io import table

    def no_line_reader(*a, **k):
        raise AssertionError("the line reader was used")

    with monkeypatch.context() as m:
        m.setattr(table, "_records", no_line_reader)
        fast = read_trial(p, spec)
    with monkeypatch.context() as m:
        m.setattr(table, "_read_clean", lambda *a: None)
        m.setattr(table, "_read_clean_stream", lambda *a: None)
        slow = read_trial(p, spec)
    return fast, slow


@pytest.mark.parametrize("variant", ["lf", "crlf", "blanks", "tab", "bom_skip", "missing",
                                     "text"])
def test_clean_csv_fast_path_equals_line_reader(tmp_path, monkeypatch, variant) -> None:
    # the bytes fast path (pandas' C parser on the undecoded data) must read every clean table
    # exactly as the line-by-line reader does; CRLF line ends, blanks after the delimiter, a
    # BOM, skipped lines and blank lines before the header, and missing cells ("", "nan", "-")
    # stay on the fast path (the line reader is made to fail to show it)

    d = "\t" if variant == "tab" else ","
    pad = " " if variant == "blanks" else ""
    rows = [d.join([f"{0.1 * i:.1f}", f"{pad}{3 * i}", f"{pad}{-0.5 * i}", f"{pad}{i % 7}"])
            for i in range(50)]
    if variant == "missing":
        rows[3], rows[4], rows[5] = "0.3,,1,2", "0.4,nan,1,2", "0.5,1,-,2"
    if variant == "text":  # a text cell in a number column: counted, named stripped
        rows[6] = "0.6, dropout ,1,2"
    head = ["t", "psi", "r", "delta"]
    lines = ([d.join(head)] if variant != "bom_skip"
             else ["logger v1 export", "", d.join(head)]) + rows
    eol = "\r\n" if variant == "crlf" else "\n"
    blob = (b"\xef\xbb\xbf" if variant == "bom_skip" else b"") + (eol.join(lines) + eol).encode()
    p = _write(tmp_path, "c.csv", blob, mode="wb")
    spec = parse_spec({**_CSV_SPEC, "delimiter": d, "skip_rows": 1 if variant == "bom_skip" else 0})

    fast, slow = _fast_and_slow(monkeypatch, p, spec)
    pd.testing.assert_frame_equal(fast.data, slow.data, check_exact=True)
    assert fast.rejected == slow.rejected
    assert [f.message for f in fast.findings] == [f.message for f in slow.findings]
    if variant == "text":  # the row rejected, its cell named without the blanks around it
        assert len(fast) == 49 and fast.rejected == {"bad_value": 1}
        assert "(first at line 8: 'dropout')" in fast.findings[0].message
        return
    assert len(fast) == 50 and np.isnan(fast.data["psi"]).sum() == (2 if variant == "missing"
                                                                     else 0)


def test_csv_lone_carriage_return_goes_to_line_reader(tmp_path) -> None:
    # a carriage return inside a line is a line break to str.splitlines (the line reader) but
    # not to pandas: the fast path must decline it, and both lines of it are counted
    text = "t,psi,r,delta\n0,1,0,0\n0.1,2,0\r,0\n0.2,3,0,0\n"
    tr = read_trial(_write(tmp_path, "cr.csv", text.encode(), mode="wb"), parse_spec(_CSV_SPEC))
    np.testing.assert_allclose(tr.t, [0.0, 0.2], atol=1e-12)
    assert tr.rejected == {"truncated": 2}


@pytest.mark.parametrize("eol", ["\n", "\r\n"])
def test_whitespace_table_fast_path_equals_line_reader(tmp_path, monkeypatch, eol) -> None:
    # whitespace-separated tables (the HSVA logs' layout: header lines, cp1252, padded columns)
    # are read by pandas' C parser from the bytes exactly as the line reader reads them: tabs,
    # runs of blanks, leading and trailing blanks, "nan" cells, LF or CRLF

    rows = [f"  {0.05 * i:.3f}\t {3 * i:>6}  {-0.5 * i:.2f} {'nan' if i == 7 else i % 7}  "
            for i in range(60)]
    blob = eol.join(["HSVA, exp\u00e9rimental data", " KVLCC2", *rows]).encode("cp1252") + b"\n"
    p = _write(tmp_path, "w.dat", blob, mode="wb")
    spec = parse_spec({**WS, "encoding": "cp1252"})

    fast, slow = _fast_and_slow(monkeypatch, p, spec)
    pd.testing.assert_frame_equal(fast.data, slow.data, check_exact=True)
    assert fast.rejected == slow.rejected == {}
    assert len(fast) == 60 and int(np.isnan(fast.data["delta"]).sum()) == 1


def test_whitespace_table_with_a_short_line_goes_to_line_reader(tmp_path) -> None:
    # one line with a field missing: the per-line field count sends the table to the line
    # reader, which rejects that line only (a total count could be balanced by a long line)
    lines = _ws_lines(6)
    lines[2] = "  0.10  2.0  2.0"
    lines[4] = lines[4] + "  9.9"
    tr = read_trial(_write(tmp_path, "s.dat", "h1\nh2\n" + "\n".join(lines) + "\n"), WS)
    assert len(tr) == 4 and tr.rejected == {"truncated": 1, "field_count": 1}


@pytest.mark.parametrize("rows", [50, 60_000])  # the bytes path, and the block check from the file
def test_a_source_column_mapped_twice_is_converted_once_for_each(tmp_path, rows):
    """The clean path converts pandas' columns in place; a source column that two channels map
    (here knots, 1 kn = 1852/3600 m/s exactly) gives each its own array, converted once, and
    the apparent wind angle in degrees is wrapped to (-pi, pi] in place (350 deg -> -10 deg)."""
    p = _write(tmp_path, "twice.csv", "time,speed,awa\n" + "".join(
        f"{i * 0.1:.1f},{2.0 + (i % 7) * 0.5:.2f},350.0\n" for i in range(rows)))
    assert (p.stat().st_size >= 2**20) == (rows > 50)  # (1 MiB: the block-checked path)
    spec = {"reader": "table", "delimiter": ",", "header": True,
            "columns": {"t": {"col": "time", "unit": "s"}, "u": {"col": "speed", "unit": "kn"},
                        "U": {"col": "speed", "unit": "kn"},
                        "wind_angle": {"col": "awa", "unit": "deg"}}}
    tr = read_trial(p, spec)
    kn = 1852.0 / 3600.0
    want = (2.0 + (np.arange(rows) % 7) * 0.5) * kn
    u, U = tr.data["u"].to_numpy(), tr.data["U"].to_numpy()
    np.testing.assert_allclose(u, want, rtol=1e-15)  # (one product: exact to rounding)
    np.testing.assert_allclose(U, want, rtol=1e-15)
    assert not np.shares_memory(u, U)
    np.testing.assert_allclose(tr.data["wind_angle"].to_numpy(), math.radians(-10.0), rtol=1e-12)
