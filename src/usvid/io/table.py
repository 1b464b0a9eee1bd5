"""Readers for tabular logs: delimited text (whitespace, CSV, ...), Excel (.xlsx) and Parquet.

Each maps source columns onto Trial channels by the spec's ``columns`` (0-based index or header
name), converts units to SI/radians (``ColumnSpec.convert``) and hands the records to
:func:`usvid.io._assemble.assemble` (NaN time, NaN rows, non-monotonic time, duplicates).

Bad records in text tables are rejected and counted per reason in ``Trial.rejected``:
``truncated`` (fewer fields than the table has), ``field_count`` (more fields), ``garbage``
(a line that is not text: control bytes or undecodable bytes), ``bad_value`` (a mapped cell that
is not a number), plus the reasons of ``assemble``. Files are opened read-only.
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from collections.abc import Collection, Iterator
from pathlib import Path

import numpy as np
import pandas as pd

from usvid.errors import FormatSpecError, LogReadError
from usvid.io._assemble import assemble, check_log_file, check_xlsx_bounds, read_log_bytes
from usvid.io.spec import ColumnSpec, FormatSpec
from usvid.io.units import DATETIME
from usvid.trial import Finding, Trial

#: A line with one of these is garbage (control bytes other than tab, undecodable bytes).
_CTRL_RE = re.compile("[\x00-\x08\x0a-\x1f\x7f\ufffd]")
#: Longest line of a text table [bytes]: a table of a thousand 64-character cells has 65 kB
#: lines; a longer one is not a table (a one-line 200 MB file would be split into gigabytes of
#: cells).
MAX_LINE_BYTES = 1_000_000
#: Cells read as missing (not as bad values).
_NA = ["", "nan", "NaN", "NA", "None", "-"]


def _resolve(
    path: Path, spec: FormatSpec, names: list[str] | None, ncols: int
) -> dict[str, int]:
    """Source column position of each spec column (optional ones may be missing)."""
    pos: dict[str, int] = {}
    for c in spec.columns.values():
        if isinstance(c.col, int):
            if c.col >= ncols:
                if c.optional:
                    continue
                raise FormatSpecError(
                    f"{path.name}: spec {spec.source} columns.{c.name}.col: index {c.col} is out "
                    f"of range (the file has {ncols} columns, indices 0..{ncols - 1})"
                )
            pos[c.name] = c.col
        else:
            if names is None:
                raise FormatSpecError(
                    f"{path.name}: spec {spec.source} columns.{c.name}.col: names column "
                    f"'{c.col}' but the file is read without a header row (set header: true)"
                )
            stripped = [str(n).strip() for n in names]
            if c.col in stripped:
                pos[c.name] = stripped.index(c.col)
            elif c.optional:
                continue
            else:
                raise FormatSpecError(
                    f"{path.name}: spec {spec.source} columns.{c.name}.col: no column named "
                    f"'{c.col}' (the header has: {', '.join(stripped)})"
                )
    return pos


def _to_float(values: pd.Series | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Numbers from a column; second array marks cells that are non-empty but not numeric."""
    s = pd.Series(values)
    if pd.api.types.is_numeric_dtype(s.dtype) and not pd.api.types.is_bool_dtype(s.dtype):
        return s.to_numpy(dtype=float), np.zeros(len(s), dtype=bool)
    num = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    nan = np.isnan(num)
    if not nan.any():  # every cell a number: none is bad (an empty cell is a NaN)
        return num, np.zeros(len(s), dtype=bool)
    txt = s.astype(str).str.strip()
    empty = s.isna().to_numpy() | txt.isin(["", "nan", "NaN", "NA", "None", "-"]).to_numpy()
    return num, nan & ~empty


