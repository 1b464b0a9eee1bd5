"""NMEA 0183 logs: reader (GGA RMC GLL ZDA VTG HDT HDG HDM THS ROT RSA VHW MWV MWD VWR VWT XDR,
any talker) and writer.

Line format: an optional *log-line time prefix* (ISO 8601 date-time such as
``2025-11-24T12:00:00.125Z``, or epoch seconds such as ``1764000000.125``, optionally in ``()`` or
``[]``), then the sentence ``$ttSSS,...*hh``. Time of a record (``time_source``):

- ``prefix``: the prefix of its line (lines without one are rejected as ``no_time``);
- ``sentence``: the UTC time of GGA/RMC/GLL/ZDA (+ the RMC or ZDA date when present; midnight
  roll-over unwrapped). A sentence without its own time that a talker sends once per fix (VTG,
  GSA after RMC: at most once between two timed sentences of the same talker) gets the time of
  the fix it follows (a ``time_from_epoch`` finding counts them); the others (another
  talker's, or several per fix such as a 10 Hz heading) a time interpolated linearly in line
  position between the neighbouring timed sentences (``time_interpolated``), clamped at the
  ends;
- ``auto`` (default): ``prefix`` when most sentence lines carry a parseable prefix, else
  ``sentence``.

Times are seconds since the first record (``t`` [s]); ``meta["t0_utc"]`` is the ISO time of t = 0
when the log gives a date (epoch prefix, ISO prefix, RMC or ZDA date).

Channels (Trial units): ``lat``, ``lon`` [deg] (GGA, RMC, GLL), ``sog`` [m/s] and ``cog`` [rad]
(RMC, VTG), ``stw`` [m/s] (VHW), ``psi`` [rad] (HDT, THS); ``psi_mag`` [rad] the magnetic heading
plus its deviation (HDG, HDM), which becomes ``psi`` with the logged magnetic variation (HDG,
RMC) when no true heading is in the log (:mod:`usvid.io._derived`); ``r`` [rad/s] (ROT,
deg/min, negative = bow to port), ``delta`` [rad] (RSA starboard/single rudder, negative = bow to
port, i.e. the Trial convention), ``delta_port`` [rad] (RSA port rudder when valid); wind:
``wind_speed``, ``wind_angle`` (MWV "R", VWR: apparent, from the bow, clockwise, coming from),
``wind_speed_true``, ``wind_angle_true`` (MWV "T", VWT: the true wind from the bow; with a
heading ``wind_dir_true = wind_angle_true + psi``), ``wind_speed_true``, ``wind_dir_true`` (MWD:
from north; a magnetic-only MWD with the variation); XDR angle groups (type A, unit D) named
ROLL/HEEL -> ``phi`` (positive starboard down), PITCH/TRIM -> ``theta`` (bow up), RUDDER ->
``delta``.

Sources: the talker of each sentence is its sender; a channel that several talkers give is
taken from one (``source:`` in the spec, else the one with the most samples) and the others are
reported (:mod:`usvid.io.sources`), never interleaved.

Rejected records, counted per reason in ``Trial.rejected``: ``garbage`` (no ``$``/``!``, or bytes
that are not printable ASCII), ``truncated`` (no ``*hh`` checksum field at the end),
``checksum`` (mismatch), ``bad_fields`` (a known sentence whose fields do not parse),
``invalid_flag`` (a status/mode field saying the data are invalid: RMC ``V``, GGA quality 0,
GLL ``V`` or mode ``N``, THS ``V``, ROT/RSA/MWV ``V``), ``no_time`` (no usable time), plus those
of
:func:`usvid.io._assemble.assemble`. Other well-formed sentences are ignored and counted in
``meta["ignored_sentences"]`` and an info finding.

Two engines decode the same records: ``"fast"`` (default; vectorised checksum over the byte
buffer, then ``bytes.split`` per line; about 10x the rate of per-line pynmeagps) and
``"pynmeagps"`` (``NMEAReader.parse`` per line with checksum validation). The tests check that
both give identical trials on clean logs and on logs with damaged framing (checksum, truncation,
garbage). One known difference: pynmeagps validates every field of a sentence, the fast path only
the fields usvid decodes, so a sentence with a malformed field usvid does not use (e.g. RMC's
magnetic variation) is ``bad_fields`` for the pynmeagps engine and read by the fast one (so is
an XDR with one malformed group: the fast engine skips that group). Times and dates of GGA/RMC
are parsed by usvid's strict rules in both engines; GLL, ZDA, HDM, VHW and the wind and XDR
sentences are decoded by usvid's field rules in both (after pynmeagps has checked the
sentence).
"""

from __future__ import annotations

import math
from datetime import UTC, date, datetime
from pathlib import Path

import numpy as np

from usvid.errors import LogReadError
from usvid.files import write_atomic
from usvid.io._assemble import (
    MAX_EPOCH_S,
    apply_renames,
    assemble,
    bad_stamps,
    ignored_finding,
    read_log_bytes,
    utc_iso,
)
from usvid.io._derived import heading_from_magnetic, true_wind_direction, wind_from_magnetic
from usvid.io.sources import Sources, select_sources
from usvid.io.spec import FormatSpec
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

