"""Shared machinery of the message-based log readers (``rosbag``, ``ulog``, ``dataflash``,
``tlog``): optional-dependency imports, field paths, the channel conversions of the spec
(``convert: yaw | pwm | speed | course``) and the merge of messages of different rates on one clock.

A reader turns each spec column into a :class:`Series`: the integer time stamps [ns] of the
messages that carry the field and the raw field values (one column, or 4 for a quaternion
``w, x, y, z``, or 2 for a velocity vector ``x, y``). :func:`build_trial` converts them (see
:mod:`usvid.io.spec` for the conversions) and merges them: the rows of the trial are the union of
all message times, NaN where a channel has no sample (the multi-rate Trial contract, as for NMEA).
A NaN field value (ROS, MAVLink and PX4 write NaN for "not available") is no sample of that
channel; a message time at which no channel has a finite value is counted by
:func:`usvid.io._assemble.assemble` as ``rejected["nan_row"]``.
"""

from __future__ import annotations

import importlib
import math
import re
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from usvid.errors import LogReadError, UsvidError
from usvid.io._assemble import assemble
from usvid.io.spec import QUATERNION_CONVERTS, ColumnSpec, FormatSpec
from usvid.trial import Finding, Trial

#: reader -> (extra, import name, distribution name)
EXTRAS = {
    "rosbag": ("ros", "rosbags", "rosbags"),
    "ulog": ("px4", "pyulog", "pyulog"),
    "dataflash": ("ardupilot", "pymavlink", "pymavlink"),
    "tlog": ("ardupilot", "pymavlink", "pymavlink"),
}


class MissingExtraError(UsvidError):
    """A log format needs an optional dependency that is not installed."""


def require(reader: str) -> Any:
    """Import the library of ``reader`` or raise :class:`MissingExtraError` naming the extra."""
    extra, mod, dist = EXTRAS[reader]
    try:
        return importlib.import_module(mod)
    except ImportError:
        raise MissingExtraError(
            f"reading {reader} logs needs the optional dependency '{dist}': "
            f"pip install 'usvid[{extra}]' (or 'usvid[all]')"
        ) from None


_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]")


def path_steps(path: str) -> list[str | int]:
    """``"twist.twist.linear.x"`` -> ``["twist", "twist", "linear", "x"]``; ``"rpm[0]"`` ->
    ``["rpm", 0]`` (attribute names and indices)."""
    return [m.group(1) if m.group(1) else int(m.group(2)) for m in _STEP.finditer(path)]


def get_path(obj: Any, steps: list[str | int]) -> Any:
    """Follow attribute names / indices ``steps`` from ``obj`` (AttributeError / IndexError /
    TypeError when the path does not exist)."""
    for s in steps:
        obj = obj[s] if isinstance(s, int) else getattr(obj, s)
    return obj


def raw_of(obj: Any, conversion: str | None) -> tuple[float, ...] | float:
    """The raw value(s) of a message field for a conversion: a quaternion object -> (w, x, y, z),
    a vector -> (x, y), anything else -> float."""
    if conversion in QUATERNION_CONVERTS:
        return (float(obj.w), float(obj.x), float(obj.y), float(obj.z))
    if conversion in ("speed", "course"):
        return (float(obj.x), float(obj.y))
    return float(obj)


def width(col: ColumnSpec) -> int:
    """Raw values per sample of ``col``: 4 (quaternion), 2 (vector) or 1."""
    return {"yaw": 4, "roll": 4, "pitch": 4, "speed": 2, "course": 2}.get(col.conversion or "",
                                                                           1)


@dataclass
class Series:
    """One channel as read: message times [ns, int64] and raw values (N,) or (N, k)."""

    col: ColumnSpec
    t_ns: np.ndarray
    raw: np.ndarray


def yaw_ned(q: np.ndarray, frame: str) -> np.ndarray:
    """Heading [rad, clockwise from north, in [0, 2 pi)] from quaternions ``q`` (N, 4) = (w, x,
    y, z) (Hamilton convention, body to earth).

    The yaw is ``atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))`` (ZYX Euler angles). In ``frame="ned"``
    (PX4 / ArduPilot: earth x north, y east, z down, body x forward, z down) it is the heading;
    in ``frame="enu"`` (ROS REP 103: earth x east, y north, z up, body x forward, z up) it is
    counted counter-clockwise from east, so the heading is ``pi/2 - yaw``.
    """
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    if frame == "enu":
        yaw = 0.5 * math.pi - yaw
    # a zero quaternion is no attitude
    bad = (w * w + x * x + y * y + z * z) < 1e-12
    yaw = np.mod(yaw, 2.0 * math.pi)
    yaw[bad] = np.nan
    return yaw


