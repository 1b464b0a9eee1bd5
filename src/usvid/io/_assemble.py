"""Turn decoded records (time + channel arrays) into a :class:`usvid.Trial`.

Shared by every reader, so that all of them treat bad records the same way:

- records without a finite time (or beyond MAX_ABS_TIME_S) are rejected
  (``rejected["nan_time"]``);
- records with no finite channel value are rejected (``rejected["nan_row"]``);
- time going backwards: with ``non_monotonic: sort`` (the default) the records are sorted by time
  (stable) and a warning finding ``non_monotonic_time`` counts the records that were out of order;
  with ``non_monotonic: reject`` every record earlier than the latest time seen before it is
  dropped and counted as ``rejected["non_monotonic"]``;
- records that share a time stamp are kept in log order and merged into one row
  (:func:`usvid.trial.merge_shared_stamps`, the one rule of usvid, also used by
  :func:`usvid.prep.prepare`): per channel the last finite value in log order wins. For tables
  the merged rows are counted as ``rejected["duplicate_time"]`` (one row per time is expected);
  for multi-rate logs (NMEA, message logs) merging different channels is the normal union of
  time stamps, but a sample superseded by a later one *of the same channel with another value*
  is lost: such samples are counted per channel (``meta["superseded"]``) and named in a
  ``shared_time_stamp`` finding (a warning when a channel loses 10 % of its samples or more: a
  gateway stamping in bursts, a clock coarser than the data);
- positions that are no fix are dropped and counted as ``rejected["no_fix"]`` (a
  ``no_fix`` finding says why): ``lat = lon = 0`` (a receiver without a fix reports "null
  island"), and where the reader delivers the receiver's fix type (internal channel
  ``_fix_type``, the last report holding until the next: 0 no GNSS, 1 no fix, 2 2-D, 3 3-D) or
  HDOP (``_hdop``), a fix type below 2 or an HDOP above :data:`MAX_HDOP` (the speed and course
  of such a record go too).
"""

from __future__ import annotations

import functools
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

from usvid.errors import LogReadError
from usvid.io.spec import FormatSpec, column_mapping, shipped_name
from usvid.trial import Finding, Trial, Vessel, merge_shared_stamps

#: Largest time stamp accepted [s]: epoch seconds up to the year 5138 (a larger prefix or stamp
#: is no time, and would overflow a date).
MAX_EPOCH_S = 1e11


def utc_iso(t: float) -> str | None:
    """ISO 8601 UTC date-time of epoch seconds ``t`` [s]; None when ``t`` is no date."""
    try:
        return datetime.fromtimestamp(t, tz=UTC).isoformat()
    except (OverflowError, OSError, ValueError):
        return None


def read_log_bytes(path: Path, limit: int = -1) -> bytes:
    """The bytes of the log ``path`` (opened read-only; at most ``limit`` bytes, -1 = all).

    Shared by every text reader. Raises :class:`LogReadError` naming the file when it cannot be
    read or holds only white space.
    """
    try:
        with open(path, "rb") as fh:  # read-only
            blob = fh.read(limit)
    except OSError as exc:
        raise LogReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not blob[:65536].strip() and not blob.strip():  # (the prefix first: no 2nd copy)
        raise LogReadError(f"{path}: empty file")
    return blob


def check_log_file(path: Path) -> None:
    """For the binary readers (Excel, Parquet): :class:`LogReadError` when ``path`` is not a file
    or is empty."""
    if not path.is_file():
        raise LogReadError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise LogReadError(f"{path}: empty file")


#: Excel's own limits: rows and columns of a worksheet.
XLSX_MAX_ROW, XLSX_MAX_COL = 1_048_576, 16_384
#: Largest uncompressed worksheet accepted [bytes] and largest compression ratio (zip bombs).
XLSX_MAX_BYTES, XLSX_MAX_RATIO = 2_000_000_000, 1000
#: A sheet is read as the dense rectangle from A1 to its last row and column (pandas pads
#: every row to the widest): a rectangle of more than ``XLSX_MAX_SPAN`` cells and more than
#: ``XLSX_MAX_SPARSE`` times the cells present is refused (a 5 kB sheet with cells A1 and
#: XFD1048576 asks for 1.7e10 cells: gigabytes, then a MemoryError or a killed process).
XLSX_MAX_SPAN, XLSX_MAX_SPARSE = 10_000_000, 50


