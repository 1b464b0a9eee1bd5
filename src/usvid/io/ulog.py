"""PX4 ULog (``.ulg``): reader through ``pyulog`` (optional extra ``usvid[px4]``) and a minimal
writer following the PX4 "ULog File Format" documentation (pyulog cannot write a log from
scratch), used for tests and benchmarks.

Reader: every spec column names a uORB topic (``message`` or ``topic``) and a field as pyulog
flattens it (``lat``, ``xyz[2]``, ``control[0]``, nested ``esc[0].esc_rpm``); ``convert: yaw``
on ``q`` reads ``q[0..3]`` = (w, x, y, z), the rotation from the body FRD to the earth NED frame
(``frame: ned``, the default); ``convert: speed/course`` on ``v`` reads ``vx``/``vy`` (or
``v[0]``/``v[1]``); ``instance`` is the topic's ``multi_id`` (default 0). Decoding is pyulog's
(numpy arrays per topic, no loop per record here). The time of a sample is its ``timestamp``
[us since boot]; when the log holds ``sensor_gps.time_utc_usec`` the boot clock is tied to UTC
(``meta["t0_utc"]``).

Bad input: a file that is not a ULog, or is cut inside the definitions, is a
:class:`usvid.errors.LogReadError`; a message cut by the end of the file is counted as
``rejected["truncated"]`` (pyulog stops there quietly); pyulog skips damaged data sections by
searching for the next sync marker and flags the log, counted as ``rejected["corrupt_data"]``
with a warning finding; logger dropouts are counted as ``rejected["dropout"]``.
"""

from __future__ import annotations

import contextlib
import io
import math
import struct
from pathlib import Path

import numpy as np

from usvid.errors import LogReadError
from usvid.files import write_atomic
from usvid.io._binlog import interleave, records
from usvid.io._messages import (
    ReadState,
    Series,
    build_trial,
    missing_field,
    missing_topic,
    quaternion_zyx,
    require,
)
from usvid.io.spec import QUATERNION_CONVERTS, ColumnSpec, FormatSpec
from usvid.io.vehicles import mav_type_kind, vehicle_finding
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

ULOG_MAGIC = b"ULog\x01\x12\x35"
#: Topics that tie the boot clock to UTC.
_GPS_TOPICS = ("sensor_gps", "vehicle_gps_position")


def is_ulog(head: bytes) -> bool:
    """True when ``head`` (the first bytes of a file) is a ULog header."""
    return head.startswith(ULOG_MAGIC)


def _cut_at_end(path: Path) -> bool:
    """True when the chain of ULog messages (uint16 payload size, uint8 type, payload) from the
    end of the 16-byte file header does not end at the end of the file: the last message is cut
    (pyulog stops there quietly). One pass over the sizes only (memory-mapped), far cheaper than
    watching pyulog's reads."""
    import mmap

    size = path.stat().st_size
    if size <= 16:
        return False
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        unpack = struct.Struct("<H").unpack_from
        pos, last = 16, size - 3
        while pos <= last:
            pos += 3 + unpack(mm, pos)[0]
    return pos != size


#: Older and newer PX4 names of the topics and fields the ``px4_boat`` preset reads:
#: (topic, field) -> [(topic, field, scale)], tried in order when the spec's topic has no data
#: (``vehicle_gps_position`` became ``sensor_gps`` with degrees instead of 1e-7 degrees;
#: ``vehicle_angular_velocity`` took the gyro of ``sensor_combined``).
ALIASES: dict[tuple[str, str], tuple[tuple[str, str, float], ...]] = {
    ("vehicle_global_position", "lat"): (("sensor_gps", "latitude_deg", 1.0),
                                         ("vehicle_gps_position", "latitude_deg", 1.0),
                                         ("vehicle_gps_position", "lat", 1e-7)),
    ("vehicle_global_position", "lon"): (("sensor_gps", "longitude_deg", 1.0),
                                         ("vehicle_gps_position", "longitude_deg", 1.0),
                                         ("vehicle_gps_position", "lon", 1e-7)),
    ("sensor_gps", "vel_m_s"): (("vehicle_gps_position", "vel_m_s", 1.0),),
    ("sensor_gps", "cog_rad"): (("vehicle_gps_position", "cog_rad", 1.0),),
    ("sensor_gps", "fix_type"): (("vehicle_gps_position", "fix_type", 1.0),),
    ("sensor_gps", "hdop"): (("vehicle_gps_position", "hdop", 1.0),),
    ("vehicle_angular_velocity", "xyz[0]"): (("sensor_combined", "gyro_rad[0]", 1.0),),
    ("vehicle_angular_velocity", "xyz[2]"): (("sensor_combined", "gyro_rad[2]", 1.0),),
}