def _owned(v: np.ndarray) -> np.ndarray | None:
    """``v`` (a float64 column of a frame the caller made and drops) made writeable, or None
    when it cannot be. pandas hands out its columns as read-only views of its own writeable
    arrays (copy-on-write); a frame nothing else refers to can give them away: converting
    units in place, and the Trial's frame taking them, then needs no new array (a new array of
    a large table costs page faults: of a 1e6 x 12 table about 0.03 s of CPU, measured)."""
    if type(v) is not np.ndarray or v.dtype != np.float64 or v.ndim != 1:
        return None
    if not v.flags.writeable:
        try:
            v.flags.writeable = True  # (numpy refuses when the memory is not writeable)
        except ValueError:
            return None
    return v


def _to_seconds(values: pd.Series | np.ndarray) -> tuple[np.ndarray, np.ndarray, str | None]:
    """Seconds since the first valid date-time; invalid cells, and the ISO origin.

    Date-times with different UTC offsets (a clock change, or "Z" next to "+01:00") are
    converted to UTC first, date-times without an offset among them taken as UTC.
    """
    s = pd.Series(values)
    try:
        dt = pd.to_datetime(s, errors="coerce", format="mixed")
    except ValueError:  # pandas: "Mixed timezones detected"
        dt = pd.to_datetime(s, errors="coerce", format="mixed", utc=True)
    bad = dt.isna().to_numpy() & s.notna().to_numpy()
    valid = dt.dropna()
    if valid.empty:
        return np.full(len(s), np.nan), bad, None
    t0 = valid.min()
    secs = (dt - t0).dt.total_seconds().to_numpy(dtype=float)
    return secs, bad, t0.isoformat()


def map_columns(
    path: Path,
    spec: FormatSpec,
    cols: dict[str, pd.Series | np.ndarray],
    rejected: dict[str, int],
    *,
    where: np.ndarray | None = None,
    where_name: str = "data row",
    findings: list[Finding] | None = None,
    own: Collection[str] = (),
) -> tuple[np.ndarray, dict[str, np.ndarray], dict]:
    """Convert the mapped source columns; rows with non-numeric cells are rejected (bad_value).

    ``where`` gives the position of each row in the file (``where_name``, e.g. "line" 1-based);
    default the 1-based data row. Each column with bad cells gets a warning appended to
    ``findings`` naming the column, the count and the first bad cell; when no row is left a
    :class:`LogReadError` says the same. ``own``: the names of the columns whose values are the
    caller's to give (of a frame made for this call and dropped after it, each source column
    mapped by no other name): such a float column is converted in place (:func:`_owned`), not
    into a new array.
    """
    out: dict[str, np.ndarray] = {}
    bad_any = None
    meta: dict = {}
    notes: list[str] = []
    for name, raw in cols.items():
        c: ColumnSpec = spec.columns[name]
        if c.unit == DATETIME:
            v, bad, t0 = _to_seconds(raw)
            if t0 is not None:
                meta["t0_utc"] = t0
        else:
            v, bad = _to_float(raw)
        if name in own and c.scale == 1.0 and c.offset == 0.0 and (w := _owned(v)) is not None:
            if c.factor != 1.0:  # (the same product as ``convert``, written into the column)
                np.multiply(w, c.factor, out=w)
            out[name] = w
        else:
            out[name] = c.convert(v)
        if bad.any():
            i = int(np.argmax(bad))
            pos = int(where[i]) if where is not None else i + 1
            cell = np.asarray(raw, dtype=object)[i]
            note = (f"column {name} (source column {c.col!r}): {int(bad.sum())} cell(s) are not "
                    f"{'date-times' if c.unit == DATETIME else 'numbers'} (first at "
                    f"{where_name} {pos}: {str(cell)[:40]!r})")
            notes.append(note)
            if findings is not None:
                findings.append(Finding("warning", "bad_value", f"{path.name}: {note}; those "
                                        "rows are rejected", count=int(bad.sum()), channel=name))
        bad_any = bad if bad_any is None else (bad_any | bad)
    if bad_any is not None and bad_any.any():
        if bad_any.all():
            raise LogReadError(f"{path}: no usable records (bad_value: {int(bad_any.sum())}): "
                               + "; ".join(notes))
        rejected["bad_value"] = rejected.get("bad_value", 0) + int(bad_any.sum())
        out = {k: v[~bad_any] for k, v in out.items()}
    t = out.pop("t")
    return t, out, meta


