"""ArduPilot logs: DataFlash (``.bin`` binary, ``.log`` text) and MAVLink telemetry logs
(``.tlog``), read through ``pymavlink`` (optional extra ``usvid[ardupilot]``); a tlog writer through
pymavlink and a minimal DataFlash writer following the ArduPilot "DataFlash log format"
documentation (pymavlink cannot write DataFlash logs), used for tests and benchmarks.

DataFlash (binary): a stream of messages ``A3 95 <type> <payload>`` whose layouts are declared by
``FMT`` messages (type 128: type, length, name, format characters, column names). pymavlink's
``DFReader_binary`` indexes the file (the offset of every message per type, the formats with their
struct layouts and multipliers); usvid then decodes each wanted type in one numpy step from that
index (the library's layouts and multipliers, no Python loop per record) -- the tests check the
values against pymavlink's own per-message decoding. Text logs go through ``DFReader_text``.
Spec columns name a message (``GPS``, ``ATT``, ``IMU``, ``RCOU``, ``STER``, ``ESC``...) and a column
(``Lat``, ``Yaw``, ``GyrZ``, ``C1``...); values carry pymavlink's multipliers (``Lat`` in degrees,
``ATT.Yaw`` in degrees). ``instance`` filters on the message's instance column (``I`` /
``Instance``). Time: ``TimeUS`` [us since boot]; GPS week and milliseconds (``GWk``/``GMS``) tie it
to UTC (``meta["t0_utc"]``, GPS - UTC = 18 s).

MAVLink tlog: records of an 8-byte big-endian receive time [us since 1970] followed by one
MAVLink 1 or 2 packet; pymavlink parses them (checksums checked) one by one, the library's own
loop. Columns name a MAVLink message (``GLOBAL_POSITION_INT``, ``ATTITUDE``, ``GPS_RAW_INT``,
``SERVO_OUTPUT_RAW``, ``ESC_TELEMETRY_1_TO_4``...) and a field (``lat``, ``yaw``, ``rpm[0]``);
values are as on the wire (``lat`` in 1e-7 deg: use ``scale``). Time: the record's receive time.

Frames: ArduPilot works in NED / FRD, so ``ATT.Yaw``, ``ATTITUDE.yaw`` are headings and ``GyrZ`` /
``yawspeed`` clockwise yaw rates as the Trial's. Rejected records: ``bad_header`` (DataFlash
bytes skipped to resynchronise), ``truncated`` (a message cut by the end of the file),
``unknown_type`` (a message type without a FMT: the rest of the log cannot be framed, a warning
finding says so), ``bad_data`` (tlog bytes that are not a valid MAVLink packet: checksum, unknown
message id, garbage).
"""

from __future__ import annotations

import contextlib
import functools
import io
import itertools
import math
import os
import re
import struct
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from usvid.errors import LogReadError
from usvid.files import write_atomic
from usvid.io._binlog import interleave, records
from usvid.io._messages import (
    ReadState,
    Series,
    build_trial,
    get_path,
    missing_field,
    missing_topic,
    path_steps,
    require,
)
from usvid.io.sources import Sources, select_sources
from usvid.io.spec import QUATERNION_CONVERTS, ColumnSpec, FormatSpec
from usvid.io.vehicles import mav_type_kind, vehicle_finding
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

DF_HEAD = b"\xa3\x95"
GPS_EPOCH = 315_964_800  # 1980-01-06 in Unix seconds
GPS_UTC_LEAP_S = 18  # GPS - UTC since 2017-01-01
_STRUCT_NP = {"b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4", "q": "<i8",
              "Q": "<u8", "f": "<f4", "d": "<f8", "e": "<f2"}


def is_dataflash_bin(head: bytes) -> bool:
    """True when ``head`` starts with a DataFlash FMT message (``A3 95 80``)."""
    return head[:3] == DF_HEAD + b"\x80"


def is_dataflash_text(head: bytes) -> bool:
    """True when ``head`` is a text DataFlash log (first line ``FMT, 128, 89, FMT, ...``)."""
    return head.lstrip().startswith(b"FMT,") and b"FMT" in head[:200]


def is_tlog(head: bytes) -> bool:
    """True when ``head`` looks like a MAVLink tlog: an 8-byte time stamp (1990..2100) followed
    by a MAVLink 1 (0xFE) or 2 (0xFD) packet start."""
    if len(head) < 10:
        return False
    (us,) = struct.unpack(">Q", head[:8])
    return 6.3e14 < us < 4.1e15 and head[8] in (0xFE, 0xFD)


def _quiet() -> contextlib.ExitStack:
    stack = contextlib.ExitStack()
    buf = io.StringIO()
    stack.enter_context(contextlib.redirect_stdout(buf))
    stack.enter_context(contextlib.redirect_stderr(buf))
    stack.buf = buf  # type: ignore[attr-defined]
    return stack


#: A temporary file kept for :func:`_fd2_captured` between reads (creating one costs more than
#: a small log's indexing); taken while in use, so a nested capture makes its own.
_FD2_SPARE: list = []
#: A capture that held more than this [bytes] is not kept for the next.
_FD2_KEEP_MAX = 1 << 20


@contextlib.contextmanager
def _fd2_captured(out: list[str]):
    """Capture what compiled code writes to file descriptor 2 (pymavlink's Cython DataFlash
    indexer prints one ``bad header`` line per damaged byte there, past ``sys.stderr``) into
    ``out``, so the command line keeps its one-line errors. Process-wide while it lasts."""
    sys.stderr.flush()
    tmp = _FD2_SPARE.pop() if _FD2_SPARE else tempfile.TemporaryFile()
    tmp.seek(0)
    tmp.truncate()
    saved = os.dup(2)
    os.dup2(tmp.fileno(), 2)
    try:
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        tmp.seek(0)
        text = tmp.read()
        out.append(text.decode("utf-8", "replace"))
        if len(text) <= _FD2_KEEP_MAX:
            _FD2_SPARE.append(tmp)
        else:
            tmp.close()


@functools.lru_cache(maxsize=1024)
def _np_dtype(msg_struct: str) -> np.dtype:
    """numpy dtype of a DataFlash struct layout (``"<QBiiffH"``, strings ``"16s"``)."""
    fields = []
    for k, (n, c) in enumerate(re.findall(r"(\d*)([a-zA-Z])", msg_struct.lstrip("<>=!@"))):
        if c == "s":
            fields.append((f"f{k}", f"S{int(n or 1)}"))
        else:
            fields.append((f"f{k}", _STRUCT_NP[c]))
    return np.dtype(fields)


# ----------------------------------------------------------------------------------------------
# DataFlash reader
# ----------------------------------------------------------------------------------------------
def read_dataflash(path: str | Path, spec: FormatSpec) -> Trial:
    """Read an ArduPilot DataFlash log (``.bin`` or text ``.log``) into a multi-rate Trial.

    Raises :class:`LogReadError` (one line naming the file, message and field) when the file is
    not a DataFlash log, a message or column of the spec is missing, or no sample is usable.
    """
    require("dataflash")
    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(256)
    if is_dataflash_bin(head):
        return _read_df_binary(path, spec)
    if is_dataflash_text(head):
        return _read_df_text(path, spec)
    raise LogReadError(f"{path}: not an ArduPilot DataFlash log (no FMT message at the start)")