def _alias(col: ColumnSpec, data: dict) -> tuple[ColumnSpec, dict, str] | None:
    """The first alias of ``col`` (:data:`ALIASES`) with data in the log: the column re-aimed
    at it (its scale times the alias's), the topic's data and a description; None if none."""
    from dataclasses import replace

    for topic, field, scale in ALIASES.get((col.topic or "", str(col.col)), ()):
        d = data.get((topic, col.instance or 0))
        if d is not None and field in d and len(d[field]):
            return (replace(col, topic=topic, col=field, scale=col.scale * scale), d,
                    f"{topic}.{field}" + (f" x {scale:g}" if scale != 1.0 else ""))
    return None


def _name_vehicle(path: Path, state: ReadState, mav_type: float | None) -> None:
    """The kind of vehicle from the PX4 parameter MAV_TYPE (:mod:`usvid.io.vehicles`)."""
    if mav_type is None or not math.isfinite(float(mav_type)):
        return
    vehicle = mav_type_kind(int(mav_type), "PX4 parameter MAV_TYPE")
    if vehicle is None:
        return
    state.meta["vehicle"] = vehicle
    f = vehicle_finding(path, vehicle)
    if f is not None:
        state.findings.append(f)


def _names(col: ColumnSpec, data: dict) -> list[str]:
    """pyulog column names of ``col`` (4 for a quaternion, 2 for a vector)."""
    f = str(col.col)
    if col.conversion in QUATERNION_CONVERTS:
        return [f"{f}[{i}]" for i in range(4)]
    if col.conversion in ("speed", "course"):
        if f"{f}[0]" in data:
            return [f"{f}[0]", f"{f}[1]"]
        return [f"{f}x", f"{f}y"]
    return [f]


def read_ulog(path: str | Path, spec: FormatSpec) -> Trial:
    """Read a PX4 ULog into a multi-rate Trial (SI units, radians).

    Raises :class:`LogReadError` (one line naming the file, topic and field) when the file is
    not a ULog, a topic or field of the spec is missing, or no sample is usable.
    """
    require("ulog")
    from pyulog import ULog

    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(16)
    if not is_ulog(head):
        raise LogReadError(f"{path}: not a PX4 ULog (no ULog header)")
    topics = sorted({c.topic for c in spec.columns.values()} | set(_GPS_TOPICS)
                    | {a[0] for c in spec.columns.values()
                       for a in ALIASES.get((c.topic or "", str(c.col)), ())})
    quiet = io.StringIO()
    try:
        with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
            ulog = ULog(str(path), message_name_filter_list=topics, disable_str_exceptions=True)
    except Exception as exc:  # pyulog raises plain Exceptions / struct errors on bad files
        raise LogReadError(f"{path}: not a readable ULog ({type(exc).__name__}: "
                           f"{' '.join(str(exc).split())[:120]})") from None
    state = ReadState()
    # (a damaged log is resynchronised by pyulog: its message chain says nothing about the end)
    if not ulog.file_corruption and _cut_at_end(path):
        state.reject("truncated")
        state.findings.append(Finding(
            "warning", "log_damaged", f"{path.name}: the last message is cut by the end of the "
            "file (truncated log)", count=1))
    if ulog.file_corruption:
        state.reject("corrupt_data")
        state.findings.append(Finding(
            "warning", "log_damaged",
            f"{path.name}: damaged data in the ULog; pyulog skipped to the next sync marker "
            "(records in the damaged part are lost)", count=1))
    if ulog.dropouts:
        state.reject("dropout", len(ulog.dropouts))
    data = {(d.name, d.multi_id): d.data for d in ulog.data_list}
    formats = ulog.message_formats
    series = []
    for col in spec.columns.values():
        inst = col.instance or 0
        d = data.get((col.topic, inst))
        if d is None:
            alt = _alias(col, data)
            if alt is not None:
                col, d, why = alt
            if alt is not None and not col.name.startswith("_"):  # (internal: no finding)
                state.findings.append(Finding(
                    "info", "topic_alias", f"{path.name}: '{col.name}' read from {why} (the "
                    f"topic of the spec has no data: an older or newer PX4)", channel=col.name))
        if d is None:
            if col.optional:
                continue
            if col.topic in formats:
                raise LogReadError(
                    f"{path}: {spec.source}: columns.{col.name}.message: topic '{col.topic}' "
                    f"instance {inst} has no data in the log (nor any older or newer name of "
                    f"it usvid knows)")
            raise missing_topic(path, spec, col, list(formats), what="message")
        names = _names(col, d)
        if any(n not in d for n in [*names, "timestamp"]) and col.optional:
            continue  # (an optional column whose field this PX4 does not log)
        if any(n not in d for n in [*names, "timestamp"]):
            shown = sorted(k for k in d if k != "timestamp")
            raise missing_field(path, spec, col, "uORB topic", shown)
        raw = np.column_stack([np.asarray(d[n], dtype=float) for n in names])
        t_ns = np.asarray(d["timestamp"], dtype=np.int64) * 1000
        series.append(Series(col, t_ns, raw if raw.shape[1] > 1 else raw[:, 0]))
    _name_vehicle(path, state, ulog.initial_parameters.get("MAV_TYPE"))
    epoch = None
    for name in _GPS_TOPICS:
        g = data.get((name, 0))
        if g is not None and "time_utc_usec" in g:
            ok = np.flatnonzero(np.asarray(g["time_utc_usec"]) > 0)
            if len(ok):
                k = int(ok[0])
                epoch = (int(g["time_utc_usec"][k]) - int(g["timestamp"][k])) * 1000
                break
    return build_trial(path, spec, series, state, reader="ulog", clock_epoch_ns=epoch)


