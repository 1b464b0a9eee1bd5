"""NMEA 2000 logs in every wire format the ``nmea2000`` package decodes: reader and writer.

Formats (``n2k_format:`` in the spec, names as ``nmea2000.input_formats.N2KFormat``; detected
from the file's content when omitted), one record per line or packet, and their clocks:

- ``candump3``: ``(1700000000.123456) can0 09F11203#003930FF7FFF7FFC`` (``candump -L``), UTC;
- ``candump1``: ``<0x09F11203> [8] 00 39 30 FF 7F FF 7F FC``, no time;
- ``candump2``: ``can0  09F11203   [8]  00 39 30 FF 7F FF 7F FC``, no time;
- ``n2k_ascii`` (Actisense): ``A221320.123 03FF2 1F112 003930FF7FFF7FFC``, time of day [3];
- ``n2k_ascii_raw``: ``03FF2 1F112 003930FF7FFF7FFC``, no time;
- ``basic_string`` (canboat): ``2023-11-14T22:13:20.123Z,2,127250,3,255,8,00,39,...``, UTC;
- ``can_frame_ascii`` (Yacht Devices): ``22:13:20.123 R 09F11203 00 39 30 ...``, time of day;
- ``can_frame_ascii_raw``: ``09F11203 00 39 30 FF 7F FF 7F FC``, no time;
- ``pcdin`` (SeaSmart): ``$PCDIN,01F112,D1DDG03U,03,003930FF7FFF7FFC*4E``, UTC [2];
- ``mxpgn`` (Shipmodul): ``$MXPGN,01F112,2803,FC7FFF7FFF303900*10``, no time;
- ``pdgy`` (Digital Yacht): ``!PDGY,127250,2,3,255,100.000,ADkw/3//f/w=``, seconds [1] and
  milliseconds written as an integer without zero padding (iKonvert: ``482.36`` is
  482.036 s, between ``481.936`` and ``482.117``);
- ``ebyte`` (binary): 13-byte TCP packets (type, CAN id big endian, data), no time;
- ``waveshare`` (binary): 20-byte USB-CAN-A packets ``AA 55 ...`` with a checksum, no time;
- ``bst_d0`` / ``bst_95`` (binary): Actisense BST D0 (reassembled PGN) / BST 95 (CAN frame) in
  BDTP framing, a millisecond counter [1];
- ``python_can``: a python-can log file (``.blf``, ``.asc``, ``.trc``, ...), its stamps;
- ``ngt1`` (binary): the Actisense NGT-1 stream as ``actisense-serial`` records it: BST 93
  ("NMEA 2000 message received": priority, PGN, destination, source, a millisecond counter,
  the reassembled PGN) in BDTP framing, with a checksum; nmea2000 does not decode it, usvid
  frames it itself [1].

[1] a relative clock (seconds since the gateway started; the BST counters wrap at 2^32 ms and
2^16 ms and are unwrapped); [2] 1/1024 s since 2010-01-01 (SeaSmart); [3] ``hhmmss.ddd`` (the
example of nmea2000's documentation, ``A173321.107``, is the moment of its ``can_frame_ascii``
example ``17:33:21.107``; nmea2000 itself turns it into an offset from the present). Times of
day wrap at midnight and are unwrapped. A format without time
stamps takes the time of the last System Time (PGN 126992, 1e-4 s) before each frame, and a
relative clock gets its date from the first System Time (``meta["t0_utc"]``); a log with neither
is a one-line error. Lines with the checksum of an NMEA 0183 sentence (PCDIN, MXPGN) are checked.
The records of each format are framed as nmea2000's format decoders frame them (tested record
by record against ``NMEA2000Decoder`` bound to the format); the payloads of the PGNs read here
(all single-frame) are then decoded at once with numpy, from the field layouts of the package's
canboat database and the valid ranges its decoder reports (:func:`valid_raw`; equal to the
package's values, tested on random payloads) -- a plain loop over ``NMEA2000Decoder.decode``
is several times slower. ``python_can`` files are read by python-can's ``LogReader`` (a
dependency of ``nmea2000``). ``pdgy_debug`` lines (``$PDGY``) hold
no PGN data (nmea2000 refuses them): such a log is a one-line error. Encoding goes through the
same canboat database (``nmea2000.backend.DATABASE.encode``, the function nmea2000's own encoders
call) plus ``can_id_compose`` and ``fast_packet_fragment``; the framing of each format follows
the package's encoders (``nmea2000.encoder_formats``), with real time stamps.

Sources: every record keeps the source address of its sender; a channel that several
devices give is taken from one of them (the spec's ``source:``, else the one with the most
samples), the others are reported (:mod:`usvid.io.sources`), never interleaved.

PGNs and the Trial channels they give (canboat field ids, SI):

- 127250 Vessel Heading: ``heading`` -> ``psi`` [rad] (reference True); a magnetic heading plus
  its ``deviation`` -> ``psi_mag``, which becomes ``psi`` (plus the magnetic variation of the
  message, or of PGN 127258, their median; a warning when none is logged) when the log has no
  true heading;
- 127251 Rate of Turn: ``rate`` -> ``r`` [rad/s];
- 127245 Rudder: ``position`` -> ``delta`` [rad] (instance 0; instance 1 -> ``delta_port``),
  ``angleOrder`` -> ``delta_cmd`` [rad];
- 128259 Speed: ``speedWaterReferenced`` -> ``stw`` [m/s], ``speedGroundReferenced`` -> ``sog``;
- 129025 Position Rapid Update: ``latitude``/``longitude`` -> ``lat``/``lon`` [deg];
- 129026 COG & SOG Rapid Update: ``cog`` -> ``cog`` [rad], ``sog`` -> ``sog`` [m/s];
- 127488 Engine Parameters Rapid Update: ``speed`` [rev/s] -> ``n`` (instance 0, single engine),
  ``n_port`` (instance 0) and ``n_stbd`` (instance 1) when both instances are present;
- 127257 Attitude: ``roll`` -> ``phi`` [rad, positive starboard down: list to starboard, as
  Signal K reads it], ``pitch`` -> ``theta`` [rad, bow up], ``yaw`` -> ``psi`` [rad, taken as
  true] when the log has no 127250 heading at all (a satellite compass);
- 127258 Magnetic Variation: ``variation`` [rad, east positive] for a magnetic heading or wind;
- 130306 Wind Data: ``windSpeed`` [m/s], ``windAngle`` [rad], by ``reference``: Apparent ->
  ``wind_speed``, ``wind_angle`` (from the bow, clockwise, coming from); True (ground
  referenced to North) -> ``wind_speed_true``, ``wind_dir_true`` (from north, coming from);
  Magnetic (ground referenced to magnetic north) -> the same plus the variation when no true
  reference is logged; True (boat referenced) and True (water referenced) -> ``wind_angle_true``
  (the true wind angle from the bow, as NMEA 0183 MWV "T") and ``wind_speed_true`` when no
  north-referenced true wind is logged, with ``wind_dir_true`` = ``wind_angle_true + psi``
  (the heading interpolated at the wind's time, within 2 s; a finding says so).

Rudder sign: NMEA 2000 defines a positive rudder angle as the vessel's bow turning to starboard,
the Trial convention. Rejected records, counted per reason: ``garbage`` (not a record of the
format), ``checksum`` (PCDIN/MXPGN sentence checksum), ``truncated`` (a record of one of these
PGNs with fewer than 8 data bytes: they are all single-frame PGNs, and the decoder would otherwise
read the missing bytes as values), ``bad_frame`` (a record that does not decode), ``no_time``,
``not_available`` (every field "not available"); other PGNs are ignored and counted in
``meta["ignored_pgns"]``.
"""

from __future__ import annotations