def _split(line: str, delim: str | None) -> list[str]:
    if delim is None:
        return line.split()
    return [f.strip().strip('"') for f in line.split(delim)]


def _records(lines: list[str], i: int, delim: str | None
             ) -> Iterator[tuple[int, str, list[str]]]:
    """(first line number, its text, fields) of each record of ``lines[i:]``. With a
    one-character delimiter and a quote character in the data, records are split by the
    :mod:`csv` module (RFC 4180 quoting: a quoted field may hold the delimiter, doubled quotes
    or a line break; the record's text is then all its lines); a record the module rejects (an
    unbalanced quote) is one bad line, split naively (its field count then rejects it), and
    parsing goes on after it. Without quotes: line by line."""
    body = lines[i:]
    if not (delim is not None and len(delim) == 1 and any('"' in s for s in body)):
        for k, s in enumerate(body, start=i + 1):
            yield k, s, _split(s, delim)
        return
    start = 0  # a bad record (an unbalanced quote) is one bad line; parsing restarts after it
    while start < len(body):
        reader = csv.reader(io.StringIO("\n".join(body[start:])), delimiter=delim,
                            skipinitialspace=True, strict=True)
        done = 0
        try:
            for fields in reader:
                first, done = done, reader.line_num
                text = "\n".join(body[start + first:start + done])
                yield (i + 1 + start + first, text,
                       [f.strip() for f in fields] if text.strip() else [])
            return
        except csv.Error:
            s = body[start + done]
            yield i + 1 + start + done, s, _split(s, delim)
            start += done + 1


def check_line_length(path: Path, blob: bytes, max_bytes: int = MAX_LINE_BYTES) -> None:
    """:class:`LogReadError` naming the line when a line of ``blob`` is longer than
    ``max_bytes``. Windows of ``max_bytes`` are searched backwards for their last line feed
    (C speed, no copy): a window without one holds part of a too long line, and the next window
    starts after the last line feed found, so every line is covered and the work is about
    ``len(blob) / max_bytes`` searches."""
    pos, n = 0, len(blob)
    while n - pos > max_bytes:
        nl = blob.rfind(b"\n", pos, pos + max_bytes + 1)
        if nl < 0:
            line = blob.count(b"\n", 0, pos) + 1
            raise LogReadError(f"{path} line {line}: longer than {max_bytes} bytes; a table "
                               f"line has at most {max_bytes} (is this a table?)")
        pos = nl + 1