# ----------------------------------------------------------------------------------------------
# writer (PX4 ULog File Format: header, flag bits, formats, subscriptions, data messages)
# ----------------------------------------------------------------------------------------------
_ESC_REPORT = np.dtype([("timestamp", "<u8"), ("esc_rpm", "<i4")])
#: topic -> numpy dtype of its payload (packed, the field order of the format message).
ULOG_TOPICS: dict[str, np.dtype] = {
    "vehicle_global_position": np.dtype([("timestamp", "<u8"), ("lat", "<f8"), ("lon", "<f8"),
                                         ("alt", "<f4")]),
    "sensor_gps": np.dtype([("timestamp", "<u8"), ("time_utc_usec", "<u8"),
                            ("latitude_deg", "<f8"), ("longitude_deg", "<f8"),
                            ("vel_m_s", "<f4"), ("cog_rad", "<f4")]),
    "vehicle_attitude": np.dtype([("timestamp", "<u8"), ("q", "<f4", (4,))]),
    "vehicle_angular_velocity": np.dtype([("timestamp", "<u8"), ("xyz", "<f4", (3,))]),
    "actuator_servos": np.dtype([("timestamp", "<u8"), ("control", "<f4", (8,))]),
    "esc_status": np.dtype([("timestamp", "<u8"), ("esc_count", "u1"),
                            ("esc", _ESC_REPORT, (8,))]),
}
_CTYPE = {"<u8": "uint64_t", "<i4": "int32_t", "<f8": "double", "<f4": "float",
          "|u1": "uint8_t"}
#: Full rudder deflection of the px4_boat preset (actuator_servos control = +-1) [deg].
SERVO_FULL_DEG = 35.0


def _format_text(name: str, dt: np.dtype, nested: dict[str, str]) -> str:
    parts = []
    for fname in dt.names:
        sub, _ = dt.fields[fname][:2]
        base, shape = (sub.base, sub.shape) if sub.subdtype else (sub, ())
        tname = nested.get(fname) or _CTYPE[base.str]
        parts.append(f"{tname}[{shape[0]}] {fname};" if shape else f"{tname} {fname};")
    return f"{name}:" + "".join(parts)


def _msg(mtype: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), mtype[0]) + payload


