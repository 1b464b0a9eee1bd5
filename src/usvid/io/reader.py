"""The one entry point of the readers, :func:`read_trial`: a log's format detected by content
(:func:`detect_message_log`, :func:`detect_reader`), the shipped preset of a message log
(:func:`auto_spec`) and the reader of its spec dispatched to. :mod:`usvid.io` re-exports these
names (and loads this module on their first use)."""

from __future__ import annotations

from pathlib import Path

from usvid.errors import FormatSpecError, LogReadError
from usvid.files import check_input
from usvid.io._assemble import read_log_bytes
from usvid.io.ardupilot import (
    is_dataflash_bin,
    is_dataflash_text,
    is_tlog,
    log_info,
    read_dataflash,
    read_tlog,
    servo_outputs,
)
from usvid.io.n2k import detect_n2k_format, read_nmea2000
from usvid.io.nmea0183 import read_nmea0183
from usvid.io.rosbag import bag_kind, read_rosbag
from usvid.io.spec import FormatSpec, coerce_spec, parse_spec, shipped_spec
from usvid.io.table import read_excel, read_parquet, read_table
from usvid.io.ulog import is_ulog, read_ulog
from usvid.trial import CHANNEL_UNITS, Trial

#: Plain-words names of the message-log kinds (for messages).
LOG_KINDS = {
    "rosbag": "ROS bag / MCAP file",
    "ulog": "PX4 ULog",
    "dataflash": "ArduPilot DataFlash log",
    "tlog": "MAVLink telemetry log (tlog)",
}


def detect_message_log(path: str | Path) -> str | None:
    """The message-log reader of ``path`` by content (``rosbag``, ``ulog``, ``dataflash``,
    ``tlog``) or ``None`` for any other file (text logs, tables)."""
    path = Path(path)
    if path.is_dir():
        return "rosbag" if bag_kind(path) else None
    try:
        with open(path, "rb") as fh:
            head = fh.read(256)
    except OSError as exc:
        raise LogReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if bag_kind(path):
        return "rosbag"
    if is_ulog(head):
        return "ulog"
    if is_dataflash_bin(head) or is_dataflash_text(head):
        return "dataflash"
    if is_tlog(head):
        return "tlog"
    return None


def auto_spec(path: str | Path, reader: str) -> tuple[FormatSpec, str]:
    """The shipped preset for a message log of ``reader`` and a sentence saying what was detected
    and chosen: ``ros2_usv`` (ROS bags), ``px4_boat`` (ULog), ``ardupilot_rover`` or
    ``ardupilot_skid_steer`` (DataFlash / tlog: skid steering when a servo output of the log's
    parameters has function 73 or 74, left / right throttle). For ArduPilot the servo
    outputs are read from the log's ``SERVOn_FUNCTION`` parameters (:func:`servo_preset`): the
    rudder is the output with function 26 (ground steering), the thrusters those with 73 / 74,
    wherever they are wired."""
    name = {"rosbag": "ros2_usv", "ulog": "px4_boat"}.get(reader)
    why = ""
    if name is None:
        info = log_info(Path(path), reader)
        outs = servo_outputs(info["params"])
        skid = bool({73, 74} & set(outs.values()))
        name = "ardupilot_skid_steer" if skid else "ardupilot_rover"
        used = {k: f for k, f in sorted(outs.items()) if f in (26, 70, 73, 74)}
        why = (", " + ", ".join(f"SERVO{k}_FUNCTION {f}" for k, f in used.items()) if used
               else ", no SERVOn_FUNCTION parameter of steering or throttle: rudder steering "
               "assumed")
        spec = shipped_spec(name)
        if reader in spec.variants:
            spec = spec.variants[reader]
        spec, more = servo_preset(spec, reader, outs)
        return spec, f"detected {LOG_KINDS[reader]}{why}; format {name}{more}"
    spec = shipped_spec(name)
    if reader in spec.variants:
        spec = spec.variants[reader]
    return spec, f"detected {LOG_KINDS[reader]}{why}; format {name}"


def servo_preset(spec: FormatSpec, reader: str, outs: dict[int, int]
                 ) -> tuple[FormatSpec, str]:
    """An ArduPilot preset with its servo-output columns moved to the outputs whose function
    the log's parameters give (``outs``: output number -> SERVOn_FUNCTION): ``delta`` of the
    tlog (``SERVO_OUTPUT_RAW.servoN_raw``) to the ground-steering output (26), ``n_port`` /
    ``n_stbd`` (``RCOU.CN`` / ``servoN_raw``) to the left / right throttle outputs (73 / 74). A
    column whose function no output has is dropped (a rudder column on an RC pass-through
    output would read the wrong servo). Returns the spec and a note of what changed."""
    from dataclasses import replace

    want = {"n_port": 73, "n_stbd": 74}
    if reader == "tlog":
        want["delta"] = 26
    cols = dict(spec.columns)
    notes = []
    by_fn = {}
    for k, f in sorted(outs.items()):
        by_fn.setdefault(f, k)
    for ch, fn in want.items():
        c = cols.get(ch)
        if c is None or c.topic not in ("RCOU", "SERVO_OUTPUT_RAW") or not outs:
            continue
        out = by_fn.get(fn)
        if out is None:
            del cols[ch]
            notes.append(f"no servo output has function {fn}: no '{ch}'")
            continue
        field = f"C{out}" if c.topic == "RCOU" else f"servo{out}_raw"
        if field != c.col:
            cols[ch] = replace(c, col=field)
            notes.append(f"'{ch}' from {c.topic}.{field}")
    return replace(spec, columns=cols), ("; " + ", ".join(notes)) if notes else ""


