"""The table reader's streaming path (io.table._read_clean_stream): a large clean CSV checked
block by block from the file and parsed by pandas from the file. Its blocks are made tiny here
(the first block 64 bytes, then 16 or 7), so that small tables cross many block boundaries:
every table must read exactly as the line reader reads it, a table that is not clean must be
handed on (to the bytes path, then the line reader), and a too long line is refused with the
line number the whole-file check gives."""

from __future__ import annotations

import pandas as pd
import pytest

from usvid.errors import LogReadError
from usvid.io import parse_spec, read_trial, table

SPEC = {"reader": "table", "delimiter": ",", "header": True, "columns": {
    "t": {"col": "t", "unit": "s"}, "psi": {"col": "psi", "unit": "deg"},
    "r": {"col": "r", "unit": "deg/s"}, "delta": {"col": "delta", "unit": "deg"}}}


@pytest.fixture(params=[16, 7], ids=["block16", "block7"])
def tiny_blocks(request, monkeypatch):
    monkeypatch.setattr(table, "_STREAM_HEAD", 64)
    monkeypatch.setattr(table, "_STREAM_BLOCK", request.param)


def _rows(d: str = ",", n: int = 40, pad: str = "") -> list[str]:
    return [d.join([f"{0.1 * i:.1f}", f"{pad}{3 * i}", f"{pad}{-0.5 * i}", f"{pad}{i % 7}"])
            for i in range(n)]


def _paths(monkeypatch, p, spec):
    """The trial by the streaming path (the bytes path and the line reader forbidden) or None
    when it declines, and the trial by the line reader alone."""
    def forbidden(*a, **k):
        raise AssertionError("not the streaming path")

    with monkeypatch.context() as m:
        m.setattr(table, "_read_clean", forbidden)
        m.setattr(table, "_records", forbidden)
        stream = table._read_clean_stream(p, spec)
    with monkeypatch.context() as m:
        m.setattr(table, "_read_clean_stream", lambda *a: None)
        m.setattr(table, "_read_clean", lambda *a: None)
        slow = read_trial(p, spec)
    return stream, slow


def _same(a, b) -> None:
    pd.testing.assert_frame_equal(a.data, b.data, check_exact=True)
    assert a.rejected == b.rejected
    assert [f.message for f in a.findings] == [f.message for f in b.findings]


@pytest.mark.parametrize("variant", ["lf", "crlf", "no_final_eol", "blanks", "tab", "missing",
                                     "text", "skip_rows", "comment_spec"])
def test_clean_tables_stream_as_the_line_reader_reads_them(tmp_path, monkeypatch, tiny_blocks,
                                                           variant) -> None:
    d = "\t" if variant == "tab" else ","
    rows = _rows(d, pad=" " if variant == "blanks" else "")
    if variant == "missing":
        rows[3], rows[4], rows[5] = "0.3,,1,2", "0.4,nan,1,2", "0.5,1,-,2"
    if variant == "text":  # a text cell in a number column: that row rejected and counted
        rows[6] = "0.6, dropout ,1,2"
    lines = [d.join(["t", "psi", "r", "delta"]), *rows]
    if variant == "skip_rows":
        lines = ["exported by logger 1.2", "", *lines]
    eol = "\r\n" if variant == "crlf" else "\n"
    text = eol.join(lines) + ("" if variant == "no_final_eol" else eol)
    p = tmp_path / "c.csv"
    p.write_bytes(text.encode())
    spec = parse_spec({**SPEC, "delimiter": d,
                       "skip_rows": 1 if variant == "skip_rows" else 0,
                       **({"comment": "#"} if variant == "comment_spec" else {})})
    stream, slow = _paths(monkeypatch, p, spec)
    assert stream is not None
    _same(stream, slow)
    assert len(stream) == (39 if variant == "text" else 40)
    _same(read_trial(p, spec), slow)


@pytest.mark.parametrize("where", [5, 17, 30])
@pytest.mark.parametrize("dirt", ["quote", "control", "del", "short", "long", "lone_cr",
                                  "cr_at_end", "non_ascii", "comment", "blank_line"])