def ulog_bytes(trial: Trial, *, t0_utc: str | None = None, boot_offset_s: float = 100.0
               ) -> bytes:
    """The bytes of :func:`write_ulog` (see there)."""
    e0 = log_start_epoch(trial, t0_utc)
    t_us = np.round((trial.t + boot_offset_s) * 1e6).astype(np.uint64)
    ch = {k: channel_or_none(trial, k) for k in
          ("lat", "lon", "sog", "cog", "psi", "r", "delta", "n", "phi", "theta", "p")}
    if ch["sog"] is None:
        ch["sog"] = channel_or_none(trial, "U")
    n = len(t_us)
    nanv = np.full(n, np.nan)

    def fin(*keys: str) -> np.ndarray:
        m = np.ones(n, dtype=bool)
        for k in keys:
            m &= np.isfinite(ch[k]) if ch[k] is not None else False
        return m

    def col(k: str) -> np.ndarray:
        return ch[k] if ch[k] is not None else nanv

    topics: dict[str, tuple[np.ndarray, dict]] = {}
    m = fin("lat", "lon")
    topics["vehicle_global_position"] = (m, {"lat": col("lat"), "lon": col("lon")})
    m2 = m & fin("sog", "cog")
    topics["sensor_gps"] = (m2, {
        "time_utc_usec": np.round((e0 + trial.t) * 1e6).astype(np.uint64),
        "latitude_deg": col("lat"), "longitude_deg": col("lon"), "vel_m_s": col("sog"),
        "cog_rad": np.where(col("cog") > math.pi, col("cog") - 2 * math.pi, col("cog"))})
    psi = col("psi")
    zero = 0 * psi
    q = quaternion_zyx(psi, np.nan_to_num(col("theta")), np.nan_to_num(col("phi")))  # NED, FRD
    topics["vehicle_attitude"] = (fin("psi"), {"q": q})
    topics["vehicle_angular_velocity"] = (fin("r"), {"xyz": np.column_stack(
        [np.nan_to_num(col("p")), zero, col("r")])})
    ctrl = np.zeros((n, 8))
    ctrl[:, 0] = col("delta") / math.radians(SERVO_FULL_DEG)
    topics["actuator_servos"] = (fin("delta"), {"control": ctrl})
    esc = np.zeros(n, dtype=np.dtype((_ESC_REPORT, (8,))))
    esc["timestamp"][:, 0] = t_us
    esc["esc_rpm"][:, 0] = np.round(np.nan_to_num(col("n")) * 60.0)
    topics["esc_status"] = (fin("n"), {"esc_count": 1, "esc": esc})

    out = [ULOG_MAGIC, struct.pack("<BQ", 1, int(t_us[0]) if n else 0)]
    out.append(_msg(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0)))
    out.append(_msg(b"F", _format_text("esc_report", _ESC_REPORT, {}).encode()))
    for name, dt in ULOG_TOPICS.items():
        nested = {"esc": "esc_report"} if name == "esc_status" else {}
        out.append(_msg(b"F", _format_text(name, dt, nested).encode()))
    key = b"char[8] sys_name"
    out.append(_msg(b"I", bytes([len(key)]) + key + b"usvidsim"))
    parts = []
    for msg_id, (name, (mask, cols)) in enumerate(topics.items()):
        out.append(_msg(b"A", struct.pack("<BH", 0, msg_id) + name.encode()))
        idx = np.flatnonzero(mask)
        dt = ULOG_TOPICS[name]
        hdr = np.dtype([("size", "<u2"), ("type", "u1"), ("msg_id", "<u2")]
                       + [(f, dt.fields[f][0]) for f in dt.names])
        vals = {"size": 2 + dt.itemsize, "type": ord("D"), "msg_id": msg_id,
                "timestamp": t_us[idx]}
        for k, v in cols.items():
            vals[k] = v[idx] if isinstance(v, np.ndarray) else v
        parts.append((t_us[idx], records(hdr, vals, len(idx))))
    return b"".join(out) + interleave(parts)


def write_ulog(trial: Trial, path: str | Path, *, t0_utc: str | None = None) -> Path:
    """Write a Trial as a PX4 ULog in the ``px4_boat`` preset's layout (atomically).

    Follows the PX4 "ULog File Format" (version 1: header, flag bits, format, info, add-logged
    and data messages; fields packed in format order). Topics: ``vehicle_global_position``
    (``lat``/``lon`` [deg], double), ``sensor_gps`` (``vel_m_s`` = ``sog`` or ``U``, ``cog_rad``,
    ``time_utc_usec``), ``vehicle_attitude`` (``q`` from ``psi``, NED), ``vehicle_angular_velocity``
    (``xyz[2]`` = ``r``), ``actuator_servos`` (``control[0]`` = ``delta`` / 35 deg) and
    ``esc_status`` (``esc[0].esc_rpm`` = ``n`` * 60, integer rpm). ``timestamp`` [us since boot]
    = t + 100 s. Quantisation: float32 (about 1e-7 relative), rpm to 1 rpm.
    """
    return write_atomic(path, ulog_bytes(trial, t0_utc=t0_utc))