def _format_ok(fmt: Any) -> bool:
    """A DataFlash message format at least as long as the 3-byte message header."""
    n = getattr(fmt, "len", None)
    return isinstance(n, int) and n >= 3


class _Formats(dict):
    """pymavlink's table of DataFlash message formats (type -> ``DFFormat``) refusing a format
    shorter than the 3-byte message header, which only a damaged FMT message declares:
    pymavlink 2.4's parser steps ``length - 3`` past a message's header, so a message of
    length 0 is parsed again forever (the reader hung) and one of 1-2 steps back. Such a
    format, and the type's earlier definition, are dropped (its messages are then skipped
    as unrecognised bytes) and the type is listed in ``dropped``."""

    def __init__(self, formats: dict, dropped: list) -> None:
        super().__init__((k, f) for k, f in formats.items() if _format_ok(f))
        self.dropped = dropped
        dropped += [k for k, f in formats.items() if not _format_ok(f)]

    def __setitem__(self, key: Any, fmt: Any) -> None:
        if _format_ok(fmt):
            super().__setitem__(key, fmt)
        else:
            self.pop(key, None)
            self.dropped.append(key)


#: The DataFlash message type of the FMT messages, and the offset of their ``Length`` byte
#: (after the 3-byte header and the 1-byte ``Type``).
FMT_TYPE, FMT_LENGTH_AT = 0x80, 4


def _may_hold_short_format(data: Any) -> bool:
    """Whether the bytes ``data`` of a DataFlash log hold a FMT message header (``A3 95 80``)
    whose ``Length`` byte is below the 3-byte header: a damaged FMT message, or those bytes by
    chance inside another message (about once per 1.4 GB of log; the log is then indexed by
    the slower indexer, nothing lost)."""
    buf = np.frombuffer(data, dtype=np.uint8)
    n = buf.size - FMT_LENGTH_AT
    if n <= 0:
        return False
    hit = ((buf[:n] == 0xA3) & (buf[1:n + 1] == 0x95) & (buf[2:n + 2] == FMT_TYPE)
           & (buf[FMT_LENGTH_AT:n + FMT_LENGTH_AT] < 3))
    return bool(hit.any())


@functools.cache
def _df_reader_class() -> type:
    """pymavlink's ``DFReader_binary`` with its format table a :class:`_Formats` before the
    first FMT message is parsed into it (both indexers fill the table in place and parse
    messages with it). pymavlink's compiled indexer stops at a FMT message declaring a length
    below the header ("Invalid length in FMT message"), losing the rest of the log: a log
    that may hold one (:func:`_may_hold_short_format`) is indexed by its Python indexer,
    which steps over it. ``short_formats`` are the offsets [bytes] of such FMT messages in
    the index, each once (the clock's set-up and the reads parse the formats again:
    ``dropped_formats`` lists a type each time)."""
    from pymavlink import DFReader

    class DFReaderChecked(DFReader.DFReader_binary):
        def __init__(self, filename: str) -> None:
            self.dropped_formats: list = []
            self.short_formats: list[int] = []
            super().__init__(filename)

        def _checked(self) -> None:
            if not isinstance(self.formats, _Formats):
                self.formats = _Formats(self.formats, self.dropped_formats)

        def _short(self) -> None:
            n = len(self.data_map)
            self.short_formats = [int(o) for o in self.offsets[FMT_TYPE]
                                  if o + FMT_LENGTH_AT < n
                                  and self.data_map[o + FMT_LENGTH_AT] < 3]

        def init_arrays(self, progress_callback: Any = None) -> None:
            self._checked()
            super().init_arrays(progress_callback=progress_callback)
            self._short()

        def init_arrays_fast(self, progress_callback: Any = None) -> None:
            if _may_hold_short_format(self.data_map):  # the compiled indexer would stop
                self.init_arrays(progress_callback=progress_callback)
                return
            self._checked()
            super().init_arrays_fast(progress_callback=progress_callback)
            self._short()

        def init_clock(self) -> None:
            self._checked()
            super().init_clock()

    return DFReaderChecked


def _df_index(path: Path) -> tuple[Any, ReadState]:
    state = ReadState()
    c_text: list[str] = []
    with _quiet() as q, _fd2_captured(c_text):
        try:
            dfr = _df_reader_class()(str(path))
        except Exception as exc:  # pymavlink raises struct/Index/Key errors on damaged logs
            raise LogReadError(f"{path}: not a readable DataFlash log ({type(exc).__name__}: "
                               f"{' '.join(str(exc).split())[:120]})") from None
    text = q.buf.getvalue() + "".join(c_text)  # type: ignore[attr-defined]
    nbad = text.count("bad header")
    if nbad:
        state.reject("bad_header", nbad)
    nshort = len(dfr.short_formats)  # each damaged FMT message once (not once per parse)
    if nshort or dfr.dropped_formats:
        nshort = max(nshort, 1)
        types = sorted({int(k) for k in dfr.dropped_formats if isinstance(k, int)})
        state.reject("bad_format", nshort)
        state.findings.append(Finding(
            "warning", "log_damaged",
            f"{path.name}: {nshort} FMT message(s) declaring a message shorter than its "
            f"3-byte header (type(s) {', '.join(map(str, types))}): those types' messages "
            "are skipped", count=nshort))
    if "unknown msg type" in text:
        state.reject("unknown_type")
        state.findings.append(Finding(
            "warning", "log_damaged",
            f"{path.name}: a message of a type without FMT definition; the log cannot be framed "
            "past it and the rest is not read", count=1))
    return dfr, state


def _gps_epoch_ns(time_us: np.ndarray, gwk: np.ndarray, gms: np.ndarray) -> int | None:
    ok = np.flatnonzero((gwk > 0) & (time_us > 0))
    if not len(ok):
        return None
    k = int(ok[0])
    utc_us = ((GPS_EPOCH - GPS_UTC_LEAP_S + int(gwk[k]) * 604800) * 10**6
              + int(gms[k]) * 1000)
    return (utc_us - int(time_us[k])) * 1000


class _Columns(Mapping):
    """The numeric columns of one decoded DataFlash message type: name -> values, each times
    its multiplier (pymavlink's ``msg_mults``; float) or as stored when it has none, converted
    when first asked for (a reader uses a few of a message's columns)."""

    def __init__(self, arr: np.ndarray, fields: dict[str, tuple[str, float | None]]) -> None:
        self._arr = arr
        self._fields = fields  # column name -> (record field, multiplier), in column order
        self._done: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        v = self._done.get(name)
        if v is None:
            field, mult = self._fields[name]
            v = self._arr[field]
            v = self._done[name] = v.astype(float) * mult if mult is not None else v
        return v

    def __iter__(self):
        return iter(self._fields)

    def __len__(self) -> int:
        return len(self._fields)