def read_table(path: str | Path, spec: FormatSpec) -> Trial:
    """Read a delimited text table (whitespace, ',', ';', tab) with a spec.

    Units: as the spec says, converted to SI/radians. Raises :class:`LogReadError` when the file
    is empty, unreadable or has no usable record, :class:`FormatSpecError` when a spec column is
    not in the file (index out of range, header name not found).
    """
    path = Path(path)
    fast = _read_clean_stream(path, spec)
    if fast is not None:
        return fast
    blob = read_log_bytes(path)
    check_line_length(path, blob)
    fast = _read_clean(path, spec, blob)
    if fast is not None:
        return fast
    text = blob.decode(spec.encoding, errors="replace")
    if text.startswith("\ufeff"):  # byte-order mark (Excel's "CSV UTF-8"): not part of the data
        text = text[1:]
    lines = text.splitlines()
    rejected: dict[str, int] = {}
    i = spec.skip_rows
    if i >= len(lines):
        raise LogReadError(
            f"{path}: the file has {len(lines)} line(s) and skip_rows = {spec.skip_rows}: "
            "no data rows after the skipped header lines"
        )
    names = None
    want_header = spec.header if spec.header is not None else spec.uses_names

    def usable(s: str) -> bool:
        st = s.strip()
        return bool(st) and not (spec.comment and st.startswith(spec.comment))

    if want_header:
        while i < len(lines) and not usable(lines[i]):
            i += 1
        if i >= len(lines):
            raise LogReadError(f"{path} line {i + 1}: expected a header row, found end of file")
        names = _split(lines[i], spec.delimiter)
        i += 1
    rows: list[list[str]] = []
    linenos: list[int] = []
    garbage = 0
    for k, s, fields in _records(lines, i, spec.delimiter):
        if not usable(s):
            continue
        if _CTRL_RE.search(s.replace("\n", " ")):  # (a quoted field may hold a line break)
            garbage += 1
            continue
        rows.append(fields)
        linenos.append(k)
    if garbage:
        rejected["garbage"] = garbage
    if not rows:
        raise LogReadError(
            f"{path} line {i + 1}: no data rows after {i} header line(s)"
            + (f" ({garbage} garbage lines)" if garbage else "")
        )
    counts = np.fromiter((len(r) for r in rows), dtype=np.int64, count=len(rows))
    if names is not None:
        ncols = len(names)
    else:
        vals, cnt = np.unique(counts, return_counts=True)
        ncols = int(vals[np.argmax(cnt)])
    pos = _resolve(path, spec, names, ncols)
    short = counts < ncols
    long_ = counts > ncols
    if short.any():
        rejected["truncated"] = int(short.sum())
    if long_.any():
        rejected["field_count"] = int(long_.sum())
    ok = ~(short | long_)
    good = [r for r, k in zip(rows, ok, strict=True) if k]
    if not good:
        raise LogReadError(f"{path}: no row has the expected {ncols} fields")
    cols = {name: np.array([r[p] for r in good], dtype=object) for name, p in pos.items()}
    findings: list[Finding] = []
    t, chans, meta = map_columns(path, spec, cols, rejected, where=np.asarray(linenos)[ok],
                                 where_name="line", findings=findings)
    return assemble(path, t, chans, spec=spec, rejected=rejected, meta=meta, findings=findings)


#: Line breaks of :meth:`str.splitlines` other than "\n" (and "\r\n"): a line before the data
#: holding one is left to the line reader.
_OTHER_BREAKS = re.compile("[\r\x0b\x0c\x1c-\x1e\x85\u2028\u2029]")


def _data_start(spec: FormatSpec, blob: bytes, d: str | None
                ) -> tuple[int, int, list[str] | None] | None:
    """Where the data of ``blob`` begins: (byte offset, number of lines before it, header names
    or None), decoding only the lines before the data (``skip_rows``, blank or comment lines
    before the header, the header) as :func:`read_table` does; None when that is not plain (a
    line break other than LF/CRLF there, or no data line after it)."""
    want_header = spec.header if spec.header is not None else spec.uses_names
    off, k = 0, 0
    while k < spec.skip_rows or want_header:
        end = blob.find(b"\n", off)
        if end < 0:  # the file ends before its data: the line reader says so
            return None
        s = blob[off:end].decode(spec.encoding, errors="replace")
        if k == 0 and s.startswith("\ufeff"):  # byte-order mark: not part of the data
            s = s[1:]
        s = s[:-1] if s.endswith("\r") else s
        if _OTHER_BREAKS.search(s):
            return None
        off, k = end + 1, k + 1
        if k <= spec.skip_rows:
            continue
        st = s.strip()
        if st and not (spec.comment and st.startswith(spec.comment)):
            return off, k, _split(s, d)
    return off, k, None