def check_xlsx_bounds(path: Path) -> None:
    """Refuse a workbook whose worksheets claim rows or columns beyond Excel's limits (a 5 kB
    file with ``<row r="1e308">`` would make a reader allocate gigabytes) or that is a zip bomb.

    Raises :class:`LogReadError` naming the file, the sheet part and the bad reference. Files
    that are not zip archives are left to the reader (its own one-line error).
    """
    import re
    import zipfile

    try:
        zf = zipfile.ZipFile(path)
    except Exception:  # BadZipFile, OSError, NotImplementedError (zip version), ...
        return
    row_re = re.compile(rb'<(?:\w+:)?row\b[^>]*?\sr="([^"]*)"')
    cell_re = re.compile(rb'<(?:\w+:)?c\b[^>]*?\sr="([A-Za-z]*)([^"]*)"')
    with zf:
        for info in zf.infolist():
            if not info.filename.startswith("xl/worksheets/"):
                continue
            ratio = info.file_size / max(info.compress_size, 1)
            if info.file_size > XLSX_MAX_BYTES or ratio > XLSX_MAX_RATIO:
                raise LogReadError(f"{path}: {info.filename} unpacks to {info.file_size} bytes "
                                   f"(ratio {ratio:.0f}); at most {XLSX_MAX_BYTES} bytes and "
                                   f"ratio {XLSX_MAX_RATIO}")
            try:
                data = zf.read(info)
            except Exception as exc:  # zipfile raises many kinds on a corrupt member
                raise LogReadError(f"{path}: {info.filename} cannot be unpacked "
                                   f"({type(exc).__name__})") from None
            last_row = last_col = cells = 0
            for m in row_re.finditer(data):
                v = m.group(1)
                if not v.isdigit() or not 1 <= int(v) <= XLSX_MAX_ROW:
                    ref = v[:30].decode(errors="replace")
                    raise LogReadError(f"{path}: {info.filename}: row r=\"{ref}\" is not a row "
                                       f"number 1..{XLSX_MAX_ROW}")
                last_row = max(last_row, int(v))
            for m in cell_re.finditer(data):
                col, row = m.group(1), m.group(2)
                ncol = 0
                for ch in col.upper()[:4]:
                    ncol = ncol * 26 + (ch - 64)
                if (not row.isdigit() or not 1 <= int(row) <= XLSX_MAX_ROW or len(col) > 3
                        or ncol > XLSX_MAX_COL):
                    ref = (col + row)[:30].decode(errors="replace")
                    raise LogReadError(f"{path}: {info.filename}: cell r=\"{ref}\" is beyond "
                                       f"Excel's {XLSX_MAX_ROW} rows x {XLSX_MAX_COL} columns")
                cells += 1
                last_row, last_col = max(last_row, int(row)), max(last_col, ncol)
            span = last_row * last_col
            if span > XLSX_MAX_SPAN:  # count every cell element, with or without a reference
                cells = max(cells, len(re.findall(rb"<(?:\w+:)?c[\s/>]", data)))
            if span > XLSX_MAX_SPAN and span > XLSX_MAX_SPARSE * max(cells, 1):
                raise LogReadError(
                    f"{path}: {info.filename}: its cells span {last_row:,} rows x {last_col:,} "
                    f"columns ({span:,} cells to read as a table, {span * 8 / 2**30:.1f} GiB at "
                    f"8 bytes a cell, of which {cells:,} are present); at most "
                    f"{XLSX_MAX_SPAN:,} cells or {XLSX_MAX_SPARSE} per present cell")


#: Largest time stamp magnitude [s] taken as a time (31,700 years; epoch seconds are 1.7e9):
#: beyond it differences of stamps overflow or lose every digit.
MAX_ABS_TIME_S = 1e12


def ignored_finding(path: Path, code: str, what: str, ignored: dict, *,
                    data: dict | None = None) -> Finding:
    """The info finding of records a reader skipped on purpose (types it does not use):
    ``"<file>: ignored N <what> not used: k1 (n1), k2 (n2)"``, ``count`` N."""
    n = sum(ignored.values())
    return Finding("info", code,
                   f"{path.name}: ignored {n} {what} not used: "
                   + ", ".join(f"{k} ({v})" for k, v in sorted(ignored.items())),
                   count=n, data=dict(data or {}))