def detect_reader(path: str | Path) -> str:
    """Guess the reader of a log without a spec: ``rosbag``, ``ulog``, ``dataflash``, ``tlog``
    (by their headers), ``nmea2000`` (a log in one of the NMEA 2000 formats of
    :mod:`usvid.io.n2k`, e.g. candump -L lines), ``nmea0183`` (``$``/``!`` sentences),
    ``parquet`` (PAR1 magic) or ``excel`` (.xlsx zip); ``table`` for a CSV with a header of Trial
    channel names. Raises :class:`LogReadError` when unreadable/empty.
    """
    path = Path(path)
    msg = detect_message_log(path)
    if msg is not None:
        return msg
    head = read_log_bytes(path, 65536)
    if head[:4] == b"PAR1":
        return "parquet"
    if head[:2] == b"PK":
        return "excel"
    if detect_n2k_format(path, head) is not None:
        return "nmea2000"
    lines = [ln.strip() for ln in head.splitlines()[:200] if ln.strip()]
    n0183 = sum(1 for ln in lines if b"$" in ln or ln.startswith(b"!"))
    if n0183:
        return "nmea0183"
    return "table"


def _matching_spec(p: Path, fs: FormatSpec, kind: str | None) -> FormatSpec:
    """``fs`` or its variant for a log of reader ``kind``; a clear error for a wrong preset."""
    if kind is not None and kind in fs.variants:
        return fs.variants[kind]
    what = LOG_KINDS.get(kind, "text log or table") if kind else "not a message log (text/table)"
    if kind is None and fs.reader not in LOG_KINDS:
        return fs
    want = LOG_KINDS.get(fs.reader, f"{fs.reader} logs")
    raise FormatSpecError(
        f"{p}: is a {what}, but format spec {fs.source} is for {want} "
        "(give the spec for this format, or leave --format out to detect it)"
        if kind else f"{p}: is {what}, but format spec {fs.source} is for {want}")


def read_trial(path: str | Path, spec: str | Path | FormatSpec | dict | None = None) -> Trial:
    """Read one log into a :class:`Trial` (SI units, radians; lat/lon in degrees).

    ``spec``: a YAML path, a shipped spec name (``"hsva_kvlcc2"``), a mapping, a
    :class:`FormatSpec`, or ``None`` / ``"auto"`` to detect the format by content: ROS bags, PX4
    ULog, ArduPilot DataFlash and tlog get their shipped preset (:func:`auto_spec`; the choice is
    in ``trial.meta["format_detected"]``), NMEA 0183 / candump logs their reader, CSV/Parquet
    tables written by usvid (header names are Trial channels in SI) the identity spec. A message
    log read with the spec of another format is a :class:`FormatSpecError` (one line); a spec
    with ``variants`` uses the variant of the log's format. Dispatches on ``spec.reader``.
    """
    fs = None if isinstance(spec, str) and spec == "auto" else coerce_spec(spec)
    p = Path(path)
    # a regular file or a folder (a ROS 2 bag): a FIFO or a device is refused before it is opened
    check_input(p, "log", folder=True, error=LogReadError)
    kind = detect_message_log(p)
    if p.is_dir() and kind is None:
        raise LogReadError(f"{p}: is a folder, not a log file (nor a ROS 2 bag with "
                           "metadata.yaml)")
    note = None
    if fs is None and kind is not None:
        fs, note = auto_spec(p, kind)
    elif fs is not None and kind != fs.reader and (kind or fs.reader in LOG_KINDS):
        fs = _matching_spec(p, fs, kind)
    reader = fs.reader if fs is not None else detect_reader(p)
    if note is not None:
        tr = read_trial(p, fs)
        tr.meta["format_detected"] = note
        return tr
    if reader in _MESSAGE_READERS:
        return _MESSAGE_READERS[reader](p, fs)
    if fs is None:
        if reader == "excel":
            raise FormatSpecError(f"{p}: an Excel log needs a format spec (--format SPEC)")
        fs = _usvid_table_spec(p, reader)
    if reader in _TABLE_READERS:
        return _TABLE_READERS[reader](p, fs)
    raise FormatSpecError(f"unknown reader {reader!r}")  # unreachable: validated by the spec


#: Reader of each ``spec.reader`` (those that need no spec, then the tables).
_MESSAGE_READERS = {"rosbag": read_rosbag, "ulog": read_ulog, "dataflash": read_dataflash,
                    "tlog": read_tlog, "nmea0183": read_nmea0183, "nmea2000": read_nmea2000}
_TABLE_READERS = {"table": read_table, "excel": read_excel, "parquet": read_parquet}


def _usvid_table_spec(p: Path, reader: str) -> FormatSpec:
    """Spec for a CSV/Parquet written by usvid: header names are channels in SI units."""
    import pandas as pd

    try:
        if reader == "parquet":
            import pyarrow.parquet as pq

            names = list(pq.read_schema(p).names)
        else:
            names = list(pd.read_csv(p, nrows=0).columns)
    except Exception as exc:
        raise LogReadError(f"{p}: cannot read the header ({type(exc).__name__})") from None
    if "t" not in names:
        raise FormatSpecError(
            f"{p}: no format spec given and the table has no 't' column (give --format SPEC)"
        )
    d: dict = {"reader": reader, "columns": {}}
    if reader == "table":
        d.update({"delimiter": ",", "header": True})
    for n in names:
        if str(n).isidentifier():
            d["columns"][n] = {"col": n, "unit": CHANNEL_UNITS.get(n, "1")}
    return parse_spec(d, source=f"{p.name} (usvid table, no spec)")
