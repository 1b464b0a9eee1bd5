"""NMEA 2000 logs in ``candump -L`` format: reader and writer.

Line format (can-utils ``candump -L``)::

    (1700000000.123456) can0 09F11203#013930FF7FFF7FFC

i.e. ``(epoch seconds) interface CANID#DATA`` with a 29-bit extended CAN id (priority, PGN, source,
destination) and up to 8 data bytes. Decoding goes through the ``nmea2000`` package
(``NMEA2000Decoder`` bound to ``candump3``, SI units; its canboat backend reassembles fast-packet
PGNs), encoding through the same canboat database (``nmea2000.backend.DATABASE.encode``, the
function nmea2000's own encoders call) plus ``can_id_compose`` and ``fast_packet_fragment``.

PGNs and the Trial channels they give (canboat field ids, SI):

- 127250 Vessel Heading: ``heading`` -> ``psi`` [rad] (reference True; a magnetic heading plus
  ``deviation`` and ``variation`` -> ``psi`` when no true heading is in the log);
- 127251 Rate of Turn: ``rate`` -> ``r`` [rad/s];
- 127245 Rudder: ``position`` -> ``delta`` [rad] (instance 0; instance 1 -> ``delta_port``),
  ``angleOrder`` -> ``delta_cmd`` [rad];
- 128259 Speed: ``speedWaterReferenced`` -> ``stw`` [m/s], ``speedGroundReferenced`` -> ``sog``;
- 129025 Position Rapid Update: ``latitude``/``longitude`` -> ``lat``/``lon`` [deg];
- 129026 COG & SOG Rapid Update: ``cog`` -> ``cog`` [rad], ``sog`` -> ``sog`` [m/s];
- 127488 Engine Parameters Rapid Update: ``speed`` [rev/s] -> ``n`` (instance 0, single engine),
  ``n_port`` (instance 0) and ``n_stbd`` (instance 1) when both instances are present.

Rudder sign: NMEA 2000 defines a positive rudder angle as the vessel's bow turning to starboard,
the Trial convention. Rejected lines, counted per reason: ``garbage`` (not a candump line),
``truncated`` (a frame of one of these PGNs with fewer than 8 data bytes: they are all single-frame
PGNs, and the decoder would otherwise read the missing bytes as values), ``bad_frame`` (a candump
line that does not decode), ``no_time``, ``not_available`` (every field "not available"); other
PGNs are ignored and counted in ``meta["ignored_pgns"]``.
"""

from __future__ import annotations

import math
import re
from datetime import datetime
from pathlib import Path

import numpy as np

from usvid.errors import LogReadError
from usvid.files import write_atomic
from usvid.io._assemble import (
    MAX_EPOCH_S,
    apply_renames,
    assemble,
    ignored_finding,
    read_log_bytes,
    utc_iso,
)
from usvid.io.spec import FormatSpec
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

PGNS = (127250, 127251, 127245, 128259, 129025, 129026, 127488)
_LINE = re.compile(r"^\s*\(([^)]*)\)\s+(\S+)\s+([0-9A-Fa-f]{8})#([0-9A-Fa-f]*)\s*$")
_PGN_ID = {
    127250: "vesselHeading",
    127251: "rateOfTurn",
    127245: "rudder",
    128259: "speed",
    129025: "positionRapidUpdate",
    129026: "cogSogRapidUpdate",
    127488: "engineParametersRapidUpdate",
}


def _fields(msg) -> dict:
    return {f.id: f for f in msg.fields}


def _val(f) -> float:
    if f is None or f.value is None:
        return math.nan
    try:
        x = float(f.value)
    except (TypeError, ValueError):
        return math.nan
    return x if math.isfinite(x) else math.nan


def _raw(f) -> int | None:
    if f is None:
        return None
    try:
        return int(f.raw_value)
    except (TypeError, ValueError):
        return None


def _channels(msg) -> dict[str, float] | None:
    """Trial channels carried by one decoded message (None: not one of ours)."""
    pgn = msg.PGN
    f = _fields(msg)
    if pgn == 127250:
        ref = _raw(f.get("reference"))
        h = _val(f.get("heading"))
        if ref == 1:  # magnetic
            dev = _val(f.get("deviation"))
            var = _val(f.get("variation"))
            h = h + (0.0 if math.isnan(dev) else dev) + (0.0 if math.isnan(var) else var)
            return {"psi_mag": h}
        return {"psi": h}
    if pgn == 127251:
        return {"r": _val(f.get("rate"))}
    if pgn == 127245:
        inst = _raw(f.get("instance")) or 0
        name = "delta" if inst == 0 else f"delta_{'port' if inst == 1 else inst}"
        out = {name: _val(f.get("position"))}
        if inst == 0:
            out["delta_cmd"] = _val(f.get("angleOrder"))
        return out
    if pgn == 128259:
        return {"stw": _val(f.get("speedWaterReferenced")),
                "sog": _val(f.get("speedGroundReferenced"))}
    if pgn == 129025:
        return {"lat": _val(f.get("latitude")), "lon": _val(f.get("longitude"))}
    if pgn == 129026:
        return {"cog": _val(f.get("cog")), "sog": _val(f.get("sog"))}
    if pgn == 127488:
        inst = _raw(f.get("instance")) or 0
        return {f"_engine{inst}": _val(f.get("speed"))}
    return None