def _clean_bytes(blob: bytes, off: int, a: np.ndarray, nl: int, spec: FormatSpec,
                 d: str | None, ncols: int) -> bool:
    """True when the data bytes ``blob[off:]`` (``a``: the same as uint8; ``nl`` line feeds)
    hold no quote character, no comment, ``ncols - 1`` delimiters per line, no control byte but
    tab, line feed and the carriage return of a CRLF line end, and (not ASCII) no undecodable
    byte or Unicode line separator. Counted over the bytes (numpy; no copy, no decoding).
    Whitespace-separated (``d`` None): the fields are counted by :func:`_ws_fields`."""
    if ncols < 2 or blob.find(b'"', off) >= 0 or blob.find(b"\x7f", off) >= 0:
        return False
    if spec.comment and blob.find(spec.comment.encode(spec.encoding), off) >= 0:
        return False
    nrows = nl + (0 if blob.endswith(b"\n") else 1)
    if d is not None and np.count_nonzero(a == ord(d)) != (ncols - 1) * nrows:
        return False
    low = np.count_nonzero(a < 32)
    if low != nl:
        cr = np.flatnonzero(a == 13)
        if len(cr) and (cr[-1] + 1 >= len(a) or not (a[cr + 1] == 10).all()):
            return False  # a carriage return that does not end a line
        if low != nl + len(cr) + np.count_nonzero(a == 9):
            return False
    if not blob.isascii():
        text = blob[off:].decode(spec.encoding, errors="replace")
        if any(ch in text for ch in ("\ufffd", "\x85", "\u2028", "\u2029")):
            return False
    return True


def _ws_fields(a: np.ndarray, breaks: np.ndarray, nrows: int) -> np.ndarray:
    """Fields of each of the ``nrows`` lines of whitespace-separated ASCII bytes ``a`` (uint8;
    ``breaks``: positions of its line feeds), as :meth:`str.split` counts them."""
    sep = (a == 32) | (a == 9) | (a == 10) | (a == 13)
    start = ~sep  # first byte of a field: not a separator, after a separator or at the start
    start[1:] &= sep[:-1]
    return np.bincount(np.searchsorted(breaks, np.flatnonzero(start)), minlength=nrows)


def _ascii_compatible(spec: FormatSpec) -> bool:
    """True when the spec's delimiter is whitespace or one character other than the quote, and
    its encoding writes the line feed and the delimiter as their ASCII bytes (the clean paths
    look at the undecoded bytes)."""
    d = spec.delimiter
    if d is not None and (len(d) != 1 or d == '"'):
        return False
    try:
        return "\n".encode(spec.encoding) == b"\n" and (
            d is None or d.encode(spec.encoding) == d.encode("ascii"))
    except (LookupError, UnicodeError):
        return False


#: Bytes of a table read at once by :func:`_read_clean_stream`: the first block (the lines
#: before the data and the first data line must lie in it; a smaller file is read whole), then
#: the blocks of the check (less than :data:`MAX_LINE_BYTES`: two line feeds in one block are
#: closer than the line bound).
_STREAM_HEAD, _STREAM_BLOCK = 1 << 20, 1 << 19


def _read_clean_stream(path: Path, spec: FormatSpec) -> Trial | None:
    """A large clean ASCII table with a one-character delimiter, checked block by block from
    the file (a block of :data:`_STREAM_BLOCK` bytes in memory, no copy of the file) and then
    parsed by pandas' C parser from the file; None when it is small, not plain ASCII, or not
    clean (:func:`_scan_clean_blocks`): :func:`read_table` then reads its bytes, the way every
    table was read before. A line longer than :data:`MAX_LINE_BYTES` is refused here as
    :func:`check_line_length` refuses it, after reading about that much of it."""
    d = spec.delimiter
    if d is None or not _ascii_compatible(spec):
        return None
    comment = spec.comment.encode(spec.encoding) if spec.comment else b""
    if len(comment) > 1:  # (a comment of one byte is searched block by block)
        return None
    try:
        fh = open(path, "rb", buffering=0)  # read-only
    except OSError:
        return None  # (read_log_bytes says why)
    with fh:
        try:
            head = fh.read(_STREAM_HEAD)
        except OSError:
            return None
        if len(head) < _STREAM_HEAD or not head.strip():
            return None  # a small file (read whole), or leading blanks: the bytes path
        start = _data_start(spec, head, d)
        if start is None:
            return None
        off, i, names = start
        check_line_length(path, head[:off])
        end = head.find(b"\n", off)
        if end < 0:
            return None
        ncols = len(names) if names is not None else head.count(d.encode("ascii"), off, end) + 1
        if ncols < 2:
            return None
        try:
            found = _scan_clean_blocks(path, fh, off, i, d, comment, ncols)
            if found is None:
                return None
            fh.seek(off)
            return _parse_clean(path, spec, fh, i, names, ncols, *found)
        except OSError:
            return None  # (the bytes path reads the file again and says why it cannot)