def _read_df_binary(path: Path, spec: FormatSpec) -> Trial:
    dfr, state = _df_index(path)
    try:
        buf = np.frombuffer(dfr.data_map, dtype=np.uint8)
        decoded: dict[str, _Columns] = {}

        def decode(name: str) -> _Columns | None:
            if name in decoded:
                return decoded[name]
            tid = dfr.name_to_id.get(name)
            if tid is None or not dfr.offsets[tid] or tid not in dfr.formats:
                return None
            fmt = dfr.formats[tid]
            offs = np.asarray(dfr.offsets[tid], dtype=np.int64)
            body = fmt.len - 3
            cut = offs + fmt.len > len(buf)
            if cut.any():
                state.reject("truncated", int(cut.sum()))
                offs = offs[~cut]
            dt = _np_dtype(fmt.msg_struct)
            if dt.itemsize != body:
                raise LogReadError(f"{path}: FMT of {name}: format '{fmt.format}' is "
                                   f"{dt.itemsize} bytes but the message is {body}")
            if len(fmt.columns) > len(dt.names or ()):
                raise LogReadError(f"{path}: FMT of {name}: {len(fmt.columns)} columns for "
                                   f"the {len(dt.names or ())} fields of format '{fmt.format}'")
            rows = np.ascontiguousarray(buf[offs[:, None] + 3 + np.arange(body)])
            arr = rows.view(dt).ravel()
            out = _Columns(arr, {c: (f"f{k}", fmt.msg_mults[k])
                                 for k, c in enumerate(fmt.columns)
                                 if arr.dtype[f"f{k}"].kind != "S"})
            decoded[name] = out
            return out

        series = []
        for col in spec.columns.values():
            d = decode(col.topic)
            if d is None:
                if col.optional:
                    continue
                raise missing_topic(path, spec, col, [n for n, i in dfr.name_to_id.items()
                                                      if dfr.offsets[i]], what="message")
            try:
                series.append(_series(path, spec, col, d))
            except LogReadError:
                if not col.optional:  # (an optional column whose field is missing: left out)
                    raise
        epoch = _df_epoch(decode("GPS"))
        vehicle = vehicle_of(_df_info(dfr))
    finally:
        buf = None
        with contextlib.suppress(Exception):
            dfr.filehandle.close()
    _name_vehicle(path, state, vehicle)
    return build_trial(path, spec, series, state, reader="dataflash", clock_epoch_ns=epoch)


def _df_epoch(gps: Mapping[str, np.ndarray] | None) -> int | None:
    """The epoch [ns] of the boot clock from a decoded GPS message: ``GWk``/``GMS`` with
    ``TimeUS``, or in older logs ``Week``/``TimeMS`` (GPS time of week) with ``T`` [ms]."""
    if gps is None:
        return None
    if {"GWk", "GMS", "TimeUS"} <= set(gps):
        return _gps_epoch_ns(gps["TimeUS"], gps["GWk"], gps["GMS"])
    if {"Week", "TimeMS", "T"} <= set(gps):
        boot_us = np.asarray(gps["T"], dtype=np.int64) * 1000
        return _gps_epoch_ns(boot_us, gps["Week"], gps["TimeMS"])
    return None


def _name_vehicle(path: Path, state: ReadState, vehicle: dict | None) -> None:
    """The vehicle's kind in ``meta["vehicle"]`` and a finding (:mod:`usvid.io.vehicles`)."""
    if vehicle is None:
        return
    state.meta["vehicle"] = dict(vehicle)
    f = vehicle_finding(path, vehicle)
    if f is not None:
        state.findings.append(f)


def _time_ns(path: Path, col: ColumnSpec, d: Mapping[str, np.ndarray]) -> np.ndarray:
    if "TimeUS" in d:
        return np.asarray(d["TimeUS"], dtype=np.int64) * 1000
    if "Week" in d and "T" in d:
        # older GPS messages (ArduPilot 3.2): TimeMS is the GPS time of week, T the time since
        # boot [ms] of the other messages
        return np.asarray(d["T"], dtype=np.int64) * 1_000_000
    if "TimeMS" in d:
        return np.asarray(d["TimeMS"], dtype=np.int64) * 1_000_000
    raise LogReadError(f"{path}: message {col.topic} has no TimeUS / TimeMS column")


def _series(path: Path, spec: FormatSpec, col: ColumnSpec, d: Mapping[str, np.ndarray]) -> Series:
    """One column of a decoded DataFlash message type (arrays per column)."""
    t = _time_ns(path, col, d)
    keep = np.ones(len(t), dtype=bool)
    if col.instance is not None:
        icol = next((c for c in ("I", "Instance", "C", "Id") if c in d), None)
        if icol is None and col.instance != 0:
            raise LogReadError(f"{path}: {spec.source}: columns.{col.name}.instance: message "
                               f"{col.topic} has no instance column (I / Instance)")
        # (older logs, e.g. ArduPilot 3.2, have one GPS without an instance column: it is
        # instance 0)
        keep = (np.asarray(d[icol]) == col.instance if icol is not None
                else np.ones(len(t), dtype=bool))
    f = str(col.col)
    if col.conversion in ("speed", "course"):
        names = [f"{f}X", f"{f}Y"] if f"{f}X" in d else [f"{f}[0]", f"{f}[1]"]
    elif col.conversion in QUATERNION_CONVERTS:
        names = [f"{f}{i}" for i in range(1, 5)]
    else:
        names = [f]
        m = re.fullmatch(r"C(\d+)", f)
        if m and f not in d and f"Chan{m.group(1)}" in d:  # RCOU/RCIN of older logs
            names = [f"Chan{m.group(1)}"]
    if any(n not in d for n in names):
        raise missing_field(path, spec, col, "DataFlash message", sorted(d))
    if col.instance is None and len(names) == 1:  # (the same values without the masking)
        return Series(col, t, np.array(d[names[0]], dtype=float))
    raw = np.column_stack([np.asarray(d[n], dtype=float)[keep] for n in names])
    return Series(col, t[keep], raw if raw.shape[1] > 1 else raw[:, 0])