def read_candump(path: str | Path, spec: FormatSpec | None = None) -> Trial:
    """Read a ``candump -L`` NMEA 2000 log into a multi-rate Trial (SI units, radians).

    Time: the line's epoch-seconds stamp; ``t`` [s] since the first record,
    ``meta["t0_utc"]`` its ISO time. Raises :class:`LogReadError` naming the file when the file
    is empty or has no usable frame.
    """
    from nmea2000.decoder import NMEA2000Decoder
    from nmea2000.input_formats import N2KFormat

    path = Path(path)
    blob = read_log_bytes(path)
    text = blob.decode("ascii", errors="replace")
    dec = NMEA2000Decoder(N2KFormat.CANDUMP3, units="si", include_pgns=list(PGNS))
    rejected: dict[str, int] = {}
    ignored: dict[int, int] = {}
    ts: list[float] = []
    rows: list[dict[str, float]] = []
    first_bad: int | None = None

    def rej(reason: str, lineno: int) -> None:
        nonlocal first_bad
        rejected[reason] = rejected.get(reason, 0) + 1
        if first_bad is None:
            first_bad = lineno

    lines = text.splitlines()
    for lineno, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        m = _LINE.match(line)
        if m is None or len(m.group(4)) % 2 or len(m.group(4)) > 16:
            rej("garbage", lineno)
            continue
        try:
            stamp = float(m.group(1))
        except ValueError:
            stamp = math.nan
        if not (math.isfinite(stamp) and abs(stamp) <= MAX_EPOCH_S):
            rej("no_time", lineno)
            continue
        can_id = int(m.group(3), 16)
        pgn = (can_id >> 8) & 0x3FFFF
        if (pgn >> 8) & 0xFF < 240:  # PDU1: destination in the low byte
            pgn &= 0x3FF00
        if pgn not in PGNS:
            ignored[pgn] = ignored.get(pgn, 0) + 1
            continue
        if len(m.group(4)) < 16:  # every PGN read here is a single 8-byte frame
            rej("truncated", lineno)
            continue
        try:
            msg = dec.decode(line.strip())
        except Exception:  # nmea2000 raises ValueError / canboat DecodeError on a bad frame
            rej("bad_frame", lineno)
            continue
        if msg is None:  # a fast-packet fragment waiting for the rest
            continue
        try:
            ch = _channels(msg)
        except (TypeError, ValueError, AttributeError):
            rej("bad_frame", lineno)
            continue
        if ch is None:
            continue
        if all(math.isnan(v) for v in ch.values()):
            rejected["not_available"] = rejected.get("not_available", 0) + 1
            continue
        ts.append(stamp)
        rows.append(ch)
    findings: list[Finding] = []
    meta: dict = {"reader": "nmea2000"}
    if ignored:
        meta["ignored_pgns"] = {str(k): v for k, v in sorted(ignored.items())}
        findings.append(ignored_finding(path, "ignored_pgns", "frame(s) of PGNs", ignored))
    if not rows:
        detail = ", ".join(f"{k}: {v}" for k, v in sorted(rejected.items()))
        where = f" (first bad line {first_bad})" if first_bad else ""
        raise LogReadError(
            f"{path}: no usable NMEA 2000 frame in {len(lines)} line(s)"
            + (f"; rejected {detail}{where}" if detail else "")
        )
    t_abs = np.asarray(ts, dtype=float)
    names = sorted({k for r in rows for k in r})
    chans = {k: np.full(len(rows), np.nan) for k in names}
    for j, r in enumerate(rows):
        for k, v in r.items():
            chans[k][j] = v
    # engine instances -> n or n_port/n_stbd
    eng = sorted(k for k in chans if k.startswith("_engine"))
    if eng == ["_engine0"]:
        chans["n"] = chans.pop("_engine0")
    else:
        for k in eng:
            inst = int(k[len("_engine"):])
            chans[{0: "n_port", 1: "n_stbd"}.get(inst, f"n_{inst}")] = chans.pop(k)
    if "psi_mag" in chans and "psi" not in chans:
        chans["psi"] = chans.pop("psi_mag")
    # fields the bus marked "not available" throughout (e.g. an unused angleOrder) are absent
    chans = {k: v for k, v in chans.items() if np.isfinite(v).any()}
    t0 = float(np.nanmin(t_abs))
    meta["t0_epoch"] = t0
    meta["t0_utc"] = utc_iso(t0)
    chans = apply_renames(chans, spec)
    return assemble(
        path,
        t_abs - t0,
        chans,
        spec=spec,
        rejected=rejected,
        findings=findings,
        count_duplicates=False,
        meta=meta,
    )