def roll_pitch(q: np.ndarray, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """Roll ``phi`` [rad, positive starboard down] and pitch ``theta`` [rad, bow up] from
    quaternions ``q`` (N, 4) = (w, x, y, z) (Hamilton, body to earth; ZYX Euler angles: roll
    ``atan2(2 (w x + y z), 1 - 2 (x^2 + y^2))``, pitch ``asin(2 (w y - z x))``). Body FRD
    (``frame="ned"``: PX4, ArduPilot) as they are; body FLU (``frame="enu"``, ROS REP 103) the
    same roll (a positive rotation about x forward lowers the starboard side in both) and the
    pitch negated (about y to port a positive rotation lowers the bow). NaN for a zero
    quaternion."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    n2 = w * w + x * x + y * y + z * z
    with np.errstate(invalid="ignore", divide="ignore"):
        w, x, y, z = (c / np.sqrt(n2) for c in (w, x, y, z))  # (a quaternion not quite unit)
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    if frame == "enu":
        pitch = -pitch
    bad = n2 < 1e-12
    roll[bad] = np.nan
    pitch[bad] = np.nan
    return roll, pitch


def quaternion_zyx(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Quaternions (N, 4) = (w, x, y, z) of ZYX Euler angles [rad] (yaw about z, then pitch
    about y, then roll about x; body to earth), the inverse of :func:`yaw_ned` and
    :func:`roll_pitch` in the same frame."""
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    return np.column_stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def pwm_command(pwm: np.ndarray, lo: float, trim: float, hi: float) -> np.ndarray:
    """Normalised command in [-1, 1] from servo pulse widths [us]: ``(pwm - trim) / (hi - trim)``
    above trim, ``(pwm - trim) / (trim - lo)`` below; 0 (no output) is NaN."""
    p = np.asarray(pwm, dtype=float)
    out = np.where(p >= trim, (p - trim) / (hi - trim), (p - trim) / (trim - lo))
    out[p <= 0] = np.nan
    return np.clip(out, -1.0, 1.0)


def convert_raw(col: ColumnSpec, raw: np.ndarray) -> np.ndarray:
    """Apply ``col.conversion`` and then ``sign * factor(unit) * (scale * raw + offset)``."""
    raw = np.asarray(raw, dtype=float)
    c = col.conversion
    if c == "yaw":
        v = yaw_ned(raw.reshape(-1, 4), col.frame)
    elif c in ("roll", "pitch"):
        v = roll_pitch(raw.reshape(-1, 4), col.frame)[0 if c == "roll" else 1]
    elif c == "pwm":
        v = pwm_command(raw, *col.pwm)
    elif c == "speed":
        r2 = raw.reshape(-1, 2)
        v = np.hypot(r2[:, 0], r2[:, 1])
    elif c == "course":
        r2 = raw.reshape(-1, 2)
        north, east = (r2[:, 1], r2[:, 0]) if col.frame == "enu" else (r2[:, 0], r2[:, 1])
        v = np.mod(np.arctan2(east, north), 2.0 * math.pi)
    else:
        v = raw
    out = col.convert(v)
    if c in ("yaw", "course") and (col.scale != 1.0 or col.offset != 0.0 or col.sign != 1.0):
        out = np.mod(out, 2.0 * math.pi)
    return out


def missing_topic(path: Path, spec: FormatSpec, col: ColumnSpec, have: list[str],
                  what: str = "topic") -> LogReadError:
    """The error of a spec column whose topic / message is not in the log."""
    listed = ", ".join(sorted(have)[:40]) or "none"
    more = f" (+{len(have) - 40} more)" if len(have) > 40 else ""
    return LogReadError(
        f"{path}: {spec.source}: columns.{col.name}.{what}: no {what} '{col.topic}' in the log "
        f"({what}s present: {listed}{more})"
    )


def missing_field(path: Path, spec: FormatSpec, col: ColumnSpec, msgtype: str,
                  fields: list[str]) -> LogReadError:
    """The error of a spec column whose field is not in its message."""
    return LogReadError(
        f"{path}: {spec.source}: columns.{col.name}.field: {msgtype} on '{col.topic}' has no "
        f"field '{col.col}' (fields: {', '.join(fields) or 'none'})"
    )


def epoch_meta(t0_epoch_s: float | None) -> dict:
    """``t0_epoch`` / ``t0_utc`` meta entries for an absolute start time [s since 1970]."""
    if t0_epoch_s is None or not math.isfinite(t0_epoch_s):
        return {}
    try:
        utc = datetime.fromtimestamp(t0_epoch_s, tz=UTC).isoformat()
    except (ValueError, OverflowError, OSError):  # a damaged clock: beyond years 1..9999
        return {}
    return {"t0_epoch": float(t0_epoch_s), "t0_utc": utc}


@dataclass
class ReadState:
    """What a reader collected besides the series: rejected counts, findings, meta."""

    rejected: dict[str, int] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)
    meta: dict = field(default_factory=dict)

    def reject(self, reason: str, n: int = 1) -> None:
        if n:
            self.rejected[reason] = self.rejected.get(reason, 0) + int(n)


def build_trial(path: Path, spec: FormatSpec, series: list[Series], state: ReadState, *,
                reader: str, clock_epoch_ns: int | None = None) -> Trial:
    """Convert and merge ``series`` into a multi-rate Trial (union of message times).

    ``t`` [s] counts from the first message of any channel; ``clock_epoch_ns`` (when the log's
    clock is absolute or can be tied to UTC: the epoch [ns] of the log clock's zero) gives
    ``meta["t0_utc"]``. Raises :class:`LogReadError` when no channel has a sample.
    """
    series = [s for s in series if len(s.t_ns)]
    if not series:
        detail = ", ".join(f"{k}: {v}" for k, v in sorted(state.rejected.items()))
        raise LogReadError(f"{path}: none of the spec's messages holds a sample"
                           + (f" (rejected {detail})" if detail else ""))
    t_all = np.unique(np.concatenate([s.t_ns for s in series]))
    t0 = int(t_all[0])
    chans: dict[str, np.ndarray] = {}
    for s in series:
        vals = convert_raw(s.col, s.raw)
        out = chans.get(s.col.name)
        if out is None:
            out = chans[s.col.name] = np.full(len(t_all), np.nan)
        idx = np.searchsorted(t_all, s.t_ns)
        ok = np.isfinite(vals)  # NaN = "not available" in ROS, MAVLink, ULog: no sample
        out[idx[ok]] = vals[ok]
    meta = {"reader": reader, **state.meta}
    if clock_epoch_ns is not None:
        meta.update(epoch_meta((clock_epoch_ns + t0) * 1e-9))
    return assemble(path, (t_all - t0) * 1e-9, chans, spec=spec, rejected=state.rejected,
                    findings=state.findings, count_duplicates=False, meta=meta)