KN = 1852.0 / 3600.0  # m/s per knot
DEG = math.pi / 180.0
TYPES = ("GGA", "RMC", "GLL", "ZDA", "VTG", "HDT", "HDG", "HDM", "THS", "ROT", "RSA", "MWV",
         "MWD", "VWR", "VWT", "VHW", "XDR")
_FAST_TYPES = {f"{t},".encode(): t for t in TYPES}
#: Sentences that carry a UTC time of day (and ZDA, RMC a date).
_TIMED = ("GGA", "RMC", "GLL", "ZDA")
#: Types decoded with usvid's own field rules in both engines (pynmeagps validates the
#: sentence; its field model of these differs between versions, or it refuses XDR groups
#: whose value is malformed although the others are good).
_OWN_RULES = ("GLL", "ZDA", "HDM", "MWV", "MWD", "VWR", "VWT", "VHW", "XDR")
#: XDR transducer names (upper case) of an angle [deg] and the channel they give.
XDR_ANGLES = {"ROLL": "phi", "HEEL": "phi", "PITCH": "theta", "PTCH": "theta", "TRIM": "theta",
              "RUDDER": "delta", "RUD": "delta"}
_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789ABCDEF"):
    _HEX[_c] = _i
for _i, _c in enumerate(b"abcdef"):
    _HEX[_c] = 10 + _i