# ----------------------------------------------------------------------------------------------
# writer
# ----------------------------------------------------------------------------------------------
class _Encoder:
    """PGN payloads through nmea2000's canboat database, framed as candump -L lines."""

    def __init__(self, source: int, interface: str, priority: int = 2) -> None:
        from nmea2000 import _canboat as cb
        from nmea2000.backend import DATABASE

        self.cb = cb
        self.db = DATABASE
        self.src = source
        self.iface = interface
        self.prio = priority
        self.seq = 0
        self.sid = 0

    def frames(self, pgn: int, fields: dict) -> list[tuple[int, bytes]]:
        payload = self.db.encode(_PGN_ID[pgn], fields, src=self.src, prio=self.prio)
        cid = self.cb.can_id_compose(self.prio, pgn, self.src, 255)
        if len(payload) <= 8:
            return [(cid, payload)]
        frags = self.cb.fast_packet_fragment(self.seq, payload)
        self.seq = (self.seq + 1) % 8
        return [(cid, f) for f in frags]

    def lines(self, stamp: float, pgn: int, fields: dict) -> list[str]:
        return [
            f"({stamp:.6f}) {self.iface} {cid:08X}#{data.hex().upper()}"
            for cid, data in self.frames(pgn, fields)
        ]


def candump_lines(
    trial: Trial,
    *,
    t0_utc: str | datetime | None = None,
    source: int = 3,
    interface: str = "can0",
) -> list[str]:
    """candump -L lines for every finite sample of ``trial`` (see :func:`write_candump`)."""
    e0 = log_start_epoch(trial, t0_utc)
    enc = _Encoder(source, interface)
    lat, lon, psi, r = (channel_or_none(trial, k) for k in ("lat", "lon", "psi", "r"))
    delta, dcmd = channel_or_none(trial, "delta"), channel_or_none(trial, "delta_cmd")
    sog = channel_or_none(trial, "sog" if "sog" in trial.data.columns else "U")
    cog = channel_or_none(trial, "cog")
    n, n_p, n_s = (channel_or_none(trial, k) for k in ("n", "n_port", "n_stbd"))
    t = trial.t
    out: list[str] = []

    def fin(a: np.ndarray | None, i: int) -> bool:
        return a is not None and math.isfinite(a[i])

    for i in range(len(t)):
        st = e0 + float(t[i])
        sid = i % 250
        if fin(lat, i) and fin(lon, i):
            out += enc.lines(st, 129025, {"latitude": float(lat[i]), "longitude": float(lon[i])})
        if fin(cog, i) or fin(sog, i):
            out += enc.lines(st, 129026, {
                "sid": sid, "cogReference": 0,
                "cog": float(cog[i]) % (2 * math.pi) if fin(cog, i) else None,
                "sog": float(sog[i]) if fin(sog, i) else None,
            })
        if fin(psi, i):
            out += enc.lines(st, 127250, {"sid": sid, "heading": float(psi[i]) % (2 * math.pi),
                                          "deviation": None, "variation": None, "reference": 0})
        if fin(r, i):
            out += enc.lines(st, 127251, {"sid": sid, "rate": float(r[i])})
        if fin(delta, i) or fin(dcmd, i):
            out += enc.lines(st, 127245, {
                "instance": 0, "directionOrder": 0,
                "angleOrder": float(dcmd[i]) if fin(dcmd, i) else None,
                "position": float(delta[i]) if fin(delta, i) else None,
            })
        for inst, arr in ((0, n), (0, n_p), (1, n_s)):
            if fin(arr, i):
                out += enc.lines(st, 127488, {"instance": inst, "speed": float(arr[i])})
    return out


def write_candump(
    trial: Trial,
    path: str | Path,
    *,
    t0_utc: str | datetime | None = None,
    source: int = 3,
    interface: str = "can0",
) -> Path:
    """Write a Trial as an NMEA 2000 ``candump -L`` log (atomically).

    Channels -> PGNs (SI on the bus): ``lat``/``lon`` -> 129025, ``cog``/``sog`` (or ``U``) ->
    129026, ``psi`` -> 127250 (true), ``r`` -> 127251, ``delta``/``delta_cmd`` -> 127245,
    ``n`` (or ``n_port``/``n_stbd``) [rps] -> 127488 instances 0/1. Quantisation (PGN
    resolutions): lat/lon 1e-7 deg, angles 1e-4 rad, rate 3.125e-8 rad/s, speed 0.01 m/s, shaft
    rate 0.25 rpm. Time stamps: microseconds, t = 0 at ``t0_utc`` (default
    ``trial.meta["t0_utc"]`` or 2025-01-01).
    """
    lines = candump_lines(trial, t0_utc=t0_utc, source=source, interface=interface)
    return write_atomic(path, "\n".join(lines) + "\n")