def _read_df_text(path: Path, spec: FormatSpec) -> Trial:
    from pymavlink import DFReader

    state = ReadState()
    with _quiet():
        try:
            dfr = DFReader.DFReader_text(str(path))
        except Exception as exc:  # noqa: BLE001
            raise LogReadError(f"{path}: not a readable DataFlash text log "
                               f"({type(exc).__name__})") from None
    names = sorted({c.topic for c in spec.columns.values()} | {"GPS"})
    got: dict[str, dict[str, list]] = {n: {} for n in names}
    with _quiet():
        while True:
            try:
                m = dfr.recv_match(type=names)
            except Exception:  # noqa: BLE001 - a line that does not parse
                state.reject("bad_record")
                continue
            if m is None:
                break
            cols = got[m.get_type()]
            for k in m.get_fieldnames():
                cols.setdefault(k, []).append(getattr(m, k, math.nan))
    decoded = {}
    for n, cols in got.items():
        if not cols:
            continue
        d = {}
        for k, v in cols.items():
            try:
                d[k] = np.asarray(v, dtype=float)
            except (TypeError, ValueError):
                continue
        decoded[n] = d
    series = []
    for col in spec.columns.values():
        d = decoded.get(col.topic)
        if d is None:
            if col.optional:
                continue
            raise missing_topic(path, spec, col, list(dfr.name_to_id), what="message")
        try:
            series.append(_series(path, spec, col, d))
        except LogReadError:
            if not col.optional:
                raise
    epoch = _df_epoch(decoded.get("GPS"))
    return build_trial(path, spec, series, state, reader="dataflash", clock_epoch_ns=epoch)


def _df_text_messages(dfr: Any, n: int):
    """The first ``n`` messages of a DataFlash text log (:data:`_FAILED` for a line that does
    not parse), then None."""
    for _ in range(n):
        try:
            yield dfr.recv_msg()
        except Exception:  # noqa: BLE001 - a line that does not parse
            yield _FAILED
    yield None


def servo1_function(path: Path, reader: str) -> float | None:
    """The log's SERVO1_FUNCTION parameter (26 ground steering, 73 left throttle...) or None
    (:func:`log_info`)."""
    return log_info(Path(path), reader)["params"].get("SERVO1_FUNCTION")


#: Messages read for :func:`log_info` before giving up (a tlog's parameters come early).
INFO_MESSAGES = 20000


def log_info(path: Path, reader: str) -> dict[str, Any]:
    """What an ArduPilot log says about itself, for choosing and completing a preset:
    ``params`` (name -> value: the DataFlash ``PARM`` messages, the tlog's ``PARAM_VALUE``
    among its first :data:`INFO_MESSAGES` messages), ``firmware`` (the first ``MSG`` text
    naming the firmware, e.g. ``"ArduCopter V3.2.1 (36b405fb)"``; DataFlash) and ``mav_type``
    (the MAVLink HEARTBEAT type of the autopilot, e.g. 11 surface boat; tlog)."""
    require(reader)
    out: dict[str, Any] = {"params": {}, "firmware": None, "mav_type": None}
    with open(path, "rb") as fh:
        head = fh.read(3)
    if reader == "dataflash" and is_dataflash_bin(head):
        dfr, _ = _df_index(Path(path))
        try:
            return _df_info(dfr)
        finally:
            with contextlib.suppress(Exception):
                dfr.filehandle.close()
    from pymavlink import DFReader, mavutil

    # the readers themselves, not mavutil.mavlink_connection: that picks the connection by the
    # file's name (UDP for a name with ':'; it runs the file as a program when its path contains
    # '/bin/'); a tlog is read as read_tlog reads it (_TlogStream)
    with _quiet():
        if reader == "dataflash":
            mlog = DFReader.DFReader_text(str(path))
            messages = _df_text_messages(mlog, INFO_MESSAGES)
        else:
            mlog = mavutil.mavlogfile(str(path), notimestamps=False, robust_parsing=True)
            stream = _TlogStream(mlog, mlog.f.read())
            try:
                stream.index()
            except Exception:  # noqa: BLE001 - damaged first packets: read_tlog says so
                mlog.close()
                return out
            messages = itertools.islice(stream.messages(), INFO_MESSAGES)
        try:
            for m in messages:
                if m is None:
                    break
                if m is _FAILED:
                    continue
                typ = m.get_type()
                try:
                    if typ == "PARM":
                        out["params"].setdefault(str(m.Name), float(m.Value))
                    elif typ == "PARAM_VALUE":
                        out["params"].setdefault(str(m.param_id), float(m.param_value))
                    elif typ == "MSG" and out["firmware"] is None and _FIRMWARE.search(
                            str(m.Message)):
                        out["firmware"] = str(m.Message).strip()
                    elif (typ == "HEARTBEAT" and out["mav_type"] is None
                          and getattr(m, "autopilot", 8) != 8):  # 8: a GCS, a companion
                        out["mav_type"] = int(m.type)
                except (AttributeError, TypeError, ValueError):  # a damaged message: skipped
                    continue
        finally:
            with contextlib.suppress(Exception):
                mlog.close()
    return out


def _df_info(dfr: Any) -> dict[str, Any]:
    """:func:`log_info` of an indexed binary DataFlash log (pymavlink's reader jumps from one
    message of a type to the next through its index)."""
    out: dict[str, Any] = {"params": {}, "firmware": None, "mav_type": None}
    with _quiet():
        for typ in ("PARM", "MSG"):
            if dfr.name_to_id.get(typ) is None:
                continue
            dfr._rewind()
            while True:
                try:
                    m = dfr.recv_match(type=typ)
                except Exception:  # noqa: BLE001 - a damaged message: the rest is not needed
                    break
                if m is None:
                    break
                try:
                    if typ == "PARM":
                        out["params"].setdefault(str(m.Name), float(m.Value))
                    elif out["firmware"] is None and _FIRMWARE.search(str(m.Message)):
                        out["firmware"] = str(m.Message).strip()
                        break
                # a damaged message: skipped (pymavlink's __getattr__ of a message whose
                # format lost fields raises IndexError)
                except (AttributeError, TypeError, ValueError, IndexError):
                    continue
    return out


_FIRMWARE = re.compile(r"\b(ArduCopter|ArduPlane|ArduRover|APMrover2|ArduSub|Rover|Blimp|"
                       r"AntennaTracker)\b", re.IGNORECASE)
#: ArduPilot servo output functions (SERVOn_FUNCTION) of the presets: the rudder, the
#: throttle and the two throttles of a skid-steer boat.
SERVO_STEERING, SERVO_THROTTLE, SERVO_LEFT, SERVO_RIGHT = 26, 70, 73, 74


def servo_outputs(params: Mapping[str, float]) -> dict[int, int]:
    """Servo output number -> its function (SERVOn_FUNCTION) from a log's parameters."""
    out = {}
    for k, v in params.items():
        m = re.fullmatch(r"SERVO(\d+)_FUNCTION", k)
        if m and math.isfinite(v):
            out[int(m.group(1))] = int(v)
    return out


