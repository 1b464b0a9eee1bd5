"""Reference decoders of message logs for the tests, independent of usvid's fast readers.

* :func:`read_nmea0183_pynmeagps`: :func:`usvid.io.read_nmea0183` with every line decoded by
  ``pynmeagps.NMEAReader.parse`` (checksums validated) instead of the reader's vectorised scan;
  the rest of the reader (timing, assembly) is the same, so the trials of both must agree.
* :func:`n2k_channels`, :func:`n2k_system_time`: the Trial channels and the System Time of one
  NMEA 2000 message decoded by the ``nmea2000`` package, the semantics that
  :func:`usvid.io.n2k.decode_payloads` reproduces on whole arrays.

Units: the Trial's (SI, radians).
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from pathlib import Path
from unittest import mock

from pynmeagps import NMEAReader
from pynmeagps.nmeatypes_core import VALCKSUM

from usvid.io import nmea0183
from usvid.io.nmea0183 import (
    _HEX,
    _TIMED,
    DEG,
    KN,
    TYPES,
    _dmy,
    _hms,
    _latlon,
    _Records,
    _sentence_type,
)
from usvid.trial import Trial


def read_nmea0183_pynmeagps(path: str | Path, spec=None) -> Trial:
    """:func:`usvid.io.read_nmea0183` with the lines decoded by pynmeagps (module docstring)."""
    with mock.patch.object(nmea0183, "_scan", _scan_pynmeagps):
        return nmea0183.read_nmea0183(path, spec)


def _scan_pynmeagps(blob: bytes):
    """Per-line decoding with ``pynmeagps.NMEAReader.parse`` (checksums validated)."""
    lines = blob.split(b"\n")
    rejected: dict[str, int] = {}
    ignored: dict[str, int] = {}
    recs = _Records()

    def rej(reason: str) -> None:
        rejected[reason] = rejected.get(reason, 0) + 1

    for i, raw in enumerate(lines):
        line = raw.rstrip()
        if not line:
            continue
        body = raw[:-1] if raw.endswith(b"\r") else raw
        if any(b < 32 or b > 126 for b in body if b != 9):
            rej("garbage")
            continue
        k1, k2 = line.find(b"$"), line.find(b"!")
        ks = [k for k in (k1, k2) if k >= 0]
        if not ks:
            rej("garbage")
            continue
        a = min(ks)
        sent = line[a:]
        star = sent.rfind(b"*")
        if star < 0 or len(sent) - star != 3:
            rej("truncated")
            continue
        if _HEX[sent[star + 1]] == 255 or _HEX[sent[star + 2]] == 255:
            rej("truncated")
            continue
        cks = 0
        for ch in sent[1:star]:
            cks ^= ch
        if cks != int(sent[star + 1 : star + 3], 16):
            rej("checksum")
            continue
        if star < 6:
            rej("garbage")
            continue
        typ = _sentence_type(sent[1:star])
        if typ not in TYPES:
            key = typ or sent[1:star].split(b",", 1)[0].decode("ascii", "replace")
            ignored[key] = ignored.get(key, 0) + 1
            continue
        if b" " in sent[:star] or b"*" in sent[1:star]:
            rej("bad_fields")
            continue
        try:
            msg = NMEAReader.parse(sent + b"\r\n", validate=VALCKSUM)
        except Exception as exc:  # pynmeagps raises NMEAParseError & friends
            if "checksum" in str(exc).lower():
                rej("checksum")
            elif typ in TYPES:
                rej("bad_fields")
            else:
                ignored[typ or "?"] = ignored.get(typ or "?", 0) + 1
            continue
        if typ not in TYPES or msg is None:
            key = typ or sent[1:star].split(b",", 1)[0].decode("ascii", "replace")
            ignored[key] = ignored.get(key, 0) + 1
            continue
        try:
            dec = _from_pynmeagps(typ, msg)
            if dec is not None and typ in _TIMED:
                # time, date and position syntax by usvid's strict rules (pynmeagps is lenient
                # there: it reads "010.5" as a longitude and a malformed time as no time)
                f = sent[1:star].split(b",")[1:]
                tod = _hms(f[0]) if f[0] else math.nan
                day = (_dmy(f[8]) if f[8] else math.nan) if typ == "RMC" else math.nan
                k = 1 if typ == "GGA" else 2
                _latlon(f[k], f[k + 1], b"S", 2)
                _latlon(f[k + 2], f[k + 3], b"W", 3)
                dec = (tod, day, dec[2])
        except (ValueError, TypeError, AttributeError, OverflowError, IndexError):
            rej("bad_fields")
            continue
        if dec is None:
            rej("invalid_flag")
            continue
        recs.add(i, line[:a], *dec)
    return recs, rejected, ignored, len(lines)


def _g(msg, name: str) -> float:
    v = getattr(msg, name, "")
    if v == "" or v is None:
        return math.nan
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(name)
    return x


def _tod(v) -> float:
    if v == "" or v is None:
        return math.nan
    return v.hour * 3600 + v.minute * 60 + v.second + v.microsecond * 1e-6


def _from_pynmeagps(typ: str, m) -> tuple[float, float, dict[str, float]] | None:
    nan = math.nan
    if typ == "GGA":
        q = m.quality if m.quality != "" else 0
        if int(q) == 0:
            return None
        return _tod(m.time), nan, {"lat": _g(m, "lat"), "lon": _g(m, "lon")}
    if typ == "RMC":
        if m.status != "A":
            if m.status == "V":
                return None
            raise ValueError("status")
        day = nan
        if m.date not in ("", None):
            day = datetime(m.date.year, m.date.month, m.date.day, tzinfo=UTC).timestamp()
        return _tod(m.time), day, {
            "lat": _g(m, "lat"),
            "lon": _g(m, "lon"),
            "sog": _g(m, "spd") * KN,
            "cog": _g(m, "cog") * DEG,
        }
    if typ == "VTG":
        if getattr(m, "posMode", "") == "N":
            return None
        sogn = _g(m, "sogn")
        sog = sogn * KN if math.isfinite(sogn) else _g(m, "sogk") / 3.6
        return nan, nan, {"cog": _g(m, "cogt") * DEG, "sog": sog}
    if typ == "HDT":
        return nan, nan, {"psi": _g(m, "headingT") * DEG}
    if typ == "THS":
        if m.mi == "V":
            return None
        if m.mi not in ("A", "E", "M", "S"):
            raise ValueError("mode")
        return nan, nan, {"psi": _g(m, "headt") * DEG}
    if typ == "HDG":
        h = _g(m, "headingM")
        dev = _g(m, "deviation")
        var = _g(m, "variation")
        dev = 0.0 if math.isnan(dev) else (-dev if m.deviationEW == "W" else dev)
        var = 0.0 if math.isnan(var) else (-var if m.variationEW == "W" else var)
        return nan, nan, {"psi_hdg": (h + dev + var) * DEG}
    if typ == "ROT":
        if m.valid != "A":
            if m.valid == "V":
                return None
            raise ValueError("status")
        return nan, nan, {"r": _g(m, "rot") * DEG / 60.0}
    if typ == "RSA":
        out = {}
        if m.stbdstatus == "A":
            out["delta"] = _g(m, "stbdangle") * DEG
        elif m.stbdstatus != "V":
            raise ValueError("status")
        if getattr(m, "portstatus", "") == "A":
            out["delta_port"] = _g(m, "portangle") * DEG
        return (nan, nan, out) if out else None
    raise ValueError(typ)


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


def n2k_system_time(msg) -> float:
    """Epoch seconds of a System Time message (``date`` [days since 1970], ``time`` [s])."""
    f = _fields(msg)
    try:
        d = float(f["date"].raw_value)
        s = float(f["time"].raw_value)
    except (KeyError, TypeError, ValueError):
        return math.nan
    # 0xFFFF days / 0xFFFFFFFF * 1e-4 s are "not available"
    if not (0 <= d < 65533 and 0 <= s < 86400.5):
        return math.nan
    return d * 86400.0 + s


def n2k_channels(msg) -> dict[str, float] | None:
    """Trial channels carried by one message decoded by the package (None: not one of ours):
    the reference semantics that :func:`usvid.io.n2k.decode_payloads` reproduces on whole
    arrays (tested equal on random payloads)."""
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
