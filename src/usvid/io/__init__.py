"""usvid.io: trial format specs, readers (tables, Excel, Parquet, NMEA 0183, NMEA 2000 candump)
and writers (CSV, Parquet, NMEA 0183, candump). Readers return :class:`usvid.Trial` in SI units and
radians (``lat``/``lon`` in degrees); bad input raises a :class:`usvid.errors.UsvidError` subclass.
"""

from __future__ import annotations

from pathlib import Path

from usvid.errors import FormatSpecError, LogReadError
from usvid.io._assemble import read_log_bytes
from usvid.io.n2k import read_candump, write_candump
from usvid.io.nmea0183 import read_nmea0183, write_nmea0183
from usvid.io.spec import (
    ColumnSpec,
    FormatSpec,
    coerce_spec,
    load_spec,
    parse_spec,
    shipped_spec,
    shipped_spec_path,
    shipped_specs,
)
from usvid.io.table import read_excel, read_parquet, read_table
from usvid.io.writers import table_spec, write_csv, write_parquet
from usvid.trial import Trial

__all__ = [
    "ColumnSpec",
    "FormatSpec",
    "detect_reader",
    "load_spec",
    "parse_spec",
    "read_candump",
    "read_excel",
    "read_nmea0183",
    "read_parquet",
    "read_table",
    "read_trial",
    "shipped_spec",
    "shipped_spec_path",
    "shipped_specs",
    "table_spec",
    "write_candump",
    "write_csv",
    "write_nmea0183",
    "write_parquet",
]


def detect_reader(path: str | Path) -> str:
    """Guess the reader of a log without a spec: ``nmea2000`` (candump -L lines), ``nmea0183``
    (``$``/``!`` sentences), ``parquet`` (PAR1 magic) or ``excel`` (.xlsx zip); ``table`` for a
    CSV with a header of Trial channel names. Raises :class:`LogReadError` when unreadable/empty.
    """
    path = Path(path)
    head = read_log_bytes(path, 65536)
    if head[:4] == b"PAR1":
        return "parquet"
    if head[:2] == b"PK":
        return "excel"
    lines = [ln.strip() for ln in head.splitlines()[:200] if ln.strip()]
    n0183 = sum(1 for ln in lines if b"$" in ln or ln.startswith(b"!"))
    n2k = sum(1 for ln in lines if ln.startswith(b"(") and b"#" in ln)
    if n2k and n2k >= n0183:
        return "nmea2000"
    if n0183:
        return "nmea0183"
    return "table"


def _identity_spec(reader: str) -> FormatSpec:
    """Spec for tables written by usvid (header names are Trial channels, SI units)."""
    return FormatSpec(reader=reader, header=True, delimiter=",", source="<usvid table>")


def read_trial(path: str | Path, spec: str | Path | FormatSpec | dict | None = None) -> Trial:
    """Read one log into a :class:`Trial` (SI units, radians; lat/lon in degrees).

    ``spec``: a YAML path, a shipped spec name (``"hsva_kvlcc2"``), a mapping, a
    :class:`FormatSpec`, or ``None`` to detect NMEA 0183 / candump logs (and CSV/Parquet tables
    written by usvid, whose header names are Trial channels in SI). Dispatches on ``spec.reader``.
    """
    fs = coerce_spec(spec)
    p = Path(path)
    if not p.exists():
        raise LogReadError(f"{p}: no such file")
    if p.is_dir():
        raise LogReadError(f"{p}: is a folder, not a log file")
    if p.is_dir() and (fs is None or fs.reader == "rosbag"):
        pass  # a ROS 2 bag is a folder
    reader = fs.reader if fs is not None else detect_reader(p)
    if reader == "rosbag":
        from usvid.io.rosbag import read_rosbag

        return read_rosbag(p, fs)
    if reader == "ulog":
        from usvid.io.ulog import read_ulog

        return read_ulog(p, fs)
    if reader == "dataflash":
        from usvid.io.ardupilot import read_dataflash

        return read_dataflash(p, fs)
    if reader == "tlog":
        from usvid.io.ardupilot import read_tlog

        return read_tlog(p, fs)
    if reader == "nmea0183":
        return read_nmea0183(p, fs)
    if reader == "nmea2000":
        return read_candump(p, fs)
    if fs is None:
        if reader == "excel":
            raise FormatSpecError(f"{p}: an Excel log needs a format spec (--format SPEC)")
        fs = _usvid_table_spec(p, reader)
    if reader == "table":
        return read_table(p, fs)
    if reader == "excel":
        return read_excel(p, fs)
    if reader == "parquet":
        return read_parquet(p, fs)
    raise FormatSpecError(f"unknown reader {reader!r}")  # unreachable: validated by the spec


def _usvid_table_spec(p: Path, reader: str) -> FormatSpec:
    """Spec for a CSV/Parquet written by usvid: header names are channels in SI units."""
    import pandas as pd

    from usvid.trial import CHANNEL_UNITS

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