def vehicle_of(info: Mapping[str, Any]) -> dict[str, Any] | None:
    """The kind of vehicle of an ArduPilot log (:func:`usvid.io.vehicles.vehicle_kind`) from
    its HEARTBEAT type, firmware text and FRAME_CLASS / SYSID_SW_TYPE parameters; None when
    the log does not say."""
    params = info.get("params", {})
    if info.get("mav_type") is not None:
        return mav_type_kind(int(info["mav_type"]), "MAVLink HEARTBEAT type")
    fw = info.get("firmware") or ""
    fc = params.get("FRAME_CLASS")
    sw = params.get("SYSID_SW_TYPE")
    fwl = fw.lower()
    if "copter" in fwl or sw == 10:
        return {"kind": "multicopter", "surface_vessel": False,
                "detail": fw or "SYSID_SW_TYPE 10 (ArduCopter)"}
    if "plane" in fwl or sw == 0:
        return {"kind": "fixed-wing aircraft", "surface_vessel": False,
                "detail": fw or "SYSID_SW_TYPE 0 (ArduPlane)"}
    if "sub" in fwl:
        return {"kind": "submarine", "surface_vessel": False, "detail": fw}
    if "rover" in fwl or sw == 20 or fc is not None:
        if fc == 2:
            return {"kind": "surface boat", "surface_vessel": True,
                    "detail": f"{fw + ', ' if fw else ''}FRAME_CLASS 2 (boat)"}
        if fc is not None:
            return {"kind": "ground rover", "surface_vessel": False,
                    "detail": f"{fw + ', ' if fw else ''}FRAME_CLASS {fc:g} (not 2, boat)"}
        return {"kind": "rover or boat", "surface_vessel": None, "detail": fw or "Rover"}
    return None


# ----------------------------------------------------------------------------------------------
# MAVLink tlog reader
# ----------------------------------------------------------------------------------------------
def read_tlog(path: str | Path, spec: FormatSpec) -> Trial:
    """Read a MAVLink telemetry log (``.tlog``) into a multi-rate Trial (SI units, radians).

    Raises :class:`LogReadError` (one line naming the file, message and field) when the file is
    not a tlog, a message or field of the spec is missing, or no sample is usable.
    """
    require("tlog")
    from pymavlink import mavutil

    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(16)
    if not is_tlog(head):
        raise LogReadError(f"{path}: not a MAVLink telemetry log (no time stamp + MAVLink packet "
                           "at the start)")
    state = ReadState()
    by_type: dict[str, list[tuple[ColumnSpec, list]]] = {}
    for col in spec.columns.values():
        by_type.setdefault(col.topic, []).append((col, path_steps(str(col.col))))
    stamps: dict[str, list[int]] = {k: [] for k in by_type}
    senders: dict[str, list[int]] = {k: [] for k in by_type}  # system * 256 + component
    values: dict[str, list] = {c.name: [] for c in spec.columns.values()}
    info: dict[str, Any] = {"params": {}, "firmware": None, "mav_type": None}
    # per message type: (list of the column's values, its value getter) for each column
    fetch = {typ: [(values[col.name], _mav_getter(st, col.conversion)) for col, st in getters]
             for typ, getters in by_type.items()}
    seen: dict[str, int] = {}
    checked: set[str] = set()
    with _quiet():
        conn = None
        try:
            conn = mavutil.mavlogfile(str(path), notimestamps=False, robust_parsing=True)
            stream = _TlogStream(conn, conn.f.read())
            stream.index()
        except Exception as exc:  # noqa: BLE001 - pymavlink on a damaged first packets
            if conn is not None:
                conn.close()
            raise LogReadError(f"{path}: not a readable MAVLink telemetry log "
                               f"({type(exc).__name__})") from None
        try:
            for m in stream.messages():
                if m is _FAILED:  # pymavlink raised on a damaged packet
                    state.reject("bad_data")
                    continue
                typ = m.get_type()
                seen[typ] = seen.get(typ, 0) + 1
                if typ == "BAD_DATA":
                    state.reject("bad_data")
                    continue
                getters = by_type.get(typ)
                if getters is None:
                    with contextlib.suppress(AttributeError, TypeError, ValueError):
                        if (typ == "HEARTBEAT" and info["mav_type"] is None
                                and getattr(m, "autopilot", 8) != 8):  # 8: a GCS, a companion
                            info["mav_type"] = int(m.type)
                        elif typ == "PARAM_VALUE":
                            info["params"].setdefault(str(m.param_id), float(m.param_value))
                    continue
                if typ not in checked:
                    _check_mav(path, spec, m, getters)
                    checked.add(typ)
                ts = m._timestamp  # [s]: a damaged header gives any float
                if not (math.isfinite(ts) and 0 <= ts < 9e9):
                    state.reject("bad_data")
                    continue
                stamps[typ].append(int(round(ts * 1e6)) * 1000)
                senders[typ].append(m.get_srcSystem() * 256 + m.get_srcComponent())
                for vals, get in fetch[typ]:
                    vals.append(get(m))
            left = conn.mav.buf_len() if hasattr(conn.mav, "buf_len") else 0
            if left:  # a packet cut by the end of the file
                state.reject("truncated")
        finally:
            with contextlib.suppress(Exception):
                conn.close()
    series = []
    for typ, getters in by_type.items():
        t = np.asarray(stamps[typ], dtype=np.int64)
        mine = _one_sender(path, spec, typ, getters, np.asarray(senders[typ], dtype=np.int64),
                           state)
        for col, _ in getters:
            if not len(t):
                if col.optional:
                    continue
                raise missing_topic(path, spec, col, [k for k in seen if k != "BAD_DATA"],
                                    what="message")
            raw = np.asarray(values[col.name], dtype=float)
            series.append(Series(col, t[mine], raw[mine]))
    _name_vehicle(path, state, vehicle_of(info))
    return build_trial(path, spec, series, state, reader="tlog", clock_epoch_ns=0)


def _one_sender(path: Path, spec: FormatSpec, typ: str, getters: list, senders: np.ndarray,
                state: ReadState) -> np.ndarray:
    """Mask of the messages of type ``typ`` from one MAVLink system/component: the one a column
    of the spec names (``source: "1/1"`` or a system id), else the one that sent the most;
    the others are reported (``several_sources``), never interleaved
    (:mod:`usvid.io.sources`)."""
    codes = np.unique(senders)
    if len(codes) <= 1:
        return np.ones(len(senders), dtype=bool)
    labels = {int(c): f"{int(c) >> 8}/{int(c) & 255}" for c in codes}
    src = Sources(senders, labels, dict(labels), "system/component", "systems/components")
    named = next((c for c, _ in getters if c.source is not None), None)
    sub = FormatSpec(reader="tlog", source=spec.source,
                     columns={typ: replace(named, name=typ, col=typ)} if named else {})
    _, _, found, _ = select_sources(path, np.zeros(len(senders)), {typ: np.ones(len(senders))},
                                    src, sub, reader="tlog")
    chosen = src.code_of(named.source) if named else None
    if chosen is None:
        n = {int(c): int((senders == c).sum()) for c in codes}
        chosen = max(n, key=lambda c: (n[c], -int(np.flatnonzero(senders == c)[0])))
    for f in found:
        f.message = f.message.replace(f"'{typ}'", f"message {typ}")
        state.findings.append(f)
    return senders == chosen


#: What :meth:`_TlogStream.messages` yields where pymavlink raised on a damaged packet.
_FAILED = object()
#: pymavlink's ``mavlogfile``: a record time further than this from the last good message's,
#: after a damaged packet, is searched for byte by byte [s] (``scan_timestamp``).
_TLOG_SCAN_S = 3 * 24 * 60 * 60