# ----------------------------------------------------------------------------------------------
# line framing and checksums (vectorised)
# ----------------------------------------------------------------------------------------------
def _frame(blob: bytes) -> tuple[list[bytes], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Split into lines; per line the sentence start, star position and status code.

    Status: 0 ok, 1 blank, 2 garbage, 3 truncated, 4 checksum.
    """
    lines = blob.split(b"\n")
    n = len(lines)
    lens = np.fromiter((len(x) for x in lines), dtype=np.int64, count=n)
    starts = np.zeros(n, dtype=np.int64)
    if n > 1:
        starts[1:] = np.cumsum(lens[:-1] + 1)
    arr = np.frombuffer(blob, dtype=np.uint8)
    # strip trailing \r / spaces: effective end per line
    ends = starts + lens
    # printable check per line: count bad bytes per line with cumulative sums
    bad_pos = np.flatnonzero(((arr < 32) | (arr > 126)) & (arr != 10) & (arr != 9))
    nbad = np.bincount(
        np.searchsorted(starts, bad_pos, side="right") - 1, minlength=n
    ).astype(np.int64)
    # a single trailing \r (CRLF line end) is not garbage; a \r inside a line is
    has = lens > 0
    nbad[has] -= arr[ends[has] - 1] == 13
    # first '$' or '!' per line
    marks = np.flatnonzero((arr == 36) | (arr == 33))
    line_of = np.searchsorted(starts, marks, side="right") - 1
    first = np.full(n, -1, dtype=np.int64)
    if len(marks):
        u, idx = np.unique(line_of, return_index=True)
        first[u] = marks[idx]
    stars = np.flatnonzero(arr == 42)
    sline = np.searchsorted(starts, stars, side="right") - 1
    last = np.full(n, -1, dtype=np.int64)
    if len(stars):
        # last star per line: unique on reversed
        rs = sline[::-1]
        u, idx = np.unique(rs, return_index=True)
        last[u] = stars[::-1][idx]
    # effective end without trailing \r and blanks
    stripped = np.fromiter((len(x.rstrip()) for x in lines), dtype=np.int64, count=n)
    eff_end = starts + stripped
    status = np.zeros(n, dtype=np.int8)
    blank = stripped == 0
    status[blank] = 1
    garbage = ~blank & ((first < 0) | (nbad > 0))
    status[garbage] = 2
    cand = status == 0
    trunc = cand & ((last < first) | (eff_end - last != 3))
    status[trunc] = 3
    cand = status == 0
    # checksum: xor of bytes strictly between '$' and '*'
    cx = np.bitwise_xor.accumulate(arr) if len(arr) else arr
    ci = np.flatnonzero(cand)
    if len(ci):
        a = first[ci]  # position of '$': xor over a+1 .. star-1 = cx[star-1] ^ cx[a]
        b = last[ci]
        calc = cx[b - 1] ^ cx[a]
        hi = _HEX[arr[b + 1]]
        lo = _HEX[arr[b + 2]]
        badhex = (hi == 255) | (lo == 255)
        decl = (hi.astype(np.int64) << 4) | lo.astype(np.int64)
        wrong = badhex | (decl != calc)
        status[ci[badhex]] = 3
        status[ci[wrong & ~badhex]] = 4
        # an empty body ($*hh) or a body shorter than an address is garbage
        short = (b - a) < 6
        status[ci[short & ~wrong]] = 2
    return lines, starts, first - starts, last - starts, status


# ----------------------------------------------------------------------------------------------
# time prefixes
# ----------------------------------------------------------------------------------------------
def _prefix_time(p: bytes) -> float:
    """Epoch seconds [s] from a log-line prefix, NaN when it is not a time."""
    s = p.strip().strip(b"()[]<>,;").strip()
    if not s:
        return math.nan
    try:
        v = float(s)
        return v if math.isfinite(v) and abs(v) <= MAX_EPOCH_S else math.nan
    except ValueError:
        pass
    try:
        txt = s.decode("ascii")
        if txt.endswith("Z"):
            txt = txt[:-1] + "+00:00"
        dt = datetime.fromisoformat(txt)
    except (UnicodeDecodeError, ValueError):
        return math.nan
    if dt.tzinfo is None:
        dt = dt.replace(tzinfo=UTC)
    return dt.timestamp()


def _hms(f: bytes) -> float:
    """Seconds of day from ``hhmmss.ss`` (ValueError when malformed)."""
    if len(f) < 6:
        raise ValueError("time field")
    h = int(f[0:2])
    m = int(f[2:4])
    s = float(f[4:])
    if not (0 <= h < 24 and 0 <= m < 60 and 0 <= s < 61):
        raise ValueError("time range")
    return h * 3600 + m * 60 + s


def _dmy(f: bytes) -> float:
    """Epoch seconds [s] of 00:00 UTC of ``ddmmyy`` (ValueError when malformed)."""
    if len(f) != 6:
        raise ValueError("date field")
    d = date(2000 + int(f[4:6]), int(f[2:4]), int(f[0:2]))
    return datetime(d.year, d.month, d.day, tzinfo=UTC).timestamp()


def _latlon(v: bytes, hemi: bytes, neg: bytes, deg_digits: int) -> float:
    """Degrees from ``ddmm.mmmm`` / ``dddmm.mmmm`` (fixed width: 2 or 3 degree digits)."""
    if not v:
        return math.nan
    dot = v.find(b".")
    if (dot if dot >= 0 else len(v)) != deg_digits + 2 or not v[:1].isdigit():
        raise ValueError("latitude/longitude width")
    x = float(v)
    d = int(x // 100)
    val = d + (x - 100 * d) / 60.0
    if deg_digits == 2 and not (0 <= val <= 90):
        raise ValueError("latitude range")
    if deg_digits == 3 and not (0 <= val <= 180):
        raise ValueError("longitude range")
    if hemi == neg:
        return -val
    if hemi not in (b"N", b"S", b"E", b"W"):
        raise ValueError("hemisphere")
    return val


def _num(f: bytes) -> float:
    if not f:
        return math.nan
    x = float(f)
    if not math.isfinite(x):
        raise ValueError("non-finite")
    return x


# Record: (time_of_day or nan, date_epoch or nan, {channel: value}) ; raises ValueError if bad,
# returns None when an invalid-status flag says the data are invalid.
def _decode_fields(typ: str, f: list[bytes]) -> tuple[float, float, dict[str, float]] | None:
    nan = math.nan
    if typ == "GGA":
        if len(f) < 6:
            raise ValueError("GGA fields")
        q = int(f[5]) if f[5] else 0
        tod = _hms(f[0]) if f[0] else nan
        if q == 0:
            return None
        return tod, nan, {
            "lat": _latlon(f[1], f[2], b"S", 2),
            "lon": _latlon(f[3], f[4], b"W", 3),
        }
    if typ == "RMC":
        if len(f) < 9:
            raise ValueError("RMC fields")
        tod = _hms(f[0]) if f[0] else nan
        day = _dmy(f[8]) if f[8] else nan
        if f[1] != b"A":
            if f[1] == b"V":
                return None
            raise ValueError("RMC status")
        out = {
            "lat": _latlon(f[2], f[3], b"S", 2),
            "lon": _latlon(f[4], f[5], b"W", 3),
            "sog": _num(f[6]) * KN,
            "cog": _num(f[7]) * DEG,
        }
        if len(f) >= 11 and f[9]:  # magnetic variation, east positive
            out["_variation"] = _num(f[9]) * DEG * (-1.0 if f[10] == b"W" else 1.0)
        return tod, day, out
    if typ == "GLL":
        if len(f) < 5:
            raise ValueError("GLL fields")
        tod = _hms(f[4]) if f[4] else nan
        if (len(f) >= 6 and f[5] == b"V") or (len(f) >= 7 and f[6] == b"N"):
            return None
        return tod, nan, {"lat": _latlon(f[0], f[1], b"S", 2),
                          "lon": _latlon(f[2], f[3], b"W", 3)}
    if typ == "ZDA":
        if len(f) < 4:
            raise ValueError("ZDA fields")
        tod = _hms(f[0]) if f[0] else nan
        day = nan
        if f[1] and f[2] and f[3]:
            y = int(f[3])
            y = 2000 + y if len(f[3]) <= 2 else y  # (some loggers write two digits)
            d = date(y, int(f[2]), int(f[1]))
            day = datetime(d.year, d.month, d.day, tzinfo=UTC).timestamp()
        return tod, day, {}
    if typ == "VTG":
        if len(f) < 7:
            raise ValueError("VTG fields")
        if len(f) >= 9 and f[8] == b"N":
            return None
        sog = _num(f[4]) * KN if f[4] else _num(f[6]) / 3.6
        return nan, nan, {"cog": _num(f[0]) * DEG, "sog": sog}
    if typ == "HDT":
        if len(f) < 1:
            raise ValueError("HDT fields")
        return nan, nan, {"psi": _num(f[0]) * DEG}
    if typ == "THS":
        if len(f) < 2:
            raise ValueError("THS fields")
        if f[1] == b"V":
            return None
        if f[1] not in (b"A", b"E", b"M", b"S"):
            raise ValueError("THS mode")
        return nan, nan, {"psi": _num(f[0]) * DEG}
    if typ == "HDG":
        if len(f) < 5:
            raise ValueError("HDG fields")
        h = _num(f[0])
        dev = _num(f[1]) if f[1] else 0.0
        if f[1] and f[2] == b"W":
            dev = -dev
        out = {"psi_mag": (h + dev) * DEG}
        if f[3]:
            out["_variation"] = _num(f[3]) * DEG * (-1.0 if f[4] == b"W" else 1.0)
        return nan, nan, out
    if typ == "HDM":
        if len(f) < 1:
            raise ValueError("HDM fields")
        return nan, nan, {"psi_mag": _num(f[0]) * DEG}
    if typ in ("MWV", "VWR", "VWT"):
        return _wind(typ, f)
    if typ == "MWD":
        if len(f) < 8:
            raise ValueError("MWD fields")
        spd = _num(f[6]) if f[6] else _num(f[4]) * KN
        out = {"wind_speed_true": spd}
        if f[0]:
            out["wind_dir_true"] = _num(f[0]) * DEG
        elif f[2]:
            out["_wind_dir_mag"] = _num(f[2]) * DEG
        return nan, nan, out
    if typ == "VHW":
        if len(f) < 7:
            raise ValueError("VHW fields")
        stw = _num(f[4]) * KN if f[4] else _num(f[6]) / 3.6
        return nan, nan, {"stw": stw}
    if typ == "XDR":
        return nan, nan, _xdr(f)
    if typ == "ROT":
        if len(f) < 2:
            raise ValueError("ROT fields")
        if f[1] != b"A":
            if f[1] == b"V":
                return None
            raise ValueError("ROT status")
        return nan, nan, {"r": _num(f[0]) * DEG / 60.0}
    if typ == "RSA":
        if len(f) < 2:
            raise ValueError("RSA fields")
        out = {}
        if f[1] == b"A":
            out["delta"] = _num(f[0]) * DEG
        elif f[1] != b"V":
            raise ValueError("RSA status")
        if len(f) >= 4 and f[3] == b"A":
            out["delta_port"] = _num(f[2]) * DEG
        if not out:
            return None
        return nan, nan, out
    raise ValueError(typ)


#: Wind speed units of MWV and their factor to m/s (K km/h, M m/s, N knots, S statute mph).
_WIND_UNITS = {b"K": 1.0 / 3.6, b"M": 1.0, b"N": KN, b"S": 1609.344 / 3600.0}


def _wind(typ: str, f: list[bytes]) -> tuple[float, float, dict[str, float]] | None:
    """MWV (angle 0-360 clockwise from the bow, R relative / T true, speed and its unit,
    status) and VWR / VWT (angle 0-180 and L/R, speed in knots, m/s or km/h): the wind comes
    from that angle. R and VWR: apparent (``wind_speed``, ``wind_angle``); T and VWT: the true
    wind relative to the bow (``wind_speed_true``, ``wind_angle_true``)."""
    nan = math.nan
    if typ == "MWV":
        if len(f) < 4:
            raise ValueError("MWV fields")
        if len(f) >= 5 and f[4] == b"V":
            return None
        if f[1] not in (b"R", b"T") or (f[2] and f[3] not in _WIND_UNITS):
            raise ValueError("MWV reference or unit")
        ang = _num(f[0]) * DEG
        spd = _num(f[2]) * _WIND_UNITS[f[3]] if f[2] else nan
        true = f[1] == b"T"
    else:
        if len(f) < 6:
            raise ValueError(f"{typ} fields")
        if f[0] and f[1] not in (b"L", b"R"):
            raise ValueError(f"{typ} side")
        ang = _num(f[0]) * DEG * (-1.0 if f[1] == b"L" else 1.0)
        spd = (_num(f[4]) if f[4] else _num(f[2]) * KN if f[2] else
               _num(f[6]) / 3.6 if len(f) >= 7 and f[6] else nan)
        true = typ == "VWT"
    if true:
        return nan, nan, {"wind_speed_true": spd, "wind_angle_true": ang}
    return nan, nan, {"wind_speed": spd, "wind_angle": ang}


def _xdr(f: list[bytes]) -> dict[str, float]:
    """XDR transducer groups (type, value, unit, name): angles (type A, unit D) named roll or
    heel (``phi``: positive starboard down, as B&G's heel), pitch or trim (``theta``: bow up)
    or rudder (``delta``: positive to starboard); other transducers, and groups whose value
    does not parse, are skipped (a damaged group does not spoil the others)."""
    out: dict[str, float] = {}
    for k in range(0, len(f) - 3, 4):
        typ, val, unit, name = f[k:k + 4]
        ch = XDR_ANGLES.get(name.strip().upper().decode("ascii", "replace"))
        if typ != b"A" or unit != b"D" or ch is None or ch in out:
            continue
        try:
            out[ch] = _num(val) * DEG
        except ValueError:
            continue
    return {k: v for k, v in out.items() if math.isfinite(v)}


def _sentence_type(body: bytes) -> str | None:
    """Sentence type (``GGA``...) of a standard address ``ttSSS``; None for proprietary/other."""
    addr = body.split(b",", 1)[0]
    if len(addr) != 5 or addr[:1] == b"P":
        return None
    try:
        return addr[2:].decode("ascii")
    except UnicodeDecodeError:
        return None


# ----------------------------------------------------------------------------------------------
class _Records:
    """Decoded records in compact per-column lists (memory: no dict per record)."""

    def __init__(self) -> None:
        self.line: list[int] = []
        self.pre: list[float] = []
        self.tod: list[float] = []
        self.day: list[float] = []
        self.talker: list[bytes] = []
        self.typ: list[str] = []
        self.idx: dict[str, list[int]] = {}
        self.val: dict[str, list[float]] = {}
        self._memo: dict[bytes, float] = {}

    def __len__(self) -> int:
        return len(self.line)

    def add(self, i: int, talker: bytes, typ: str, prefix: bytes, tod: float, day: float,
            values: dict) -> None:
        j = len(self.line)
        self.line.append(i)
        self.talker.append(talker)
        self.typ.append(typ)
        v = self._memo.get(prefix)
        if v is None:
            v = self._memo[prefix] = _prefix_time(prefix)
        self.pre.append(v)
        self.tod.append(tod)
        self.day.append(day)
        for k, x in values.items():
            if k not in self.idx:
                self.idx[k] = []
                self.val[k] = []
            self.idx[k].append(j)
            self.val[k].append(x)


# ----------------------------------------------------------------------------------------------
# engines: each returns per-line (line_no, type, tod, day, values) and a rejected counter
# ----------------------------------------------------------------------------------------------
def _scan_fast(blob: bytes):
    lines, _starts, first, last, status = _frame(blob)
    rejected: dict[str, int] = {}
    for code, reason in ((2, "garbage"), (3, "truncated"), (4, "checksum")):
        k = int((status == code).sum())
        if k:
            rejected[reason] = k
    recs = _Records()
    ignored: dict[str, int] = {}
    firsts = first.tolist()
    lasts = last.tolist()
    for i in np.flatnonzero(status == 0).tolist():
        line = lines[i]
        a = firsts[i]
        body = line[a + 1 : lasts[i]]
        typ = _FAST_TYPES.get(body[2:6]) if body[:1] != b"P" else None
        if typ is None:
            typ = _sentence_type(body)
            key = typ or body.split(b",", 1)[0].decode("ascii", "replace")
            ignored[key] = ignored.get(key, 0) + 1
            continue
        if b" " in body or b"*" in body:  # no decoded field holds a blank or a star
            rejected["bad_fields"] = rejected.get("bad_fields", 0) + 1
            continue
        try:
            dec = _decode_fields(typ, body.split(b",")[1:])
        except (ValueError, IndexError, OverflowError):
            rejected["bad_fields"] = rejected.get("bad_fields", 0) + 1
            continue
        if dec is None:
            rejected["invalid_flag"] = rejected.get("invalid_flag", 0) + 1
            continue
        if typ == "XDR" and not dec[2]:  # transducers usvid does not read
            ignored["XDR"] = ignored.get("XDR", 0) + 1
            continue
        recs.add(i, body[:2], typ, line[:a], *dec)
    return recs, rejected, ignored, len(lines)


def _scan_pynmeagps(blob: bytes):
    """Per-line decoding with ``pynmeagps.NMEAReader.parse`` (checksums validated)."""
    from pynmeagps import NMEAReader
    from pynmeagps.nmeatypes_core import VALCKSUM

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
            dec = (_decode_fields(typ, sent[1:star].split(b",")[1:]) if typ in _OWN_RULES
                   else _from_pynmeagps(typ, msg))
            if dec is not None and typ in ("GGA", "RMC"):
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
        if typ == "XDR" and not dec[2]:
            ignored["XDR"] = ignored.get("XDR", 0) + 1
            continue
        recs.add(i, sent[1:3], typ, line[:a], *dec)
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
        out = {
            "lat": _g(m, "lat"),
            "lon": _g(m, "lon"),
            "sog": _g(m, "spd") * KN,
            "cog": _g(m, "cog") * DEG,
        }
        var = _g(m, "mv")
        if math.isfinite(var):
            out["_variation"] = var * DEG * (-1.0 if getattr(m, "mvEW", "") == "W" else 1.0)
        return _tod(m.time), day, out
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
        out = {"psi_mag": (h + dev) * DEG}
        if not math.isnan(var):
            out["_variation"] = (-var if m.variationEW == "W" else var) * DEG
        return nan, nan, out
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


# ----------------------------------------------------------------------------------------------
# reader
# ----------------------------------------------------------------------------------------------
def _unwrap_days(tod: np.ndarray) -> np.ndarray:
    """Add 86400 s at each midnight roll-over (a drop of more than 12 h)."""
    out = tod.copy()
    ok = np.isfinite(out)
    v = out[ok]
    if len(v) > 1:
        jumps = np.r_[0, np.cumsum(np.diff(v) < -43200.0)]
        out[ok] = v + 86400.0 * jumps
    return out


def read_nmea0183(
    path: str | Path, spec: FormatSpec | None = None, *, engine: str = "fast"
) -> Trial:
    """Read an NMEA 0183 log into a multi-rate Trial (union of time stamps, NaN elsewhere).

    ``engine``: ``"fast"`` or ``"pynmeagps"`` (see module docstring). Raises
    :class:`LogReadError` (one line, naming the file) when the file is empty or holds no usable
    sentence.
    """
    path = Path(path)
    blob = read_log_bytes(path)
    if blob.startswith(b"\xef\xbb\xbf"):  # UTF-8 byte-order mark: not part of the first line
        blob = blob[3:]
    if engine == "fast":
        recs, rejected, ignored, nlines = _scan_fast(blob)
    elif engine == "pynmeagps":
        recs, rejected, ignored, nlines = _scan_pynmeagps(blob)
    else:
        raise ValueError(f"engine must be 'fast' or 'pynmeagps', got {engine!r}")
    findings: list[Finding] = []
    if ignored:
        findings.append(ignored_finding(path, "ignored_sentences", "sentence(s) of types",
                                        ignored, data={"types": dict(ignored)}))
    if not recs:
        detail = ", ".join(f"{k}: {v}" for k, v in sorted(rejected.items()))
        status = _frame(blob)[4]
        badl = np.flatnonzero(status >= 2)
        where = f"; first bad line {int(badl[0]) + 1}" if len(badl) else ""
        raise LogReadError(
            f"{path}: no usable NMEA 0183 sentence in {nlines} line(s)"
            + (f" (rejected {detail}{where})" if detail else "")
        )
    n = len(recs)
    line_no = np.asarray(recs.line, dtype=np.int64)
    pre = np.asarray(recs.pre, dtype=float)
    tod = np.asarray(recs.tod, dtype=float)
    day = np.asarray(recs.day, dtype=float)
    talkers = sorted(set(recs.talker))
    code = {tk: i for i, tk in enumerate(talkers)}
    src = np.fromiter((code[tk] for tk in recs.talker), dtype=np.int64, count=n)
    mode = spec.time_source if spec is not None else "auto"
    if mode == "auto":
        mode = "prefix" if np.isfinite(pre).mean() > 0.5 else "sentence"
    meta: dict = {"time_source": mode, "engine": engine}
    if ignored:
        meta["ignored_sentences"] = dict(ignored)
    timed_in_order = False
    if mode == "prefix":
        t_rel = pre  # epoch seconds (float64: 0.24 us resolution)
        base = 0.0
        has_date = True
    else:
        have = np.isfinite(tod)
        if not have.any():
            raise LogReadError(
                f"{path}: no time in the log: no log-line time prefix and no GGA/RMC/GLL/ZDA "
                "time")
        tod_u = _unwrap_days(tod)
        dayv = day[np.isfinite(day)]
        has_date = len(dayv) > 0
        base = float(dayv[0]) if has_date else 0.0
        # the first dated record may come after a midnight roll-over: its date is that of the
        # unwrapped day it lies in, so the date of day 0 is earlier by the roll-overs before it
        dated = np.flatnonzero(np.isfinite(day) & np.isfinite(tod))
        if len(dated):
            j = int(dated[0])
            base = float(day[j] - (tod_u[j] - tod[j]))
        # an isolated sentence time out of line with its neighbours is a bad stamp: the record
        # is timed like the sentences without a time
        order = np.argsort(line_no[have], kind="stable")
        bad = np.zeros(n, dtype=bool)
        bad[np.flatnonzero(have)[order[bad_stamps(tod_u[have][order])]]] = True
        if bad.any():
            findings.append(Finding(
                "warning", "bad_time_stamp",
                f"{path.name}: {int(bad.sum())} sentence time(s) out of line with their "
                f"neighbours (first on line {int(line_no[bad][0]) + 1}); each was re-timed "
                "between its neighbours", count=int(bad.sum())))
            have &= ~bad
        t_rel, n_epoch, n_interp = _sentence_times(line_no, tod_u, have, src,
                                                   np.asarray(recs.typ))
        lo = np.argsort(line_no[have], kind="stable")
        timed_in_order = bool(np.all(np.diff(tod_u[have][lo]) >= 0))
        if n_epoch:
            findings.append(Finding(
                "info", "time_from_epoch",
                f"{path.name}: {n_epoch} sentence(s) without their own time (e.g. VTG) got the "
                "time of the fix they follow (the last timed sentence of the same talker: a "
                "receiver sends them once per fix)", count=n_epoch))
        if n_interp:
            findings.append(
                Finding(
                    "info",
                    "time_interpolated",
                    f"{path.name}: {n_interp} sentence(s) without their own time got a time "
                    "interpolated between the neighbouring timed sentences (no log-line prefix)",
                    count=n_interp,
                )
            )
    notime = ~np.isfinite(t_rel)
    if notime.any():
        rejected["no_time"] = rejected.get("no_time", 0) + int(notime.sum())
    ok = np.isfinite(t_rel)
    if not ok.any():
        raise LogReadError(f"{path}: no sentence with a usable time ({n} sentences)")
    rel0 = float(np.min(t_rel[ok]))
    t0 = base + rel0
    if has_date:
        meta["t0_utc"] = utc_iso(t0)
        meta["t0_epoch"] = t0
    else:
        meta["t0_time_of_day_s"] = t0
    # long format -> channel arrays aligned to records
    chans = {}
    for k in sorted(recs.idx):
        a = np.full(n, np.nan)
        a[np.asarray(recs.idx[k], dtype=np.int64)] = np.asarray(recs.val[k], dtype=float)
        chans[k] = a
    t = (t_rel - rel0)[ok]
    chans = {k: v[ok] for k, v in chans.items()}
    # a message stream: one sentence type of one talker
    types = sorted(set(recs.typ))
    tcode = {ty: i for i, ty in enumerate(types)}
    stream = (np.fromiter((tcode[ty] for ty in recs.typ), dtype=np.int64, count=n) * 4096
              + src)[ok]
    src = src[ok]
    if timed_in_order:
        # the log's own times run forward: an order the sentences without a time got from
        # their fix or their neighbours (a VTG given its RMC's time after a heading given an
        # interpolated later one) is the reader's doing, not time running backwards
        o = np.argsort(t, kind="stable")
        t, src, stream = t[o], src[o], stream[o]
        chans = {k: v[o] for k, v in chans.items()}
    labels = {i: f"talker {tk.decode('ascii', 'replace')}" for i, tk in enumerate(talkers)}
    sources = Sources(src, labels, {i: tk.decode("ascii", "replace")
                                    for i, tk in enumerate(talkers)}, "talker", "talkers")
    chans, sourced, found, smeta = select_sources(path, t, chans, sources, spec,
                                                  reader="nmea0183")
    findings += found
    meta.update(smeta)
    heading_from_magnetic(path, chans, findings, "HDM/HDG")
    wind_from_magnetic(path, chans, findings, "MWD")
    true_wind_direction(path, t, chans, findings, "MWV T / VWT")
    # (fields empty throughout, e.g. an HDT without a heading, give no channel)
    chans = {k: v for k, v in chans.items() if not k.startswith("_") and np.isfinite(v).any()}
    # records left without a value: timing sentences (ZDA), another talker's (reported above),
    # a variation consumed by the heading - not bad records
    used = np.zeros(len(t), dtype=bool)
    for v in (*chans.values(), *sourced.values()):
        used |= np.isfinite(v)
    if not used.any():
        raise LogReadError(f"{path}: no channel in the log's sentences ({n} sentences, "
                           "time only)")
    chans = apply_renames({k: v[used] for k, v in chans.items()}, spec,
                          {k: v[used] for k, v in sourced.items()})
    return assemble(
        path,
        t[used],
        chans,
        spec=spec,
        rejected=rejected,
        findings=findings,
        count_duplicates=False,
        meta={**meta, "reader": "nmea0183"},
        streams=stream[used],
    )


#: A sentence type of a talker that appears at most once between two timed sentences of the
#: same talker in at least this fraction of those intervals belongs to the fix (epoch) it
#: follows.
EPOCH_SHARE = 0.9


def _sentence_times(line_no: np.ndarray, tod: np.ndarray, have: np.ndarray, src: np.ndarray,
                    typ: np.ndarray) -> tuple[np.ndarray, int, int]:
    """Times [s of day, roll-overs unwrapped] of the records of a log without line prefixes:
    the sentence's own time where it has one (``have``); for a sentence type that a talker
    sends once per fix (at most once between two timed sentences of the same talker, e.g.
    VTG after RMC) the time of the last timed sentence of that talker before it (the next one
    for those before its first); else (another talker's sentences, or several per fix such as
    a 10 Hz heading) interpolated by line position between the timed sentences of any talker,
    clamped at the ends. Returns the times and the counts of the two kinds."""
    t = np.full(len(tod), np.nan)
    t[have] = tod[have]
    need = ~have
    epoch = np.zeros(len(tod), dtype=bool)
    for tk in np.unique(src[need]):
        timed = np.flatnonzero(have & (src == tk))
        if len(timed) < 2:
            continue
        tl = line_no[timed]
        o = np.argsort(tl, kind="stable")
        tl, ti = tl[o], timed[o]
        for ty in np.unique(typ[need & (src == tk)]):
            rows = np.flatnonzero(need & (src == tk) & (typ == ty))
            slot = np.searchsorted(tl, line_no[rows], side="right")  # timed lines before it
            inner = (slot > 0) & (slot < len(tl))
            if not inner.any():
                continue
            per = np.bincount(slot[inner], minlength=len(tl) + 1)[1:len(tl)]
            if np.mean(per <= 1) < EPOCH_SHARE:
                continue
            k = np.clip(slot - 1, 0, len(tl) - 1)  # the last timed one before (or the first)
            t[rows] = tod[ti[k]]
            epoch[rows] = True
    rest = need & ~epoch
    if rest.any():
        ln = line_no[have]
        o = np.argsort(ln, kind="stable")
        ln, tt = ln[o], tod[have][o]
        # one anchor per time (the first sentence of a fix: GGA, GLL, RMC of one second would
        # give the sentences between them the same time)
        first = np.r_[True, tt[1:] != tt[:-1]]
        t[rest] = np.interp(line_no[rest].astype(float), ln[first].astype(float), tt[first])
    return t, int(epoch.sum()), int(rest.sum())


# ----------------------------------------------------------------------------------------------
# writer
# ----------------------------------------------------------------------------------------------
def checksum(body: str) -> str:
    """NMEA 0183 checksum of the text between ``$`` and ``*`` (XOR of the bytes, 2 hex digits)."""
    c = 0
    for ch in body.encode("ascii"):
        c ^= ch
    return f"{c:02X}"


def sentence(body: str) -> str:
    """``$body*hh`` with the correct checksum."""
    return f"${body}*{checksum(body)}"


def _fmt_deg_min(value: float, deg_digits: int, pos: str, neg: str) -> tuple[str, str]:
    """NMEA ``d..dmm.mmmmmm`` field (``deg_digits`` degree digits) and hemisphere letter of an
    angle [deg]."""
    a = abs(value)
    d = int(a)
    m = (a - d) * 60.0
    if round(m, 6) >= 60.0:
        d, m = d + 1, 0.0
    return f"{d:0{deg_digits}d}{m:09.6f}", (pos if value >= 0 else neg)


def _fmt_lat(lat: float) -> tuple[str, str]:
    return _fmt_deg_min(lat, 2, "N", "S")


def _fmt_lon(lon: float) -> tuple[str, str]:
    return _fmt_deg_min(lon, 3, "E", "W")


def nmea0183_lines(
    trial: Trial,
    *,
    t0_utc: str | datetime | None = None,
    gnss_talker: str = "GP",
    heading_talker: str = "HE",
    rudder_talker: str = "II",
    prefix: str = "iso",
) -> list[str]:
    """Sentences for every finite sample of ``trial`` (see :func:`write_nmea0183`)."""
    if prefix not in ("iso", "epoch", "none"):
        raise ValueError(f"prefix must be 'iso', 'epoch' or 'none', got {prefix!r}")
    e0 = log_start_epoch(trial, t0_utc)
    t = trial.t
    lat, lon = channel_or_none(trial, "lat"), channel_or_none(trial, "lon")
    psi, r = channel_or_none(trial, "psi"), channel_or_none(trial, "r")
    delta = channel_or_none(trial, "delta")
    sog = channel_or_none(trial, "sog")
    if sog is None:
        sog = channel_or_none(trial, "U")
    cog = channel_or_none(trial, "cog")
    out: list[str] = []
    for i in range(len(t)):
        ep = e0 + float(t[i])
        if prefix == "iso":
            us = int(round(ep * 1e6))
            dt = datetime.fromtimestamp(us // 1_000_000, tz=UTC)
            pre = dt.strftime("%Y-%m-%dT%H:%M:%S") + f".{us % 1_000_000:06d}Z "
        elif prefix == "epoch":
            pre = f"{ep:.6f} "
        else:
            pre = ""
        cs = int(round(ep * 100))  # GGA/RMC carry centiseconds
        dtc = datetime.fromtimestamp(cs // 100, tz=UTC)
        hms = dtc.strftime("%H%M%S") + f".{cs % 100:02d}"
        has_sog = sog is not None and math.isfinite(sog[i])
        has_cog = cog is not None and math.isfinite(cog[i])
        sog_kn = f"{sog[i] / KN:.3f}" if has_sog else ""
        cog_deg = f"{(math.degrees(cog[i]) % 360.0):.2f}" if has_cog else ""
        if lat is not None and lon is not None and math.isfinite(lat[i]) and math.isfinite(lon[i]):
            la, ns = _fmt_lat(float(lat[i]))
            lo, ew = _fmt_lon(float(lon[i]))
            out.append(pre + sentence(f"{gnss_talker}GGA,{hms},{la},{ns},{lo},{ew},1,10,0.8,0.0,M,"
                                      "0.0,M,,"))
            out.append(pre + sentence(f"{gnss_talker}RMC,{hms},A,{la},{ns},{lo},{ew},{sog_kn},"
                                      f"{cog_deg},{dtc.strftime('%d%m%y')},,,A"))
        if has_sog or has_cog:
            sog_kmh = f"{sog[i] * 3.6:.3f}" if has_sog else ""
            out.append(pre + sentence(f"{gnss_talker}VTG,{cog_deg},T,,M,{sog_kn},N,{sog_kmh},K,A"))
        if psi is not None and math.isfinite(psi[i]):
            out.append(pre + sentence(f"{heading_talker}HDT,{math.degrees(psi[i]) % 360.0:.3f},T"))
        if r is not None and math.isfinite(r[i]):
            out.append(pre + sentence(f"{heading_talker}ROT,{math.degrees(r[i]) * 60.0:.3f},A"))
        if delta is not None and math.isfinite(delta[i]):
            out.append(pre + sentence(f"{rudder_talker}RSA,{math.degrees(delta[i]):.3f},A,,V"))
    return out


def write_nmea0183(
    trial: Trial,
    path: str | Path,
    *,
    t0_utc: str | datetime | None = None,
    gnss_talker: str = "GP",
    heading_talker: str = "HE",
    rudder_talker: str = "II",
    prefix: str = "iso",
) -> Path:
    """Write a Trial as an NMEA 0183 log (atomically).

    Each finite sample becomes sentences: ``lat``/``lon`` -> GGA + RMC (with ``sog`` or ``U``
    [m/s] -> knots and ``cog`` [rad] -> degrees), ``sog``/``cog`` -> VTG, ``psi`` -> HDT [deg],
    ``r`` -> ROT [deg/min], ``delta`` -> RSA [deg] (starboard rudder field). Every line starts
    with a time prefix (``prefix="iso"``: ISO 8601 UTC with microseconds; ``"epoch"``: epoch
    seconds; ``"none"``: sentence times only) so that sub-second timing survives; t = 0 is
    ``t0_utc`` (default ``trial.meta["t0_utc"]`` or 2025-01-01). Quantisation: positions 1e-6
    arc-minutes (< 2 mm), heading/rate/rudder 1e-3 deg (deg/min), speed 1e-3 kn.
    """
    lines = nmea0183_lines(
        trial,
        t0_utc=t0_utc,
        gnss_talker=gnss_talker,
        heading_talker=heading_talker,
        rudder_talker=rudder_talker,
        prefix=prefix,
    )
    return write_atomic(path, "\r\n".join(lines) + "\r\n")