def _scan_clean_blocks(path: Path, fh: io.RawIOBase, off: int, i: int, d: str,
                       comment: bytes, ncols: int) -> tuple[int, bool] | None:
    """(data lines, a blank in them) of the file ``fh`` from byte ``off`` (line ``i + 1``) when
    its data are clean as :func:`_clean_bytes` says (ASCII here: a byte above 127 returns
    None), read block by block into one buffer: the counts of line feeds, delimiters and bytes
    below 32 (numpy on the block), the search for a quote, DEL or the comment byte (C). A
    line longer than :data:`MAX_LINE_BYTES` raises :class:`LogReadError` naming it."""
    block = bytearray(min(_STREAM_BLOCK, MAX_LINE_BYTES))
    fh.seek(off)
    pos = line_start = off  # file offsets: of the block, of the current line
    nl = nd = 0
    blanks = cr_open = False
    last = 10
    dcode = ord(d)

    def too_long() -> LogReadError:
        return LogReadError(f"{path} line {i + nl + 1}: longer than {MAX_LINE_BYTES} bytes; a "
                            f"table line has at most {MAX_LINE_BYTES} (is this a table?)")

    while True:
        n = fh.readinto(block)
        if not n:
            break
        if (block.find(b'"', 0, n) >= 0 or block.find(b"\x7f", 0, n) >= 0
                or (comment and block.find(comment, 0, n) >= 0)):
            return None
        blanks = blanks or block.find(b" ", 0, n) >= 0 or (
            d != "\t" and block.find(b"\t", 0, n) >= 0)
        a = np.frombuffer(block, dtype=np.uint8, count=n)
        k = int(np.count_nonzero(a == 10))
        nd += int(np.count_nonzero(a == dcode))
        low = int(np.count_nonzero(a.view(np.int8) < 32))  # (bytes above 127 count: negative)
        if cr_open and a[0] != 10:
            return None  # a carriage return that does not end a line
        cr_open = False
        if low != k:  # carriage returns of CRLF line ends, tabs; else not clean
            cr = np.flatnonzero(a == 13)
            if len(cr) and cr[-1] == n - 1:
                cr_open, cr = True, cr[:-1]  # (its line feed begins the next block)
            if len(cr) and not (a[cr + 1] == 10).all():
                return None
            if low != k + np.count_nonzero(a == 13) + np.count_nonzero(a == 9):
                return None
        if k:
            if pos + block.find(b"\n", 0, n) - line_start > MAX_LINE_BYTES:
                raise too_long()
            line_start = pos + block.rfind(b"\n", 0, n) + 1
        elif pos + n - line_start > MAX_LINE_BYTES:
            raise too_long()
        nl += k
        pos += n
        last = block[n - 1]
    if cr_open or pos == off:
        return None
    nrows = nl + (0 if last == 10 else 1)
    if nd != (ncols - 1) * nrows:
        return None
    return nrows, blanks