class _TlogStream:
    """The reading of pymavlink's ``mavutil.mavlink_connection(tlog)`` (a ``mavmmaplog``) over
    the log's bytes in memory, message for message the same (pymavlink 2.4's ``pre_message``,
    ``recv_msg``, ``post_message`` and ``init_arrays``), without the library's per-message
    bookkeeping that a reader does not use.

    ``conn`` is a ``mavutil.mavlogfile`` on the log: its dialect's ``MAVLink`` parser does all
    framing, CRC checks and robust parsing (``parse_char`` fed ``bytes_needed()`` bytes at a
    time) and its ``auto_mavlink_version`` sees the first bytes (switching to MAVLink 2 as
    ``mavlink_connection`` does). Before each packet the 8-byte big-endian record time [us] is
    read; after a BAD_DATA packet a time more than 3 days from the last good message's is
    searched for byte by byte (``scan_timestamp``). ``mavfile.post_message``'s per-system
    state (modes, parameters, packet loss, the latest message of each type) is not kept: only
    each message's ``_timestamp`` [s] and what the next packet's reading depends on. Unlike
    ``mavlink_connection``, which picks the connection by the file's name (a DataFlash reader
    for ``.bin``, UDP for a name with ``:``, running the file for a path with ``/bin/``), the
    file is always read as a tlog.
    """

    def __init__(self, conn: Any, data: bytes) -> None:
        self.conn = conn
        self.data = data
        self.pos = 0
        self.ts: float | None = None  # time of the record being read [s]
        self.last_ts: float | None = None  # of the last message that was not BAD_DATA [s]
        self.last_bad = False  # the last message was BAD_DATA

    def recv(self) -> Any:
        """The next message (``mavlogfile.recv_msg``), None at the end; what pymavlink raises
        on a damaged packet propagates."""
        data, n, conn = self.data, len(self.data), self.conn
        pos = self.pos
        if n - pos >= 8:  # pre_message
            tbuf = data[pos:pos + 8]
            pos += 8
            t = int.from_bytes(tbuf, "big") * 1.0e-6
            if self.last_ts is not None and self.last_bad and abs(t - self.last_ts) > _TLOG_SCAN_S:
                while abs(t - self.last_ts) > _TLOG_SCAN_S and pos < n:  # scan_timestamp
                    tbuf = tbuf[1:] + data[pos:pos + 1]
                    pos += 1
                    t = int.from_bytes(tbuf, "big") * 1.0e-6
            self.ts = t
        else:  # a short time stamp at the end: read and dropped
            pos = n
        self.pos = pos
        while True:
            k = conn.mav.bytes_needed()
            s = data[self.pos:self.pos + k]
            self.pos += len(s)
            if s and conn.first_byte:
                conn.auto_mavlink_version(s)
            m = conn.mav.parse_char(s)
            if m:
                break
            if not s:
                return None
        m._timestamp = self.ts  # post_message
        self.last_bad = m.get_type() == "BAD_DATA"
        if not self.last_bad:
            self.last_ts = self.ts
        return m

    def index(self) -> None:
        """``mavmmaplog.init_arrays``'s pass over the file (it indexes the records by message
        type, reading the first message of each type on the way: what that leaves in the parser
        and the clock is where the reading of the log starts). Raises what pymavlink raises
        there (an ``AttributeError`` when such a first message cannot be read)."""
        from pymavlink import mavutil

        data, n = self.data, len(self.data)
        seen: set[int] = set()
        with_instance: set[int] = set()
        ofs = 0
        while ofs + 8 + 6 < n:
            marker = data[ofs + 8]
            payload_len = data[ofs + 9]
            mlen = payload_len + 8
            if marker == 0xFE:
                mtype = data[ofs + 13]
                mlen += 8
                data_ofs = 14
            elif marker == 0xFD:
                if ofs + 8 + 10 > n:
                    break
                mtype = data[ofs + 15] | (data[ofs + 16] << 8) | (data[ofs + 17] << 16)
                mlen += 12
                data_ofs = 18
                if data[ofs + 10] & mavutil.mavlink.MAVLINK_IFLAG_SIGNED:
                    mlen += mavutil.mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
            else:
                ofs += 1
                continue
            if mtype not in seen:
                if mtype not in mavutil.mavlink.mavlink_map:
                    ofs += mlen
                    continue
                seen.add(mtype)
                self.pos = ofs
                m = self.recv()
                if m is None:  # pymavlink: add_message(..., None)
                    raise AttributeError("'NoneType' object has no attribute '_instance_field'")
                if m._instance_field is not None:
                    with_instance.add(mtype)
            if mtype in with_instance and ofs + data_ofs + payload_len > n:
                break  # (pymavlink: a truncated log)
            ofs += mlen
        self.pos = 0

    def messages(self):
        """Every message from the start of the file (:data:`_FAILED` where pymavlink raised)."""
        while True:
            try:
                m = self.recv()
            except Exception:  # noqa: BLE001 - pymavlink on a damaged packet
                yield _FAILED
                continue
            if m is None:
                return
            yield m


def _mav_raw(m: Any, steps: list, conversion: str | None) -> float | tuple[float, ...]:
    """The value of field path ``steps`` of MAVLink message ``m`` as float (a tuple of floats
    for ``conversion`` ``yaw``); NaN when the path does not exist or is no number."""
    try:
        v = get_path(m, steps)
        if conversion in QUATERNION_CONVERTS:
            return tuple(float(x) for x in v)
        return float(v)
    except (AttributeError, IndexError, TypeError, ValueError):
        return math.nan


def _mav_getter(steps: list, conversion: str | None) -> Any:
    """``m -> _mav_raw(m, steps, conversion)``; for a plain field name the same steps
    (``float(getattr(m, name))``, NaN on the same errors) without the path walk."""
    if conversion not in QUATERNION_CONVERTS and len(steps) == 1 and isinstance(steps[0], str):
        name = steps[0]

        def get(m: Any) -> float:
            try:
                return float(getattr(m, name))
            except (AttributeError, IndexError, TypeError, ValueError):
                return math.nan

        return get
    return functools.partial(_mav_raw, steps=steps, conversion=conversion)


def _check_mav(path: Path, spec: FormatSpec, m: Any, getters: list) -> None:
    for col, steps in getters:
        if col.optional:
            continue  # (a missing field reads as NaN: no samples)
        try:
            get_path(m, steps)
        except (AttributeError, IndexError, TypeError):
            raise missing_field(path, spec, col, f"MAVLink {m.get_type()}",
                                list(m.get_fieldnames())) from None


