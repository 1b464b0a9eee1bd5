"""Trial format specs: how a log file maps onto the Trial contract (``ARCHITECTURE.md``).

A spec is YAML read with ``yaml.safe_load`` only and validated field by field; an unknown key, a
wrong type, an unknown unit or a unit that does not fit its channel raises
:class:`usvid.errors.FormatSpecError` naming the spec file and the field
(``"hsva.yaml: columns.psi.unit: unknown unit 'degs' (known: s, ms, ...)"``).

Schema (every key optional except ``reader``)::

    reader: table            # table | excel | parquet | nmea0183 | nmea2000
    delimiter: whitespace    # table only: whitespace | "," | ";" | "\\t" (or "tab")
    skip_rows: 4             # lines (table) / rows (excel) skipped before the header or the data
    header: false            # true: the first row after skip_rows holds the column names
    comment: "#"             # table only: lines starting with this are ignored
    encoding: cp1252         # text encoding (table, nmea0183)
    sheet: Sheet1            # excel only: sheet name or 0-based index
    non_monotonic: sort      # sort | reject: records whose time goes back (see readers)
    time_source: auto        # nmea0183 only: auto | prefix | sentence
    description: "..."       # free text
    columns:                 # Trial channel -> source column (0-based index or header name)
      t:     {col: 0, unit: s}
      psi:   {col: 3, unit: deg, sign: 1, offset: 0.0, scale: 1.0, optional: false}
      delta: 8               # shorthand: {col: 8} with the channel's SI unit
    vessel: {length: 7.0, speed: 1.18, beam: 1.27, draft: 0.455, mass: 3272,
             displacement: 3.27, block_coefficient: 0.81, extra: {scale_factor: 45.7}}

Conversion of one column: ``value = sign * factor(unit) * (scale * raw + offset)``, i.e. ``scale``
and ``offset`` act in the source unit, then the unit is converted to the Trial unit of the channel
(SI, radians; ``lat``/``lon`` in degrees) and ``sign`` (+1 or -1) flips the convention (e.g. a
rudder angle positive to port gets ``sign: -1``).

For the ``nmea0183`` and ``nmea2000`` readers ``columns`` is optional: the readers decode the
standard channels themselves (``lat lon psi r delta U sog cog n ...``); an entry there renames or
re-signs a decoded channel (``delta: {col: delta, sign: -1}``) and must not name a unit other than
the channel's Trial unit. ``n2k_format`` (nmea2000 only) names the wire format of the log (one of
:data:`N2K_FORMATS`, default ``auto``). ``source:`` (readers ``nmea0183``, ``nmea2000``,
``tlog``) takes a channel from one sender when several give it (:mod:`usvid.io.sources`): a
talker (``psi: {col: psi, source: HE}``), a source address (``source: 23``), a MAVLink
``"system/component"``; a second column may keep another sender's samples under its own name
(``psi_b: {col: psi, source: 128}``).

Message-based logs (readers ``rosbag``, ``ulog``, ``dataflash``, ``tlog``) map each channel onto one
field of one message type; the time of a row is the time of its message, and messages of different
rates are merged on one clock (the union of their times, NaN elsewhere)::

    columns:
      lat:   {topic: /gps/fix, field: latitude, unit: deg}
      psi:   {topic: /imu/data, field: orientation, convert: yaw, frame: enu}
      r:     {topic: /imu/data, field: angular_velocity.z, unit: rad/s, sign: -1}
      delta: {message: RCOU, field: C1, convert: pwm, pwm: [1100, 1500, 1900], scale: 35,
              unit: deg}
      n:     {message: ESC, field: RPM, instance: 0, unit: rpm}

``topic`` and ``message`` are synonyms (a ROS topic, a PX4 uORB topic, an ArduPilot DataFlash or
MAVLink message name). ``field`` is a dotted path with ``[i]`` indices (``twist.twist.linear.x``,
``xyz[2]``, ``rpm[0]``). ``instance`` selects a multi-instance message (PX4 ``multi_id``,
DataFlash instance column ``I``/``Instance``). ``convert``:

- ``yaw``: the field is a quaternion (ROS ``geometry_msgs/Quaternion`` with x, y, z, w, or PX4's
  ``q[0..3]`` = w, x, y, z); the heading is its yaw. ``frame: enu`` (ROS REP 103: x east, y north,
  z up, yaw counter-clockwise from east; the default for ``rosbag``) gives ``psi = pi/2 - yaw``;
  ``frame: ned`` (PX4, ArduPilot; the default elsewhere) gives ``psi = yaw``. Wrapped to
  [0, 2 pi).
- ``roll`` / ``pitch``: the roll ``phi`` [rad, positive starboard down] and the pitch ``theta``
  [rad, bow up] of a quaternion (ZYX Euler angles). A body frame FRD (``frame: ned``) gives
  them as they are; a body frame FLU (``frame: enu``, ROS: y to port, z up) the same roll and
  the pitch with the opposite sign (a positive rotation about y to port puts the bow down).
- ``pwm``: a servo pulse width [us] becomes a normalised command in [-1, 1] through
  ``pwm: [min, trim, max]`` (default ``[1100, 1500, 1900]``); ``scale``/``unit`` then turn it
  into a rudder angle (``scale: 35, unit: deg``) or leave it a dimensionless thruster command.
- ``speed`` / ``course``: the field is a horizontal velocity vector (x, y) in ``frame``; the
  channel is its norm [m/s] or its direction [rad, clockwise from north, in [0, 2 pi)].

After the conversion ``value = sign * factor(unit) * (scale * raw + offset)`` as for tables.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from usvid.errors import FormatSpecError, UsvidError
from usvid.files import load_yaml_text, read_input_text, special_file
from usvid.io import units as _units
from usvid.trial import CHANNEL_UNITS, VESSEL_FIELDS, Vessel

_FIELD_PATH = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*(\.[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*)*$")

READERS = ("table", "excel", "parquet", "nmea0183", "nmea2000", "rosbag", "ulog", "dataflash",
           "tlog")
#: Readers of message-based logs (columns name a message type and a field).
MESSAGE_READERS = ("rosbag", "ulog", "dataflash", "tlog")
#: NMEA 2000 wire formats the ``nmea2000`` reader reads: every input format the ``nmea2000``
#: package decodes, named as ``nmea2000.input_formats.N2KFormat`` (see :mod:`usvid.io.n2k`);
#: ``python_can`` is a log file python-can reads (.asc, .blf, .trc, ...); ``ngt1`` the
#: Actisense NGT-1 binary stream (BST 93 in DLE framing, framed by usvid); ``auto`` detects it.
N2K_FORMATS = ("auto", "candump3", "candump1", "candump2", "n2k_ascii", "n2k_ascii_raw",
               "basic_string", "can_frame_ascii", "can_frame_ascii_raw", "pcdin", "mxpgn", "pdgy",
               "ebyte", "waveshare", "bst_d0", "bst_95", "python_can", "ngt1")
CONVERTS = ("yaw", "roll", "pitch", "pwm", "speed", "course")
#: Conversions of a quaternion field (4 raw values: w, x, y, z).
QUATERNION_CONVERTS = ("yaw", "roll", "pitch")
FRAMES = ("enu", "ned")
DELIMITERS = {"whitespace": None, ",": ",", ";": ";", "\t": "\t", "tab": "\t"}
SPEC_KEYS = (
    "reader",
    "delimiter",
    "skip_rows",
    "header",
    "comment",
    "encoding",
    "sheet",
    "non_monotonic",
    "time_source",
    "n2k_format",
    "description",
    "variants",
    "columns",
    "vessel",
)
COLUMN_KEYS = ("col", "unit", "sign", "offset", "scale", "optional", "source")
MESSAGE_COLUMN_KEYS = ("topic", "message", "field", "unit", "sign", "offset", "scale", "optional",
                       "convert", "frame", "instance", "pwm", "source")
#: Readers whose records name their sender (``source:`` of a column; :mod:`usvid.io.sources`).
SOURCE_READERS = ("nmea0183", "nmea2000", "tlog")
#: Optional particulars the ``vessel`` block also accepts directly (SI; kept in
#: ``Vessel.extra``): centre of gravity forward of midship [m], yaw moment of inertia about it
#: [kg m^2], propeller diameter [m], rudder area [m^2] (the MMG model's particulars).
VESSEL_PARTICULARS = ("x_g", "yaw_inertia", "propeller_diameter", "rudder_area")
VESSEL_KEYS = (*VESSEL_FIELDS, *VESSEL_PARTICULARS, "extra")
_SPECS_DIR = Path(__file__).resolve().parents[1] / "specs"


@dataclass(frozen=True)
class ColumnSpec:
    """One Trial channel read from one source column.

    ``col`` is a 0-based index or a header name; ``unit`` a key of :data:`usvid.io.units.UNITS`
    (or ``datetime`` for the time column); ``sign`` +1/-1; ``offset``/``scale`` in the source unit;
    ``optional`` columns may be absent from the file.

    Message-based logs (see the module docstring): ``topic`` is the message type or topic,
    ``col`` the field path, ``conversion`` (YAML ``convert``) one of :data:`CONVERTS`
    (``None``: the field's value), ``frame`` the earth frame of a quaternion or velocity vector,
    ``instance`` the instance of a multi-instance message, ``pwm`` the (min, trim, max) pulse
    widths [us] of ``convert: pwm``.

    ``source`` (readers ``nmea2000``, ``nmea0183``, ``tlog``): the sender to take the channel
    from when several give it (:mod:`usvid.io.sources`): an NMEA 2000 source address 0-253,
    an NMEA 0183 talker (``"HE"``), a MAVLink ``"system/component"`` (``"1/1"``) or system id.
    """

    name: str
    col: int | str
    unit: str | None = None
    sign: float = 1.0
    offset: float = 0.0
    scale: float = 1.0
    optional: bool = False
    topic: str | None = None
    conversion: str | None = None
    frame: str = "ned"
    instance: int | None = None
    pwm: tuple[float, float, float] = (1100.0, 1500.0, 1900.0)
    source: int | str | None = None

    @property
    def factor(self) -> float:
        """Multiplier from the (scaled, offset) source value to the Trial unit, sign included."""
        if self.unit is None or self.unit == _units.DATETIME:
            return self.sign
        return self.sign * _units.target_factor(self.name, self.unit)

    def convert(self, raw: Any) -> Any:
        """``sign * factor(unit) * (scale * raw + offset)`` (numpy arrays or floats)."""
        if self.scale == 1.0 and self.offset == 0.0:  # (one pass over an array, not three)
            return self.factor * raw
        return self.factor * (self.scale * raw + self.offset)


@dataclass(frozen=True)
class FormatSpec:
    """A validated trial format spec (see the module docstring for the YAML schema)."""

    reader: str
    columns: dict[str, ColumnSpec] = field(default_factory=dict)
    delimiter: str | None = None  # None = whitespace
    skip_rows: int = 0
    header: bool | None = None  # None: decided by the reader (excel/parquet: True, table: False)
    comment: str | None = None
    encoding: str = "utf-8"
    sheet: int | str = 0
    non_monotonic: str = "sort"
    time_source: str = "auto"
    n2k_format: str = "auto"
    description: str = ""
    vessel: Vessel = field(default_factory=Vessel)
    source: str = "<spec>"
    variants: dict[str, FormatSpec] = field(default_factory=dict)

    @property
    def uses_names(self) -> bool:
        """True when any column is addressed by header name."""
        return any(isinstance(c.col, str) for c in self.columns.values())


#: Codecs that are text codecs to Python but not encodings of a text file (IDNA host names,
#: escape sequences, the codec that refuses everything).
NOT_FILE_ENCODINGS = frozenset({"idna", "punycode", "undefined", "unicode-escape",
                                "raw-unicode-escape", "unicode_escape", "raw_unicode_escape"})


def _err(source: str, where: str, msg: str) -> FormatSpecError:
    if len(msg) > 300:  # a value echoed in the message may be huge (hostile YAML)
        msg = msg[:300] + "..."
    return FormatSpecError(f"{source}: {where}: {msg}" if where else f"{source}: {msg}")


def _check_keys(d: dict, allowed: tuple[str, ...], source: str, where: str) -> None:
    for k in d:
        if k not in allowed:
            loc = f"{where}.{k}" if where else str(k)
            raise _err(source, loc, f"unknown key '{k}' (allowed: {', '.join(allowed)})")


def _number(v: Any, source: str, where: str, *, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise _err(source, where, f"expected a number, got {v!r}")
    f = float(v)
    if not math.isfinite(f):
        raise _err(source, where, f"expected a finite number, got {v!r}")
    if positive and f <= 0:
        raise _err(source, where, f"must be > 0 (got {v!r})")
    return f


def _unit(name: str, unit: Any, source: str, where: str) -> str | None:
    if unit is None:
        return None
    cu = _units.canonical_unit(str(unit))
    if cu is None:
        raise _err(source, f"{where}.unit",
                   f"unknown unit '{unit}' (known: {', '.join(_units.known_units())})")
    if cu == _units.DATETIME and name != "t":
        raise _err(source, f"{where}.unit", "unit 'datetime' is only allowed for 't'")
    if cu != _units.DATETIME:
        try:
            _units.target_factor(name, cu)
        except ValueError as exc:
            raise _err(source, f"{where}.unit", str(exc)) from None
    return cu


def _message_column(name: str, v: Any, reader: str, source: str) -> ColumnSpec:
    """A column of a message-based log: ``{topic|message: NAME, field: PATH, ...}``."""
    where = f"columns.{name}"
    if not isinstance(v, dict):
        raise _err(source, where, f"expected a mapping {{topic: ..., field: ..., unit: ...}}, "
                                  f"got {v!r}")
    _check_keys(v, MESSAGE_COLUMN_KEYS, source, where)
    if name == "t":
        raise _err(source, where, f"the {reader} reader takes the time of each message; "
                                  "no 't' column")
    if "topic" in v and "message" in v:
        raise _err(source, where, "give 'topic' or 'message', not both")
    key = "topic" if "topic" in v else "message"
    topic = v.get(key)
    if not isinstance(topic, str) or not topic.strip():
        raise _err(source, f"{where}.{key}", f"missing or not a name (got {topic!r}): the "
                                            "topic / message the channel is read from")
    fld = v.get("field")
    if not isinstance(fld, str) or not _FIELD_PATH.match(fld):
        raise _err(source, f"{where}.field", f"expected a field path such as 'latitude', "
                                             f"'twist.twist.linear.x' or 'xyz[2]', got {fld!r}")
    conv = v.get("convert")
    if conv is not None and conv not in CONVERTS:
        raise _err(source, f"{where}.convert", f"expected one of {', '.join(CONVERTS)}, "
                                               f"got {conv!r}")
    frame = v.get("frame", "enu" if reader == "rosbag" else "ned")
    if frame not in FRAMES:
        raise _err(source, f"{where}.frame", f"expected enu or ned, got {frame!r}")
    if "frame" in v and conv not in (*QUATERNION_CONVERTS, "speed", "course"):
        raise _err(source, f"{where}.frame", "only used with convert: yaw, roll, pitch, speed "
                                             "or course")
    unit = _unit(name, v.get("unit"), source, where)
    if conv in (*QUATERNION_CONVERTS, "course") and unit not in (None, "rad"):
        raise _err(source, f"{where}.unit", f"convert: {conv} gives radians; no unit needed")
    if conv == "speed" and unit not in (None, "m/s"):
        raise _err(source, f"{where}.unit", "convert: speed gives m/s; no unit needed")
    inst = v.get("instance")
    if inst is not None and (isinstance(inst, bool) or not isinstance(inst, int) or inst < 0):
        raise _err(source, f"{where}.instance", f"expected an integer >= 0, got {inst!r}")
    pwm = v.get("pwm", [1100, 1500, 1900])
    if "pwm" in v and conv != "pwm":
        raise _err(source, f"{where}.pwm", "only used with convert: pwm")
    if not isinstance(pwm, list | tuple) or len(pwm) != 3:
        raise _err(source, f"{where}.pwm", f"expected [min, trim, max] in us, got {pwm!r}")
    lo, trim, hi = (_number(x, source, f"{where}.pwm") for x in pwm)
    if not lo < trim < hi:
        raise _err(source, f"{where}.pwm", f"expected min < trim < max, got {list(pwm)!r}")
    return ColumnSpec(name=name, col=fld, unit=unit, **_linear(v, source, where),
                      topic=topic.strip(), conversion=conv, frame=frame, instance=inst,
                      pwm=(lo, trim, hi), source=_source(v, reader, source, where))


def _source(v: dict, reader: str, source: str, where: str) -> int | str | None:
    """The ``source`` of a column, checked for its reader: an NMEA 2000 address 0-253, an
    NMEA 0183 talker of two characters, a MAVLink ``"system/component"`` or system id."""
    if "source" not in v:
        return None
    x = v["source"]
    w = f"{where}.source"
    if reader not in SOURCE_READERS:
        raise _err(source, w, f"only used by reader {' / '.join(SOURCE_READERS)}, not {reader}")
    if reader == "nmea2000":
        if isinstance(x, bool) or not isinstance(x, int) or not 0 <= x <= 253:
            raise _err(source, w, f"expected an NMEA 2000 source address 0..253, got {x!r}")
        return x
    if reader == "nmea0183":
        if not isinstance(x, str) or not re.fullmatch(r"[A-Z0-9]{2}", x.strip().upper()):
            raise _err(source, w, f"expected an NMEA 0183 talker such as \"HE\", got {x!r}")
        return x.strip().upper()
    if isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= 255:
        return f"{x}"
    if not isinstance(x, str) or not re.fullmatch(r"\d{1,3}(/\d{1,3})?", x.strip()) or any(
            int(p) > 255 for p in x.strip().split("/")):
        raise _err(source, w, f"expected a MAVLink system/component such as \"1/1\" (or a "
                              f"system id), got {x!r}")
    return x.strip()


def _linear(v: dict, source: str, where: str) -> dict[str, Any]:
    """``sign`` (1 or -1), ``offset``, ``scale`` and ``optional`` of a column mapping (the
    keys every reader's columns share), checked."""
    sign = _number(v.get("sign", 1), source, f"{where}.sign")
    if sign not in (1.0, -1.0):
        raise _err(source, f"{where}.sign", f"must be 1 or -1 (got {v['sign']!r})")
    optional = v.get("optional", False)
    if not isinstance(optional, bool):
        raise _err(source, f"{where}.optional", f"expected true or false, got {optional!r}")
    return {"sign": sign, "offset": _number(v.get("offset", 0.0), source, f"{where}.offset"),
            "scale": _number(v.get("scale", 1.0), source, f"{where}.scale"),
            "optional": optional}


def _column(name: str, v: Any, reader: str, source: str) -> ColumnSpec:
    where = f"columns.{name}"
    if reader in MESSAGE_READERS:
        return _message_column(name, v, reader, source)
    if isinstance(v, int | str) and not isinstance(v, bool):
        v = {"col": v}
    if not isinstance(v, dict):
        raise _err(source, where, f"expected a mapping {{col: ..., unit: ...}}, got {v!r}")
    _check_keys(v, COLUMN_KEYS, source, where)
    if "col" not in v:
        raise _err(source, where, "missing key 'col' (0-based column index or header name)")
    col = v["col"]
    if isinstance(col, bool) or not isinstance(col, int | str):
        raise _err(source, f"{where}.col", f"expected an index or a header name, got {col!r}")
    if isinstance(col, int) and col < 0:
        raise _err(source, f"{where}.col", f"column index must be >= 0 (got {col})")
    unit = _unit(name, v.get("unit"), source, where)
    lin = _linear(v, source, where)
    if lin["optional"] and name == "t":
        raise _err(source, f"{where}.optional", "the time column cannot be optional")
    return ColumnSpec(name=name, col=col, unit=unit, **lin,
                      source=_source(v, reader, source, where))


def column_mapping(c: ColumnSpec, reader: str) -> dict[str, Any]:
    """The YAML mapping of a column as a spec file writes it (keys with their default values
    left out): the inverse of the parsing, for messages that quote a user's own column with a
    change (``{col: 8, unit: deg, sign: -1}``)."""
    out: dict[str, Any] = {}
    if reader in MESSAGE_READERS:
        out["message" if reader in ("dataflash", "tlog", "ulog") else "topic"] = c.topic
        out["field"] = c.col
        if c.conversion:
            out["convert"] = c.conversion
        if c.conversion in (*QUATERNION_CONVERTS, "speed", "course") and c.frame != (
                "enu" if reader == "rosbag" else "ned"):
            out["frame"] = c.frame
        if c.instance is not None:
            out["instance"] = c.instance
        if c.conversion == "pwm" and c.pwm != (1100.0, 1500.0, 1900.0):
            out["pwm"] = [_plain(x) for x in c.pwm]
    else:
        out["col"] = c.col
    if c.scale != 1.0:
        out["scale"] = _plain(c.scale)
    if c.offset != 0.0:
        out["offset"] = _plain(c.offset)
    if c.unit is not None:
        out["unit"] = c.unit
    if c.sign != 1.0:
        out["sign"] = -1
    if c.source is not None:
        out["source"] = c.source
    if c.optional:
        out["optional"] = True
    return out


def _plain(x: float) -> float | int:
    return int(x) if float(x).is_integer() else float(x)


def _vessel(v: Any, source: str) -> Vessel:
    if not isinstance(v, dict):
        raise _err(source, "vessel", f"expected a mapping, got {v!r}")
    _check_keys(v, VESSEL_KEYS, source, "vessel")
    kw = {k: _number(v[k], source, f"vessel.{k}", positive=True) for k in v
          if k != "extra" and k not in VESSEL_PARTICULARS}
    extra = v.get("extra", {}) or {}
    if not isinstance(extra, dict):
        raise _err(source, "vessel.extra", f"expected a mapping name -> number, got {extra!r}")
    ex = {str(k): _number(x, source, f"vessel.extra.{k}") for k, x in extra.items()}
    for k in VESSEL_PARTICULARS:
        if k in v:
            ex[k] = _number(v[k], source, f"vessel.{k}", positive=k != "x_g")
    return Vessel(**kw, extra=ex)


def parse_spec(d: Any, source: str = "<spec>") -> FormatSpec:
    """Validate a spec given as a mapping (already parsed YAML) and build a :class:`FormatSpec`.

    Raises :class:`FormatSpecError` naming ``source`` and the offending field.
    """
    if not isinstance(d, dict):
        raise _err(source, "", f"a format spec must be a mapping, got {type(d).__name__}")
    _check_keys(d, SPEC_KEYS, source, "")
    if "reader" not in d:
        raise _err(source, "reader", f"missing (one of: {', '.join(READERS)})")
    reader = d["reader"]
    if reader not in READERS:
        raise _err(source, "reader", f"unknown reader {reader!r} (one of: {', '.join(READERS)})")

    def only(key: str, readers: tuple[str, ...]) -> None:
        if key in d and reader not in readers:
            raise _err(source, key, f"only used by reader {' / '.join(readers)}, not {reader}")

    only("delimiter", ("table",))
    only("comment", ("table",))
    only("sheet", ("excel",))
    only("time_source", ("nmea0183",))
    only("encoding", ("table", "nmea0183"))
    only("skip_rows", ("table", "excel"))
    only("header", ("table", "excel"))
    only("n2k_format", ("nmea2000",))

    delim = d.get("delimiter", "whitespace")
    if not isinstance(delim, str) or delim not in DELIMITERS:
        raise _err(
            source, "delimiter", f"expected whitespace, ',', ';' or '\\t', got {delim!r}"
        )
    skip = d.get("skip_rows", 0)
    if isinstance(skip, bool) or not isinstance(skip, int) or skip < 0:
        raise _err(source, "skip_rows", f"expected an integer >= 0, got {skip!r}")
    header = d.get("header")
    if header is not None and not isinstance(header, bool):
        raise _err(source, "header", f"expected true or false, got {header!r}")
    comment = d.get("comment")
    if comment is not None and (not isinstance(comment, str) or len(comment) != 1):
        raise _err(source, "comment", f"expected one character, got {comment!r}")
    encoding = d.get("encoding", "utf-8")
    if not isinstance(encoding, str):
        raise _err(source, "encoding", f"expected a codec name, got {encoding!r}")
    import codecs

    try:
        info = codecs.lookup(encoding)
    except (LookupError, ValueError, TypeError):
        raise _err(source, "encoding", f"unknown text encoding {encoding!r}") from None
    if not getattr(info, "_is_text_encoding", True) or info.name in NOT_FILE_ENCODINGS:
        raise _err(source, "encoding", f"{encoding!r} is not a text encoding of files (e.g. "
                                       "utf-8, cp1252, latin-1)")
    sheet = d.get("sheet", 0)
    if isinstance(sheet, bool) or not isinstance(sheet, int | str):
        raise _err(source, "sheet", f"expected a sheet name or 0-based index, got {sheet!r}")
    nm = d.get("non_monotonic", "sort")
    if nm not in ("sort", "reject"):
        raise _err(source, "non_monotonic", f"expected 'sort' or 'reject', got {nm!r}")
    ts = d.get("time_source", "auto")
    if ts not in ("auto", "prefix", "sentence"):
        raise _err(source, "time_source", f"expected auto, prefix or sentence, got {ts!r}")
    n2kf = d.get("n2k_format", "auto")
    if n2kf not in N2K_FORMATS:
        raise _err(source, "n2k_format", f"unknown NMEA 2000 format {n2kf!r} (one of: "
                                         f"{', '.join(N2K_FORMATS)})")
    desc = d.get("description", "")
    if not isinstance(desc, str):
        raise _err(source, "description", f"expected text, got {desc!r}")

    cols_raw = d.get("columns", {}) or {}
    if not isinstance(cols_raw, dict):
        raise _err(source, "columns", f"expected a mapping channel -> column, got {cols_raw!r}")
    columns: dict[str, ColumnSpec] = {}
    for name, v in cols_raw.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise _err(source, f"columns.{name}", "channel names must be identifiers")
        columns[name] = _column(name, v, reader, source)
    if reader in ("table", "excel", "parquet"):
        if "t" not in columns:
            raise _err(source, "columns.t", "missing: the time column is required")
        for c in columns.values():
            if c.unit is None:
                raise _err(source, f"columns.{c.name}.unit", "missing: every column needs a unit")
        if reader == "table" and header is False and any(
            isinstance(c.col, str) for c in columns.values()
        ):
            raise _err(source, "header", "columns are named by header, but header is false")
    elif reader in MESSAGE_READERS:
        if not columns:
            raise _err(source, "columns", f"missing: the {reader} reader needs at least one "
                                          "column {topic: ..., field: ...}")
    else:
        for c in columns.values():
            if not isinstance(c.col, str):
                raise _err(
                    source,
                    f"columns.{c.name}.col",
                    "NMEA readers name decoded channels, not column indices",
                )
            want = CHANNEL_UNITS.get(c.col)
            if c.unit is not None and want is not None and c.unit != want:
                raise _err(
                    source,
                    f"columns.{c.name}.unit",
                    f"the {reader} reader delivers '{c.col}' in {want}, not {c.unit}",
                )

    vessel = _vessel(d["vessel"], source) if "vessel" in d else Vessel()
    variants = _variants(d, reader, source)
    return FormatSpec(
        reader=reader,
        columns=columns,
        delimiter=DELIMITERS[delim],
        skip_rows=skip,
        header=header,
        comment=comment,
        encoding=encoding,
        sheet=sheet,
        non_monotonic=nm,
        time_source=ts,
        n2k_format=n2kf,
        description=desc,
        vessel=vessel,
        source=source,
        variants=variants,
    )


def _variants(d: dict, reader: str, source: str) -> dict[str, FormatSpec]:
    """``variants: {READER: {columns: ...}}``: the same setup logged in another format (e.g. an
    ArduPilot DataFlash preset's MAVLink tlog columns); each inherits ``description`` and
    ``vessel`` and is used when the log turns out to be of that reader's format."""
    v = d.get("variants", {}) or {}
    if not isinstance(v, dict):
        raise _err(source, "variants", f"expected a mapping reader -> spec, got {v!r}")
    out = {}
    for k, sub in v.items():
        if k not in MESSAGE_READERS or k == reader or reader not in MESSAGE_READERS:
            raise _err(source, f"variants.{k}", f"expected another message-log reader than "
                                                f"{reader} (one of {', '.join(MESSAGE_READERS)})")
        if not isinstance(sub, dict) or "reader" in sub or "variants" in sub:
            raise _err(source, f"variants.{k}", "expected a mapping without 'reader'/'variants'")
        base = {x: d[x] for x in ("description", "vessel") if x in d}
        out[k] = parse_spec({**base, **sub, "reader": k}, source=f"{source} (variants.{k})")
    return out


#: Largest format spec file accepted [characters] (the shipped ones are about 2 kB).
MAX_SPEC_BYTES = 1_000_000


def load_spec(path: str | Path) -> FormatSpec:
    """Read and validate a trial format spec (YAML, ``yaml.SafeLoader`` only, with bounds on
    size, nesting and alias expansion: :func:`usvid.files.load_yaml_text`).

    Raises :class:`FormatSpecError` for an unreadable file, bad YAML or any schema violation.
    """
    p = Path(path)
    # a regular file of at most MAX_SPEC_BYTES bytes, UTF-8 (a FIFO or /dev/zero is refused)
    text = read_input_text(p, "format spec", MAX_SPEC_BYTES, error=FormatSpecError)
    try:
        # yaml.SafeLoader with bounds on nesting and alias expansion (usvid.files)
        d = load_yaml_text(text, str(p))
    except UsvidError as exc:
        raise FormatSpecError(str(exc)) from None
    return parse_spec(d, source=p.name)


def shipped_specs() -> list[str]:
    """Names of the specs shipped with usvid (``src/usvid/specs/*.yaml``, without suffix)."""
    return list(_shipped_stems(_specs_dir_version()))


def _specs_dir_version() -> int | None:
    """The modification time [ns] of the folder of shipped specs (a file added, removed or
    renamed changes it), None when the folder cannot be read."""
    try:
        return _SPECS_DIR.stat().st_mtime_ns
    except OSError:
        return None


@functools.lru_cache(maxsize=8)
def _shipped_stems(version: int | None) -> tuple[str, ...]:
    """The sorted stems of the shipped specs, listed once per folder version: every read with a
    spec names the shipped spec it came from (:func:`shipped_name`), and listing the folder
    cost more than the rest of a small log's assembly (0.1-0.2 ms)."""
    return tuple(sorted(p.stem for p in _SPECS_DIR.glob("*.yaml")))


def shipped_name(source: str) -> str | None:
    """The name of the shipped spec a spec was loaded from (its ``source``: ``"px4_boat.yaml"``,
    ``"ardupilot_rover.yaml (variants.tlog)"``), None for any other spec."""
    stem = source.split(" (")[0]
    stem = stem[:-5] if stem.endswith(".yaml") else stem
    return stem if stem in _shipped_stems(_specs_dir_version()) else None


def shipped_spec_path(name: str) -> Path:
    """Path of a shipped spec (``"hsva_kvlcc2"`` or ``"hsva_kvlcc2.yaml"``)."""
    stem = name[:-5] if name.endswith(".yaml") else name
    p = _SPECS_DIR / f"{stem}.yaml"
    if not p.is_file():
        raise FormatSpecError(
            f"no shipped format spec '{name}' (shipped: {', '.join(shipped_specs())})"
        )
    return p


def shipped_spec(name: str) -> FormatSpec:
    """Load a shipped spec by name, e.g. ``shipped_spec("hsva_kvlcc2")`` (parsed once per file
    version: every auto-detected message log loads its preset, and YAML parsing costs more
    than reading a short log)."""
    p = shipped_spec_path(name)
    return _load_shipped(p, p.stat().st_mtime_ns)


@functools.lru_cache(maxsize=64)
def _load_shipped(path: Path, mtime_ns: int) -> FormatSpec:
    return load_spec(path)


def coerce_spec(spec: str | Path | FormatSpec | dict | None) -> FormatSpec | None:
    """A :class:`FormatSpec` from a path, a shipped name, a mapping or a spec (None passes)."""
    if spec is None or isinstance(spec, FormatSpec):
        return spec
    if isinstance(spec, dict):
        return parse_spec(spec)
    p = Path(spec)
    if p.is_file() or special_file(p) is not None:  # (a FIFO or device: load_spec says so)
        return load_spec(p)
    if isinstance(spec, str) and "/" not in spec and "\\" not in spec:
        stem = spec[:-5] if spec.endswith(".yaml") else spec
        if (_SPECS_DIR / f"{stem}.yaml").is_file():
            return shipped_spec(stem)
    raise FormatSpecError(f"{spec}: format spec file not found (nor a shipped spec name)")