def _read_clean(path: Path, spec: FormatSpec, blob: bytes) -> Trial | None:
    """The file parsed by pandas' C parser when its table is clean (see :func:`_clean_bytes`:
    an ASCII-compatible encoding, a one-character delimiter or whitespace (ASCII data), no
    quote, no control byte, no comment, every data line with the same number of fields); else
    None (:func:`read_table`
    then reads it line by line, counting and reporting every bad line). Only the lines before
    the data are decoded; pandas is handed the bytes."""
    d = spec.delimiter
    if not _ascii_compatible(spec):
        return None
    start = _data_start(spec, blob, d)
    if start is None or start[0] >= len(blob):
        return None
    off, i, names = start
    a = np.frombuffer(blob, dtype=np.uint8, offset=off)
    if d is None:  # whitespace: ASCII only (str.split also splits at e.g. a no-break space)
        if not blob.isascii() and not blob[off:].isascii():
            return None
        breaks = np.flatnonzero(a == 10)
        nl = len(breaks)
        nrows = nl + (0 if blob.endswith(b"\n") else 1)
        fields = _ws_fields(a, breaks, nrows)
        ncols = len(names) if names is not None else int(fields[0])
        if not (fields == ncols).all():
            return None
    else:
        nl = int(np.count_nonzero(a == 10))
        nrows = nl + (0 if blob.endswith(b"\n") else 1)  # (lines; a last break ends none)
        end = blob.find(b"\n", off)
        first = blob[off:end if end >= 0 else len(blob)]
        ncols = len(names) if names is not None else first.count(d.encode("ascii")) + 1
    if not _clean_bytes(blob, off, a, nl, spec, d, ncols):
        return None
    # (skipinitialspace costs pandas a quarter of its time; it is a no-op without blanks)
    blanks = d is not None and (blob.find(b" ", off) >= 0
                                or (d != "\t" and blob.find(b"\t", off) >= 0))
    buf = io.BytesIO(blob)
    buf.seek(off)  # (pandas reads on from there: no copy of the data)
    return _parse_clean(path, spec, buf, i, names, ncols, nrows, blanks)


def _parse_clean(path: Path, spec: FormatSpec, source: io.RawIOBase | io.BufferedIOBase,
                 i: int, names: list[str] | None, ncols: int, nrows: int, blanks: bool
                 ) -> Trial | None:
    """The clean data of ``source`` (a binary file positioned at the first data line, line
    ``i + 1`` of the file; ``nrows`` lines of ``ncols`` fields, ``blanks``: a blank in them)
    parsed by pandas' C parser, mapped and assembled; None when pandas does not read exactly
    those lines as the line reader would (the caller then reads the file line by line)."""
    d = spec.delimiter
    pos = _resolve(path, spec, names, ncols)
    usecols = sorted(set(pos.values()))
    if usecols == list(range(ncols)):  # (every column: the same frame, without pandas' per-field
        usecols = None                 # column selection, 4-15 % of its parse, measured)
    dates = {p for n, p in pos.items() if spec.columns[n].unit == DATETIME}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            df = pd.read_csv(source, sep=d if d is not None else r"\s+", header=None,
                             usecols=usecols, encoding=spec.encoding,
                             dtype={p: str for p in dates} or None, keep_default_na=False,
                             na_values=_NA, skipinitialspace=blanks, engine="c",
                             skip_blank_lines=False, quoting=3)  # QUOTE_NONE
    except (ValueError, pd.errors.ParserError, pd.errors.ParserWarning):
        return None
    if len(df) != nrows:
        return None
    cols = {}
    for name, p in pos.items():
        col = df[p]
        if pd.api.types.is_string_dtype(col.dtype):  # text cells (object in pandas 2, str in
            col = col.str.strip()                     # pandas 3): strip as the line reader does
        cols[name] = col
    rejected: dict[str, int] = {}
    findings: list[Finding] = []
    del df  # (the frame is this call's: its columns are given away, converted in place)
    used = list(pos.values())
    own = {n for n, p in pos.items() if used.count(p) == 1}  # (a column mapped twice: copies)
    t, chans, meta = map_columns(path, spec, cols, rejected, where=i + 1 + np.arange(nrows),
                                 where_name="line", findings=findings, own=own)
    return assemble(path, t, chans, spec=spec, rejected=rejected, meta=meta, findings=findings,
                    own=True)  # (the arrays are this call's: pandas' columns or new ones)