# ----------------------------------------------------------------------------------------------
# writers
# ----------------------------------------------------------------------------------------------
#: Full rudder deflection of the ArduPilot presets (steering output +-4500 / PWM +-400 us) [deg].
SERVO_FULL_DEG = 35.0
#: DataFlash messages written by :func:`write_dataflash`: name -> (type id, format, columns).
DF_MESSAGES = {
    "PARM": (64, "QNff", "TimeUS,Name,Value,Default"),
    "GPS": (65, "QBBIHBcLLeffffB", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,"
                                   "Yaw,U"),
    "ATT": (66, "QccccCCCCB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF"),
    "IMU": (67, "QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ"),
    "RCOU": (68, "QHHHHHHHHHHHHHH", "TimeUS,C1,C2,C3,C4,C5,C6,C7,C8,C9,C10,C11,C12,C13,C14"),
    "STER": (69, "Qhhffff", "TimeUS,SteerIn,SteerOut,DesLatAcc,LatAcc,DesTurnRate,TurnRate"),
    "ESC": (70, "QBeeffcfcf", "TimeUS,Instance,RPM,RawRPM,Volt,Curr,Temp,CTot,MotTemp,Err"),
}
_DF_CHAR = {"a": "64s", "b": "b", "B": "B", "h": "h", "H": "H", "i": "i", "I": "I", "f": "f",
            "d": "d", "n": "4s", "N": "16s", "Z": "64s", "c": "h", "C": "H", "e": "i", "E": "I",
            "L": "i", "M": "B", "q": "q", "Q": "Q"}


def _df_dtype(fmt: str, columns: str) -> np.dtype:
    return np.dtype([(c, _STRUCT_NP.get(_DF_CHAR[f], None) or f"S{_DF_CHAR[f][:-1]}")
                     for f, c in zip(fmt, columns.split(","), strict=True)])


def dataflash_bytes(trial: Trial, *, t0_utc: str | None = None, skid_steer: bool = False,
                    boot_offset_s: float = 100.0) -> bytes:
    """The bytes of :func:`write_dataflash` (see there)."""
    e0 = log_start_epoch(trial, t0_utc)
    n = len(trial.t)
    t_us = np.round((trial.t + boot_offset_s) * 1e6).astype(np.int64)
    ch = {k: channel_or_none(trial, k) for k in
          ("lat", "lon", "sog", "cog", "psi", "r", "delta", "delta_cmd", "n", "n_port",
           "n_stbd", "phi", "theta", "p")}
    if ch["sog"] is None:
        ch["sog"] = channel_or_none(trial, "U")
    nanv = np.full(n, np.nan)

    def col(k: str) -> np.ndarray:
        return ch[k] if ch[k] is not None else nanv

    def fin(*keys: str) -> np.ndarray:
        m = np.ones(n, dtype=bool)
        for k in keys:
            m &= np.isfinite(col(k))
        return m

    full = math.radians(SERVO_FULL_DEG)
    gps_s = (e0 + trial.t) - (GPS_EPOCH - GPS_UTC_LEAP_S)
    gwk = np.floor(gps_s / 604800).astype(np.int64)
    gms = np.round((gps_s - gwk * 604800) * 1000).astype(np.int64)
    msgs: dict[str, tuple[np.ndarray, dict]] = {
        "GPS": (fin("lat", "lon"), {
            "Status": 3, "GMS": gms, "GWk": gwk, "NSats": 12, "HDop": 80,
            "Lat": np.round(np.nan_to_num(col("lat")) * 1e7),
            "Lng": np.round(np.nan_to_num(col("lon")) * 1e7),
            "Spd": col("sog"), "GCrs": np.degrees(col("cog")) % 360.0}),
        "ATT": (fin("psi"), {"Yaw": np.round(np.degrees(np.nan_to_num(col("psi")) % (2 * np.pi))
                                              * 100) % 36000,
                             "Roll": np.round(np.degrees(np.nan_to_num(col("phi"))) * 100),
                             "Pitch": np.round(np.degrees(np.nan_to_num(col("theta"))) * 100)}),
        "IMU": (fin("r"), {"GyrZ": col("r"), "GyrX": np.nan_to_num(col("p")), "AccZ": -9.81}),
    }
    steer_out = np.round(np.clip(np.nan_to_num(col("delta")) / full, -1, 1) * 4500)
    steer_in = np.round(np.clip(np.nan_to_num(col("delta_cmd")) / full, -1, 1) * 4500)
    msgs["STER"] = (fin("delta"), {"SteerOut": steer_out, "SteerIn": steer_in})
    rc = {f"C{i}": 1500 for i in range(1, 15)}
    if skid_steer:
        rc["C1"] = np.round(1500 + 400 * np.clip(np.nan_to_num(col("n_port")), -1, 1))
        rc["C3"] = np.round(1500 + 400 * np.clip(np.nan_to_num(col("n_stbd")), -1, 1))
        msgs["RCOU"] = (fin("n_port") | fin("n_stbd"), rc)
    else:
        rc["C1"] = np.round(1500 + 400 * np.clip(np.nan_to_num(col("delta")) / full, -1, 1))
        msgs["RCOU"] = (fin("delta"), rc)
    msgs["ESC"] = (fin("n"), {"Instance": 0, "RPM": np.round(np.nan_to_num(col("n")) * 6000)})
    out = []
    fmt_dt = np.dtype([("h1", "u1"), ("h2", "u1"), ("type", "u1"), ("Type", "u1"),
                       ("Length", "u1"), ("Name", "S4"), ("Format", "S16"), ("Columns", "S64")])
    fmts = [("FMT", 128, "BBnNZ", "Type,Length,Name,Format,Columns"),
            *((k, tid, f, c) for k, (tid, f, c) in DF_MESSAGES.items())]
    for name, tid, f, c in fmts:
        ln = 3 + (_df_dtype(f, c).itemsize if name != "FMT" else 86)
        out.append(records(fmt_dt, {"h1": 0xA3, "h2": 0x95, "type": 128, "Type": tid,
                                    "Length": ln, "Name": name.encode(), "Format": f.encode(),
                                    "Columns": c.encode()}, 1).tobytes())
    parts = []
    hdr = [("h1", "u1"), ("h2", "u1"), ("type", "u1")]
    params = [("FRAME_CLASS", 2.0), ("SERVO1_FUNCTION", 73.0 if skid_steer else 26.0),
              ("SERVO3_FUNCTION", 74.0 if skid_steer else 70.0)]
    tid, f, c = DF_MESSAGES["PARM"]
    pdt = np.dtype(hdr + list(_df_dtype(f, c).descr))
    parts.append((np.zeros(len(params), dtype=np.int64), records(pdt, {
        "h1": 0xA3, "h2": 0x95, "type": tid, "TimeUS": 0,
        "Name": np.array([p[0].encode() for p in params]),
        "Value": np.array([p[1] for p in params]), "Default": 0.0}, len(params))))
    for name, (mask, vals) in msgs.items():
        tid, f, c = DF_MESSAGES[name]
        dt = np.dtype(hdr + list(_df_dtype(f, c).descr))
        idx = np.flatnonzero(mask)
        v = {"h1": 0xA3, "h2": 0x95, "type": tid, "TimeUS": t_us[idx]}
        for k, a in vals.items():
            v[k] = a[idx] if isinstance(a, np.ndarray) else a
        parts.append((t_us[idx], records(dt, v, len(idx))))
    return b"".join(out) + interleave(parts)