import base64
import functools
import io
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from usvid.errors import FormatSpecError, LogReadError
from usvid.files import write_atomic
from usvid.io._assemble import (
    MAX_EPOCH_S,
    apply_renames,
    assemble,
    ignored_finding,
    read_log_bytes,
    utc_iso,
)
from usvid.io._derived import heading_from_magnetic, true_wind_direction, wind_from_magnetic
from usvid.io.sources import Sources, select_sources
from usvid.io.spec import N2K_FORMATS, FormatSpec
from usvid.io.writers import channel_or_none, log_start_epoch
from usvid.trial import Finding, Trial

PGNS = (127250, 127251, 127245, 128259, 129025, 129026, 127488, 127257, 127258, 130306)
#: System Time: the clock of a format without time stamps.
SYSTEM_TIME_PGN = 126992
_PGN_ID = {
    127250: "vesselHeading",
    127251: "rateOfTurn",
    127245: "rudder",
    128259: "speed",
    129025: "positionRapidUpdate",
    129026: "cogSogRapidUpdate",
    127488: "engineParametersRapidUpdate",
    127257: "attitude",
    127258: "magneticVariation",
    130306: "windData",
    SYSTEM_TIME_PGN: "systemTime",
}
#: PGN 130306 wind references (canboat lookup WIND_REFERENCE) -> the (speed, angle) channels.
WIND_REFERENCES = {0: ("wind_speed_true", "wind_dir_true"),  # True (ground referenced to North)
                   1: ("_wind_speed_mag", "_wind_dir_mag"),  # Magnetic (ground, magnetic north)
                   2: ("wind_speed", "wind_angle"),  # Apparent
                   3: ("_wind_speed_boat", "wind_angle_true"),  # True (boat referenced)
                   4: ("_wind_speed_water", "_wind_angle_water")}  # True (water referenced)
#: SeaSmart ($PCDIN) timer origin: 2010-01-01T00:00:00Z [epoch s]; the timer counts 1/1024 s.
PCDIN_EPOCH = 1262304000.0


@dataclass(frozen=True)
class N2kFormat:
    """How a wire format carries time: ``epoch`` (UTC seconds), ``rel`` (a relative clock of
    wrap period ``period`` [s], 0 = none) or ``none``; ``binary`` for packet formats."""

    clock: str
    period: float = 0.0
    binary: bool = False


FORMATS: dict[str, N2kFormat] = {
    "candump3": N2kFormat("epoch"),
    "candump1": N2kFormat("none"),
    "candump2": N2kFormat("none"),
    "n2k_ascii": N2kFormat("rel", 86400.0),
    "n2k_ascii_raw": N2kFormat("none"),
    "basic_string": N2kFormat("epoch"),
    "can_frame_ascii": N2kFormat("rel", 86400.0),
    "can_frame_ascii_raw": N2kFormat("none"),
    "pcdin": N2kFormat("epoch"),
    "mxpgn": N2kFormat("none"),
    "pdgy": N2kFormat("rel"),
    "ebyte": N2kFormat("none", binary=True),
    "waveshare": N2kFormat("none", binary=True),
    "bst_d0": N2kFormat("rel", 2.0**32 / 1000.0, binary=True),
    "bst_95": N2kFormat("rel", 2.0**16 / 1000.0, binary=True),
    "python_can": N2kFormat("epoch", binary=True),
    "ngt1": N2kFormat("rel", 2.0**32 / 1000.0, binary=True),
}
assert set(FORMATS) == set(N2K_FORMATS) - {"auto"}
#: Suffixes of the python-can log files detected as ``n2k_format: python_can`` (any file
#: python-can's ``LogReader`` reads, e.g. ``.mf4`` with asammdf, when named in the spec).
PYTHON_CAN_SUFFIXES = (".blf", ".asc", ".trc")


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


def _system_time(msg) -> float:
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


def _channels(msg) -> dict[str, float] | None:
    """Trial channels carried by one message decoded by the package (None: not one of ours):
    the reference semantics that :func:`decode_payloads` reproduces on whole arrays (tested
    equal on random payloads)."""
    pgn = msg.PGN
    f = _fields(msg)
    if pgn == 127250:
        ref = _raw(f.get("reference"))
        h = _val(f.get("heading"))
        if ref == 1:  # magnetic
            dev = _val(f.get("deviation"))
            out = {"psi_mag": h + (0.0 if math.isnan(dev) else dev)}
            var = _val(f.get("variation"))
            if not math.isnan(var):
                out["_variation"] = var
            return out
        return {"psi": h}
    if pgn == 127257:
        return {"_yaw": _val(f.get("yaw")), "theta": _val(f.get("pitch")),
                "phi": _val(f.get("roll"))}
    if pgn == 127258:
        return {"_variation": _val(f.get("variation"))}
    if pgn == 130306:
        ref = _raw(f.get("reference"))
        if ref not in WIND_REFERENCES:
            return {}
        sp, an = WIND_REFERENCES[ref]
        return {sp: _val(f.get("windSpeed")), an: _val(f.get("windAngle"))}
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


# ----------------------------------------------------------------------------------------------
# vectorised decoding of the payloads (layouts from the package's canboat database)
# ----------------------------------------------------------------------------------------------
#: Fields read per PGN: (canboat field id, signed). Their bit offsets, lengths and resolutions
#: are the package's (``nmea2000.backend.DATABASE``); ``reference`` and ``instance`` are lookups
#: read as their wire code.
_FIELDS: dict[int, tuple[tuple[str, bool], ...]] = {
    127250: (("heading", False), ("deviation", True), ("variation", True), ("reference", False)),
    127251: (("rate", True),),
    127245: (("instance", False), ("angleOrder", True), ("position", True)),
    128259: (("speedWaterReferenced", False), ("speedGroundReferenced", False)),
    129025: (("latitude", True), ("longitude", True)),
    129026: (("cog", False), ("sog", False)),
    127488: (("instance", False), ("speed", False)),
    127257: (("yaw", True), ("pitch", True), ("roll", True)),
    127258: (("variation", True),),
    130306: (("windSpeed", False), ("windAngle", False), ("reference", False)),
    SYSTEM_TIME_PGN: (("date", False), ("time", False)),
}
_CODES = ("reference", "instance")


@functools.cache
def _layout(pgn: int) -> tuple[tuple[str, int, int, float, bool], ...]:
    """``(field id, bit offset, bit length, resolution, signed)`` of the fields read."""
    from nmea2000.backend import DATABASE

    info = {f.id: f for f in DATABASE.pgn_info(_PGN_ID[pgn]).fields}
    return tuple((fid, int(info[fid].bit_offset), int(info[fid].bit_length),
                  float(info[fid].resolution or 1.0), signed) for fid, signed in _FIELDS[pgn])


