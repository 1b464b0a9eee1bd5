"""usvid.io: trial format specs, readers (tables, Excel, Parquet, NMEA 0183, NMEA 2000, ROS bags,
PX4 ULog, ArduPilot DataFlash and tlog) and writers (CSV, Parquet, NMEA 0183, candump, ROS bags,
ULog, DataFlash, tlog). Readers return :class:`usvid.Trial` in SI units and
radians (``lat``/``lon`` in degrees); bad input raises a :class:`usvid.errors.UsvidError` subclass.

The one entry point is :func:`read_trial` (:mod:`usvid.io.reader`). The names below load with
their modules on first use (PEP 562): importing a module of the package that needs none of the
readers (the model files, :mod:`usvid.io.modelfile`, as ``usvid simulate`` does) loads neither
them nor pandas.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from usvid.lazy import lazy_names

if TYPE_CHECKING:
    from usvid.io.ardupilot import servo1_function  # noqa: F401 - public helper
    from usvid.io.n2k import read_candump, read_nmea2000, write_candump, write_nmea2000
    from usvid.io.nmea0183 import read_nmea0183, write_nmea0183
    from usvid.io.reader import auto_spec, detect_message_log, detect_reader, read_trial
    from usvid.io.spec import (
        ColumnSpec,
        FormatSpec,
        load_spec,
        parse_spec,
        shipped_spec,
        shipped_spec_path,
        shipped_specs,
    )
    from usvid.io.table import read_excel, read_parquet, read_table
    from usvid.io.writers import table_spec, write_csv, write_parquet

#: Public name -> the module that defines it (loaded on first use of the name).
_LAZY = {
    "ColumnSpec": "usvid.io.spec",
    "FormatSpec": "usvid.io.spec",
    "auto_spec": "usvid.io.reader",
    "detect_message_log": "usvid.io.reader",
    "detect_reader": "usvid.io.reader",
    "load_spec": "usvid.io.spec",
    "parse_spec": "usvid.io.spec",
    "read_candump": "usvid.io.n2k",
    "read_excel": "usvid.io.table",
    "read_nmea0183": "usvid.io.nmea0183",
    "read_nmea2000": "usvid.io.n2k",
    "read_parquet": "usvid.io.table",
    "read_table": "usvid.io.table",
    "read_trial": "usvid.io.reader",
    "servo1_function": "usvid.io.ardupilot",
    "shipped_spec": "usvid.io.spec",
    "shipped_spec_path": "usvid.io.spec",
    "shipped_specs": "usvid.io.spec",
    "table_spec": "usvid.io.writers",
    "write_candump": "usvid.io.n2k",
    "write_csv": "usvid.io.writers",
    "write_nmea0183": "usvid.io.nmea0183",
    "write_nmea2000": "usvid.io.n2k",
    "write_parquet": "usvid.io.writers",
}


__getattr__, __dir__ = lazy_names(__name__, _LAZY)


__all__ = [
    "ColumnSpec",
    "FormatSpec",
    "auto_spec",
    "detect_message_log",
    "detect_reader",
    "load_spec",
    "parse_spec",
    "read_candump",
    "read_nmea2000",
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
    "write_nmea2000",
    "write_csv",
    "write_nmea0183",
    "write_parquet",
]