#: Direction channels and the interval every reader delivers them in (the Trial contract):
#: the apparent and the true wind angle from the bow in (-pi, pi], the true wind direction
#: from north in [0, 2 pi) [rad].
DIRECTION_CHANNELS = {"wind_angle": "pm_pi", "wind_angle_true": "pm_pi",
                      "wind_dir_true": "two_pi"}


def wrap_directions(chans: dict[str, np.ndarray], *, own: bool = False
                    ) -> dict[str, np.ndarray]:
    """``chans`` with the direction channels of :data:`DIRECTION_CHANNELS` wrapped into their
    interval (a wind angle logged in [0, 2 pi), as many anemometers write it, becomes
    (-pi, pi]); other channels as they are. ``own``: the arrays are the caller's to give
    (writeable float arrays are then wrapped in place: the same operations, no new array)."""
    out = dict(chans)
    for k, kind in DIRECTION_CHANNELS.items():
        if k in out:
            a = np.asarray(out[k], dtype=float)
            w = a if own and a.flags.writeable and a is out[k] else None
            if kind == "two_pi":
                out[k] = np.remainder(a, 2.0 * np.pi, out=w)
            else:  # (-pi, pi]: the mirror of [-pi, pi)
                b = np.subtract(np.pi, a, out=w)
                b = np.remainder(b, 2.0 * np.pi, out=w)
                b = np.subtract(b, np.pi, out=w)
                out[k] = np.negative(b, out=w)
    return out


#: Largest HDOP of a usable fix (receivers report 50-99.99 without a fix; a good fix is
#: below 2, a poor one below 20).
MAX_HDOP = 50.0
#: HDOP values that mean "unknown" rather than a measurement (MAVLink GPS_RAW_INT.eph = 65535,
#: read with scale 0.01): at or above this the HDOP is ignored.
HDOP_UNKNOWN = 655.0