def _frame_to_trial(path: Path, spec: FormatSpec, df: pd.DataFrame, header: bool,
                    first_row: int = 1, where_name: str = "data row") -> Trial:
    """``first_row``: the position in the file (``where_name``) of the frame's first row."""
    names = [str(c) for c in df.columns] if header else None
    pos = _resolve(path, spec, names, df.shape[1])
    rejected: dict[str, int] = {}
    cols = {name: df.iloc[:, p] for name, p in pos.items()}
    findings: list[Finding] = []
    t, chans, meta = map_columns(path, spec, cols, rejected,
                                 where=first_row + np.arange(len(df)), where_name=where_name,
                                 findings=findings)
    return assemble(path, t, chans, spec=spec, rejected=rejected, meta=meta, findings=findings)


def read_excel(path: str | Path, spec: FormatSpec) -> Trial:
    """Read one sheet of an Excel workbook (.xlsx) into a Trial (SI units, the spec's columns).

    Through pandas with the calamine engine (python-calamine, Rust): about ten times faster
    than openpyxl (a 1,536-row, 24-column log in 0.04 s against 0.39 s) with the same values.
    Refused before reading (:func:`check_xlsx_bounds`): references beyond Excel's limits, zip
    bombs and sheets whose cells span a table far larger than what they hold (calamine
    allocates the whole rectangle)."""
    path = Path(path)
    check_log_file(path)
    header = spec.header if spec.header is not None else True
    check_xlsx_bounds(path)  # row/column references within Excel's limits, no zip bomb
    try:
        xl = pd.ExcelFile(path, engine="calamine")
    except Exception as exc:  # calamine raises CalamineError, zip and XML errors
        raise LogReadError(
            f"{path}: not a readable .xlsx workbook ({type(exc).__name__})"
        ) from None
    with xl:
        sheets = xl.sheet_names
        if isinstance(spec.sheet, int):
            if spec.sheet >= len(sheets):
                raise FormatSpecError(
                    f"{path.name}: spec {spec.source} sheet: index {spec.sheet} out of range "
                    f"(sheets: {', '.join(sheets)})"
                )
        elif spec.sheet not in sheets:
            raise FormatSpecError(
                f"{path.name}: spec {spec.source} sheet: no sheet '{spec.sheet}' "
                f"(sheets: {', '.join(sheets)})"
            )
        try:
            df = pd.read_excel(
                xl, sheet_name=spec.sheet, header=0 if header else None,
                skiprows=spec.skip_rows,
            )
        except Exception as exc:
            raise LogReadError(f"{path}: cannot read sheet {spec.sheet!r} ({exc})") from None
    if df.empty:
        raise LogReadError(f"{path}: sheet {spec.sheet!r} has no data rows")
    # spreadsheet row of the first data row: skipped rows, the header row, 1-based
    first = spec.skip_rows + (2 if header else 1)
    return _frame_to_trial(path, spec, df, header, first, f"sheet {spec.sheet!r} row")


def read_parquet(path: str | Path, spec: FormatSpec) -> Trial:
    """Read a Parquet table (columns by name or 0-based index)."""
    path = Path(path)
    check_log_file(path)
    try:
        df = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises ArrowInvalid / OSError on a non-parquet file
        raise LogReadError(f"{path}: not a readable Parquet file ({type(exc).__name__})") from None
    if df.empty:
        raise LogReadError(f"{path}: Parquet table has no rows")
    return _frame_to_trial(path, spec, df, True)