@functools.cache
def _needed_bytes(pgn: int) -> int:
    """Data bytes a record of ``pgn`` needs to hold every field read here (fewer: truncated);
    8 for System Time and PGNs not decoded."""
    if pgn not in _FIELDS or pgn == SYSTEM_TIME_PGN:
        return 8
    return max((off + ln + 7) // 8 for _, off, ln, _, _ in _layout(pgn))


@functools.cache
def valid_raw(pgn: int, fid: str) -> tuple[int, int]:
    """The interval of raw values of field ``fid`` that the package decodes as a value: outside
    it canboat reports "not available" (its markers at the top of the range, e.g. 0xFFFD..0xFFFF,
    and its range limits, e.g. -pi for a signed angle, -90 deg for a latitude). Found by asking
    the package's decoder (bisection on single-field payloads), so that the vectorised decoder
    keeps canboat's verdicts without restating its rules."""
    from nmea2000.backend import decode

    _, off, ln, _, signed = next(f for f in _layout(pgn) if f[0] == fid)

    def ok(r: int) -> bool:
        word = (r & ((1 << ln) - 1)) << off
        msg = decode(pgn, word.to_bytes(8, "little"), units="si")
        return msg is not None and next(f for f in msg.fields if f.id == fid).value is not None

    lo, hi = (-(1 << (ln - 1)), (1 << (ln - 1)) - 1) if signed else (0, (1 << ln) - 1)
    a, b = 0, hi
    while a < b:  # the largest valid raw value
        m = (a + b + 1) // 2
        a, b = (m, b) if ok(m) else (a, m - 1)
    top = a
    a, b = lo, 0
    while a < b:  # the smallest
        m = (a + b) // 2
        a, b = (a, m) if ok(m) else (m + 1, b)
    return a, top


def decode_payloads(pgn: np.ndarray, payload: np.ndarray
                    ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Decode 8-byte payloads ``payload`` (N, 8) uint8 of PGNs ``pgn`` (N,) at once.

    Returns the Trial channels (name -> (N,) float, NaN where a record does not carry it or the
    field is "not available"; the names and values of :func:`_channels` on the package's
    decoding) and the System Time of each 126992 record [epoch s] (NaN elsewhere). Values are
    ``raw * resolution`` in SI, as canboat's; the valid raw intervals are :func:`valid_raw`.
    """
    n = len(pgn)
    word = np.ascontiguousarray(payload, dtype=np.uint8).view("<u8")[:, 0]
    chans: dict[str, np.ndarray] = {}
    sys_epoch = np.full(n, np.nan)

    def put(name: str, rows: np.ndarray, values: np.ndarray) -> None:
        if not len(rows):
            return
        if name not in chans:
            chans[name] = np.full(n, np.nan)
        chans[name][rows] = values

    for p in np.unique(pgn):
        p = int(p)
        if p not in _FIELDS:
            continue
        rows = np.flatnonzero(pgn == p)
        w = word[rows]
        raw: dict[str, np.ndarray] = {}
        val: dict[str, np.ndarray] = {}
        for fid, off, ln, res, signed in _layout(p):
            r = ((w >> np.uint64(off)) & np.uint64((1 << ln) - 1)).astype(np.int64)
            if signed:
                r = np.where(r >= 1 << (ln - 1), r - (1 << ln), r)
            raw[fid] = r
            if fid not in _CODES:
                lo, hi = valid_raw(p, fid)
                val[fid] = np.where((r >= lo) & (r <= hi), r * res, np.nan)
        if p == 127250:
            mag = raw["reference"] == 1
            put("psi", rows[~mag], val["heading"][~mag])
            if mag.any():
                put("psi_mag", rows[mag], val["heading"][mag]
                    + np.nan_to_num(val["deviation"][mag]))
                var = val["variation"][mag]
                put("_variation", rows[mag][np.isfinite(var)], var[np.isfinite(var)])
        elif p == 127257:
            put("_yaw", rows, val["yaw"])
            put("theta", rows, val["pitch"])
            put("phi", rows, val["roll"])
        elif p == 127258:
            put("_variation", rows, val["variation"])
        elif p == 130306:
            for ref, (sp, an) in WIND_REFERENCES.items():
                k = raw["reference"] == ref
                put(sp, rows[k], val["windSpeed"][k])
                put(an, rows[k], val["windAngle"][k])
        elif p == 127251:
            put("r", rows, val["rate"])
        elif p == 127245:
            # a number here (a lookup in 127488): "not available" reads as instance 0
            lo, hi = valid_raw(p, "instance")
            ri = np.where((raw["instance"] >= lo) & (raw["instance"] <= hi), raw["instance"], 0)
            for inst in np.unique(ri):
                k = ri == inst
                put("delta" if inst == 0 else f"delta_{'port' if inst == 1 else int(inst)}",
                    rows[k], val["position"][k])
                if inst == 0:
                    put("delta_cmd", rows[k], val["angleOrder"][k])
        elif p == 128259:
            put("stw", rows, val["speedWaterReferenced"])
            put("sog", rows, val["speedGroundReferenced"])
        elif p == 129025:
            put("lat", rows, val["latitude"])
            put("lon", rows, val["longitude"])
        elif p == 129026:
            put("cog", rows, val["cog"])
            put("sog", rows, val["sog"])
        elif p == 127488:
            for inst in np.unique(raw["instance"]):
                k = raw["instance"] == inst
                put(f"_engine{int(inst)}", rows[k], val["speed"][k])
        else:  # System Time
            d, t = val["date"], val["time"]
            ok = (d < 65533) & (t < 86400.5)  # (NaN compares False)
            sys_epoch[rows[ok]] = d[ok] * 86400.0 + t[ok]
    return chans, sys_epoch


# ----------------------------------------------------------------------------------------------
# records of each format: (wire time or NaN, PGN, data bytes) or None (not a record: garbage)
# ----------------------------------------------------------------------------------------------
def pgn_of_can_id(can_id: int) -> int:
    """PGN of a 29-bit CAN id (PDU1 PGNs carry the destination in their low byte)."""
    pgn = (can_id >> 8) & 0x3FFFF
    if (pgn >> 8) & 0xFF < 240:
        pgn &= 0x3FF00
    return pgn


def _pgn_dpp(pdus: int, pduf: int, dpp: int) -> int:
    return ((dpp & 0x03) << 16) | (pduf << 8) | (pdus if pduf >= 240 else 0)


_H = r"[0-9A-Fa-f]"
_BYTES = rf"((?:\s+{_H}{{2}})*)"
_RE = {
    "candump3": re.compile(rf"^\(([^)]*)\)\s+\S+\s+({_H}{{8}})#({_H}*)$"),
    "candump1": re.compile(rf"^<0x({_H}{{1,8}})>\s+\[(\d+)\]{_BYTES}$"),
    "candump2": re.compile(rf"^[A-Za-z][A-Za-z0-9_-]*\s+({_H}{{8}})\s+\[(\d+)\]{_BYTES}$"),
    "n2k_ascii": re.compile(
        rf"^A(\d\d)(\d\d)(\d\d(?:\.\d+)?)\s+({_H}{{5}})\s+({_H}{{5,6}})\s+({_H}*)$"),
    "n2k_ascii_raw": re.compile(rf"^({_H}{{5}})\s+({_H}{{5,6}})\s+({_H}*)$"),
    "can_frame_ascii": re.compile(
        rf"^(\d\d):(\d\d):(\d\d(?:\.\d+)?)\s+[RT]\s+({_H}{{8}}){_BYTES}$"),
    "can_frame_ascii_raw": re.compile(rf"^({_H}{{8}}){_BYTES}$"),
    "pcdin": re.compile(rf"^\$PCDIN,({_H}{{6}}),([0-9A-Va-v]{{1,8}}),({_H}{{2}}),({_H}*)$"),
    "mxpgn": re.compile(rf"^\$MXPGN,({_H}{{6}}),({_H}{{2}})({_H}{{2}}),({_H}*)$"),
}
_BASIC_TIME = re.compile(r"^\d{4}-\d\d-\d\d[T-]\d\d:\d\d:\d\d(\.\d+)?Z?$")


def _hex(hexs: str) -> bytes | None:
    """Bytes of a hex string (None: an odd number of digits)."""
    return bytes.fromhex(hexs) if len(hexs) % 2 == 0 else None


def _spaced(hexs: str, dlc: int | None = None) -> bytes | None:
    """Bytes of space-separated hex pairs (at most ``dlc`` of them; None: more than 8)."""
    b = bytes.fromhex(hexs)
    if len(b) > 8:
        return None
    return b if dlc is None else b[:dlc]


def _sentence(line: str) -> tuple[str, bool | None]:
    """An NMEA 0183 sentence without its tag block and checksum; whether the checksum matched
    (None: no checksum)."""
    if line.startswith("\\"):
        parts = line.split("\\")
        if len(parts) >= 3:
            line = parts[2]
    body, star, cs = line.partition("*")
    if not star:
        return body, None
    try:
        return body, int(cs[:2], 16) == xor8(body[1:].encode("latin-1"))
    except (ValueError, UnicodeEncodeError):
        return body, False


def xor8(b: bytes) -> int:
    """XOR of all bytes of ``b`` (the NMEA 0183 checksum), folded as one integer in halves at
    byte boundaries (a few big-integer operations instead of a loop over the characters)."""
    x, n = int.from_bytes(b, "little"), len(b)
    while n > 1:
        h = (n + 1) // 2
        x = (x & ((1 << (8 * h)) - 1)) ^ (x >> (8 * h))
        n = h
    return x


def _basic_time(stamp: str) -> float:
    if not _BASIC_TIME.match(stamp):
        return math.nan
    s = stamp.rstrip("Z")
    if "T" not in s:
        s = s[:10] + "T" + s[11:]
    try:
        return datetime.fromisoformat(s).replace(tzinfo=UTC).timestamp()
    except ValueError:
        return math.nan


def pdgy_time(stamp: str) -> float:
    """Seconds [s] of a Digital Yacht PDGY stamp: whole seconds, a point, then the
    milliseconds as an integer without zero padding (iKonvert writes 482.036 s as ``482.36``,
    and 482.117 s as ``482.117``); NaN when it is not such a stamp."""
    sec, dot, ms = stamp.partition(".")
    if not sec.isdigit() or (dot and not (ms.isdigit() and len(ms) <= 3)):
        return math.nan
    return int(sec) + (int(ms) / 1000.0 if ms else 0.0)


def parse_text_record(fmt: str, line: str
                      ) -> tuple[float, int, bytes | None, int] | str | None:
    """``(wire time [s] or NaN, PGN, payload, source address)`` of one line of text format
    ``fmt`` (the payload in wire order: a CAN frame's data, or the whole PGN of a reassembled
    format; None when its data field is malformed; the source -1 where the format gives none);
    None when the line is not a record of the format, ``"checksum"`` when its sentence checksum
    is wrong."""
    nan = math.nan
    if fmt == "basic_string":
        p = line.split(",")
        if len(p) < 6 or not all(x.isdigit() for x in p[1:6]):
            return None
        if any(len(x) != 2 for x in p[6:]):
            return None
        try:
            data = bytes.fromhex("".join(p[6:]))
        except ValueError:
            return None
        return (_basic_time(p[0]), int(p[2]), data if len(data) >= int(p[5]) else None,
                int(p[3]) & 0xFF)
    if fmt == "pdgy":
        if not line.startswith("!PDGY,"):
            return None
        p = line.split(",")
        try:
            if len(p) == 7:
                return (pdgy_time(p[5]), int(p[1]), base64.b64decode(p[6], validate=True),
                        int(p[3]) & 0xFF)
            if len(p) == 4:
                return nan, int(p[1]), base64.b64decode(p[3], validate=True), -1
        except ValueError:
            return None
        return None
    if fmt in ("pcdin", "mxpgn"):
        body, ok = _sentence(line)
        m = _RE[fmt].match(body)
        if m is None:
            return None
        if ok is False:
            return "checksum"
        pgn = int(m.group(1), 16)
        data = _hex(m.group(4))
        src = int(m.group(3), 16)
        if fmt == "pcdin":
            return int(m.group(2), 32) / 1024 + PCDIN_EPOCH, pgn, data, src
        # Shipmodul: the data bytes in reverse order, their count in the attribute word
        if data is None or len(data) != int(m.group(2), 16) & 0x0F:
            return nan, pgn, None, src
        return nan, pgn, data[::-1], src
    m = _RE[fmt].match(line)
    if m is None:
        return None
    g = m.groups()
    if fmt == "candump3":
        try:
            stamp = float(g[0])
        except ValueError:
            stamp = nan
        data = _hex(g[2])
        cid = int(g[1], 16)
        return (stamp, pgn_of_can_id(cid), data if data is None or len(data) <= 8 else None,
                cid & 0xFF)
    if fmt in ("candump1", "candump2"):
        cid = int(g[0], 16)
        return nan, pgn_of_can_id(cid), _spaced(g[2], int(g[1])), cid & 0xFF
    if fmt == "n2k_ascii":  # the 5 hex digits: source (2), destination (2), priority (1)
        return (int(g[0]) * 3600 + int(g[1]) * 60 + float(g[2]), int(g[4], 16), _hex(g[5]),
                int(g[3], 16) >> 12)
    if fmt == "n2k_ascii_raw":
        return nan, int(g[1], 16), _hex(g[2]), int(g[0], 16) >> 12
    if fmt == "can_frame_ascii":
        cid = int(g[3], 16)
        return (int(g[0]) * 3600 + int(g[1]) * 60 + float(g[2]), pgn_of_can_id(cid),
                _spaced(g[4]), cid & 0xFF)
    # can_frame_ascii_raw
    cid = int(g[0], 16)
    return nan, pgn_of_can_id(cid), _spaced(g[1]), cid & 0xFF


_DLE, _STX, _ETX = 0x10, 0x02, 0x03


def bdtp_frames(blob: bytes) -> Iterator[tuple[int, int, bytes | None]]:
    """The data blocks of an Actisense BDTP stream (``DLE STX .. DLE ETX``, ``DLE DLE`` escapes
    a data DLE): ``(start, end, block)`` (byte offsets), block None for a damaged frame (an
    unknown escape, a new start inside a frame, or the end of the file inside a frame)."""
    n = len(blob)
    i = blob.find(b"\x10\x02")
    while i >= 0:
        out = bytearray()
        j = i + 2
        block: bytes | None = None
        nxt = -1
        while True:
            k = blob.find(b"\x10", j)
            if k < 0 or k + 1 >= n:
                out = None  # type: ignore[assignment]
                break
            out += blob[j:k]
            c = blob[k + 1]
            if c == _ETX:
                block = bytes(out)
                nxt = k + 2
                break
            if c == _DLE:
                out.append(_DLE)
                j = k + 2
                continue
            nxt = k if c == _STX else k + 2  # a new frame starts / unknown escape: damaged
            break
        yield i, (nxt if nxt >= 0 else n), block
        if nxt < 0:
            return
        i = blob.find(b"\x10\x02", nxt)


def binary_records(fmt: str, blob: bytes) -> Iterator[tuple[float, int, bytes, int] | str]:
    """Records of a binary format: ``(wire time [s] or NaN, PGN, payload in wire order, source
    address)``, or a reason string (``garbage``, ``truncated``, ``bad_frame``) for a damaged
    stretch."""
    nan = math.nan
    if fmt == "ebyte":
        i, n, junk = 0, len(blob), False
        while i < n:
            b = blob[i]
            ln = b & 0x0F
            if b & 0x80 and 1 <= ln <= 8 and i + 5 + ln <= n:
                pkt = blob[i:i + 5 + ln]
                cid = int.from_bytes(pkt[1:5], "big") & 0x1FFFFFFF
                yield nan, pgn_of_can_id(cid), pkt[5:], cid & 0xFF
                i += 5 + ln
                junk = False
                continue
            if not junk:
                yield "truncated" if b & 0x80 and 1 <= ln <= 8 else "garbage"
                junk = True
            i += 1
        return
    if fmt == "waveshare":
        i, n = 0, len(blob)
        while True:
            k = blob.find(b"\xaa\x55", i)
            if k < 0:
                if blob[i:].strip(b"\x00"):
                    yield "garbage"
                return
            if k > i and blob[i:k].strip(b"\x00"):
                yield "garbage"
            if k + 20 > n:
                yield "truncated"
                return
            pkt = blob[k:k + 20]
            if sum(pkt[2:19]) & 0xFF != pkt[19]:
                yield "bad_frame"  # the checksum: resynchronise after the marker (as nmea2000)
                i = k + 2
                continue
            cid = int.from_bytes(pkt[5:9], "little") & 0x1FFFFFFF
            yield nan, pgn_of_can_id(cid), pkt[10:10 + min(pkt[9], 8)], cid & 0xFF
            i = k + 20
        return
    # bst_d0 / bst_95 / ngt1 (BST 93) in BDTP framing
    want = {"bst_d0": 0xD0, "bst_95": 0x95, "ngt1": 0x93}[fmt]
    last = 0
    for off, end, blk in bdtp_frames(blob):
        if off > last and blob[last:off].strip(b"\x00"):
            yield "garbage"
        last = end
        if blk is None:
            yield "truncated"
            continue
        if blk and want == 0x93 and blk[0] == 0xA0:
            yield "device_message"  # the NGT-1's own status and settings
            continue
        if not blk or blk[0] != want:
            yield "garbage"
            continue
        if sum(blk) & 0xFF:
            yield "bad_frame"
            continue
        if want == 0xD0:
            if len(blk) < 14 or int.from_bytes(blk[1:3], "little") != len(blk) - 1:
                yield "bad_frame"
                continue
            ms = int.from_bytes(blk[9:13], "little")
            yield ms / 1000.0, _pgn_dpp(blk[5], blk[6], blk[7]), blk[13:-1], blk[4]
        elif want == 0x93:
            # 93, length (of what follows up to the checksum), priority, PGN (3 bytes, little
            # endian), destination, source, milliseconds (4), data length, data, checksum
            if len(blk) < 14 or blk[1] != len(blk) - 3 or blk[12] != len(blk) - 14:
                yield "bad_frame"
                continue
            ms = int.from_bytes(blk[8:12], "little")
            pgn = int.from_bytes(blk[3:6], "little") & 0x3FFFF
            yield ms / 1000.0, pgn, blk[13:-1], blk[7]
        else:
            if len(blk) < 9 or blk[1] != len(blk) - 3:
                yield "bad_frame"
                continue
            ms = int.from_bytes(blk[2:4], "little")
            yield ms / 1000.0, _pgn_dpp(blk[5], blk[6], blk[7]), blk[8:-1], blk[4]
    if blob[last:].strip(b"\x00"):
        yield "garbage"


# ----------------------------------------------------------------------------------------------
# format detection
# ----------------------------------------------------------------------------------------------
#: Plausible NMEA 2000 PGNs (ISO request 59392 up to the last proprietary fast-packet 131071):
#: a line of another kind that happens to match a format's pattern rarely names one.
_PGN_RANGE = (59392, 131071)


def _library_text_format(line: str) -> str | None:
    """nmea2000's own detection of one text line, refined where it lumps two of our formats."""
    from nmea2000.input_formats import detect_format

    try:
        f = detect_format(line).value
    except ValueError:
        return None
    if f == "n2k_ascii_raw" and line.startswith("A"):
        return "n2k_ascii"
    if f == "can_frame_ascii" and not re.match(r"^\d\d:", line):
        return "can_frame_ascii_raw"
    return f


#: The first byte of a BDTP frame (the BST command) of each binary Actisense format.
_BST_COMMANDS = {0xD0: "bst_d0", 0x95: "bst_95", 0x93: "ngt1"}


def detect_n2k_format(path: Path, head: bytes) -> str | None:
    """The NMEA 2000 wire format of a log from its first bytes ``head`` (None: not one)."""
    k = head.find(b"\x10\x02", 0, 16)  # (a capture may start inside a frame)
    if k >= 0 and len(head) > k + 2 and head[k + 2] in _BST_COMMANDS:
        return _BST_COMMANDS[head[k + 2]]
    if head[:2] == b"\xaa\x55":
        return "waveshare"
    if head[:4] == b"LOGG" or path.suffix.lower() in PYTHON_CAN_SUFFIXES:
        return "python_can"
    if len(head) >= 13 and head[0] & 0x80 and 1 <= head[0] & 0x0F <= 8:
        recs = []
        for r in binary_records("ebyte", head[:13 * 8]):
            recs.append(r)
            if len(recs) == 4:
                break
        if recs and all(isinstance(r, tuple) and _PGN_RANGE[0] <= r[1] <= _PGN_RANGE[1]
                        for r in recs):
            return "ebyte"
    try:
        text = head.decode("ascii")
    except UnicodeDecodeError:
        text = head.decode("ascii", errors="replace")
    lines = [ln.strip() for ln in text.splitlines()[:200] if ln.strip()]
    votes: dict[str, int] = {}
    for ln in lines:
        f = _library_text_format(ln)
        if f is None or f not in FORMATS and f != "pdgy_debug":
            continue
        if f != "pdgy_debug":
            r = parse_text_record(f, ln)
            if not isinstance(r, tuple) or not _PGN_RANGE[0] <= r[1] <= _PGN_RANGE[1]:
                continue
        votes[f] = votes.get(f, 0) + 1
    if not votes:
        return None
    best = max(votes, key=lambda k: votes[k])
    # the majority of the lines: a NMEA 0183 log with a few $PCDIN sentences stays NMEA 0183
    return best if 2 * votes[best] >= len(lines) else None


# ----------------------------------------------------------------------------------------------
# reader
# ----------------------------------------------------------------------------------------------
def _unwrap(w: np.ndarray, period: float) -> np.ndarray:
    """A wrapping relative clock [s] made monotonic (a step back of more than half the period
    is a wrap)."""
    if period <= 0 or len(w) < 2:
        return w
    d = np.diff(w)
    wraps = np.r_[0.0, np.cumsum(np.where(d < -period / 2, period, 0.0))]
    return w + wraps


def _python_can_records(path: Path):
    """Messages of a python-can log file as ``(stamp, PGN, data)``."""
    import can

    try:
        reader = can.LogReader(str(path))
    except Exception as exc:  # unknown suffix, a missing optional package, unreadable file
        why = str(exc).splitlines()[0][:120] if str(exc) else ""
        raise LogReadError(f"{path}: python-can cannot read this file "
                           f"({type(exc).__name__}: {why})") from None
    it = iter(reader)
    try:
        while True:
            try:
                m = next(it)
            except StopIteration:
                return
            if not m.is_extended_id or m.is_error_frame or m.is_remote_frame:
                yield "garbage"
                continue
            yield (float(m.timestamp), pgn_of_can_id(m.arbitration_id), bytes(m.data),
                   m.arbitration_id & 0xFF)
    except Exception:  # python-can raises struct/zlib/value errors on a damaged file
        yield "damaged"
    finally:
        stop = getattr(reader, "stop", None)
        if stop is not None:
            try:
                stop()
            except Exception:  # noqa: S110 - closing a damaged file
                pass


def read_nmea2000(path: str | Path, spec: FormatSpec | None = None) -> Trial:
    """Read an NMEA 2000 log in any format of :data:`FORMATS` into a multi-rate Trial (SI units,
    radians).

    The format: ``spec.n2k_format``, detected from the content when ``auto`` or no spec
    (``meta["n2k_format"]``). Time: ``t`` [s] since the first record, ``meta["t0_utc"]`` its
    ISO time when the log carries a date (see the module docstring). Raises
    :class:`LogReadError` naming the file when the file is empty, not of the format, or has no
    usable frame.
    """
    path = Path(path)
    blob = read_log_bytes(path)
    fmt = spec.n2k_format if spec is not None else "auto"
    if fmt == "auto":
        found = detect_n2k_format(path, blob[:65536])
        if found == "pdgy_debug":
            raise LogReadError(f"{path}: Digital Yacht debug lines ($PDGY) carry no PGN data "
                               "(nmea2000 does not decode them)")
        if found is None:
            raise LogReadError(
                f"{path}: not an NMEA 2000 log in a format usvid reads (n2k_format: one of "
                f"{', '.join(FORMATS)})")
        fmt = found
    info = FORMATS[fmt]
    rejected: dict[str, int] = {}
    ignored: dict[int, int] = {}
    wires: list[float] = []  # per record kept: wire time (NaN: none), PGN, 8-byte payload,
    pgns: list[int] = []  # source address (-1: none in the format)
    payloads: list[bytes] = []
    srcs: list[int] = []
    first_bad: int | None = None
    n_records = 0
    device_msgs = 0  # NGT-1 messages of the gateway itself (BST A0), not bus traffic
    wanted = {*PGNS, SYSTEM_TIME_PGN}
    epoch_clock = info.clock == "epoch"

    def rej(reason: str, where: int) -> None:
        nonlocal first_bad
        rejected[reason] = rejected.get(reason, 0) + 1
        if first_bad is None:
            first_bad = where

    def take(where: int, wire: float, pgn: int, payload: bytes | None, src: int) -> None:
        if pgn not in wanted:
            ignored[pgn] = ignored.get(pgn, 0) + 1
        elif payload is None:
            rej("garbage", where)
        elif len(payload) < _needed_bytes(pgn):  # every PGN read here is a single frame
            rej("truncated", where)
        elif epoch_clock and not (math.isfinite(wire) and abs(wire) <= MAX_EPOCH_S):
            rej("no_time", where)
        else:
            wires.append(wire)
            pgns.append(pgn)
            # (a sender may leave out trailing reserved bytes: "not available" there)
            payloads.append(payload[:8].ljust(8, b"\xff"))
            srcs.append(src)

    if not info.binary:
        text = blob.decode("ascii", errors="replace")
        lines = text.splitlines()
        for lineno, raw in enumerate(lines, start=1):
            line = raw.strip()
            if not line:
                continue
            n_records += 1
            r = parse_text_record(fmt, line)
            if r is None:
                rej("garbage", lineno)
                continue
            if isinstance(r, str):
                rej(r, lineno)
                continue
            take(lineno, r[0], r[1], r[2], r[3])
        what = f"{len(lines)} line(s)"
    else:
        recs = (_python_can_records(path) if fmt == "python_can"
                else binary_records(fmt, blob))
        damaged = False
        for r in recs:
            n_records += 1
            if isinstance(r, str):
                if r == "damaged":
                    damaged = True
                elif r == "device_message":
                    device_msgs += 1
                else:
                    rej(r, n_records)
                continue
            take(n_records, r[0], r[1], r[2], r[3])
        what = f"{n_records} record(s)"
        if damaged:
            rej("damaged_file", n_records)
    findings: list[Finding] = []
    meta: dict = {"reader": "nmea2000", "n2k_format": fmt}
    if ignored:
        meta["ignored_pgns"] = {str(k): v for k, v in sorted(ignored.items())}
        findings.append(ignored_finding(path, "ignored_pgns", "frame(s) of PGNs", ignored))
    if device_msgs:
        findings.append(Finding(
            "info", "gateway_messages", f"{path.name}: ignored {device_msgs} message(s) of the "
            "NGT-1 gateway itself (BST A0: its status and settings, no bus traffic)",
            count=device_msgs))

    def fail(extra: str = "") -> LogReadError:
        detail = ", ".join(f"{k}: {v}" for k, v in sorted(rejected.items()))
        where = f" (first bad record {first_bad})" if first_bad else ""
        return LogReadError(
            f"{path}: no usable NMEA 2000 frame ({fmt}) in {what}"
            + (f"; rejected {detail}{where}" if detail else "") + extra)

    if not pgns:
        raise fail()
    pg = np.asarray(pgns, dtype=np.int64)
    pay = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(-1, 8)
    chans, sys_epoch = decode_payloads(pg, pay)
    w_all = np.asarray(wires, dtype=float)
    is_sys = pg == SYSTEM_TIME_PGN
    anyval = np.zeros(len(pg), dtype=bool)
    for v in chans.values():
        anyval |= np.isfinite(v)
    n_na = int((~is_sys & ~anyval).sum())  # every field "not available"
    if n_na:
        rejected["not_available"] = rejected.get("not_available", 0) + n_na
    data = ~is_sys & anyval
    if not data.any():
        raise fail()
    # the System Time before each record (index of the last valid one)
    sys_ok = is_sys & np.isfinite(sys_epoch)
    last = np.maximum.accumulate(np.where(sys_ok, np.arange(len(pg)), -1))
    systs = np.where(last >= 0, sys_epoch[np.maximum(last, 0)], np.nan)
    w = w_all[data]
    chans = {k: v[data] for k, v in chans.items()}
    src = np.asarray(srcs, dtype=np.int64)[data]
    stream = pg[data] * 256 + src  # a message stream: one PGN from one sender
    clock = info.clock
    if fmt == "python_can" and np.nanmax(np.abs(w)) < 1e8:
        clock = "rel"  # python-can gives time since the start of the file (e.g. .asc, .trc)
    t0_epoch = math.nan
    if clock == "epoch":
        t_abs = w
        t0_epoch = float(np.nanmin(t_abs))
    elif clock == "rel" and np.isfinite(w).any():
        fin = np.isfinite(w_all) & (data | sys_ok)
        unw = np.full(len(w_all), np.nan)
        unw[fin] = _unwrap(w_all[fin], info.period)
        w = unw[data]
        keep = np.isfinite(w)
        _add_no_time(rejected, int((~keep).sum()))
        chans = {k: v[keep] for k, v in chans.items()}
        src, stream = src[keep], stream[keep]
        t_abs = w[keep]
        first_sys = np.flatnonzero(sys_ok & np.isfinite(unw))
        if len(first_sys):  # the first System Time on the same clock dates the log
            j = int(first_sys[0])
            t0_epoch = float(sys_epoch[j]) - (float(unw[j]) - float(np.min(t_abs)))
    else:  # no wire time: the System Time broadcast on the bus
        s_d = systs[data]
        ok = np.isfinite(s_d)
        if not ok.any():
            raise fail(f"; the {fmt} format has no time stamps and the log no System Time "
                       f"(PGN {SYSTEM_TIME_PGN})")
        _add_no_time(rejected, int((~ok).sum()))
        chans = {k: v[ok] for k, v in chans.items()}
        src, stream = src[ok], stream[ok]
        t_abs = s_d[ok]
        t0_epoch = float(np.min(t_abs))
    # engine instances -> n or n_port/n_stbd
    eng = sorted(k for k in chans if k.startswith("_engine"))
    if eng == ["_engine0"]:
        chans["n"] = chans.pop("_engine0")
    else:
        for k in eng:
            inst = int(k[len("_engine"):])
            chans[{0: "n_port", 1: "n_stbd"}.get(inst, f"n_{inst}")] = chans.pop(k)
    # fields the bus marked "not available" throughout (e.g. an unused angleOrder) are absent
    chans = {k: v for k, v in chans.items() if np.isfinite(v).any()}
    t_min = float(np.min(t_abs))
    t_rel = t_abs - t_min
    # one source per channel (the spec's, else the most samples); the others reported
    labels = {int(a): (f"0x{int(a):02X}" if a >= 0 else "unknown") for a in np.unique(src)}
    sources = Sources(src, labels, {int(a): int(a) for a in np.unique(src) if a >= 0},
                      "source address", "source addresses")
    chans, sourced, found, smeta = select_sources(path, t_rel, chans, sources, spec,
                                                  reader="nmea2000")
    findings += found
    meta.update(smeta)
    _derive(path, t_rel, chans, findings)
    chans = {k: v for k, v in chans.items()
             if not k.startswith("_") and np.isfinite(v).any()}
    # records left without a value: another source's (reported above) or consumed by a
    # derived channel (a magnetic variation) - not bad records
    used = np.zeros(len(t_rel), dtype=bool)
    for v in (*chans.values(), *sourced.values()):
        used |= np.isfinite(v)
    if not used.all():
        chans = {k: v[used] for k, v in chans.items()}
        sourced = {k: v[used] for k, v in sourced.items()}
        t_rel, stream = t_rel[used], stream[used]
    _check_bus_rate(path, t_rel, findings)
    if math.isfinite(t0_epoch):
        meta["t0_epoch"] = t0_epoch
        meta["t0_utc"] = utc_iso(t0_epoch)
    chans = apply_renames(chans, spec, sourced)
    return assemble(
        path,
        t_rel,
        chans,
        spec=spec,
        rejected=rejected,
        findings=findings,
        count_duplicates=False,
        meta=meta,
        streams=stream,
    )


#: Records per second no NMEA 2000 bus carries: 250 kbit/s over CAN frames of 8 data bytes
#: (at least 111 bits with a 29-bit identifier, before bit stuffing) is at most 2,250 frames/s,
#: and a reassembled fast-packet PGN is several frames.
MAX_BUS_RECORDS_S = 2250.0


def _check_bus_rate(path: Path, t: np.ndarray, findings: list[Finding]) -> None:
    """A warning when the records decoded here arrive faster than a bus can carry them (over
    the whole log, at least 100 records): their stamps are not their times of arrival (a
    recorder that stamped a buffer as it read it)."""
    n = len(t)
    span = float(np.max(t) - np.min(t)) if n else 0.0
    if n < 100 or n <= MAX_BUS_RECORDS_S * span:
        return
    rate = n / span if span > 0 else math.inf
    findings.append(Finding(
        "warning", "time_stamps_collapsed",
        f"{path.name}: {n} records of the PGNs read are stamped within {span:.3f} s "
        f"({rate:,.0f} per second, more than a 250 kbit/s NMEA 2000 bus carries: at most "
        f"{MAX_BUS_RECORDS_S:,.0f}): the stamps are not the records' times of arrival (a "
        "recorder that stamped a buffer as it read it); rates, derivatives and the physics "
        "checks of this log are meaningless", count=n,
        data={"records": n, "span_s": span}))


def _derive(path: Path, t: np.ndarray, chans: dict[str, np.ndarray],
            findings: list[Finding]) -> None:
    """Channels derived from others (module docstring): the heading from PGN 127257's yaw or a
    magnetic heading, the true wind from its magnetic or bow-referenced forms. In place."""
    if not ("psi" in chans and np.isfinite(chans["psi"]).any()):
        yaw = chans.get("_yaw")
        mag = chans.get("psi_mag")
        if mag is not None and np.isfinite(mag).any():  # 127250 says it is magnetic
            heading_from_magnetic(path, chans, findings, "PGN 127250")
        elif yaw is not None and np.isfinite(yaw).any():
            chans["psi"] = np.remainder(yaw, 2 * math.pi)
            findings.append(Finding(
                "info", "heading_from_attitude",
                f"{path.name}: no heading (PGN 127250) in the log: psi is the yaw of the "
                "attitude (PGN 127257), taken as a true heading (a satellite compass; the "
                "yaw of a magnetic compass is off by the variation)",
                count=int(np.isfinite(yaw).sum()), channel="psi"))
    wind_from_magnetic(path, chans, findings, "PGN 130306")
    have = {k for k, v in chans.items() if np.isfinite(v).any()}
    for sp, an in (("_wind_speed_boat", "wind_angle_true"),
                   ("_wind_speed_water", "_wind_angle_water")):
        if sp in have and "wind_speed_true" not in have:
            chans["wind_speed_true"] = chans[sp]
            have.add("wind_speed_true")
        if an in have and "wind_angle_true" not in have:
            chans["wind_angle_true"] = chans[an]
            have.add("wind_angle_true")
    true_wind_direction(path, t, chans, findings, "PGN 130306")


def _add_no_time(rejected: dict[str, int], n: int) -> None:
    if n:
        rejected["no_time"] = rejected.get("no_time", 0) + n


def read_candump(path: str | Path, spec: FormatSpec | None = None) -> Trial:
    """Read a ``candump -L`` NMEA 2000 log (the ``candump3`` format of :func:`read_nmea2000`,
    unless ``spec.n2k_format`` names another)."""
    if spec is None:
        spec = FormatSpec(reader="nmea2000", n2k_format="candump3", source="<candump>")
    elif spec.n2k_format == "auto":
        spec = replace(spec, n2k_format="candump3")
    return read_nmea2000(path, spec)
# ----------------------------------------------------------------------------------------------
# writer
# ----------------------------------------------------------------------------------------------
class _Encoder:
    """PGN payloads through nmea2000's canboat database, framed as CAN frames."""

    def __init__(self, source: int, interface: str, priority: int = 2) -> None:
        from nmea2000 import _canboat as cb
        from nmea2000.backend import DATABASE

        self.cb = cb
        self.db = DATABASE
        self.src = source
        self.iface = interface
        self.prio = priority
        self.seq = 0

    def payload(self, pgn: int, fields: dict) -> bytes:
        return self.db.encode(_PGN_ID[pgn], fields, src=self.src, prio=self.prio)

    def can_id(self, pgn: int) -> int:
        return self.cb.can_id_compose(self.prio, pgn, self.src, 255)

    def frames(self, pgn: int, fields: dict) -> list[tuple[int, bytes]]:
        payload = self.payload(pgn, fields)
        cid = self.can_id(pgn)
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


def _pgn_messages(trial: Trial, e0: float) -> Iterator[tuple[int, float, int, dict]]:
    """``(sample index, epoch [s], PGN, canboat fields)`` for every finite sample of ``trial``."""
    lat, lon, psi, r = (channel_or_none(trial, k) for k in ("lat", "lon", "psi", "r"))
    delta, dcmd = channel_or_none(trial, "delta"), channel_or_none(trial, "delta_cmd")
    sog = channel_or_none(trial, "sog" if "sog" in trial.data.columns else "U")
    cog = channel_or_none(trial, "cog")
    n, n_p, n_s = (channel_or_none(trial, k) for k in ("n", "n_port", "n_stbd"))
    t = trial.t

    def fin(a: np.ndarray | None, i: int) -> bool:
        return a is not None and math.isfinite(a[i])

    for i in range(len(t)):
        st = e0 + float(t[i])
        sid = i % 250
        if fin(lat, i) and fin(lon, i):
            yield i, st, 129025, {"latitude": float(lat[i]), "longitude": float(lon[i])}
        if fin(cog, i) or fin(sog, i):
            yield i, st, 129026, {
                "sid": sid, "cogReference": 0,
                "cog": float(cog[i]) % (2 * math.pi) if fin(cog, i) else None,
                "sog": float(sog[i]) if fin(sog, i) else None,
            }
        if fin(psi, i):
            yield i, st, 127250, {"sid": sid, "heading": float(psi[i]) % (2 * math.pi),
                                  "deviation": None, "variation": None, "reference": 0}
        if fin(r, i):
            yield i, st, 127251, {"sid": sid, "rate": float(r[i])}
        if fin(delta, i) or fin(dcmd, i):
            yield i, st, 127245, {
                "instance": 0, "directionOrder": 0,
                "angleOrder": float(dcmd[i]) if fin(dcmd, i) else None,
                "position": float(delta[i]) if fin(delta, i) else None,
            }
        for inst, arr in ((0, n), (0, n_p), (1, n_s)):
            if fin(arr, i):
                yield i, st, 127488, {"instance": inst, "speed": float(arr[i])}


def candump_lines(
    trial: Trial,
    *,
    t0_utc: str | datetime | None = None,
    source: int = 3,
    interface: str = "can0",
) -> list[str]:
    """candump -L lines for every finite sample of ``trial`` (see :func:`write_candump`)."""
    enc = _Encoder(source, interface)
    out: list[str] = []
    for _, st, pgn, fields in _pgn_messages(trial, log_start_epoch(trial, t0_utc)):
        out += enc.lines(st, pgn, fields)
    return out


def _b32(x: int, width: int = 8) -> str:
    digits = "0123456789ABCDEFGHIJKLMNOPQRSTUV"
    out = ""
    for _ in range(width):
        out = digits[x % 32] + out
        x //= 32
    return out


def _nmea0183(body: str) -> str:
    x = 0
    for ch in body[1:]:
        x ^= ord(ch)
    return f"{body}*{x:02X}"


def _bdtp(block: bytes) -> bytes:
    return b"\x10\x02" + block.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def _bst_checksum(block: bytes) -> bytes:
    return block + bytes([(256 - sum(block) % 256) % 256])


class _KeepOpen(io.BytesIO):
    def close(self) -> None:  # python-can's writers close their file on stop()
        pass


def nmea2000_bytes(
    trial: Trial,
    n2k_format: str = "candump3",
    *,
    t0_utc: str | datetime | None = None,
    source: int = 3,
    boot_offset_s: float = 100.0,
) -> bytes:
    """The bytes of :func:`write_nmea2000` (see there)."""
    if n2k_format not in FORMATS:
        raise FormatSpecError(f"n2k_format: unknown NMEA 2000 format {n2k_format!r} (one of: "
                              f"{', '.join(FORMATS)})")
    if n2k_format == "candump3":
        return ("\n".join(candump_lines(trial, t0_utc=t0_utc, source=source)) + "\n").encode()
    e0 = log_start_epoch(trial, t0_utc)
    enc = _Encoder(source, "can0")
    info = FORMATS[n2k_format]
    msgs: list[tuple[float, int, dict]] = []
    last = -1
    for i, st, pgn, fields in _pgn_messages(trial, e0):
        if info.clock != "epoch" and i != last:  # the bus clock before each sample's frames
            day = math.floor(round(st, 4) / 86400.0)
            msgs.append((st, SYSTEM_TIME_PGN, {"sid": i % 250, "source": 0, "date": day,
                                               "time": round(st - 86400.0 * day, 4)}))
            last = i
        msgs.append((st, pgn, fields))
    out_t: list[str] = []
    out_b: list[bytes] = []
    prio, src = enc.prio, enc.src
    can_msgs = []
    for st, pgn, fields in msgs:
        rel = st - e0 + boot_offset_s  # a gateway clock started boot_offset_s before the log
        if n2k_format in ("n2k_ascii", "n2k_ascii_raw", "basic_string", "pcdin", "mxpgn",
                          "pdgy", "bst_d0", "ngt1"):  # reassembled PGN formats
            pl = enc.payload(pgn, fields)
            if n2k_format in ("n2k_ascii", "n2k_ascii_raw"):
                rec = f"{(src << 12) | (255 << 4) | prio:05X} {pgn:05X} {pl.hex().upper()}"
                tod = datetime.fromtimestamp(round(st, 3), tz=UTC).strftime("%H%M%S.%f")[:-3]
                out_t.append(f"A{tod} {rec}" if n2k_format == "n2k_ascii" else rec)
            elif n2k_format == "basic_string":
                ts = datetime.fromtimestamp(round(st, 3), tz=UTC).strftime(
                    "%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
                out_t.append(",".join([ts, str(prio), str(pgn), str(src), "255", str(len(pl)),
                                       *(f"{b:02x}" for b in pl)]))
            elif n2k_format == "pcdin":
                timer = _b32(round((st - PCDIN_EPOCH) * 1024))
                out_t.append(_nmea0183(f"$PCDIN,{pgn:06X},{timer},{src:02X},{pl.hex().upper()}"))
            elif n2k_format == "mxpgn":
                attr = f"{(prio & 7) << 4 | (len(pl) & 0x0F):02X}{src:02X}"
                out_t.append(_nmea0183(f"$MXPGN,{pgn:06X},{attr},{pl[::-1].hex().upper()}"))
            elif n2k_format == "pdgy":  # (iKonvert: milliseconds without zero padding)
                ms = round(rel * 1000)
                out_t.append(f"!PDGY,{pgn},{prio},{src},255,{ms // 1000}.{ms % 1000},"
                             + base64.b64encode(pl).decode("ascii"))
            elif n2k_format == "ngt1":
                ms = round(rel * 1000) % 2**32
                blk = bytes([0x93, 11 + len(pl), prio, *pgn.to_bytes(3, "little"), 255, src,
                             *ms.to_bytes(4, "little"), len(pl)]) + pl
                out_b.append(_bdtp(_bst_checksum(blk)))
            else:  # bst_d0
                pf = (pgn >> 8) & 0xFF
                head = bytes([0xD0, *(13 + len(pl)).to_bytes(2, "little"), 255, src,
                              pgn & 0xFF if pf >= 240 else 255, pf,
                              (prio & 7) << 2 | (pgn >> 16) & 3, 0])
                ms = round(rel * 1000) % 2**32
                out_b.append(_bdtp(_bst_checksum(head + ms.to_bytes(4, "little") + pl)))
            continue
        for cid, data in enc.frames(pgn, fields):  # CAN frame formats
            hx = " ".join(f"{b:02X}" for b in data)
            if n2k_format == "candump1":
                out_t.append(f"<0x{cid:08X}> [{len(data)}] {hx}")
            elif n2k_format == "candump2":
                out_t.append(f"can0  {cid:08X}   [{len(data)}]  {hx}")
            elif n2k_format == "can_frame_ascii":
                tod = datetime.fromtimestamp(round(st, 3), tz=UTC).strftime("%H:%M:%S.%f")[:-3]
                out_t.append(f"{tod} R {cid:08X} {hx}")
            elif n2k_format == "can_frame_ascii_raw":
                out_t.append(f"{cid:08X} {hx}")
            elif n2k_format == "ebyte":
                out_b.append(bytes([0x80 | len(data)]) + cid.to_bytes(4, "big") + data)
            elif n2k_format == "waveshare":
                pkt = (b"\xaa\x55\x01\x02\x01" + cid.to_bytes(4, "little") + bytes([len(data)])
                       + data.ljust(8, b"\x00") + b"\x00")
                out_b.append(pkt + bytes([sum(pkt[2:19]) & 0xFF]))
            elif n2k_format == "bst_95":
                pf = (pgn >> 8) & 0xFF
                ms = round(rel * 1000) % 2**16
                blk = bytes([0x95, 6 + len(data), *ms.to_bytes(2, "little"), src,
                             pgn & 0xFF if pf >= 240 else 255, pf,
                             (prio & 7) << 2 | (pgn >> 16) & 3]) + data
                out_b.append(_bdtp(_bst_checksum(blk)))
            else:  # python_can
                can_msgs.append((st, cid, data))
    if n2k_format == "python_can":
        import can

        buf = _KeepOpen()
        writer = can.BLFWriter(buf)
        for st, cid, data in can_msgs:
            writer.on_message_received(can.Message(timestamp=st, arbitration_id=cid,
                                                   is_extended_id=True, data=data))
        writer.stop()
        return buf.getvalue()
    if out_t:
        return ("\r\n".join(out_t) + "\r\n").encode()
    return b"".join(out_b)


def write_nmea2000(
    trial: Trial,
    path: str | Path,
    n2k_format: str = "candump3",
    *,
    t0_utc: str | datetime | None = None,
    source: int = 3,
) -> Path:
    """Write a Trial as an NMEA 2000 log in wire format ``n2k_format`` (any of :data:`FORMATS`;
    ``python_can`` writes a Vector BLF file through python-can), atomically.

    Channels -> PGNs as :func:`write_candump`. Time: the format's own time stamps (``candump3``
    microseconds, ``basic_string`` / ``can_frame_ascii`` milliseconds, ``pcdin`` 1/1024 s,
    ``n2k_ascii`` / ``pdgy`` / BST a gateway clock in ms started 100 s before the log); a System
    Time frame (PGN 126992, 1e-4 s) precedes each sample's frames in every format without UTC
    stamps, so that the log can be dated (and timed, where the format has no stamps).
    """
    return write_atomic(path, nmea2000_bytes(trial, n2k_format, t0_utc=t0_utc, source=source))


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