def _drop_no_fix(path: Path, chans: dict[str, np.ndarray], keep: np.ndarray,
                 rejected: dict[str, int], findings: list[Finding]
                 ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Positions that are no fix set missing (see the module docstring); the internal
    ``_fix_type`` / ``_hdop`` channels removed. Returns the channels and the records left
    without any value by it."""
    chans = dict(chans)
    fix = chans.pop("_fix_type", None)
    hdop = chans.pop("_hdop", None)
    lat, lon = chans.get("lat"), chans.get("lon")
    n = len(keep)
    emptied = np.zeros(n, dtype=bool)
    if lat is None or lon is None:
        return chans, emptied
    has_pos = np.isfinite(lat) & np.isfinite(lon) & keep
    null = has_pos & (lat == 0.0) & (lon == 0.0)
    nofix = np.zeros(n, dtype=bool)
    badh = np.zeros(n, dtype=bool)
    if fix is not None:  # the last fix type reported holds until the next (log order)
        idx = np.where(np.isfinite(fix), np.arange(n), -1)
        np.maximum.accumulate(idx, out=idx)
        held = np.where(idx >= 0, fix[np.maximum(idx, 0)], np.nan)
        nofix = held < 2  # (NaN: unknown, kept)
    if hdop is not None:
        idx = np.where(np.isfinite(hdop), np.arange(n), -1)
        np.maximum.accumulate(idx, out=idx)
        held = np.where(idx >= 0, hdop[np.maximum(idx, 0)], np.nan)
        badh = (held > MAX_HDOP) & (held < HDOP_UNKNOWN)
    drop_pos = has_pos & (null | nofix | badh)
    if not drop_pos.any():
        return chans, emptied
    before = np.zeros(n, dtype=bool)
    for k, v in chans.items():
        if not k.startswith("_"):
            before |= np.isfinite(v)
    for k in ("lat", "lon"):
        chans[k] = np.where(drop_pos, np.nan, chans[k])
    for k in ("sog", "cog"):  # the speed and course of a record without a fix
        if k in chans:
            chans[k] = np.where(keep & (nofix | badh), np.nan, chans[k])
    after = np.zeros(n, dtype=bool)
    for k, v in chans.items():
        if not k.startswith("_"):
            after |= np.isfinite(v)
    emptied = before & ~after
    nd = int(drop_pos.sum())
    _add(rejected, "no_fix", nd)
    n_pos = int(has_pos.sum())
    why = [f"{int(k.sum())} {w}" for k, w in (
        (drop_pos & null, "at lat = lon = 0 (\"null island\": the receiver had no fix yet)"),
        (drop_pos & nofix & ~null, "with the receiver's fix type 'no fix'"),
        (drop_pos & badh & ~null & ~nofix, f"with HDOP above {MAX_HDOP:g}")) if k.any()]
    i0 = int(np.flatnonzero(drop_pos)[0])
    findings.append(Finding(
        "warning" if nd == n_pos else "info", "no_fix",
        f"{path.name}: {nd} of {n_pos} position(s) are no fix and were dropped: "
        + "; ".join(why) + (" - the log holds no valid position" if nd == n_pos else ""),
        count=nd, channel="lat", data={"first_record": i0}))
    return chans, emptied


def shared_stamp_finding(name: str, superseded: dict[str, int],
                         merged: dict[str, np.ndarray]) -> Finding:
    """The finding of samples lost to shared time stamps (:func:`merge_shared_stamps`):
    a warning when a channel lost 10 % of its samples or more."""
    frac = {k: n / (n + int(np.isfinite(merged[k]).sum())) for k, n in superseded.items()}
    worst = max(frac, key=lambda k: frac[k])
    total = sum(superseded.values())
    parts = ", ".join(f"{k} {n} of {n + int(np.isfinite(merged[k]).sum())}"
                      for k, n in sorted(superseded.items(), key=lambda kv: -kv[1])[:6])
    return Finding(
        "warning" if frac[worst] >= 0.1 else "info", "shared_time_stamp",
        f"{name}: {total} sample(s) share a time stamp with a later sample of the same channel "
        f"and another value ({parts}); the time stamps do not resolve the records (a gateway "
        "stamping in bursts, or a clock coarser than the data): the last sample of each stamp "
        "is kept", count=total, channel=worst,
        data={"superseded": dict(superseded), "fraction": {k: round(v, 4)
                                                           for k, v in frac.items()}})


def _add(rejected: dict[str, int], reason: str, n: int) -> None:
    if n:
        rejected[reason] = rejected.get(reason, 0) + int(n)


def assemble(
    path: str | Path,
    t: np.ndarray,
    channels: dict[str, np.ndarray],
    *,
    spec: FormatSpec | None,
    rejected: dict[str, int] | None = None,
    findings: list[Finding] | None = None,
    count_duplicates: bool = True,
    meta: dict | None = None,
    non_monotonic: str | None = None,
    streams: np.ndarray | None = None,
    own: bool = False,
) -> Trial:
    """Build a Trial from records ``t`` [s] and ``channels`` (arrays of the same length, SI).

    ``streams``: the message stream of each record (a code per sentence type and talker, PGN
    and source address, ...): a sample superseded at a shared stamp is counted as lost only
    when the sample that wins is of the same stream (two sentences of one fix that round a
    position differently report one instant twice; one heading sender stamped in bursts loses
    samples). ``own``: ``t`` and the channel arrays are made for this call and referred to by
    nothing else (see :func:`channel_frame`; a large trial then keeps them without a copy).
    Raises :class:`LogReadError` when no usable record remains.
    """
    path = Path(path)
    rejected = dict(rejected or {})
    findings = list(findings or [])
    t = np.asarray(t, dtype=float)
    chans = wrap_directions({k: np.asarray(v, dtype=float) for k, v in channels.items()},
                            own=own)
    if streams is not None:  # carried along as an internal channel, taken out for the merge
        chans["_stream"] = np.asarray(streams, dtype=float)
    nm = non_monotonic or (spec.non_monotonic if spec is not None else "sort")

    if len(t) and -MAX_ABS_TIME_S <= t.min() and t.max() <= MAX_ABS_TIME_S:
        keep = np.ones(len(t), dtype=bool)  # (every stamp usable: a NaN fails the comparison)
    else:
        with np.errstate(invalid="ignore"):  # beyond MAX_ABS_TIME_S differences overflow
            keep = np.isfinite(t) & (np.abs(t) <= MAX_ABS_TIME_S)
    _add(rejected, "nan_time", int((~keep).sum()))
    emptied = np.zeros(len(t), dtype=bool)
    if "lat" in chans or "lon" in chans or "_fix_type" in chans or "_hdop" in chans:
        chans, emptied = _drop_no_fix(path, chans, keep, rejected, findings)
    if chans:
        anyval = np.zeros(len(t), dtype=bool)
        for k, v in chans.items():
            if k != "_stream":
                finite = np.isfinite(v)
                if finite.all():  # (a channel without a gap: every record has a value)
                    anyval = finite
                    break
                anyval |= finite
        bad = keep & ~anyval & ~emptied  # (a record emptied by a dropped fix is counted there)
        _add(rejected, "nan_row", int(bad.sum()))
        keep &= anyval
    if not keep.all():  # (no copy of a clean log)
        t = t[keep]
        chans = {k: v[keep] for k, v in chans.items()}
    if len(t) == 0:
        detail = ", ".join(f"{k}: {n}" for k, n in rejected.items()) or "no data records"
        raise LogReadError(f"{path}: no usable records ({detail})")

    # isolated bad stamps, clock resets and forward jumps (time integrity)
    t, chans, breaks = _time_integrity(path, t, chans, rejected, findings)
    if breaks:
        meta = {**(meta or {}), "time_breaks": breaks}

    # time going backwards (small steps: jitter, records written slightly out of order)
    if len(t) > 1 and not _non_decreasing(t):
        runmax = np.maximum.accumulate(t)
        late = np.zeros(len(t), dtype=bool)
        np.less(t[1:], runmax[:-1], out=late[1:])
        n_back = int(late.sum())
        if n_back:
            i0 = int(np.argmax(late))
            if nm == "reject":
                _add(rejected, "non_monotonic", n_back)
                t = t[~late]
                chans = {k: v[~late] for k, v in chans.items()}
                what = "rejected"
            else:
                order = np.argsort(t, kind="stable")
                t = t[order]
                chans = {k: v[order] for k, v in chans.items()}
                what = "sorted into place"
            findings.append(
                Finding(
                    "warning",
                    "non_monotonic_time",
                    f"{path.name}: time goes backwards at {n_back} record(s) (first at record "
                    f"{i0}, t = {float(runmax[i0 - 1] if i0 else 0.0):.3f} s); they were {what}",
                    count=n_back,
                )
            )

    # records sharing a time stamp -> one row (t is in time order here, stably sorted: the
    # records of one stamp are in log order)
    n_rows = len(t)
    stream = chans.pop("_stream", None)
    t, chans, superseded = merge_shared_stamps(t, chans, stream)
    if count_duplicates and len(t) < n_rows:
        _add(rejected, "duplicate_time", n_rows - len(t))
    if superseded and not count_duplicates:
        findings.append(shared_stamp_finding(path.name, superseded, chans))
        meta = {**(meta or {}), "superseded": dict(superseded)}

    data = channel_frame({"t": t, **chans}, own=own)
    vessel = spec.vessel if spec is not None else Vessel()
    return Trial(
        data=data,
        vessel=Vessel(**{**vessel.__dict__, "extra": dict(vessel.extra)}),
        sources=[str(path)],
        rejected=rejected,
        findings=findings,
        name=path.stem,
        meta={"reader": spec.reader if spec else None, "spec": spec.source if spec else None,
              **({"spec_columns": {c.name: column_mapping(c, spec.reader)
                                   for c in spec.columns.values()},
                  "spec_shipped": shipped_name(spec.source)} if spec else {}),
              **(meta or {})},
    )


@functools.lru_cache(maxsize=256)
def _column_index(names: tuple[str, ...]) -> pd.Index:
    """The column labels ``names`` as ``pd.DataFrame(dict)`` makes them (``Index(list(keys))``),
    kept across reads: building a string Index and its hash table costs 0.1 ms a read with
    pandas 3 (measured), the rest of a small frame's construction 0.01 ms."""
    return pd.Index(list(names))


#: Largest frame [bytes of values] that :func:`channel_frame` builds as one block from arrays it
#: may take (``own``): a larger one takes them as its blocks, one per column, as
#: ``pandas.read_csv`` returns a table. (The copy into one block needs fresh pages from the
#: kernel for a large frame: for a 1e6 x 12 table 96 MB, 0.13-0.2 s of CPU at every read,
#: mostly page faults; measured on the development machine.)
MAX_BLOCK_BYTES = 32 * 2**20


def channel_frame(columns: dict[str, np.ndarray], *, own: bool = False) -> pd.DataFrame:
    """``pd.DataFrame(columns)`` for float arrays of one length: the same frame (one float64
    block in column order, a RangeIndex, the labels' Index as pandas infers it), built from one
    2-D array and a kept Index of the labels (each frame gets its own ``Index.view()`` of it:
    pandas shares the immutable values and the lookup cache between views, the ``name`` is
    the view's own). Anything else (labels that are not all ``str``, arrays of another shape or
    dtype) goes through ``pd.DataFrame(columns)`` itself.

    ``own``: the arrays are the caller's to give (made for this frame, referred to by nothing
    else): a frame of more than :data:`MAX_BLOCK_BYTES` takes the writeable ones without a copy,
    one block per column."""
    arrays = list(columns.values())
    n = len(arrays[0]) if arrays else 0
    if not arrays or not all(type(k) is str for k in columns) or not all(
            type(a) is np.ndarray and a.dtype == np.float64 and a.shape == (n,) for a in arrays):
        return pd.DataFrame(columns)
    if own and len(arrays) * n * 8 > MAX_BLOCK_BYTES:
        return pd.DataFrame({k: a if a.flags.writeable and a.flags.c_contiguous else a.copy()
                             for k, a in columns.items()}, copy=False)
    block = np.empty((len(arrays), n))
    for i, a in enumerate(arrays):
        block[i] = a
    return pd.DataFrame(block.T, columns=_column_index(tuple(columns)).view(), copy=False)


#: A time step is a jump (clock reset backwards, or a jump forwards) when it exceeds
#: ``max(JUMP_STEPS * median step, JUMP_MIN_S)``; smaller backward steps are jitter, left to the
#: spec's ``non_monotonic`` policy.
JUMP_STEPS, JUMP_MIN_S = 10.0, 1.0
#: Records compared with their neighbours to find an isolated bad stamp (a running median of
#: this many records; up to (BAD_STAMP_WINDOW - 1) / 2 consecutive bad stamps are found).
BAD_STAMP_WINDOW = 5


def _diff(t: np.ndarray) -> np.ndarray:
    """``np.diff(t)`` of a 1-D float array (which is ``t[1:] - t[:-1]``), without its
    argument handling (a few microseconds a call, as much as the subtraction of a short log)."""
    return t[1:] - t[:-1]


def _non_decreasing(t: np.ndarray) -> bool:
    """``(np.diff(t) >= 0).all()`` of a 1-D float array, without the array of differences."""
    return bool(np.greater_equal(t[1:], t[:-1]).all())


def _median(d: np.ndarray, *, overwrite: bool = False) -> float:
    """``float(np.median(d))`` of a non-empty 1-D float array without NaN: the middle of the
    sorted values, or the mean of the two middle ones (``(a + b) / 2``, as ``np.mean`` of two
    values), without ``np.median``'s general machinery (30 us a call here, 2 us this way). The
    middle values are found by a partition (linear time), not a sort; ``overwrite``: of ``d``
    itself (a scratch array of the caller's), not of a copy."""
    n = len(d)
    k = n // 2 if n % 2 else (n // 2 - 1, n // 2)
    if overwrite:
        d.partition(k)
        s = d
    else:
        s = np.partition(d, k)
    if n % 2:
        return float(s[n // 2])
    return float((s[n // 2 - 1] + s[n // 2]) / 2.0)


def _positive_median(d: np.ndarray) -> float:
    """Median of the positive time steps ``d`` [s] (0 when there is none)."""
    pos = d[d > 0]
    return _median(pos, overwrite=True) if len(pos) else 0.0


def jump_threshold(t: np.ndarray) -> float:
    """The step [s] beyond which a time step of ``t`` [s] is a jump (see ``JUMP_STEPS``)."""
    return _jump_threshold(_positive_median(_diff(t)))


def _jump_threshold(med: float) -> float:
    """:func:`jump_threshold` from the median positive step ``med`` [s]."""
    return max(JUMP_STEPS * med, JUMP_MIN_S)


def bad_stamps(t: np.ndarray) -> np.ndarray:
    """Mask of isolated bad time stamps in ``t`` [s] (records in log order): stamps farther
    than the jump threshold from the running median of their ``BAD_STAMP_WINDOW`` neighbours,
    while those neighbours agree with each other. A clock reset (a lasting step) is not a bad
    stamp: on either side of it the running median follows the records.
    """
    n = len(t)
    if n < BAD_STAMP_WINDOW or _non_decreasing(t):
        # (in time order the running median of each stamp is the stamp itself)
        return np.zeros(n, dtype=bool)
    h = BAD_STAMP_WINDOW // 2
    pad = np.r_[np.full(h, t[0]), t, np.full(h, t[-1])]
    win = np.lib.stride_tricks.sliding_window_view(pad, BAD_STAMP_WINDOW)
    # (the median of an odd number of values without NaN is the middle one sorted, which is
    # what np.median(win, axis=1) returns, at a tenth of its cost)
    med = np.sort(win, axis=1)[:, h] if BAD_STAMP_WINDOW % 2 else np.median(win, axis=1)
    return np.abs(t - med) > jump_threshold(t)


def _time_integrity(path: Path, t: np.ndarray, chans: dict[str, np.ndarray],
                    rejected: dict[str, int], findings: list[Finding]
                    ) -> tuple[np.ndarray, dict[str, np.ndarray], list[dict]]:
    """Isolated bad stamps -> re-timed between their neighbours (a warning finding counts
    them; the log is not reordered); clock resets
    (a step back beyond the jump threshold) -> the later records continue the clock one median
    step after the last record before the reset; forward jumps kept as they are. Every reset
    and jump is returned as a time break ``{"t", "t_before", "kind", "step_s", "record"}``
    (``t`` [s]: the first time of the new segment, after the repair; ``t_before`` [s]: the last
    time before the break) and named in a warning finding. A clock reset after which the
    records repeat earlier ones exactly (:func:`_repeated_block`: a log holding a copy of
    itself) is no break: the copy is dropped and counted as ``rejected["repeated_records"]``.
    """
    if len(t) < 3:
        return t, chans, []
    bad = bad_stamps(t)
    rec = np.arange(len(t))
    if bad.any():
        # the record is good, its stamp is not: re-time it between its neighbours (by record
        # position; within one sample step of the truth), so the log is not reordered
        idx = np.flatnonzero(bad)
        good = np.flatnonzero(~bad)
        t0 = float(t[idx[0]])
        t = t.copy()
        t[idx] = np.interp(idx.astype(float), good.astype(float), t[good])
        findings.append(Finding(
            "warning", "bad_time_stamp",
            f"{path.name}: {len(idx)} isolated record(s) with a time stamp out of line with "
            f"their neighbours (first at record {int(idx[0])}, stamped {t0:.3f} s, re-timed "
            f"{float(t[idx[0]]):.3f} s); each was re-timed between its neighbours",
            count=len(idx), data={"records": [int(i) for i in idx[:20]]}))
    d = _diff(t)
    med = _positive_median(d)
    thr = _jump_threshold(med)  # (jump_threshold(t), from the same differences)
    jumps = np.flatnonzero(np.abs(d, out=d) > thr)  # (d is not used after this)
    if not len(jumps):
        return t, chans, []
    t = t.copy()
    breaks = []
    repaired = []
    repeated = np.zeros(len(t), dtype=bool)
    for j in jumps:
        if repeated[j + 1]:
            continue  # inside a dropped copy
        step = float(t[j + 1] - t[j])  # after earlier repairs
        kind = "clock_reset" if step < 0 else "forward_jump"
        if step < 0:
            m = _repeated_block(t, chans, j)
            if m:  # the log holds a copy of its own earlier records: the copy is dropped
                repeated[j + 1:j + 1 + m] = True
                continue
        if step < 0:
            t[j + 1:] += (t[j] + med) - t[j + 1]
            if _continuous(chans, j):  # only the clock jumped: the repair is exact
                repaired.append({"record": int(rec[j + 1]), "step_s": step})
                continue
        breaks.append({"t": float(t[j + 1]), "t_before": float(t[j]), "kind": kind,
                       "step_s": step, "record": int(rec[j + 1])})
    if repeated.any():
        n_rep = int(repeated.sum())
        i0 = int(np.flatnonzero(repeated)[0])
        findings.append(Finding(
            "warning", "log_repeated",
            f"{path.name}: {n_rep} record(s) from record {int(rec[i0])} on repeat earlier "
            "records exactly (time stamps and values: the log holds a second copy of a part of "
            "itself, e.g. two captures joined); the copy is dropped",
            count=n_rep, data={"first_record": int(rec[i0])}))
        rejected["repeated_records"] = rejected.get("repeated_records", 0) + n_rep
        t = t[~repeated]
        rec = rec[~repeated]
        chans = {k: v[~repeated] for k, v in chans.items()}
    if repaired:
        desc = "; ".join(f"{r['step_s']:+.3f} s at record {r['record']}" for r in repaired[:3])
        more = ", ..." if len(repaired) > 3 else ""
        findings.append(Finding(
            "warning", "clock_reset_repaired",
            f"{path.name}: {len(repaired)} clock reset(s) ({desc}{more})"
            " with every channel continuous across them: the clock continues one sample step "
            "later (no data lost)", count=len(repaired)))
    if not breaks:
        return t, chans, []
    desc = "; ".join(f"{b['kind'].replace('_', ' ')} of {b['step_s']:+.3f} s at record "
                     f"{b['record']}" for b in breaks[:3])
    findings.append(Finding(
        "warning", "time_discontinuity",
        f"{path.name}: {len(breaks)} time discontinuit{'y' if len(breaks) == 1 else 'ies'} "
        f"({desc}{', ...' if len(breaks) > 3 else ''}); the log is split into "
        f"{len(breaks) + 1} segments there (meta['time_breaks']; clock resets continue the "
        "clock one sample step later); identification fits each segment separately",
        count=len(breaks)))
    return t, chans, breaks


def _repeated_block(t: np.ndarray, chans: dict[str, np.ndarray], j: int) -> int:
    """Records after a clock reset between records ``j`` and ``j + 1`` that repeat, stamp for
    stamp and value for value, the records that start at the same stamp earlier in the log (a
    log that holds a copy of itself): how many (0: not a copy). At least 10 records, or all
    that follow, must match."""
    after = j + 1
    starts = np.flatnonzero(t[:after] == t[after])
    if not len(starts):
        return 0
    i0 = int(starts[0])
    m = min(len(t) - after, after - i0)
    if m < min(10, len(t) - after):
        return 0
    if not np.array_equal(t[i0:i0 + m], t[after:after + m]):
        return 0
    for v in chans.values():
        if not np.array_equal(v[i0:i0 + m], v[after:after + m], equal_nan=True):
            return 0
    return m


def _continuous(chans: dict[str, np.ndarray], j: int, n: int = 3, factor: float = 4.0) -> bool:
    """True when every channel with samples on both sides of the step between records ``j``
    and ``j + 1`` changes across it by at most ``factor`` times its largest change between the
    ``n`` samples on either side (a clock that jumped, no data lost). At least one channel
    must show it."""
    seen = False
    for k, v in chans.items():
        if k.startswith("_"):
            continue
        before = v[max(0, j - 4 * n):j + 1]
        after = v[j + 1:j + 1 + 4 * n]
        before = before[np.isfinite(before)][-n:]
        after = after[np.isfinite(after)][:n]
        if len(before) < 2 or len(after) < 2:
            continue
        typical = max(np.max(np.abs(np.diff(before))), np.max(np.abs(np.diff(after))))
        scale = max(np.max(np.abs(before)), np.max(np.abs(after)), 1.0)
        if abs(after[0] - before[-1]) > factor * typical + 1e-9 * scale:
            return False
        seen = True
    return seen


def apply_renames(chans: dict[str, np.ndarray], spec: FormatSpec | None,
                  sourced: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """For the NMEA readers: apply ``columns`` entries (rename / sign / offset / scale).

    An entry ``name: {col: decoded, sign: -1}`` produces channel ``name`` from decoded channel
    ``decoded``; the decoded channel is dropped when renamed. A missing decoded channel is an error
    unless the entry is ``optional``. ``sourced``: the samples of the entries that name a
    ``source`` (entry name -> samples of that source, :func:`usvid.io.sources.select_sources`).
    """
    if spec is None or not spec.columns:
        return chans
    sourced = sourced or {}
    out = dict(chans)
    for c in spec.columns.values():
        src = str(c.col)
        if c.name in sourced:
            raw = sourced[c.name]
        elif src in chans:
            raw = chans[src]
        elif c.optional:
            continue
        else:
            decoded = ", ".join(sorted(k for k in chans if not k.startswith("_"))) or "none"
            raise LogReadError(
                f"{spec.source}: columns.{c.name}.col: the log has no decoded channel '{src}' "
                f"(decoded: {decoded})"
            )
        if c.name not in sourced and src != c.name and src in out:
            del out[src]  # renamed (a column naming a source is a copy: the channel stays)
        out[c.name] = c.sign * (c.scale * raw + c.offset)
    return out