def test_tables_that_are_not_clean_are_handed_on(tmp_path, monkeypatch, tiny_blocks, dirt,
                                                 where) -> None:
    rows = _rows()
    r = rows[where]
    rows[where] = {"quote": r + ',"x"', "control": r[:2] + "\x01" + r[2:], "del": r + "\x7f",
                   "short": r.rsplit(",", 1)[0], "long": r + ",9", "lone_cr": r[:3] + "\r" + r[3:],
                   "cr_at_end": r, "non_ascii": r + "\u00b0", "comment": "# " + r,
                   "blank_line": ""}[dirt]
    text = "\n".join(["t,psi,r,delta", *rows]) + ("\r" if dirt == "cr_at_end" else "\n")
    p = tmp_path / "d.csv"
    p.write_bytes(text.encode())
    spec = parse_spec({**SPEC, **({"comment": "#"} if dirt == "comment" else {})})
    stream, slow = _paths(monkeypatch, p, spec)
    assert stream is None
    _same(read_trial(p, spec), slow)  # whatever path reads it: as the line reader reads it


@pytest.mark.parametrize("bound", [30, 31, 45])
@pytest.mark.parametrize("at", [0, 9, 25, -1])
def test_a_too_long_line_is_refused_with_its_line_number(tmp_path, monkeypatch, tiny_blocks,
                                                         bound, at) -> None:
    """The streaming check refuses a line longer than the bound as check_line_length does on
    the whole file, with the same message (header line 1, data from line 2); a line of exactly
    the bound passes."""
    monkeypatch.setattr(table, "MAX_LINE_BYTES", bound)
    rows = _rows()
    long = "1," * (bound // 2) + "1"  # bound + 1 bytes when bound is even, bound when odd
    rows[at] = long
    p = tmp_path / "l.csv"
    p.write_bytes(("\n".join(["t,psi,r,delta", *rows]) + ("" if at == -1 else "\n")).encode())
    blob = p.read_bytes()
    try:
        table.check_line_length(p, blob, bound)
        want = None
    except LogReadError as exc:
        want = str(exc)
    assert (want is None) == (len(long) <= bound)
    with monkeypatch.context() as m:
        m.setattr(table, "_read_clean", lambda *a: pytest.fail("the bytes path was used"))
        if want is None:
            table._read_clean_stream(p, parse_spec(SPEC))  # (declines: the field count)
        else:
            with pytest.raises(LogReadError) as got:
                table._read_clean_stream(p, parse_spec(SPEC))
            assert str(got.value) == want
            assert f"line {(at % len(rows)) + 2}:" in want


def test_small_files_and_whitespace_tables_take_the_bytes_path(tmp_path) -> None:
    """Below the first block (1 MiB) the file is read whole as before; whitespace-separated
    tables (fields counted per line) always are."""
    p = tmp_path / "s.csv"
    p.write_text("\n".join(["t,psi,r,delta", *_rows()]) + "\n")
    assert table._read_clean_stream(p, parse_spec(SPEC)) is None
    spec = parse_spec({**SPEC, "delimiter": "whitespace"})
    assert table._read_clean_stream(p, spec) is None


def test_a_large_table_keeps_its_arrays_one_block_per_column(tmp_path, monkeypatch,
                                                             tiny_blocks) -> None:
    """Above the frame's block bound (32 MiB of values; 64 bytes here) the streamed table's
    frame keeps the converted arrays, one writeable block per column, with the line reader's
    values; below it the frame is one block, as before."""
    from usvid.io import _assemble

    p = tmp_path / "c.csv"
    p.write_text("\n".join(["t,psi,r,delta", *_rows()]) + "\n")
    spec = parse_spec(SPEC)
    _, slow = _paths(monkeypatch, p, spec)
    assert read_trial(p, spec).data._mgr.nblocks == 1
    monkeypatch.setattr(_assemble, "MAX_BLOCK_BYTES", 64)
    tr = read_trial(p, spec)
    _same(tr, slow)
    assert tr.data._mgr.nblocks == 4
    tr.data.iloc[0, 1] = 99.0  # its own, writeable values
    assert tr.data.iloc[0, 1] == 99.0