def write_dataflash(trial: Trial, path: str | Path, *, t0_utc: str | None = None,
                    skid_steer: bool = False) -> Path:
    """Write a Trial as an ArduPilot DataFlash ``.bin`` log in the layout of the
    ``ardupilot_rover`` (or, with ``skid_steer``, ``ardupilot_skid_steer``) preset (atomically).

    Follows the ArduPilot DataFlash log format (FMT messages first, then ``A3 95 type payload``
    messages, little-endian, multipliers of the format characters). Messages: ``PARM``
    (FRAME_CLASS = 2 boat, SERVO1/3_FUNCTION: 26/70 ground steering + throttle, or 73/74 left /
    right throttle), ``GPS`` (``Lat``/``Lng`` 1e-7 deg, ``Spd`` = ``sog`` or ``U``, ``GCrs`` [deg],
    ``GWk``/``GMS`` from ``t0_utc + t``), ``ATT`` (``Yaw`` = ``psi`` [cdeg]), ``IMU``
    (``GyrZ`` = ``r``),
    ``STER`` (``SteerOut`` / ``SteerIn`` = ``delta`` / ``delta_cmd`` over 35 deg, +-4500),
    ``RCOU`` (``C1`` = rudder PWM 1500 +- 400 us over +-35 deg; skid steer: ``C1``/``C3`` =
    1500 + 400 ``n_port``/``n_stbd``), ``ESC`` (``RPM`` = 60 ``n`` [0.01 rpm]). ``TimeUS`` = t +
    100 s. Quantisation: position 1e-7 deg, heading 0.01 deg, steering 35/4500 deg, PWM 1 us.
    """
    return write_atomic(path, dataflash_bytes(trial, t0_utc=t0_utc, skid_steer=skid_steer))


def tlog_bytes(trial: Trial, *, t0_utc: str | None = None, skid_steer: bool = False) -> bytes:
    """The bytes of :func:`write_tlog` (see there)."""
    require("tlog")
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    e0 = log_start_epoch(trial, t0_utc)
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    ch = {k: channel_or_none(trial, k) for k in
          ("lat", "lon", "sog", "cog", "psi", "r", "delta", "n", "n_port", "n_stbd", "phi",
           "theta", "p")}
    if ch["sog"] is None:
        ch["sog"] = channel_or_none(trial, "U")
    full = math.radians(SERVO_FULL_DEG)
    t = trial.t
    boot_ms = np.round((t + 100.0) * 1000).astype(np.int64)

    def fin(k: str, i: int) -> bool:
        return ch[k] is not None and math.isfinite(ch[k][i])

    def pwm(x: float) -> int:
        return int(round(1500 + 400 * max(-1.0, min(1.0, x))))

    out = []

    def put(us: int, msg: Any) -> None:
        out.append(struct.pack(">Q", us) + msg.pack(mav))

    us0 = int(round(e0 * 1e6))
    for name, val in (("FRAME_CLASS", 2.0), ("SERVO1_FUNCTION", 73.0 if skid_steer else 26.0),
                      ("SERVO3_FUNCTION", 74.0 if skid_steer else 70.0)):
        put(us0, mavlink.MAVLink_param_value_message(name.encode(), val, 9, 3, 0))
    for i in range(len(t)):
        us = us0 + int(round(t[i] * 1e6))
        bm = int(boot_ms[i])
        if fin("lat", i) and fin("lon", i):
            put(us, mavlink.MAVLink_global_position_int_message(
                bm, int(round(ch["lat"][i] * 1e7)), int(round(ch["lon"][i] * 1e7)), 0, 0, 0, 0,
                0, 65535))
            sog = ch["sog"][i] if fin("sog", i) else 0.0
            cog = ch["cog"][i] if fin("cog", i) else 0.0
            put(us, mavlink.MAVLink_gps_raw_int_message(
                bm * 1000, 3, int(round(ch["lat"][i] * 1e7)), int(round(ch["lon"][i] * 1e7)),
                0, 80, 65535, int(round(sog * 100)),
                int(round(math.degrees(cog % (2 * math.pi)) * 100)) % 36000, 12))
        if fin("psi", i) or fin("r", i):
            psi = ch["psi"][i] if fin("psi", i) else math.nan
            put(us, mavlink.MAVLink_attitude_message(
                bm, float(ch["phi"][i]) if fin("phi", i) else 0.0,
                float(ch["theta"][i]) if fin("theta", i) else 0.0,
                math.remainder(psi, 2 * math.pi) if fin("psi", i) else math.nan,
                float(ch["p"][i]) if fin("p", i) else 0.0, 0.0,
                float(ch["r"][i]) if fin("r", i) else math.nan))
        servo = [1500] * 16
        if skid_steer and (fin("n_port", i) or fin("n_stbd", i)):
            servo[0] = pwm(ch["n_port"][i]) if fin("n_port", i) else 1500
            servo[2] = pwm(ch["n_stbd"][i]) if fin("n_stbd", i) else 1500
            put(us, mavlink.MAVLink_servo_output_raw_message(bm * 1000, 0, *servo))
        elif not skid_steer and fin("delta", i):
            servo[0] = pwm(ch["delta"][i] / full)
            put(us, mavlink.MAVLink_servo_output_raw_message(bm * 1000, 0, *servo))
        if fin("n", i):
            rpm = int(round(ch["n"][i] * 60))
            put(us, mavlink.MAVLink_esc_telemetry_1_to_4_message(
                temperature=[0] * 4, voltage=[0] * 4, current=[0] * 4, totalcurrent=[0] * 4,
                rpm=[rpm, 0, 0, 0], count=[0] * 4))
    return b"".join(out)


def write_tlog(trial: Trial, path: str | Path, *, t0_utc: str | None = None,
               skid_steer: bool = False) -> Path:
    """Write a Trial as a MAVLink 2 telemetry log (``.tlog``) through pymavlink (atomically).

    Each record: 8-byte big-endian receive time [us since 1970] = ``t0_utc + t``, then the
    packet. Messages (ArduPilot dialect): ``PARAM_VALUE`` (FRAME_CLASS, SERVO1/3_FUNCTION as
    :func:`write_dataflash`), ``GLOBAL_POSITION_INT`` and ``GPS_RAW_INT`` (``lat``/``lon`` 1e-7 deg,
    ``vel`` = ``sog`` [cm/s], ``cog`` [cdeg]), ``ATTITUDE`` (``yaw`` = ``psi`` [rad, -pi..pi],
    ``yawspeed`` = ``r``; NaN where a sample is missing), ``SERVO_OUTPUT_RAW`` (``servo1_raw``
    rudder PWM as :func:`write_dataflash`; skid steer ``servo1/3_raw``), ``ESC_TELEMETRY_1_TO_4``
    (``rpm[0]`` = 60 ``n``, whole rpm).
    """
    return write_atomic(path, tlog_bytes(trial, t0_utc=t0_utc, skid_steer=skid_steer))
